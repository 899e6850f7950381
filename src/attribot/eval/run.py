"""Runs of the evaluation suite: items x methods x noise levels, resumable, on one machine or a Ray cluster.

A run directory holds `run.json` (the settings every record was made with), `dataset/` (the items and their
images) and `records/<task>__<method>__<noise>.jsonl`, one record a line, appended as results arrive and
flushed line by line, so that a stopped or crashed run loses at most the items under way. Running again
into the same directory skips every finished (item, method, noise) and refuses when the settings differ,
naming the setting.

Executors: `local` runs items in this process (`workers=1`) or in a pool of processes; `ray` runs them as
Ray tasks on the cluster at `RAY_ADDRESS` (a local Ray instance when none is set), streaming records back
into the same files.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from attribot.config import Settings
from attribot.errors import ConfigError, InputError
from attribot.eval.datasets import DATASET_VERSION, TASKS, Item, build_items, read_dataset, write_dataset
from attribot.eval.methods import METHODS, PAPER_METHODS, Record, check_condition, run_method

__all__ = ["EvalPlan", "RunSummary", "run_eval", "read_records", "records_path"]

Job = tuple[Item, str, str]  # item, method, noise


@dataclass(frozen=True)
class EvalPlan:
    """What to run: tasks, methods (None: the paper's per task), noise levels, at most `limit` per task."""

    tasks: tuple[str, ...] = TASKS
    methods: tuple[str, ...] | None = None
    noise: tuple[str, ...] = ("clean",)
    limit: int | None = None

    def __post_init__(self) -> None:
        for condition in self.noise:
            check_condition(condition)
        for name, given, known in (
            ("task", self.tasks, TASKS),
            ("method", self.methods or (), METHODS),
        ):
            unknown = [g for g in given if g not in known]
            if unknown:
                raise InputError(f"unknown {name} {', '.join(unknown)}", f"choose from: {', '.join(known)}")
        if self.limit is not None and self.limit < 1:
            raise InputError(f"--limit {self.limit} runs nothing", "give a limit of 1 or more")

    def methods_for(self, task: str) -> tuple[str, ...]:
        return self.methods if self.methods is not None else PAPER_METHODS[task]


@dataclass(frozen=True)
class RunSummary:
    done: int  # records written by this call
    skipped: int  # finished before, not run again
    seconds: float
    out: Path


def fingerprint(settings: Settings) -> dict[str, Any]:
    """The settings a record depends on: a run refuses to mix records made with different ones."""
    return {
        "dataset_version": DATASET_VERSION,
        "planner": settings.planner,
        "detector": str(settings.detector),
        "vqa": str(settings.vqa),
        "language": str(settings.language),
        "checks": settings.checks,
        "llm_model": getattr(settings, "llm_model", None),
        "llm_base_url": getattr(settings, "llm_base_url", None),
    }


def records_path(out: Path, task: str, method: str, noise: str) -> Path:
    return out / "records" / f"{task}__{method}__{noise}.jsonl"


def read_records(out: Path) -> list[Record]:
    """Every record of a run directory (a torn last line, from a crash mid-write, is skipped)."""
    records = []
    for path in sorted((out / "records").glob("*.jsonl")):
        for line in path.read_text(encoding="utf-8").splitlines():
            try:
                records.append(Record.model_validate_json(line))
            except ValueError:
                continue
    return records


def _check_run(out: Path, settings: Settings) -> None:
    want = fingerprint(settings)
    path = out / "run.json"
    if path.is_file():
        have = json.loads(path.read_text(encoding="utf-8"))
        differ = [k for k in want if have.get(k) != want[k]]
        if differ:
            detail = "; ".join(f"{k}: this run {want[k]!r}, the directory {have.get(k)!r}" for k in differ)
            raise ConfigError(
                f"{out} holds a run made with other settings ({detail})",
                "run with the same settings to resume it, or give another --out",
            )
        return
    out.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(want, indent=2) + "\n", encoding="utf-8")


def _dataset(out: Path, plan: EvalPlan, progress: Callable[[str], None]) -> list[Item]:
    """The plan's items: from the run's dataset when it holds them, else generated and added to it."""
    folder = out / "dataset"
    have = {i.id: i for i in read_dataset(folder)} if (folder / "manifest.jsonl").is_file() else {}
    wanted = [t for t in plan.tasks]
    items: list[Item] = []
    missing: list[Item] = []
    for task in wanted:
        built = build_items([task], plan.limit) if not _covered(have, task, plan.limit) else None
        if built is None:
            items += [i for i in have.values() if i.task == task][: plan.limit or None]
            continue
        progress(f"generating {len(built)} {task} items")
        items += built
        missing += [i for i in built if i.id not in have]
    if missing:
        write_dataset(missing, folder / "new", images=True)
        for image in (folder / "new" / "images").glob("*.png"):
            (folder / "images").mkdir(parents=True, exist_ok=True)
            image.replace(folder / "images" / image.name)
        merged = {**have, **{i.id: i for i in missing}}
        write_dataset(
            sorted(merged.values(), key=lambda i: (TASKS.index(i.task), i.id)), folder, images=False
        )
        for leftover in (folder / "new").rglob("*"):
            if leftover.is_file():
                leftover.unlink()
        for sub in (folder / "new" / "images", folder / "new"):
            if sub.is_dir():
                sub.rmdir()
    return items


