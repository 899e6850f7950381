"""The `attribot` command: the typer app, one module per command beside this one.

Commands import their layers lazily so that `attribot --help` stays fast; only the configs are read at
start, since the flags derive from them (`attribot.cli.flags`). Every `AttribotError` ends the
command with its message and fix on stderr and exit code 2 (in `_Commands.invoke`, the one place that
converts them); nothing prints a traceback at a user. The modules named in `ATTRIBOT_PLUGINS` are imported
before any command runs: a lab's own sensors, worlds or layouts register themselves there.
"""

from __future__ import annotations

from typing import Any

import typer
from typer.core import TyperGroup

from attribot.cli import ask, backends, bridge, dataset, demo, evaluate, scene, serve
from attribot.cli.output import Command, PlainFlags, fail, stdout_for_json
from attribot.cli.plugins import load_plugins
from attribot.errors import AttribotError

__all__ = ["app", "main"]


class _Commands(PlainFlags, TyperGroup):
    """The root command group: turns an `AttribotError` from any command into its message and exit code 2."""

    def invoke(self, ctx: Any) -> Any:  # typer.Context; typer vendors click, whose private Context mypy wants
        from attribot.shutdown import termination_as_exit

        command = getattr(ctx, "_protected_args", None) or getattr(ctx, "protected_args", [])
        args = [*command, *ctx.args]  # read now: the group consumes them
        # SIGTERM and SIGHUP unwind like Ctrl-C: the sandbox worker, renderer and model processes stop
        with termination_as_exit(), stdout_for_json("--json" in args):
            try:
                _refuse_empty_values(args)
                load_plugins()
                return super().invoke(ctx)
            except AttribotError as exc:
                raise fail(exc.message, exc.fix) from None
            except OSError as exc:  # the machine's, not the input's: a full disk, a folder that is a file
                from attribot.files import disk_full

                where = f" ({exc.filename})" if exc.filename else ""
                raise fail(
                    f"{exc.strerror or exc.__class__.__name__}{where}",
                    "free some space (the disk or your quota is full) and run the same command again; what "
                    "was written before is kept"
                    if disk_full(exc)
                    else "check that path and its permissions, or give another, and run the command again",
                ) from None
            except _USAGE_ERROR as exc:
                # a flag click could not parse: a script that asked for --json still gets the answer's shape
                # on stdout (click prints its usage message to stderr and exits 2 as usual)
                if args and args[0] in ("ask", "exec") and "--json" in args:
                    ask.print_error_answer(
                        "input", exc.format_message(), "", "rules" if args[0] == "ask" else "file"
                    )
                raise


_NEVER_EMPTY = (
    *("--out", "--save", "--runs-dir", "--dataset", "--image"),
    *("--allow-host", "--host", "--bridge-url"),
)
"""Flags whose value names a place: an empty one is refused before any work (`--out ''` would be the
current folder, and a whole suite would run into it)."""


def _refuse_empty_values(args: list[str]) -> None:
    """Refuse `--out ''`, `--out=` or `--out '  '` (and the other flags of `_NEVER_EMPTY`), naming it."""
    from attribot.errors import InputError

    for i, arg in enumerate(args):
        flag, sep, value = arg.partition("=")
        if flag not in _NEVER_EMPTY:
            continue
        if not sep:
            if i + 1 >= len(args):
                continue
            value = args[i + 1]
        if not value.strip():
            raise InputError(
                f"{flag} is empty", f"give {flag} a value, e.g. {flag} {_EXAMPLES.get(flag, 'VALUE')}"
            )


_EXAMPLES = {
    "--out": "results/run1",
    "--save": "answers/q1",
    "--runs-dir": "demo-runs",
    "--dataset": "data/paper",
    "--image": "photo.jpg",
    "--allow-host": "lab-pc.local",
    "--host": "127.0.0.1",
    "--bridge-url": "tcp://ROBOT:7777",
}

_USAGE_ERROR: type[typer.BadParameter] = typer.BadParameter.__mro__[1]
"""click's UsageError (typer vendors click and exports only its BadParameter subclass)."""


app = typer.Typer(
    name="attribot",
    cls=_Commands,
    help="Find objects by attributes a camera alone cannot settle: LLM-written perception-action programs.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)


def version() -> None:
    """Print the attribot version."""
    from attribot import __version__

    typer.echo(__version__)


# the order of `attribot --help`: the commands, then the groups
app.command(cls=Command)(version)
app.command(cls=Command)(ask.ask)
app.command("exec", cls=Command)(ask.exec_program)
app.command("eval", cls=Command)(evaluate.evaluate)
app.command("report", cls=Command)(evaluate.report)
app.command(cls=Command)(backends.backends)
app.command(cls=Command)(backends.fetch)
app.command(cls=Command)(demo.demo)
app.add_typer(scene.scene_app, name="scene")
app.add_typer(dataset.dataset_app, name="dataset")
app.add_typer(serve.serve_app, name="serve")
app.add_typer(bridge.bridge_app, name="bridge")


def _survive_any_locale() -> None:
    """Output that survives any locale: a stream that cannot encode a character (an ASCII locale, "°C" or
    "é" in an answer) writes it as a backslash escape instead of ending the command in a traceback."""
    import sys

    for stream in (sys.stdout, sys.stderr):
        try:
            "°é—".encode(getattr(stream, "encoding", None) or "utf-8")
        except (UnicodeEncodeError, LookupError):
            reconfigure = getattr(stream, "reconfigure", None)
            if reconfigure is not None:
                reconfigure(errors="backslashreplace")


def main() -> None:
    """Console-script entry point."""
    _survive_any_locale()
    app()
