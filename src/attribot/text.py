"""Text that came from outside (a program, a model, a command line) made safe for where it goes: a JSON
file (no lone surrogates) and a terminal (no control characters that act)."""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import Any

__all__ = [
    "json_safe",
    "json_safe_data",
    "visible",
    "control_characters",
    "terminal_json",
    "shown_url",
    "plain_value",
    "comma_names",
]

_SURROGATES = re.compile("[\ud800-\udfff]")
# C0 controls but tab and newline, DEL, C1 controls, and the bidirectional overrides and isolates (which
# reorder what a terminal shows)
_CONTROLS = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")
# what JSON leaves unescaped but a terminal acts on (JSON already escapes C0 controls)
_JSON_UNESCAPED = re.compile("[\x7f-\x9f\u202a-\u202e\u2066-\u2069]")
_USERINFO = re.compile(r"(?<=://)[^/@\s]*@")


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


def shown_url(text: str) -> str:
    """`text` (a URL, or a backend spec that holds one) to show in a message: a user name and password in
    it (`http://user:secret@host`) are left out."""
    return _USERINFO.sub("***@", text)


def plain_value(value: Any, number: bool = False) -> Any:
    """A configuration value from outside, checked before its type's own check: true or false is no number
    when `number` (pydantic would take `program_wall_s = true` as 1 s), and text holds no byte that is no
    character (a non-UTF-8 byte of an environment variable) and no control character (newlines and tabs
    included). Raises ValueError, which pydantic reports under the field's name."""
    if number and isinstance(value, bool):
        raise ValueError("a number is needed, not true or false")
    if isinstance(value, str):
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            raise ValueError("it holds bytes that are not UTF-8 text") from None
        controls = control_characters(value) + [_escape(m) for m in re.finditer("[\t\n]", value)][:1]
        if controls:
            raise ValueError(f"it holds control characters ({', '.join(dict.fromkeys(controls))})")
    return value


def one_of(value: str, names: Iterable[str], what: str) -> str:
    """`value` when it is one of `names`; else a ValueError naming `what` it was to be and the choices
    (pydantic reports it under the field's name)."""
    choices = list(names)
    if value not in choices:
        raise ValueError(f"unknown {what}; choose one of: {', '.join(choices)}")
    return value


def comma_names(text: str) -> list[str]:
    """The names of a comma-separated list, in order, stripped, the empty ones left out ("a, ,b" -> a, b)."""
    return [part.strip() for part in text.split(",") if part.strip()]
