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
from dataclasses import asdict, dataclass, field
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from attribot.config import SECRETS, Settings
from attribot.errors import ConfigError, InputError
from attribot.eval.datasets import (
    DATASET_VERSION,
    Item,
    build_items,
    check_root_seed,
    drawn_in,
    item_count,
    read_dataset,
    read_jsonl,
    write_dataset,
)
from attribot.eval.methods import (
    PROGRAM_METHODS,
    Condition,
    Record,
    paper_methods,
    run_method,
)
from attribot.eval.subset import Subset, closed_set_detector, findable_items
from attribot.eval.suite import METHODS, task_names
from attribot.files import (
    disk_full,
    inside,
    make_folder,
    not_a_file,
    read_capped,
    read_json,
    write_whole,
)
from attribot.models.base import findable_categories, without_oracle_vqa
from attribot.registry import import_plugins, plugin_modules
from attribot.shutdown import die_with_parent

__all__ = [
    "EvalPlan",
    "RunSummary",
    "RunLock",
    "run_eval",
    "read_records",
    "read_about",
    "records_path",
    "worker_pool",
]
_RUN_FIX = "give a run folder written by attribot eval, unchanged, or another --out"
MAX_RECORD_BYTES = 16 * 1024 * 1024
"""The longest records line looked for at the end of a records file (a record is a few kB)."""
_IMAGE_BYTES = 50 * 1024 * 1024
"""The largest dataset image copied into a run (ours are PNGs of a few hundred kB)."""

Job = tuple[Item, str, Condition]  # item, method, run condition


@dataclass(frozen=True)
class EvalPlan:
    """What to run: tasks, methods (None: the paper's per task), run conditions (noise levels and ablations,
    given as `Condition`s or by their names, which are read here, once), at most `limit` per task, and the
    detector whose classes choose the items (None: the run's own; see `attribot.eval.subset`)."""

    tasks: tuple[str, ...] = field(default_factory=lambda: tuple(task_names()))
    methods: tuple[str, ...] | None = None
    noise: tuple[Condition, ...] = (Condition("clean"),)
    limit: int | None = None
    findable_by: str | None = None
    seed: int = 0  # the root seed every item's seeds derive from (`attribot.eval.datasets.task_seeds`)

    def __post_init__(self) -> None:
        conditions = tuple(c if isinstance(c, Condition) else Condition.parse(c) for c in self.noise)
        object.__setattr__(self, "noise", conditions)
        for name, given, known in (
            ("task", self.tasks, task_names(None)),
            ("method", self.methods or (), METHODS.names()),
        ):
            unknown = [g for g in given if g not in known]
            if unknown:
                raise InputError(f"unknown {name} {', '.join(unknown)}", f"choose from: {', '.join(known)}")
        if self.limit is not None and self.limit < 1:
            raise InputError(f"--limit {self.limit} runs nothing", "give a limit of 1 or more")
        check_root_seed(self.seed)  # a root out of range fails before any work

    def methods_for(self, task: str) -> tuple[str, ...]:
        return self.methods if self.methods is not None else paper_methods(task)


@dataclass(frozen=True)
class RunSummary:
    done: int  # records written by this call
    skipped: int  # finished before, not run again
    seconds: float
    out: Path
    subset: Subset | None = None  # the items a closed-set detector kept, per task; None: every item


MACHINE_LOCAL = frozenset({"cache_dir", "coco_dir", "yolov5_dir", "hf_device"})
"""Settings no record depends on: where files are kept and which device runs a model (the same weights,
hash-checked, anywhere): a run resumes on another machine."""
RECORDED = tuple(n for n in Settings.model_fields if n not in set(SECRETS) | MACHINE_LOCAL)
"""The settings a run keeps in its run.json: every one but the secrets and the machine-local ones."""


