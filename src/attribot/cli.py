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


@app.command()
def backends(
    as_json: bool = typer.Option(False, "--json", help="Print the statuses as JSON."),
    strict: bool = typer.Option(False, "--strict", help="Exit 1 when a configured backend is unavailable."),
) -> None:
    """List the backend of each role (config file + ATTRIBOT_* env) and whether it can be used here."""
    import json
    import os

    from pydantic import ValidationError
    from rich.table import Table

    from attribot.config import load_settings
    from attribot.models.base import ROLES, BackendStatus, probe_backend

    try:
        settings = load_settings()
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first.get("loc", ())) or "settings"
        raise fail(
            f"the configuration is invalid: {where}: {first.get('msg', exc)}",
            "check attribot.toml (or $ATTRIBOT_CONFIG) and the ATTRIBOT_* variables",
        ) from exc
    statuses = [probe_backend(role, getattr(settings, role), settings) for role in ROLES]
    statuses.append(_planner_status(settings, BackendStatus))
    if as_json:
        typer.echo(json.dumps([s.model_dump() for s in statuses], indent=2))
    else:
        source = os.environ.get("ATTRIBOT_CONFIG", "attribot.toml")
        found = "" if os.path.isfile(source) else ", not found: defaults"
        table = Table(title=f"attribot backends (config: {source}{found} + env)")
        for column in ("role", "spec", "kind", "available", "detail"):
            table.add_column(column, overflow="fold")
        shown = {True: "[green]yes[/]", False: "[red]no[/]", None: "[yellow]?[/]"}
        for s in statuses:
            table.add_row(s.role, s.spec, s.kind or "-", shown[s.available], s.detail)
        Console().print(table)
    if strict and any(s.available is False for s in statuses):
        raise typer.Exit(1)


def _planner_status(settings, record):  # type: ignore[no-untyped-def]
    """The planner row: the `llm` planner needs the OpenAI-compatible endpoint, the others run in-process."""
    if settings.planner != "llm":
        return record(
            role="planner", spec=settings.planner, kind=settings.planner, arg=None, registered=True,
            available=None, detail="runs in-process",
        )
    from attribot.models.openai_chat import probe_endpoint

    available, detail = probe_endpoint(None, settings)
    return record(
        role="planner", spec="llm", kind="llm", arg=settings.llm_model, registered=True,
        available=available, detail=detail,
    )


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
