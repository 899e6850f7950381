"""`attribot eval` and `attribot report`: run the suite's methods on its items, report a run."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import typer

from attribot.cli.flags import (
    BACKEND_FLAGS,
    LIMIT,
    PLANNER_FLAGS,
    ROOT_SEED,
    SUITE,
    TASKS,
    settings_of,
    suite_tasks,
    with_flags,
    without,
)
from attribot.cli.output import console, err_console, writable_folder
from attribot.text import comma_names

_EVAL_METHODS = typer.Option(
    None,
    "--methods",
    help="Comma-separated: ovd,vqa,vqa+llm,vlm,attr-api,pa-api (default: the paper's per task).",
)
_EVAL_NOISE = typer.Option(
    "clean",
    "--noise",
    help="Comma-separated noise presets: clean, frame (per-frame perception noise, earlier releases' "
    "realistic), perception, sensing, acting, realistic (all three); PRESET-no-MECHANISM for one "
    "ablation condition; PRESET-priorsFACTOR (e.g. clean-priors0.7): the mechanisms' perception priors "
    "scaled.",
)
_EVAL_ABLATION = typer.Option(
    False,
    "--ablation",
    help="Add realistic with each error-catching mechanism off in turn (api methods).",
)
_EVAL_DATASET = typer.Option(
    None,
    "--dataset",
    help="A dataset folder made by `attribot dataset build`: its items and images are used instead of "
    "generating them.",
)
_EVAL_FINDABLE_BY = typer.Option(
    None,
    "--findable-by",
    metavar="SPEC",
    help="Run on the items of this closed-set detector (default: the run's own --detector; an "
    "open-vocabulary one keeps every item): the embodied tasks are drawn in scenes whose objects it can "
    "all find, the other tasks keep the items whose objects it can find; e.g. --detector oracle "
    "--findable-by coco runs the oracle on exactly the coco run's items.",
)


@with_flags(PLANNER_FLAGS, without(BACKEND_FLAGS, "checks", "priors_scale"))
def evaluate(
    out: Path = typer.Option(..., "--out", help="The run folder: records/, dataset/, run.json."),
    suite: str = SUITE,
    tasks: str | None = TASKS,
    methods: str | None = _EVAL_METHODS,
    limit: int | None = LIMIT,
    noise: str = _EVAL_NOISE,
    ablation: bool = _EVAL_ABLATION,
    workers: int = typer.Option(1, "--workers", help="Items run in this many processes."),
    executor: str = typer.Option("local", "--executor", help="local, or ray (the cluster at RAY_ADDRESS)."),
    dataset: Path | None = _EVAL_DATASET,
    findable_by: str | None = _EVAL_FINDABLE_BY,
    seed: int = ROOT_SEED,
    given: Any = None,
) -> None:
    """Run the suite's methods on its items; resumes a stopped run, refuses one made with other settings."""
    from attribot.eval.methods import Condition, ablations
    from attribot.eval.run import EvalPlan

    plan = EvalPlan(
        tasks=tuple(suite_tasks(suite, tasks)),
        methods=tuple(comma_names(methods)) if methods else None,
        noise=tuple(Condition.parse(name) for name in comma_names(noise)) + (ablations() if ablation else ()),
        limit=limit,
        findable_by=findable_by,
        seed=seed,
    )
    settings = settings_of(given)
    summary = _run_eval_shown(plan, settings, out, workers=workers, executor=executor, dataset=dataset)
    console.print(
        f"{summary.done} records written, {summary.skipped} already done, {summary.seconds:.1f} s -> {out}; "
        f"report: attribot report {out}",
        highlight=False,
    )


def _run_eval_shown(
    plan: Any, settings: Any, out: Path, *, workers: int, executor: str, dataset: Path | None
) -> Any:
    """Run the evaluation with a progress bar on stderr (the items done, their rate, the time left) and the
    run's notes printed above it; return its summary."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from attribot.eval.run import run_eval

    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[rate]}"),
        TimeRemainingColumn(),
        console=err_console,
        transient=False,
    ) as bar:
        job = bar.add_task("items", total=None, rate="")
        started = time.perf_counter()

        def on_record(record: Any, finished: int, total: int) -> None:
            rate = finished / max(time.perf_counter() - started, 1e-9)
            bar.update(job, completed=finished, total=total, rate=f"{rate:.1f}/s", description=record.task)

        return run_eval(
            plan,
            settings,
            out,
            workers=workers,
            executor=executor,
            progress=lambda msg: bar.update(job, description=msg),
            on_record=on_record,
            dataset=dataset,
            note=lambda line: bar.console.print(line, highlight=False),
        )


def report(
    runs: list[Path] = typer.Argument(
        ...,
        help="A run folder written by attribot eval, or several made with different detectors, reported side "
        "by side on the items they share.",
    ),
    out: Path | None = typer.Option(
        None, "--out", help="The HTML file (default: RUN/report.html; FIRST_RUN/compared.html for several)."
    ),
) -> None:
    """Write the run's report: one self-contained HTML file; its figures and Table I in LaTeX beside it."""
    from attribot.errors import InputError
    from attribot.eval.compare import read_runs
    from attribot.eval.report import answer_lines, default_out, summarize, write_report
    from attribot.files import check_target

    for run in runs:
        if not (run / "records").is_dir():
            raise InputError(f"{run} holds no run (no records/)", "run attribot eval --out DIR first")
    writable_folder((out or default_out(runs)).parent, "--out")
    check_target(out or default_out(runs), "--out", "give --out a path where an HTML file can be written")
    path = write_report(runs, out)
    for line in answer_lines(summarize(read_runs(list(runs)).records)):
        console.print(line, highlight=False)
    console.print(f"report -> {path}", highlight=False)
