"""The items a closed-set detector can be judged on: those whose objects are among its classes.

A detector trained on a closed set of classes (the `coco` backend: COCO's 80) cannot find a kettle, so an
item whose query chooses among a kettle, a mug and a book measures the detector's vocabulary, not the
method. Two rules make a closed-set run's items, per task:
- drawn: a task that can be drawn in a vocabulary (`Task.build_in_vocabulary`, the embodied tasks) draws
  its items in scenes whose objects are all of the catalog categories the detector can find
  (`attribot.models.base.findable_categories`), and every item is kept;
- kept: for the other tasks (the still-image ones), the run keeps the items whose `object_categories` (the
  objects the query chooses among, from the world's truth) the detector says it can find.
Either way the detector is asked itself (`attribot.models.base.can_find`): nothing here knows its classes.
`--findable-by SPEC` takes the items of another detector, so that the oracle runs on exactly the items the
coco detector is judged on (the same seeds, scenes and queries). An open-vocabulary detector keeps every
item of the catalog's scenes. The run says per task which rule made its items, how many it kept of how
many, and which categories left the others out.
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
    drawn: set[str] = field(default_factory=set)  # the tasks whose items were drawn in its vocabulary

    @property
    def rule(self) -> str:
        kept = (
            f"items whose objects are all among the classes of the detector {self.spec} ({self.name}): the "
            "true object and those its query chooses among"
        )
        if not self.drawn:
            return kept
        drawn = (
            f"{', '.join(t for t in self.kept if t in self.drawn)}: items drawn in scenes whose objects, "
            f"the candidates and all others, are of the categories the detector {self.spec} ({self.name}) "
            "can find"
        )
        others = [t for t in self.kept if t not in self.drawn]
        return drawn if not others else f"{drawn}; {', '.join(others)}: {kept}"

    def says(self, task: str) -> str:
        """What was kept of `task`: "62 of 100 items kept; 38 left out, with objects ... (kettle 20, ...)",
        or for a task drawn in the detector's vocabulary "50 of 50 items kept, drawn in scenes whose objects
        coco can all find"."""
        kept, of = self.kept[task]
        text = f"{kept} of {of} items kept"
        if task in self.drawn:
            text += f", drawn in scenes whose objects {self.spec} can all find"
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
    """The items whose object categories `detector` can all find, in their order, and what was kept. Items
    drawn in its vocabulary are checked the same way (their tasks are named as drawn): by construction
    every one is kept."""
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
        if item.vocabulary is not None:
            subset.drawn.add(item.task)
        had, of = subset.kept.get(item.task, (0, 0))
        subset.left_out.setdefault(item.task, Counter()).update(missing)
        subset.kept[item.task] = (had + (not missing), of + 1)
        if not missing:
            kept.append(item)
    return kept, subset
