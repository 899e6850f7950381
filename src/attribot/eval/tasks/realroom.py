"""The real-room suite: the embodied questions asked in rooms that also hold things a closed-set detector
cannot name, and about objects that are not there.

A lab's kitchen is not drawn for its detector. Each scene here is a household room whose query objects are
of categories a COCO detector names (one per COCO class, so that a name picks one object), standing with two
or three things of categories no COCO class covers (a tomato, a dumbbell, a can, a toy block...), at least two
of them on a surface the query's objects stand on. Three tasks:
- `weight_realroom`: "Out of the A, the B and the C, which one is the most lightweight?" (force sensor);
- `distance_realroom`: "Is the A or the B closer to me?" / "Out of ..., which one is closer to me?";
- `absent_realroom`: a question that names an object the room does not hold, among ones it does, or alone
  ("How far away is the X?"). Its truth is that the object is not there: a record is right only where the
  answer chose no object (a refusal, "not found"), and naming any object is wrong.
The truth is the world's own state (masses, distances, what the scene holds). Records say right, refused
(no answer) or wrong, and a wrong answer that said it was a guess is told apart from a confident one
(`attribot.eval.report`). The scenes are the same whichever detector runs (the COCO classes are the room's
definition, not a detector's answer), so the oracle runs on exactly the items a real detector does.
"""

from __future__ import annotations

from collections.abc import Iterator
from functools import cache

import numpy as np

from attribot.config import SceneConfig
from attribot.errors import InputError
from attribot.eval.datasets import HEIGHT, WIDTH, Item, scene_info
from attribot.eval.suite import Task, register_task
from attribot.eval.tasks.embodied import _visible, asked_about
from attribot.sim.truth import ObjectInfo

__all__ = ["nameable_categories", "unnameable_categories"]

SUITE = "realroom"
MAX_OTHER_M = 0.35
"""Things no detector names are drawn up to this large (a teapot, a dumbbell; not a pan or a broom)."""


@cache
def nameable_categories() -> tuple[str, ...]:
    """The catalog's drawn categories a COCO detector names, one per COCO class (the first in catalog order:
    a ball and a basketball are both a sports ball)."""
    from attribot.models.coco import COCO_CLASS_OF
    from attribot.sim.catalog import categories

    seen: set[str] = set()
    names = []
    for cat in categories():
        cls = COCO_CLASS_OF.get(cat.name)
        if cat.drawn and cls is not None and cls not in seen:
            seen.add(cls)
            names.append(cat.name)
    return tuple(names)


@cache
def unnameable_categories() -> tuple[str, ...]:
    """The catalog's drawn categories no COCO class covers, of a size to stand on a table among the others."""
    from attribot.models.coco import COCO_CLASS_OF
    from attribot.sim.catalog import categories

    return tuple(
        c.name
        for c in categories()
        if c.drawn
        and c.pickable
        and c.placement == "surface"
        and c.name not in COCO_CLASS_OF
        and c.size_range_m[1] <= MAX_OTHER_M
    )


def _pickable_nameable() -> tuple[str, ...]:
    from attribot.sim.catalog import get_category

    return tuple(
        n
        for n in nameable_categories()
        if get_category(n).pickable and get_category(n).placement == "surface"
    )


def _room(seed: int, asked: list[str], others: list[str]) -> list[ObjectInfo] | None:
    """The objects of the room of `seed` that holds `asked` and `others` (each once), where every asked one
    is seen and at least two of the others are seen on a surface an asked one stands on; None otherwise."""
    names = [*asked, *others]
    config = SceneConfig(
        layout="household", seed=seed, width=WIDTH, height=HEIGHT, objects=len(names), categories=tuple(names)
    )
    try:
        info = scene_info(config)
    except InputError:
        return None  # the layout found no room for these objects
    seen = _visible(info)
    by_name = {o.category: o for o in seen}
    if any(n not in by_name for n in asked):
        return None
    surfaces = {by_name[n].surface for n in asked}
    if sum(o.category in others and o.surface in surfaces for o in seen) < 2:
        return None
    return [by_name[n] for n in asked]


