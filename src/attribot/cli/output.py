"""What every command shares: the click classes that show their help, the consoles, errors, JSON output."""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.markup import escape
from typer.core import TyperCommand, TyperGroup


class PlainFlags:
    """In --help, a plain flag (--json, --help) shows no value type: it takes none; and a help text's
    `{worlds}` is read when the help is shown, after the plug-ins that add worlds (`help_text`)."""

    def get_params(self, ctx: Any) -> list[Any]:
        params: list[Any] = super().get_params(ctx)  # type: ignore[misc]
        for param in params:
            if getattr(param, "is_flag", False) and getattr(param, "metavar", None) is None:
                param.metavar = ""
            if "{worlds}" in (getattr(param, "help", None) or ""):
                param.help = help_text(param.help)
        return params


def help_text(text: str) -> str:
    """A help text with `{worlds}` (the registered worlds) filled in."""
    from attribot.config import WORLD_CONFIGS

    return text.replace("{worlds}", ", ".join(WORLD_CONFIGS.names()))


class Command(PlainFlags, TyperCommand):
    """Every command of `attribot`."""


class Group(PlainFlags, TyperGroup):
    """Every command group below the root (scene, dataset, serve, bridge)."""


_JSON_STDOUT: list[Any] = []
"""The real stdout while a --json command runs: only the JSON goes there (`json_echo`), and anything else
printed meanwhile (a plug-in's or a backend's `print`) goes to stderr, so that the output stays JSON."""


@contextlib.contextmanager
def stdout_for_json(on: bool) -> Iterator[None]:
    if not on:
        yield
        return
    import sys

    _JSON_STDOUT.append(sys.stdout)
    sys.stdout = sys.stderr
    try:
        yield
    finally:
        sys.stdout = _JSON_STDOUT.pop()


def json_echo(text: str) -> None:
    """Print JSON on the command's stdout (see `_JSON_STDOUT`); a stream that cannot encode every character
    (an ASCII locale) gets the same JSON with `\\u` escapes, which read back to the same data."""
    import sys

    out = _JSON_STDOUT[-1] if _JSON_STDOUT else sys.stdout
    try:
        text.encode(getattr(out, "encoding", None) or "utf-8")
    except (UnicodeEncodeError, LookupError):
        text = json.dumps(json.loads(text), indent=2, ensure_ascii=True)
    typer.echo(text, file=out)


def brief(text: str, limit: int = 120) -> str:
    """`text` cut to `limit` characters for a message (a 5,000-character variable is not echoed whole)."""
    return text if len(text) <= limit else text[: limit - 3] + "..."


err_console = Console(stderr=True, soft_wrap=True)  # no hard breaks inside paths and messages
console = Console(soft_wrap=True)


def fail(message: str, fix: str | None = None, code: int = 2) -> typer.Exit:
    """Print an error (and its fix) to stderr, its control characters shown as escapes (a message may quote
    a program's or a file's text); return the Exit to raise."""
    from attribot.text import visible

    err_console.print(f"[bold red]error:[/] {escape(visible(message))}", highlight=False)
    if fix:
        err_console.print(f"[yellow]fix:[/] {escape(visible(fix))}", highlight=False)
    return typer.Exit(code)


def writable_folder(folder: Path, flag: str) -> None:
    """Create `folder` if need be and check that files can be written in it (before any work)."""
    from attribot.errors import InputError
    from attribot.files import check_writable

    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(
            f"{flag} {str(folder)!r} cannot be created ({exc.strerror})", "give a writable folder"
        ) from None
    check_writable(folder, f"{flag} {str(folder)!r}", "give a writable folder")


def prefetch_rendering() -> None:
    """Start the OpenGL probe (a child process) before the slow imports, so that they overlap."""
    from attribot.sim.render import prefetch_gl_backend

    prefetch_gl_backend()