def fingerprint(
    settings: Settings,
    subset: str | None = None,
    vocabulary: tuple[str, ...] | None = None,
    seed: int = 0,
) -> dict[str, Any]:
    """The settings a record depends on (`RECORDED`: a run refuses to mix records made with different
    ones), the dataset's version, `subset` (the closed-set detector whose classes chose the items; None:
    every item), `vocabulary` (the categories it can find, in which the embodied tasks' items are drawn;
    None: the catalog's) and `seed`, the root seed of the items (written only when it is not 0, so that
    runs made before it was one still resume). A password in a URL is not written down
    (`Settings.public_dict`)."""
    values = settings.public_dict()
    about = {
        "dataset_version": DATASET_VERSION,
        **{key: values[key] for key in RECORDED},
        "subset": subset,
        "vocabulary": None if vocabulary is None else list(vocabulary),
    }
    return {**about, "seed": seed} if seed else about


def records_path(out: Path, task: str, method: str, noise: str) -> Path:
    return out / "records" / f"{task}__{method}__{noise}.jsonl"


def _identity(record: Record) -> tuple[str, str, str, str]:
    """What makes a record the one record of its kind in a run: its item, task, method and noise level
    (read from the record itself, never from the name of the file it sits in)."""
    return (record.task, record.id, record.method, record.noise)


def read_records(out: Path) -> list[Record]:
    """Every record of a run directory (a torn last line, from a crash mid-write, is skipped), each counted
    once whatever the names of the files it sits in: a copy of a records file under another noise level's
    name adds nothing.

    An item recorded twice with different results for one method and noise level (two runs that wrote into
    one folder) is an `InputError`: counted twice, it would narrow every interval of the report."""
    records: list[Record] = []
    seen: dict[tuple[str, str, str, str], tuple[Path, str]] = {}
    for path in _records_files(out):
        in_file: dict[str, int] = {}
        twice: list[str] = []
        for record in _records_in(path):
            key = _identity(record)
            in_file[record.id] = in_file.get(record.id, 0) + 1
            if in_file[record.id] == 2:
                twice.append(record.id)
            text = record.model_dump_json()
            if key in seen:
                if seen[key][1] != text and in_file[record.id] == 1:
                    raise InputError(
                        f"{path} and {seen[key][0]} record {record.id} ({record.method}, {record.noise}) "
                        f"with different results: two runs wrote into {out}",
                        "run the evaluation again into a new --out (one run per folder)",
                    )
                continue  # the same record again (a copied file): counted once
            seen[key] = (path, text)
            records.append(record)
        if twice:
            raise InputError(
                f"{path} records {len(twice)} item(s) more than once ({', '.join(sorted(twice)[:3])}"
                f"{', ...' if len(twice) > 3 else ''}): two runs wrote into {out}",
                "run the evaluation again into a new --out (one run per folder; attribot eval now locks it)",
            )
    return records


class RunLock:
    """An exclusive lock on a run folder (`.lock`, held with flock): a second `attribot eval` into the same
    folder is refused at once, not left to interleave its records with the first's. The kernel drops the
    lock when the process ends, however it ends, so a killed run leaves no stale lock."""

    def __init__(self, out: Path) -> None:
        import fcntl

        try:
            out.mkdir(parents=True, exist_ok=True)
            # never through a link: a run folder from elsewhere could point .lock at a file to truncate
            fd = os.open(out / ".lock", os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644)
        except OSError as exc:
            raise InputError(
                f"the run folder {out} cannot be written ({exc.strerror or exc})", "give a writable --out"
            ) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 64).decode("ascii", "replace").strip() or "?"
            os.close(fd)
            raise InputError(
                f"another attribot eval (process {holder}) is writing into {out}",
                "wait for it to finish, or give another --out; two runs must not write one folder",
            ) from None
        except OSError as exc:
            os.close(fd)
            raise InputError(f"{out} cannot be locked ({exc.strerror})", "give another --out") from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode("ascii"))
        self._fd: int | None = fd

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)  # closing the descriptor drops the flock
            self._fd = None

    def __enter__(self) -> RunLock:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def _set_aside_torn(path: Path) -> str | None:
    """A records file whose last line was torn by a crash mid-write: the fragment is moved to
    `<name>.torn` and the file cut back to its last whole line, so that the next record starts on a line
    of its own. Returns a note when it did so."""
    if not path.is_file():
        return None
    with path.open("rb+") as f:
        size = f.seek(0, os.SEEK_END)
        if size == 0:
            return None
        f.seek(size - 1)
        if f.read(1) == b"\n":
            return None
        keep = size  # the end of the last whole line: looked for backwards, a block at a time
        while keep > 0:
            if size - keep > MAX_RECORD_BYTES:
                raise InputError(
                    f"the records file {str(path)!r} ends in more than {MAX_RECORD_BYTES:,} bytes that "
                    "are no record (no line ends there)",
                    _RUN_FIX,
                )
            start = max(0, keep - (1 << 16))
            f.seek(start)
            block = f.read(keep - start)
            at = block.rfind(b"\n")
            keep = start if at < 0 else start + at + 1
            if at >= 0:
                break
        f.seek(keep)
        fragment = f.read(min(size - keep, 1 << 20))  # a torn record is kept as far as the first MB
        torn = os.open(
            path.with_name(path.name + ".torn"), os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW
        )
        try:
            os.write(torn, fragment + b"\n")
        finally:
            os.close(torn)
        f.truncate(keep)
    return f"{path.name}: a record torn by a crash was set aside in {path.name}.torn"