def _covered(have: dict[str, Item], task: str, limit: int | None) -> bool:
    from attribot.eval.datasets import TASK_SIZES

    n = sum(1 for i in have.values() if i.task == task)
    need = TASK_SIZES[task] if limit is None else min(limit, TASK_SIZES[task])
    return n >= need * (2 if task == "size" else 1)


def _jobs(items: Iterable[Item], plan: EvalPlan, out: Path) -> tuple[list[Job], int]:
    done: dict[Path, set[str]] = {}
    jobs, skipped = [], 0
    for item in items:
        for method in plan.methods_for(item.task):
            for noise in plan.noise:
                if check_condition(noise)[1] != "all" and method not in ("attr-api", "pa-api"):
                    continue  # an ablation of the error-catching mechanisms: only programs have them
                path = records_path(out, item.task, method, noise)
                if path not in done:
                    done[path] = {r.id for r in _records_in(path)}
                if item.id in done[path]:
                    skipped += 1
                else:
                    jobs.append((item, method, noise))
    return jobs, skipped


def _records_in(path: Path) -> Iterator[Record]:
    if not path.is_file():
        return
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            yield Record.model_validate_json(line)
        except ValueError:
            continue


def _run_job(job_json: str, settings_json: str) -> str:
    """One job in a worker process or Ray task: JSON in, the record's JSON out."""
    job = json.loads(job_json)
    item = Item.model_validate(job["item"])
    settings = Settings.model_validate_json(settings_json)
    return run_method(item, job["method"], settings, job["noise"]).model_dump_json()


def _job_json(job: Job) -> str:
    item, method, noise = job
    return json.dumps({"item": item.model_dump(mode="json"), "method": method, "noise": noise})


def run_eval(
    plan: EvalPlan,
    settings: Settings,
    out: Path,
    workers: int = 1,
    executor: str = "local",
    progress: Callable[[str], None] | None = None,
    on_record: Callable[[Record, int, int], None] | None = None,
) -> RunSummary:
    """Run the plan into `out` (see the module docstring). `on_record(record, finished, total)` is called
    as each record is written (the CLI's progress bar)."""
    if workers < 1:
        raise InputError(f"--workers {workers} runs nothing", "give 1 or more workers")
    if executor not in ("local", "ray"):
        raise InputError(f"unknown executor {executor!r}", "choose local or ray")
    say = progress or (lambda _msg: None)
    started = time.perf_counter()
    _check_run(out, settings)
    items = _dataset(out, plan, say)
    jobs, skipped = _jobs(items, plan, out)
    total = len(jobs)
    handles: dict[Path, Any] = {}

    def write(record: Record) -> None:
        path = records_path(out, record.task, record.method, record.noise)
        if path not in handles:
            path.parent.mkdir(parents=True, exist_ok=True)
            handles[path] = path.open("a", encoding="utf-8")
        handles[path].write(record.model_dump_json() + "\n")
        handles[path].flush()

    finished = 0
    try:
        for record in _execute(jobs, settings, workers, executor):
            write(record)
            finished += 1
            if on_record is not None:
                on_record(record, finished, total)
    finally:
        for handle in handles.values():
            handle.close()
    return RunSummary(done=finished, skipped=skipped, seconds=time.perf_counter() - started, out=out)


def _execute(jobs: list[Job], settings: Settings, workers: int, executor: str) -> Iterator[Record]:
    if not jobs:
        return
    settings_json = settings.model_dump_json()
    if executor == "ray":
        yield from _execute_ray(jobs, settings_json)
        return
    if workers == 1:
        for item, method, noise in jobs:
            yield run_method(item, method, settings, noise)
        return
    # spawned workers: each builds its own renderer (a forked EGL context is not safe)
    with ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn")) as pool:
        pending = {pool.submit(_run_job, _job_json(j), settings_json) for j in jobs[: workers * 4]}
        queued = jobs[workers * 4 :]
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                yield Record.model_validate_json(future.result())
                if queued:
                    pending.add(pool.submit(_run_job, _job_json(queued.pop(0)), settings_json))


def _execute_ray(jobs: list[Job], settings_json: str) -> Iterator[Record]:
    from attribot.deps import require

    ray = require("ray", "the ray executor (--executor ray)")
    started_here = not ray.is_initialized()
    if started_here:
        address = os.environ.get("RAY_ADDRESS") or None
        ray.init(address=address, ignore_reinit_error=True, log_to_driver=False, include_dashboard=False)
    try:
        remote = ray.remote(num_cpus=1)(_run_job)
        pending = [remote.remote(_job_json(j), settings_json) for j in jobs]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                yield Record.model_validate_json(ray.get(ref))
    finally:
        if started_here:
            ray.shutdown()
