"""`attribot ask` and `attribot exec`: plan (or take) a program, run it against the world, show the answer."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.markup import escape

from attribot.cli.flags import (
    BACKEND_FLAGS,
    OUTPUT_FLAGS,
    PLANNER_FLAGS,
    SCENE_FLAGS,
    WORLD_FLAGS,
    flag_name,
    settings_of,
    with_flags,
)
from attribot.cli.output import err_console, fail, json_echo
from attribot.cli.worlds import query_scene
from attribot.errors import AttribotError


@contextlib.contextmanager
def _errors_as_json(as_json: bool, query: str, planner: str) -> Iterator[None]:
    """With --json, an `AttribotError` before the answer is printed as an answer with `error` set (the
    shape a script already reads), then exit code 2; without, it goes on to the one plain-text handler."""
    try:
        yield
    except AttribotError as exc:
        if not as_json:
            raise
        from attribot.errors import ConfigError, InputError

        category = (
            "input" if isinstance(exc, InputError) else "config" if isinstance(exc, ConfigError) else "error"
        )
        message = exc.message if exc.fix is None else f"{exc.message} (fix: {exc.fix})"
        print_error_answer(category, message, query, planner)
        raise typer.Exit(2) from None


def print_error_answer(category: str, message: str, query: str, planner: str) -> None:
    """Print, as --json does, an answer that holds only an error (no program ran)."""
    from attribot.planning.answer import Answer, AnswerError

    answer = Answer(
        query=query,  # an Answer makes undecodable command-line bytes JSON-safe
        answer=f"no answer: {message}",
        planner=planner,
        backends={},
        attempts=0,
        error=AnswerError(category=category, message=message),
    )
    from attribot.text import terminal_json

    json_echo(terminal_json(answer.model_dump_json(indent=2)))


def _show(answer: Any, as_json: bool) -> None:
    """Print an answer; what a program made (answer text, output, error message) cannot act on the
    terminal: its control characters are shown as escapes (JSON escapes those JSON leaves as they are)."""
    from attribot.text import terminal_json, visible

    if as_json:
        json_echo(terminal_json(answer.model_dump_json(indent=2)))
    else:
        out = Console(soft_wrap=True)
        if answer.error is None:
            out.print(f"[bold green]answer:[/] {escape(visible(answer.answer))}", highlight=False)
        else:
            where = f" at line {answer.error.line}" if answer.error.line else ""
            out.print(
                f"[bold red]no answer[/] ({answer.error.category} error{where}): "
                f"{escape(visible(answer.error.message))}",
                highlight=False,
            )
            if answer.error.category == "timeout":
                out.print("[dim]fix: a program that needs longer may have it: --program-wall-s SECONDS[/]")
        if answer.output.strip():
            out.print(
                f"[dim]the program printed:[/]\n{escape(visible(answer.output.rstrip()))}", highlight=False
            )
        if answer.checks:
            out.print(f"[dim]checks: {escape(_tally(answer.checks))}[/]", highlight=False)
        backends = ", ".join(f"{k}={v}" for k, v in answer.backends.items())
        prompt = f" prompt={answer.prompt}" if answer.prompt else ""
        out.print(
            f"[dim]planner={answer.planner}{prompt} attempts={answer.attempts} {escape(backends)}; "
            f"{len(answer.trace)} API calls (--json shows the program and the trace)[/]",
            highlight=False,
        )
    if answer.error is not None:
        raise typer.Exit(1)


def _tally(checks: list[dict[str, Any]]) -> str:
    """The checks log in one line: each mechanism with the count of each outcome."""
    tally: dict[str, dict[str, int]] = {}
    for c in checks:
        outcomes = tally.setdefault(c["mechanism"], {})
        outcomes[c["outcome"]] = outcomes.get(c["outcome"], 0) + 1
    return "; ".join(
        f"{m} " + ", ".join(f"{n} {o}" for o, n in sorted(outs.items())) for m, outs in tally.items()
    )


@with_flags(SCENE_FLAGS, WORLD_FLAGS, BACKEND_FLAGS, PLANNER_FLAGS, OUTPUT_FLAGS)
def ask(
    query: str = typer.Argument(
        ..., metavar="QUERY", help='The question, e.g. "Which object is the heaviest?"'
    ),
    given: Any = None,
) -> None:
    """Answer a query: plan a program, run it in the sandbox against the world, print the answer."""
    with _errors_as_json(given.as_json, query, given.planner or "rules"):
        scene = query_scene(given)
        from attribot.session import ask as run_ask

        answer = run_ask(query, scene, settings_of(given), save_dir=given.save)
    _show(answer, given.as_json)


_REPLAY_KEPT = ("as_json", "save")  # flags that a replay takes: where its answer goes, not what it does


@with_flags(SCENE_FLAGS, WORLD_FLAGS, BACKEND_FLAGS, OUTPUT_FLAGS)
def exec_program(
    program: Path = typer.Argument(
        ...,
        metavar="PROGRAM",
        help="A .py file defining "
        "execute_command(image, robot), or a folder written by --save, which is "
        "replayed as it was saved.",
    ),  # fmt: skip
    query: str = typer.Option(
        "", "--query", metavar="TEXT", help="The question the program answers (recorded only)."
    ),  # fmt: skip
    trust_saved: bool = typer.Option(
        False,
        "--trust-saved-backends",
        help="Replay a saved folder with its own endpoints, models and world (remote:URL, openai: at its "
        "llm_base_url, hf:MODEL, a robot bridge): its settings then decide where your ATTRIBOT_LLM_API_KEY, "
        "ATTRIBOT_REMOTE_TOKEN, ATTRIBOT_BRIDGE_TOKEN and camera images go. Only for folders you made; "
        "without it those come from your own settings.",
    ),
    given: Any = None,
) -> None:
    """Run a given program through the same runner and world as `ask`: to replay, debug or hand-write one. A
    --save folder (or its program.py, with no scene flags) runs with the scene and settings saved there."""
    from attribot.saved_runs import RUN_FILE

    with _errors_as_json(given.as_json, query, "file"):
        flags = [
            name for name, value in vars(given).items() if name not in _REPLAY_KEPT and value is not None
        ]
        if program.is_dir():
            from attribot.session import load_saved

            # a folder that is no saved run says what it lacks, before the flags
            load_saved(program, trust_saved_backends=trust_saved)
            if flags:
                shown = ", ".join(flag_name(n) for n in flags)
                raise fail(
                    f"{shown}: a saved folder replays exactly as it was saved",
                    "drop them, or run its program elsewhere: "
                    f"attribot exec {program / 'program.py'} {shown} ...",
                )
            from attribot.session import replay

            answer = replay(program, save_dir=given.save, trust_saved_backends=trust_saved)
        elif not flags and (program.parent / RUN_FILE).is_file():
            err_console.print(
                f"[dim]running in the scene saved beside it ({escape(str(program.parent / RUN_FILE))}); "
                "scene flags run it elsewhere[/]",
                highlight=False,
            )
            answer = _saved_scene_run(program, query, given.save, trust_saved)
        elif trust_saved:
            raise fail(
                "--trust-saved-backends replays a folder written by --save, and this program runs in the "
                "world its flags describe",
                "drop --trust-saved-backends, or give the saved folder",
            )
        else:
            answer = _file_run(program, query, given)
    _show(answer, given.as_json)


def _file_run(program: Path, query: str, given: Any) -> Any:
    scene = query_scene(given)
    from attribot.saved_runs import read_program
    from attribot.session import run_program

    source = read_program(program)
    return run_program(source, scene, settings_of(given), query=query, save_dir=given.save)


def _saved_scene_run(program: Path, query: str, save: Path | None, trusted: bool) -> Any:
    from attribot.saved_runs import read_program
    from attribot.session import load_saved, run_program

    _, scene, settings, saved_query = load_saved(program.parent, trust_saved_backends=trusted)
    source = read_program(program)
    return run_program(source, scene, settings, query=query or saved_query, save_dir=save, planner="replay")