def read_about(out: Path) -> dict[str, Any]:
    """The run folder's run.json (the settings its records were made with), read within bounds; {} when
    there is none."""
    if not (out / "run.json").exists():
        return {}
    about = read_json(inside(out, "run.json", "the run's settings", _RUN_FIX), "the run's settings", _RUN_FIX)
    if not isinstance(about, dict):
        raise InputError(f"the run's settings {str(out / 'run.json')!r} are not a table", _RUN_FIX)
    # a run made before a setting was kept was made with its default (there was no other way then)
    return {**{key: Settings.model_fields[key].default for key in RECORDED}, **about} if about else about


def _records_files(out: Path) -> list[Path]:
    """The records files of a run folder, each inside it (a link that leads out is refused)."""
    folder = out / "records"
    if not folder.is_dir():
        return []
    return [
        inside(out, f"records/{p.name}", "the records file", _RUN_FIX) for p in sorted(folder.glob("*.jsonl"))
    ]


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 120 else text[:117] + "..."


def _check_run(
    out: Path, settings: Settings, subset: str | None, vocabulary: tuple[str, ...] | None, seed: int
) -> None:
    want = fingerprint(settings, subset, vocabulary, seed)
    have = read_about(out)
    newer = sorted(set(have) - set(want) - {"seed", "items"})
    if newer:
        shown = ", ".join(_shown(k) for k in newer[:5]) + (", ..." if len(newer) > 5 else "")
        raise ConfigError(
            f"{out / 'run.json'} holds setting(s) this release of attribot does not know ({shown}): a newer "
            "release made the run, and resuming it here would ignore them",
            "resume it with the release that made it, or give another --out",
        )
    if have:
        # a run folder without a root seed was made with 0: it was the only one
        ours, theirs = {**want, "seed": seed}, {"seed": 0, **have}
        differ = [k for k in ours if theirs.get(k) != ours[k]]
        if differ:
            detail = "; ".join(
                f"{k}: this run {_shown(ours[k])}, the directory {_shown(theirs.get(k))}" for k in differ
            )
            raise ConfigError(
                f"{out} holds a run made with other settings ({detail})",
                "run with the same settings to resume it, or give another --out",
            )
        return
    out.mkdir(parents=True, exist_ok=True)
    write_whole(out / "run.json", (json.dumps(want, indent=2) + "\n").encode("utf-8"))


def _counter(progress: Callable[[str], None], what: str, total: int) -> Callable[[Item], None]:
    """A callback that says "`what`: done/total" each time it is called."""
    done = [0]

    def count(_item: Item) -> None:
        done[0] += 1
        progress(f"{what}: {done[0]}/{total}")

    return count


def _first(items: dict[str, Item], task: str, n: int) -> list[Item]:
    """The task's first `n` items by id: the ones `build_items` makes for that count, whatever else the
    dataset holds (a resumed run takes the same items as the first, so its counts agree)."""
    return sorted((i for i in items.values() if i.task == task), key=lambda i: i.id)[:n]