def _draw(rng: np.random.Generator, pool: tuple[str, ...], n: int, but: tuple[str, ...] = ()) -> list[str]:
    left = [p for p in pool if p not in but]
    return [left[i] for i in rng.choice(len(left), size=n, replace=False)]


def _item(task: str, made: int, query: str, seed: int, names: list[str], sensors: list[str],
          truth: ObjectInfo | None, chosen: list[ObjectInfo], absent: list[str]) -> Item:  # fmt: skip
    return Item(
        id=f"{task}-{made:03d}",
        task=task,
        query=query,
        form="comparative",
        phrasing="paper",
        layout="household",
        seed=seed,
        objects=len(names),
        categories=names,
        sensors=sensors,
        embodied=True,
        true_id=truth.id if truth is not None else "",
        true_box=(truth.box or []) if truth is not None else [],
        candidates=[o.id for o in chosen],
        object_categories=sorted({*(o.category for o in chosen), *absent}),
        absent=absent,
    )


def _present_items(task: str, n: int, start_seed: int) -> Iterator[Item]:
    distance = task == "distance_realroom"
    pool = nameable_categories() if distance else _pickable_nameable()
    made, seed = 0, start_seed
    while made < n:
        seed += 1
        rng = np.random.default_rng(seed)
        asked = _draw(rng, pool, 3)
        others = _draw(rng, unnameable_categories(), int(rng.integers(2, 4)))
        chosen = _room(seed, asked, others)
        if chosen is None:
            continue
        asked_ = asked_about(made, chosen, distance)
        if asked_ is None:
            continue
        query, chosen, truth, sensors = asked_
        yield _item(task, made, query, seed, [*asked, *others], sensors, truth, chosen, [])
        made += 1


def _absent_items(n: int, start_seed: int) -> Iterator[Item]:
    """Questions naming one object the room does not hold: alone ("How far away is the X?"), or among two
    it does (which is the heaviest, which is closer); the forms in turn."""
    task = "absent_realroom"
    made, seed = 0, start_seed
    while made < n:
        seed += 1
        rng = np.random.default_rng(seed)
        form = made % 3
        drawn = _draw(rng, _pickable_nameable() if form == 1 else nameable_categories(), 3)
        asked, missing = drawn[:2], drawn[2]
        others = _draw(rng, unnameable_categories(), int(rng.integers(2, 4)))
        chosen = _room(seed, asked, others)
        if chosen is None:
            continue
        if form == 0:
            query, sensors = f"How far away is the {missing}?", ["camera", "distance"]
        elif form == 1:
            names = [f"the {chosen[0].category}", f"the {missing}", f"the {chosen[1].category}"]
            query = f"Out of {names[0]}, {names[1]} and {names[2]}, which one is the heaviest?"
            sensors = ["camera", "force"]
        else:
            query, sensors = (
                f"Is the {missing} or the {chosen[0].category} closer to me?",
                ["camera", "distance"],
            )
        yield _item(task, made, query, seed, [*asked, *others], sensors, None, chosen, [missing])
        made += 1


_WHY_ROOM = (
    " The room also holds two or three things no COCO class covers, at least two on the query objects' "
    "surfaces; the truth is the world's own state."
)

register_task(
    Task(
        name="weight_realroom",
        size=50,
        seed_base=90_000,
        build=lambda n, start: _present_items("weight_realroom", n, start),
        methods=("pa-api",),
        why='"Out of the ..., which one is the most lightweight?" with the wrist force sensor.' + _WHY_ROOM,
        tags=frozenset({SUITE}),
        suite=SUITE,
    )
)
register_task(
    Task(
        name="distance_realroom",
        size=50,
        seed_base=91_000,
        build=lambda n, start: _present_items("distance_realroom", n, start),
        methods=("pa-api",),
        why='"Is the X or the Y closer to me?" with the rangefinder.' + _WHY_ROOM,
        tags=frozenset({SUITE}),
        suite=SUITE,
    )
)
register_task(
    Task(
        name="absent_realroom",
        size=48,
        seed_base=92_000,
        build=_absent_items,
        methods=("pa-api",),
        why="A question naming an object the room does not hold: right only where no object is named "
        "(refused, not found)." + _WHY_ROOM,
        tags=frozenset({SUITE}),
        suite=SUITE,
    )
)
