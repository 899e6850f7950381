"""The items a closed-set detector can be judged on: those whose objects are among its classes.

A detector trained on a closed set of classes (the `coco` backend: COCO's 80) cannot find a kettle, so an
item whose query chooses among a kettle, a mug and a book measures the detector's vocabulary, not the
method. A run with such a detector keeps the items whose `object_categories` (the objects the query
chooses among, from the world's truth) the detector says it can find: it is asked itself
(`attribot.models.base.can_find`), nothing here knows its classes. `--findable-by SPEC` takes the subset
of another detector, so that the oracle runs on the items the coco detector is judged on. An
open-vocabulary detector keeps every item. The run says per task how many items of how many it kept, and
which categories left the others out.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from attribot.models.base import Detector, build_backend, can_find

if TYPE_CHECKING:
    from attribot.config import Settings
    from attribot.eval.datasets import Item

__all__ = ["Subset", "closed_set_detector", "findable_items"]


@dataclass(frozen=True)
class Subset:
    """Which items a closed-set detector keeps: per task, (kept, of) and the categories it cannot find
    with the number of items each left out."""

    spec: str  # the detector spec asked, as the run was given it
    name: str  # the detector's own name
    kept: dict[str, tuple[int, int]] = field(default_factory=dict)
    left_out: dict[str, Counter[str]] = field(default_factory=dict)

    @property
    def rule(self) -> str:
        return (
            f"items whose objects are all among the classes of the detector {self.spec} ({self.name}): the "
            "true object and those its query chooses among"
        )

    def says(self, task: str) -> str:
        """What was kept of `task`: "62 of 100 items kept; 38 left out, with objects ... (kettle 20, ...)"."""
        kept, of = self.kept[task]
        text = f"{kept} of {of} items kept"
        if kept < of:
            why = ", ".join(f"{c} {n}" for c, n in self.left_out[task].most_common())
            text += f"; {of - kept} left out, with objects {self.spec} cannot find ({why})"
        return text

    def lines(self) -> list[str]:
        """One line per task, for the console."""
        return [f"{task}: {self.says(task)}" for task in self.kept]

    def as_json(self) -> dict[str, str]:
        """What the run's `run.json` keeps under "items": the rule and what was kept of each task."""
        return {"rule": self.rule, **{task: self.says(task) for task in self.kept}}


def closed_set_detector(spec: str, settings: Settings) -> Detector | None:
    """The detector of `spec`, built to ask what it can find; None when it is open-vocabulary (it takes any
    name, and every item is kept)."""
    detector = build_backend("detector", spec, settings)
    return detector if getattr(detector, "can_find", None) is not None else None


def findable_items(items: list[Item], spec: str, detector: Detector) -> tuple[list[Item], Subset]:
    """The items whose object categories `detector` can all find, in their order, and what was kept."""
    known: dict[str, bool] = {}
    subset = Subset(spec=spec, name=detector.name)
    kept: list[Item] = []
    for item in items:
        missing = []
        for category in item.object_categories:
            if category not in known:
                known[category] = can_find(detector, category)
            if not known[category]:
                missing.append(category)
        if not item.object_categories:
            missing.append("(no categories recorded)")
        had, of = subset.kept.get(item.task, (0, 0))
        subset.left_out.setdefault(item.task, Counter()).update(missing)
        subset.kept[item.task] = (had + (not missing), of + 1)
        if not missing:
            kept.append(item)
    return kept, subset
