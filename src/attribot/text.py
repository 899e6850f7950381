"""Text that came from outside (a program, a model, a command line) made safe for where it goes: a JSON
file (no lone surrogates) and a terminal (no control characters that act)."""

from __future__ import annotations

import re
from typing import Any

__all__ = ["json_safe", "json_safe_data", "visible", "control_characters", "terminal_json"]

_SURROGATES = re.compile("[\ud800-\udfff]")
# C0 controls but tab and newline, DEL, C1 controls, and the bidirectional overrides and isolates (which
# reorder what a terminal shows)
_CONTROLS = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")
# what JSON leaves unescaped but a terminal acts on (JSON already escapes C0 controls)
_JSON_UNESCAPED = re.compile("[\x7f-\x9f\u202a-\u202e\u2066-\u2069]")


def json_safe(text: str) -> str:
    """`text` as text any JSON file can hold: lone surrogates (undecodable bytes of a command line, or a
    program's own making) become U+FFFD."""
    try:
        text.encode("utf-8")
        return text
    except UnicodeEncodeError:
        return _SURROGATES.sub("\ufffd", text)


def json_safe_data(value: Any) -> Any:
    """`json_safe` over every string (keys too) inside lists, tuples and dicts."""
    if isinstance(value, str):
        return json_safe(value)
    if isinstance(value, list | tuple):
        return type(value)(json_safe_data(v) for v in value)
    if isinstance(value, dict):
        return {json_safe_data(k): json_safe_data(v) for k, v in value.items()}
    return value


def _escape(match: re.Match[str]) -> str:
    code = ord(match.group())
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def visible(text: str) -> str:
    """`text` for a terminal: control characters (escape sequences, carriage returns, bidirectional
    overrides) are shown as `\\x1b`-style escapes instead of acting; tab and newline stay."""
    return _CONTROLS.sub(_escape, json_safe(text))


def control_characters(text: str) -> list[str]:
    """The distinct control characters in `text` (those `visible` escapes), as escapes, in order."""
    return list(dict.fromkeys(_escape(m) for m in _CONTROLS.finditer(text)))


def terminal_json(text: str) -> str:
    """JSON text for a terminal: the characters JSON leaves as they are but a terminal acts on (C1
    controls, bidirectional overrides) written as `\\u` escapes, which read back to the same data."""
    return _JSON_UNESCAPED.sub(lambda m: f"\\u{ord(m.group()):04x}", text)