def _dataset(
    out: Path,
    plan: EvalPlan,
    progress: Callable[[str], None],
    source: Path | None = None,
    source_items: list[Item] | None = None,
    vocabulary: tuple[str, ...] | None = None,
) -> list[Item]:
    """The plan's items: from the run's dataset when it holds them, else taken from the built dataset at
    `source` (`source_items`, with its images) or generated, and added to the run's dataset. `vocabulary`:
    the categories the run's closed-set detector can find, in which the tasks that can be are drawn."""
    folder = out / "dataset"
    have = {i.id: i for i in read_dataset(folder)} if (folder / "manifest.jsonl").is_file() else {}
    given = None if source is None else {i.id: i for i in source_items or []}
    items: list[Item] = []
    missing: list[Item] = []
    for task in plan.tasks:
        need = item_count(task, plan.limit)
        within = drawn_in(task, vocabulary)
        present = _first(have, task, need)
        if len(present) == need and all(i.vocabulary == within for i in present):
            items += present
            continue
        if given is not None and source is not None:
            built = _first(given, task, need)
            if len(built) < need:
                raise InputError(
                    f"the dataset at {source} holds {len(built)} {task} items, and this run needs {need}",
                    f"give a --limit it covers, or build it with more: attribot dataset build --tasks {task}",
                )
            absent = [i.id for i in built if not (source / "images" / f"{i.id}.png").exists()]
            if absent:
                raise InputError(
                    f"the dataset at {source} has no image of {', '.join(absent[:3])}",
                    "build it again with attribot dataset build",
                )
            _same_vocabulary(task, built, within, source)
            progress(f"taking {need} {task} items from {source}")
        else:
            progress(f"generating {task} items: 0/{need}")
            built = build_items(
                [task],
                plan.limit,
                on_item=_counter(progress, f"generating {task} items", need),
                vocabulary=vocabulary,
                seed=plan.seed,
            )
        items += built
        missing += [i for i in built if have.get(i.id) != i]
    if missing:
        _add_to_dataset(folder, have, missing, progress, source if given is not None else None)
    return items


def _same_vocabulary(task: str, items: list[Item], within: list[str] | None, source: Path) -> None:
    """Refuses a built dataset whose `task` items were drawn in another vocabulary than this run draws in."""
    other = next((i for i in items if i.vocabulary != within), None)
    if other is None:
        return
    if other.vocabulary is None:
        what = "in any category of the catalog, and this run draws them in those its detector can find"
    elif within is None:
        what = "in the categories a closed-set detector can find, and this run draws them in any category"
    else:
        what = "in other categories than those this run's detector can find"
    raise InputError(
        f"the dataset at {source} drew its {task} items {what}",
        "build the dataset with the run's --findable-by (attribot dataset build --findable-by SPEC), or "
        "leave out --dataset to generate them",
    )


def _add_to_dataset(
    folder: Path,
    have: dict[str, Item],
    missing: list[Item],
    progress: Callable[[str], None],
    source: Path | None,
) -> None:
    """Add `missing` to the run's dataset at `folder`: their images copied from the built dataset at
    `source`, or rendered; the manifest rewritten with every item, in the suite's order."""
    fix = "give a run folder written by attribot eval, unchanged, or another --out"
    make_folder(folder, "the run's dataset folder", fix)  # never a link planted to lead the images out
    make_folder(folder / "images", "the run's dataset images folder", fix)
    if source is not None:
        for item in missing:
            name = f"images/{item.id}.png"
            image = inside(
                source, name, "the dataset image", "build the dataset again with attribot dataset build"
            )
            write_whole(
                folder / name, read_capped(image, "the dataset image", _IMAGE_BYTES, "build it again")
            )
    else:
        rendered = _counter(progress, "rendering images", len(missing))
        make_folder(folder / "new", "the run's dataset folder", fix)
        write_dataset(missing, folder / "new", images=True, on_image=rendered)
        for image in (folder / "new" / "images").glob("*.png"):
            image.replace(folder / "images" / image.name)
    merged = {**have, **{i.id: i for i in missing}}
    order = task_names(None)
    write_dataset(sorted(merged.values(), key=lambda i: (order.index(i.task), i.id)), folder, images=False)
    for leftover in (folder / "new").rglob("*"):
        if leftover.is_file():
            leftover.unlink()
    for sub in (folder / "new" / "images", folder / "new"):
        if sub.is_dir():
            sub.rmdir()


