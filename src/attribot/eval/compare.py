"""Several run folders read as one report: the same items, each run with its own detector, side by side.

A run folder never mixes settings, so a real detector is set beside the oracle by running each into its own
folder (`attribot eval --detector coco --out runs/coco`, `attribot eval --out runs/oracle`) and reporting
them together (`attribot report runs/oracle runs/coco`). The runs must differ in their detector only (and
in the detector that chose their items); the same detector twice, another planner, other backends or
another dataset version are refused, naming the setting. Where several runs hold a task, every run is
counted on the items that all of them hold (a closed-set detector's subset, see `attribot.eval.subset`),
and the report says which; a task that one run alone holds is shown as it is, compared with nothing.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from attribot.errors import InputError
from attribot.eval.methods import Record
from attribot.eval.run import read_about, read_records
from attribot.eval.suite import task_names

__all__ = ["Runs", "read_runs", "SIDE_BY_SIDE"]

SIDE_BY_SIDE = ("detector", "vqa", "subset", "items", "vocabulary")
"""The entries of `run.json` in which runs reported together may differ (an item of one id drawn in two
vocabularies is not the same item, and is refused as such). The VQA goes with the detector: a real
detector's run asks no oracle VQA (`attribot.eval.run`), so the oracle's run beside it has another."""


@dataclass(frozen=True)
class Runs:
    """The runs of one report: their folders, their records (each naming its detector; restricted to the
    shared items where runs are compared), their settings (one value per run) and what was compared."""

    dirs: tuple[Path, ...]
    records: list[Record]
    settings: list[tuple[str, list[str]]]
    compared: list[str]  # one line per task: on which items the runs were compared, or why not


def _value(v: Any) -> str:
    if isinstance(v, dict):
        text = "; ".join(f"{k}: {_value(x)}" for k, x in v.items())
    else:
        text = "-" if v is None else str(v)
    return text if len(text) <= 500 else text[:497] + "..."  # a run.json from elsewhere may hold anything


def _check_side_by_side(dirs: tuple[Path, ...], abouts: list[dict[str, Any]]) -> None:
    """Refuses runs that differ in anything but their detector, or that share one."""
    keys = sorted({k for a in abouts for k in a} - set(SIDE_BY_SIDE))
    for key in keys:
        values = [a.get(key) for a in abouts]
        if any(v != values[0] for v in values):
            shown = ", ".join(f"{d}: {_value(v)}" for d, v in zip(dirs, values, strict=True))
            raise InputError(
                f"the runs differ in {key} ({shown}); a report sets side by side runs that differ only in "
                "their detector",
                "report them one by one, or run them again with the same settings but --detector",
            )
    detectors = [str(a.get("detector")) for a in abouts]
    twice = sorted({d for d in detectors if detectors.count(d) > 1})
    if twice:
        raise InputError(
            f"two of the runs were made with the same detector ({', '.join(twice)})",
            "give one run folder per detector",
        )


def _shared(dirs: tuple[Path, ...], per_run: list[list[Record]]) -> tuple[list[Record], list[str]]:
    """The records of the items every run that holds their task holds, and a line per task saying so."""
    records: list[Record] = []
    lines: list[str] = []
    for task in task_names():
        held = [(d, [r for r in rs if r.task == task]) for d, rs in zip(dirs, per_run, strict=True)]
        held = [(d, rs) for d, rs in held if rs]
        if not held:
            continue
        ids = [{r.id for r in rs} for _, rs in held]
        common = set.intersection(*ids)
        _same_items(task, held, common)
        counts = ", ".join(f"{d} {len(i)}" for (d, _), i in zip(held, ids, strict=True))
        if len(held) == 1:
            lines.append(f"{task}: only {held[0][0]} holds it ({len(common)} items), compared with nothing")
        else:
            lines.append(f"{task}: every run counted on the {len(common)} items all of them hold ({counts})")
        records += [r for _, rs in held for r in rs if r.id in common]
    return records, lines


def _same_items(task: str, held: list[tuple[Path, list[Record]]], common: set[str]) -> None:
    """Refuses two runs whose item of one id is not the same item (its query or its truth differ)."""
    seen: dict[str, tuple[Path, tuple[str, str, list[float]]]] = {}
    for run, rs in held:
        for r in rs:
            if r.id not in common:
                continue
            key = (r.query, r.true_id, r.true_box)
            first = seen.setdefault(r.id, (run, key))
            if first[1] != key:
                raise InputError(
                    f"{task} item {r.id} is not the same item in {first[0]} and {run}",
                    "report side by side only runs made from one dataset; to set the oracle beside a "
                    "closed-set detector, run it on that detector's items: attribot eval --findable-by SPEC",
                )


def read_runs(dirs: list[Path]) -> Runs:
    """The records and settings of the run folders `dirs` (one or several; see the module docstring)."""
    runs = tuple(dict.fromkeys(dirs))
    if len(runs) < len(dirs):
        raise InputError("a run folder is given twice", "give each run folder once")
    abouts = [read_about(d) for d in runs]
    per_run = [read_records(d) for d in runs]
    for about, records in zip(abouts, per_run, strict=True):
        for record in records:
            if record.detector is None:  # records made before they named it: the run's detector
                record.detector = str(about.get("detector", "oracle"))
    keys = list(dict.fromkeys(k for a in abouts for k in a))
    settings = [(k, [_value(a.get(k)) for a in abouts]) for k in keys]
    if len(runs) == 1:
        return Runs(runs, per_run[0], settings, [])
    _check_side_by_side(runs, abouts)
    records, compared = _shared(runs, per_run)
    return Runs(runs, records, settings, compared)
