"""The evaluation suite as registered records: tasks and methods, found by name like every other plug-in.

A `Task` says everything the suite knows about one of the paper's experiments: its name, how many queries
the paper asked, the seed its scenes start from, the function that builds its items, the methods the paper
compares on it, the paper's published accuracies, why our rows differ from them, and tags (dm_control's
tagged task registry is the model: `tagged("embodied")` lists the embodied tasks). A `Method` says how one
of the paper's rows runs on an item. Tasks register themselves in the modules of `attribot.eval.tasks`,
methods in `attribot.eval.methods`; adding a task is one `register_task(Task(...))` in one of those modules.
A task whose scenes are generated may say how to draw its items in the categories a closed-set detector can
find (`build_in_vocabulary`): a run with such a detector draws them so, and keeps every item. A task belongs
to a suite (`attribot eval --suite NAME`): `paper`, the paper's five experiments, or
`senses`, the senses the paper proposed adding (temperature, softness, fullness).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from attribot.registry import Registry

if TYPE_CHECKING:
    from attribot.config import Settings
    from attribot.eval.datasets import Item
    from attribot.eval.methods import Condition, Record

__all__ = [
    "Task",
    "Method",
    "TASKS",
    "METHODS",
    "register_task",
    "register_method",
    "tagged",
    "task_names",
    "suite_names",
    "paper_numbers",
]

Build = Callable[[int, int], Iterator["Item"]]
"""Builds a task's items: (queries, seed base) -> items, deterministic."""
BuildIn = Callable[[int, int, tuple[str, ...]], Iterator["Item"]]
"""Builds a task's items in a vocabulary: (queries, seed base, categories) -> items whose scenes draw their
objects from those categories only (each item records them), deterministic."""
Run = Callable[["Item", "Settings", "Condition"], "Record"]
"""Runs a method on one item: (item, settings, run condition) -> its record."""


@dataclass(frozen=True)
class Task:
    """One experiment of the paper (see the module docstring)."""

    name: str
    size: int  # queries, as many as the paper asked
    seed_base: int  # its scenes' seeds start above this
    build: Build
    methods: tuple[str, ...]  # the paper's rows on this task: what `attribot eval` runs by default
    paper: Mapping[str, tuple[tuple[str, float], ...]] = field(default_factory=dict)
    """method -> the paper's published accuracies as (its label, accuracy); other models, another world."""
    why: str = ""  # what the task measures, and what its rows show offline
    tags: frozenset[str] = frozenset()  # e.g. "embodied" (Table I), "image" (the bar figures)
    forms: tuple[str, ...] = ("n/a",)  # each query is asked in each form (size: superlative and absolute)
    suite: str = "paper"  # the suite it belongs to: paper (the paper's experiments) or senses
    build_in_vocabulary: BuildIn | None = None
    """How its items are drawn in the categories a closed-set detector can find, so that a run with that
    detector keeps every item (`attribot.eval.subset`); None: it cannot be, and such a run keeps the items
    whose objects the detector can find."""

    def item_count(self, limit: int | None = None) -> int:
        """Items built for at most `limit` queries (every query gives one item per form)."""
        return (self.size if limit is None else min(limit, self.size)) * len(self.forms)


@dataclass(frozen=True)
class Method:
    """One row of the paper's tables, run on one item at a time."""

    name: str
    run: Run
    program: bool = False  # runs a program through the API: has error-catching mechanisms to ablate
    why: str = ""  # what the row measures, and why it looks as it does with the offline backends


TASKS: Registry[Task] = Registry(
    "task",
    (
        "attribot.eval.tasks.still",
        "attribot.eval.tasks.embodied",
        "attribot.eval.tasks.senses",
        "attribot.eval.tasks.realroom",
    ),
)  # still-image tasks first: the order of the paper, the datasets and the report; then the senses, the real
# rooms
METHODS: Registry[Method] = Registry("method", ("attribot.eval.methods",))


def register_task(task: Task) -> Task:
    """Add `task` to the suite under its name (a name used twice is an error)."""
    return TASKS.register(task.name)(task)


def register_method(method: Method) -> Method:
    """Add `method` under its name (a name used twice is an error)."""
    return METHODS.register(method.name)(method)


def task_names(suite: str | None = "paper") -> list[str]:
    """The tasks of `suite` (None: of every suite), in the suite's order."""
    return [name for name, task in TASKS.items() if suite is None or task.suite == suite]


def suite_names() -> list[str]:
    """The suites, in the order of their first task."""
    return list(dict.fromkeys(task.suite for _, task in TASKS.items()))


def tagged(*tags: str) -> list[str]:
    """The tasks (of any suite) that carry every one of `tags`, in the suite's order."""
    return [name for name, task in TASKS.items() if set(tags) <= task.tags]


def paper_numbers(task: str, method: str) -> list[tuple[str, float]]:
    """The paper's published accuracies for `method` on `task` (none for a task the suite does not know)."""
    return list(TASKS.get(task).paper.get(method, ())) if task in TASKS else []