def _jobs(items: Iterable[Item], plan: EvalPlan, out: Path) -> tuple[list[Job], int]:
    # by what each record says, whatever its file's name; what is no file (a FIFO) holds no record to skip
    done = {_identity(r) for p in _records_files(out) if not_a_file(p) is None for r in _records_in(p)}
    jobs, skipped = [], 0
    for item in items:
        for method in plan.methods_for(item.task):
            for condition in plan.noise:
                if condition.ablation and method not in PROGRAM_METHODS:
                    continue  # an ablation of the error-catching mechanisms: only programs have them
                if (item.task, item.id, method, condition.name) in done:
                    skipped += 1
                else:
                    jobs.append((item, method, condition))
    return jobs, skipped


def _records_in(path: Path) -> Iterator[Record]:
    """The records of one file (an unfinished last line, from a crash mid-write, is left out; any other
    line that is no record is an `InputError` naming it)."""
    if not path.exists():
        return
    for _, record in read_jsonl(path, Record, "the records file", _RUN_FIX):
        yield record


class WorkerFailed(Exception):
    """What ended a job in a worker process or Ray task, as one line of text (an exception of a plug-in's
    own class may not unpickle in the parent; `sys.exit` there is a failure, never the run's success)."""


def _worker_line(exc: BaseException, what: str) -> str:
    if isinstance(exc, SystemExit):
        text = f"{what} called sys.exit({exc.code!r})"
    else:
        told = getattr(exc, "message", None) or str(exc)
        text = (
            f"{what} failed: {type(exc).__name__}: {told}" if told else f"{what} failed: {type(exc).__name__}"
        )
    text = " ".join(text.split())
    return text if len(text) <= 400 else text[:397] + "..."


def _run_job(job_json: str, settings: Settings) -> str:
    """One job in a worker process or Ray task: the job's JSON and the settings (pickled, secrets and all:
    JSON would mask them) in, the record's JSON out. The job names the command's plug-ins, imported here
    first: a worker has none of the command's imports, and a Ray node not its environment either. Anything
    that ends the job otherwise (a plug-in that fails to import, `sys.exit` anywhere) is a `WorkerFailed`."""
    job = json.loads(job_json)
    try:
        import_plugins(job["plugins"])
    except BaseException as exc:  # noqa: BLE001 (a plug-in's failure, whatever it is, is told in one line)
        names = ", ".join(job["plugins"])
        raise WorkerFailed(
            _worker_line(exc, f"a plug-in ({names[:100]}) imported in an eval worker")
        ) from None
    try:
        item = Item.model_validate(job["item"])
        condition = Condition(**job["condition"])
        return run_method(item, job["method"], settings, condition).model_dump_json()
    except BaseException as exc:  # noqa: BLE001
        raise WorkerFailed(_worker_line(exc, f"{job['method']} on item {job['item'].get('id')}")) from None


def _worker_result(future: Any) -> Record:
    """The record a worker sent back; a worker that failed or ended early is a `ConfigError` in one line
    (never a traceback, never a success with no records)."""
    from concurrent.futures.process import BrokenProcessPool

    fix = "fix the plug-in (or take it out of ATTRIBOT_PLUGINS) and run the same command again: it resumes"
    try:
        return Record.model_validate_json(future.result())
    except WorkerFailed as exc:
        raise ConfigError(f"an eval worker stopped the run: {exc}", fix) from None
    except BrokenProcessPool:
        raise ConfigError(
            "an eval worker process ended early (os._exit, a crash, or killed) before sending its record",
            fix,
        ) from None


def _job_json(job: Job) -> str:
    item, method, condition = job
    return json.dumps(
        {
            "item": item.model_dump(mode="json"),
            "method": method,
            "condition": asdict(condition),  # its parsed form: the worker reads no name again
            "plugins": plugin_modules(),
        }
    )


