"""The `attribot` command.

Commands import their layers lazily so that `attribot --help` stays fast. Every `AttribotError` ends the
command with its message and fix on stderr and exit code 2; nothing prints a traceback at a user.
"""

from __future__ import annotations

import sys

import typer
from rich.console import Console

from attribot.errors import AttribotError

__all__ = ["app", "main"]

app = typer.Typer(
    name="attribot",
    help="Find objects by attributes a camera alone cannot settle: LLM-written perception-action programs.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
err_console = Console(stderr=True)


def fail(message: str, fix: str | None = None, code: int = 2) -> typer.Exit:
    """Print an error (and its fix) to stderr; return the Exit to raise."""
    err_console.print(f"[bold red]error:[/] {message}", highlight=False)
    if fix:
        err_console.print(f"[yellow]fix:[/] {fix}", highlight=False)
    return typer.Exit(code)


@app.command()
def version() -> None:
    """Print the attribot version."""
    from attribot import __version__

    typer.echo(__version__)


# ---- scene commands (the embodied world) -------------------------------------------------------------

# ---- ask / exec (planner, runner, API) ---------------------------------------------------------------

# ---- backends (model configuration) ------------------------------------------------------------------

# ---- serve (remote model server) ---------------------------------------------------------------------


def main() -> None:
    """Console-script entry point."""
    try:
        app()
    except AttribotError as exc:
        raise SystemExit(_report(exc)) from None


def _report(exc: AttribotError) -> int:
    fail(exc.message, exc.fix)
    return 2


if __name__ == "__main__":
    sys.exit(main())