def run_eval(
    plan: EvalPlan,
    settings: Settings,
    out: Path,
    workers: int = 1,
    executor: str = "local",
    progress: Callable[[str], None] | None = None,
    on_record: Callable[[Record, int, int], None] | None = None,
    dataset: Path | None = None,
    note: Callable[[str], None] | None = None,
) -> RunSummary:
    """Run the plan into `out` (see the module docstring). `on_record(record, finished, total)` is called
    as each record is written (the CLI's progress bar); `note(line)` with what the run should say once
    (the items a closed-set detector kept, per task). `dataset`: a folder made by `attribot dataset
    build`, whose items and images the run takes instead of generating them.

    The run holds a lock on `out` throughout: a second run into it is refused with an `InputError`."""
    if workers < 1:
        raise InputError(f"--workers {workers} runs nothing", "give 1 or more workers")
    most = 4 * (os.cpu_count() or 1)
    if executor == "local" and workers > most:  # each is a process with its own simulator and renderer
        raise InputError(
            f"--workers {workers} starts more processes than this machine's {os.cpu_count()} CPUs can run",
            f"give at most {most} (about one per CPU is fastest), or run on a cluster: --executor ray",
        )
    if executor not in ("local", "ray"):
        raise InputError(f"unknown executor {executor!r}", "choose local or ray")
    if dataset is not None and (dataset / "dataset" / "manifest.jsonl").is_file():
        dataset = dataset / "dataset"  # a run folder's dataset
    given = None if dataset is None else read_dataset(dataset)  # a wrong folder fails before any work
    say = progress or (lambda _msg: None)
    started = time.perf_counter()
    # the detector whose classes choose the items, asked before any work (a bad spec fails here)
    chooser = plan.findable_by or str(settings.detector)
    closed = closed_set_detector(chooser, settings)
    real_eyes = without_oracle_vqa(settings)
    if real_eyes is not None:
        settings = real_eyes
        (note or say)("a real detector's run uses no oracle VQA: --vqa none (give --vqa SPEC for a real one)")
    vocabulary = None if closed is None else findable_categories(closed)
    with RunLock(out):
        _check_run(out, settings, chooser if closed is not None else None, vocabulary, plan.seed)
        summary = _run_locked(plan, settings, out, workers, executor, say, on_record, dataset, given, started,
                              _Chooser(chooser, closed, note or say, vocabulary))  # fmt: skip
    return summary


@dataclass(frozen=True)
class _Chooser:
    """The closed-set detector that chooses a run's items (None: every item is kept), where to say what it
    kept, and the categories it can find (in which the tasks that can be are drawn; None: any)."""

    spec: str
    detector: Any
    note: Callable[[str], None]
    vocabulary: tuple[str, ...] | None = None

    def choose(self, out: Path, items: list[Item]) -> tuple[list[Item], Subset | None]:
        if self.detector is None:
            return items, None
        kept, subset = findable_items(items, self.spec, self.detector)
        about = read_about(out)
        write_whole(
            out / "run.json", (json.dumps({**about, "items": subset.as_json()}, indent=2) + "\n").encode()
        )
        self.note(f"the detector {self.spec} is closed-set: {subset.rule}")
        for line in subset.lines():
            self.note(line)
        return kept, subset


def _run_locked(
    plan: EvalPlan,
    settings: Settings,
    out: Path,
    workers: int,
    executor: str,
    say: Callable[[str], None],
    on_record: Callable[[Record, int, int], None] | None,
    dataset: Path | None,
    given: list[Item] | None,
    started: float,
    chooser: _Chooser,
) -> RunSummary:
    for path in _records_files(out):
        note = _set_aside_torn(path)
        if note is not None:
            say(note)
    items, subset = chooser.choose(out, _dataset(out, plan, say, dataset, given, chooser.vocabulary))
    jobs, skipped = _jobs(items, plan, out)
    total = len(jobs)
    finished = 0
    with _RecordsWriter(out) as writer:
        for record in _execute(jobs, settings, workers, executor):
            writer.write(record, finished + skipped)
            finished += 1
            if on_record is not None:
                on_record(record, finished, total)
    return RunSummary(
        done=finished, skipped=skipped, seconds=time.perf_counter() - started, out=out, subset=subset
    )


class _RecordsWriter:
    """Appends records to their files, a line each, written out at once with one system call, so that a
    record is on disk before the next is run. A write that fails (the disk full) ends the run with an
    `InputError` that says how many records are kept; the unfinished line, if any, is set aside when the
    run resumes (`_set_aside_torn`), so that nothing written before is lost."""

    def __init__(self, out: Path) -> None:
        self.out = out
        self.fds: dict[Path, int] = {}

    def write(self, record: Record, kept: int) -> None:
        path = records_path(self.out, record.task, record.method, record.noise)
        line = (record.model_dump_json() + "\n").encode("utf-8")
        try:
            if path not in self.fds:  # never through a link out of the run folder
                path.parent.mkdir(parents=True, exist_ok=True)
                inside(self.out, f"records/{path.name}", "the records file", _RUN_FIX)
                flags = os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC
                self.fds[path] = os.open(path, flags, 0o644)
            view = memoryview(line)
            while view:
                view = view[os.write(self.fds[path], view) :]
        except OSError as exc:
            mend = (
                "free some space (the disk or your quota is full, or move the run folder to a disk with room)"
                if disk_full(exc)
                else f"make {path} a file that can be written"
            )
            raise InputError(
                f"writing the records in {self.out} failed ({exc.strerror or exc}): the run stopped after "
                f"{kept} records, which are kept in {self.out / 'records'}",
                f"{mend} and run the same command again: it resumes where it stopped",
            ) from None

    def close(self) -> None:
        for fd in self.fds.values():
            os.close(fd)
        self.fds.clear()

    def __enter__(self) -> _RecordsWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def worker_pool(workers: int) -> ProcessPoolExecutor:
    """The local executor's pool. Spawned workers: each builds its own renderer (a forked EGL context is
    not safe); each dies with this process, however it ends (after a kill -9 they ran on, 360 MB each)."""
    return ProcessPoolExecutor(
        max_workers=workers,
        mp_context=get_context("spawn"),
        initializer=die_with_parent,
        initargs=(os.getpid(),),
    )


def _execute(jobs: list[Job], settings: Settings, workers: int, executor: str) -> Iterator[Record]:
    if not jobs:
        return
    if executor == "ray":
        yield from _execute_ray(jobs, settings)
        return
    if workers == 1:
        for item, method, condition in jobs:
            try:
                record = run_method(item, method, settings, condition)
            except SystemExit as exc:  # a plug-in's sys.exit: a failure, never the run's success
                raise ConfigError(
                    _worker_line(exc, f"{method} on item {item.id}"),
                    "a plug-in returns or raises; fix it, or take it out of ATTRIBOT_PLUGINS",
                ) from None
            yield record
        return
    from concurrent.futures.process import BrokenProcessPool

    with worker_pool(workers) as pool:
        try:
            pending = {pool.submit(_run_job, _job_json(j), settings) for j in jobs[: workers * 4]}
            queued = jobs[workers * 4 :]
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    yield _worker_result(future)
                    if queued:
                        pending.add(pool.submit(_run_job, _job_json(queued.pop(0)), settings))
        except BrokenProcessPool:  # a worker that ended early, seen as the next job was handed over
            raise ConfigError(
                "an eval worker process ended early (os._exit, a crash, or killed) before sending its record",
                "fix the plug-in (or take it out of ATTRIBOT_PLUGINS) and run the same command again: it "
                "resumes",
            ) from None


def _execute_ray(jobs: list[Job], settings: Settings) -> Iterator[Record]:
    from attribot.deps import require

    ray = require("ray", "the ray executor (--executor ray)")
    started_here = not ray.is_initialized()
    if started_here:
        address = os.environ.get("RAY_ADDRESS") or None
        ray.init(address=address, ignore_reinit_error=True, log_to_driver=False, include_dashboard=False)
    try:
        remote = ray.remote(num_cpus=1)(_run_job)
        pending = [remote.remote(_job_json(j), settings) for j in jobs]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                try:
                    text = ray.get(ref)
                except Exception as exc:  # noqa: BLE001 (Ray wraps the task's WorkerFailed)
                    cause = getattr(exc, "cause", None) or exc
                    raise ConfigError(
                        f"an eval task stopped the run: {' '.join(str(cause).split())[:400]}",
                        "fix the plug-in (or take it out of ATTRIBOT_PLUGINS) and run the same command again",
                    ) from None
                yield Record.model_validate_json(text)
    finally:
        if started_here:
            ray.shutdown()
