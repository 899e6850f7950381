"""The paper's still-image tasks (its bar figures): location, size and weight by image.

Location and size items use the released phrasings wherever a generated arrangement can carry them, their
category (and colour) swapped for the scene's, and templates of ours otherwise. The meaning of a released
phrasing is written down once, by hand, in `data/paper_meanings.jsonl` (which object it names, the row or
column, the side and the count, the extreme of size it asks for), and the truth is the object at that place
in the scene's own rows and columns or at that rank of its physical sizes: no planner reads these queries
for the truth.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Literal

from pydantic import BaseModel, ConfigDict

from attribot.config import SceneConfig
from attribot.eval.corpus import PaperQuery, paper_queries
from attribot.eval.datasets import HEIGHT, WIDTH, Item, scene_info
from attribot.eval.suite import Task, register_task
from attribot.sim.table_layouts import NoRoomOnTable
from attribot.sim.world import ObjectInfo

__all__ = ["Place", "Extreme", "place_truth", "paper_places", "paper_extremes"]

_SIDES = ("left", "right", "top", "bottom")


@dataclass(frozen=True)
class Place:
    """Where a location phrasing points in an arrangement.

    noun: the phrasing's word for the objects (None: any object); colors: its colour words; line: a row or
    column, "row 1" the top row, "row -1" the bottom one, "column 2" the second from the left, "middle row";
    pick: within the line (or the whole arrangement), "left 2" (the second from the left), "top 1",
    "middle" (the middle one along the line), "centre" (the centre of the arrangement)."""

    noun: str | None
    pick: str
    line: str | None = None
    colors: tuple[str, ...] = ()

    @property
    def side(self) -> str | None:
        word = self.pick.split()[0]
        return word if word in _SIDES else None


@dataclass(frozen=True)
class Extreme:
    """What a size phrasing asks for: the `rank`-th largest (or smallest) of the objects it names."""

    noun: str | None
    largest: bool
    rank: int = 1
    colors: tuple[str, ...] = ()


class _Written(BaseModel):
    """One line of `data/paper_meanings.jsonl`: a released phrasing and its meaning, written by hand."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    task: Literal["location", "size"]
    query: str
    noun: str | None  # None: any object ("item", "object")
    colors: tuple[str, ...] = ()
    line: str | None = None  # location
    pick: str = ""  # location
    largest: bool = True  # size
    rank: int = 1  # size


@cache
def _meanings() -> tuple[_Written, ...]:
    text = resources.files("attribot.eval").joinpath("data/paper_meanings.jsonl").read_text(encoding="utf-8")
    return tuple(_Written.model_validate_json(line) for line in text.splitlines() if line.strip())


def paper_places() -> list[tuple[str, Place]]:
    """The released location phrasings with their written meaning, in the corpus's order."""
    written = {m.query: m for m in _meanings() if m.task == "location"}
    out = []
    for q in paper_queries("location"):
        m = written.get(q.query or "")
        if m is not None:
            out.append((m.query, Place(noun=m.noun, pick=m.pick, line=m.line, colors=m.colors)))
    return out


def paper_extremes() -> list[tuple[str, str, Extreme]]:
    """The released size phrasings with their written meaning: (superlative, its released absolute form or
    "", meaning), in the corpus's order."""
    written = {m.query: m for m in _meanings() if m.task == "size"}
    size = paper_queries("size")
    out = []
    for q in size:
        m = written.get(q.query or "")
        if q.form == "superlative" and m is not None:
            extreme = Extreme(noun=m.noun, largest=m.largest, rank=m.rank, colors=m.colors)
            out.append((m.query, _absolute_of(q, size), extreme))
    return out


def _absolute_of(q: PaperQuery, size: list[PaperQuery]) -> str:
    """The released absolute form written for the same image as the superlative `q`."""
    return next((a.query or "" for a in size if a.form == "absolute" and a.model_extra == q.model_extra), "")


# ---- truth from the arrangement's rows and columns ------------------------------------------------------


def _line_kind(line: str) -> str:
    """ "row" or "column", of "row 1", "column -1", "middle row"."""
    words = line.split()
    return words[-1] if words[0] == "middle" else words[0]


def _line_of(line: str, group: list[ObjectInfo]) -> list[ObjectInfo] | None:
    """The objects of one row or column ("row 1", "column -1", "middle row"); None where it is not one."""
    words = line.split()
    middle = words[0] == "middle"
    key = "row" if _line_kind(line) == "row" else "col"
    lines = sorted({int(getattr(o, key)) for o in group})
    if middle:
        if len(lines) % 2 == 0:
            return None
        want = lines[len(lines) // 2]
    else:
        index = int(words[1])
        if abs(index) > len(lines):
            return None
        want = lines[index - 1] if index > 0 else lines[index]
    return [o for o in group if getattr(o, key) == want]


def _centre(group: list[ObjectInfo]) -> ObjectInfo | None:
    rows = sorted({int(o.row or 0) for o in group})
    cols = sorted({int(o.col or 0) for o in group})
    if len(rows) % 2 == 0 or len(cols) % 2 == 0:
        return None
    centre = [o for o in group if o.row == rows[len(rows) // 2] and o.col == cols[len(cols) // 2]]
    return centre[0] if len(centre) == 1 else None


def place_truth(place: Place, objects: list[ObjectInfo]) -> ObjectInfo | None:
    """The object `place` points at among `objects` (all of one category), by the world's rows and
    columns; None where the arrangement cannot carry the phrasing (no such row, two at one place)."""
    if not objects or any(o.row is None or o.col is None for o in objects):
        return None
    group = list(objects)
    if place.line is not None:
        group = _line_of(place.line, group) or []
        if not group:
            return None
    if place.pick == "centre":
        return _centre(group)
    if place.pick == "middle":
        # the middle along the line: down a column, across a row (or across the whole arrangement)
        key = "row" if place.line is not None and _line_kind(place.line) == "column" else "col"
        if len(group) % 2 == 0 or len({getattr(o, key) for o in group}) != len(group):
            return None
        return sorted(group, key=lambda o: getattr(o, key))[len(group) // 2]
    side, count = place.pick.split()
    k = int(count)
    key = "col" if side in ("left", "right") else "row"
    order = sorted(group, key=lambda o: getattr(o, key), reverse=side in ("right", "bottom"))
    if len({getattr(o, key) for o in group}) != len(group) or k > len(order):
        return None
    return order[k - 1]


# ---- the items -------------------------------------------------------------------------------------------


def _swap(query: str, old: str | None, new: str) -> str:
    """`query` with its word `old` (and its plural) swapped for `new`, once; unchanged when `old` is None."""
    if old is None:
        return query
    return re.sub(rf"\b{re.escape(old)}(?:e?s)?\b", new, query, count=1)


def _in_scene(text: str, noun: str | None, colors: tuple[str, ...], obj: ObjectInfo) -> str:
    """A released phrasing made to name the scene's objects: its noun and colour words swapped for theirs
    (an arrangement's objects share both; "the rightmost black book" over blue mugs would name nothing)."""
    if "{cat}" in text:  # one of our templates
        return text.replace("{cat}", obj.category)
    for color in colors:
        text = _swap(text, color, obj.color)
    return _swap(text, noun, obj.category)


_ORDINALS = ("second", "third", "first")
_TEMPLATES: tuple[tuple[str, str | None, str], ...] = (
    ("the {ord} {cat} from the left", None, "left {k}"),
    ("the {ord} {cat} from the right", None, "right {k}"),
    ("the leftmost {cat}", None, "left 1"),
    ("the rightmost {cat}", None, "right 1"),
    ("the {ord} {cat} from the left in the top row", "row 1", "left {k}"),
    ("the {ord} {cat} from the right in the bottom row", "row -1", "right {k}"),
)
"""Our own location phrasings: (text, line, pick), `{ord}` the k-th ordinal."""


def _pattern(place: Place) -> str:
    """The arrangement a phrasing needs: a grid for a row or column, a column for top and bottom."""
    if place.line is not None:
        return "grid"
    return "column" if place.side in ("top", "bottom") else "row"


def _arrangement(seed: int, pattern: str) -> tuple[SceneConfig, list[ObjectInfo]] | None:
    """An arrangement's scene and its objects, with their rows, columns and sizes (the world's truth); None
    where the seed's objects do not fit on a table in `pattern` (three large bowls in a column)."""
    config = SceneConfig(
        layout="arrangement",
        seed=seed,
        options={"pattern": pattern, "odd": "size"},
        width=WIDTH,
        height=HEIGHT,
    )
    try:
        return config, scene_info(config).objects
    except NoRoomOnTable:
        return None


def _location_query(made: int, tries: int, places: list[tuple[str, Place]]) -> tuple[str, Place, bool]:
    """The phrasing of the `made`-th item at its `tries`-th attempt: every other one released."""
    if made % 2 == 0 and places:
        text, place = places[(made // 2 + tries) % len(places)]
        return text, place, True
    text, line, pick = _TEMPLATES[(made + tries) % len(_TEMPLATES)]
    k = (2, 3, 1)[made % 3]
    text = text.replace("{ord}", _ORDINALS[made % 3])
    return text, Place(noun="{cat}", pick=pick.format(k=k), line=line), False


def _location_items(n: int, start_seed: int) -> Iterator[Item]:
    places = paper_places()
    made, seed, tries = 0, start_seed, 0
    while made < n:
        seed += 1
        text, place, released = _location_query(made, tries, places)
        drawn = _arrangement(seed, _pattern(place))
        if drawn is None:
            tries += 1  # no room for this phrasing's pattern: the next phrasing, the next seed
            continue
        config, placed = drawn
        objects = [o for o in placed if o.row is not None]
        first = objects[0]
        same = [o for o in objects if place.noun is None or o.category == first.category]
        truth = place_truth(place, same) if all(o.box is not None for o in same) else None
        if truth is None or truth.box is None:
            tries += 1  # this scene cannot carry this phrasing: the next phrasing, the next seed
            continue
        query = _in_scene(text, place.noun, place.colors, first)
        yield Item(
            id=f"location-{made:03d}",
            task="location",
            query=query,
            form="n/a",
            phrasing="paper" if released else "template",
            layout="arrangement",
            seed=seed,
            options=dict(config.options),
            sensors=["camera"],
            embodied=False,
            true_id=truth.id,
            true_box=truth.box,
            object_categories=sorted({o.category for o in same}),
        )
        made += 1


def _ranked(extreme: Extreme, objects: list[ObjectInfo]) -> list[ObjectInfo] | None:
    """The objects by physical size, the asked-for extreme first; None when the rank-th cannot be told
    apart by eye (within 5% of a neighbour) or the odd one out is not at that extreme."""
    ranked = sorted(objects, key=lambda o: o.size_m, reverse=extreme.largest)
    k = extreme.rank
    if k > len(ranked) - 1:
        return None
    sizes = [o.size_m for o in ranked]
    if abs(sizes[k - 1] - sizes[k]) < 0.05 * sizes[k] or (
        k > 1 and abs(sizes[k - 2] - sizes[k - 1]) < 0.05 * sizes[k - 1]
    ):
        return None
    return ranked if ranked[0].odd_one_out is True else None


_ABSOLUTE = {
    "tallest": "tall", "biggest": "big", "largest": "large", "smallest": "small", "shortest": "short",
    "longest": "long", "widest": "wide", "thinnest": "thin", "thickest": "thick", "narrowest": "narrow",
    "tiniest": "tiny", "highest": "high",
}  # fmt: skip


def _absolute(superlative: str) -> str:
    """The absolute form of one of our superlatives, without its ordinal ("third tallest" -> "tall")."""
    text = re.sub(r"\b(\w+?)(?:iest|est)\b", lambda m: _ABSOLUTE.get(m.group(0), m.group(0)), superlative)
    return re.sub(r"^(?:first|second|third|fourth|fifth)\s+", "", text)


def _size_forms(
    superlative: str, absolute: str, extreme: Extreme, ranked: list[ObjectInfo]
) -> Iterator[tuple[str, str, ObjectInfo]]:
    """(form, query, truth) for both forms; an absolute form names the extreme itself ("the tall X")."""
    yield "superlative", superlative, ranked[extreme.rank - 1]
    if absolute and extreme.rank == 1:
        yield "absolute", absolute, ranked[0]
    else:
        yield "absolute", _absolute(superlative), ranked[0]


def _size_items(n: int, start_seed: int) -> Iterator[Item]:
    phrasings = paper_extremes()
    made, seed = 0, start_seed
    while made < n:
        superlative, absolute, extreme = phrasings[made % len(phrasings)]
        seed += 1
        drawn = _arrangement(seed, "row")
        if drawn is None:
            continue
        config, placed = drawn
        objects = [o for o in placed if o.box is not None]
        ranked = _ranked(extreme, objects) if len(objects) == len(placed) else None
        if ranked is None:
            continue
        for form, text, truth in _size_forms(superlative, absolute, extreme, ranked):
            query = _in_scene(text, extreme.noun, extreme.colors, objects[0])
            yield Item(
                id=f"size-{made:03d}-{form}",
                task="size",
                query=query if query.startswith("the ") else "the " + query,
                form=form,
                phrasing="paper",
                layout="arrangement",
                seed=seed,
                options=dict(config.options),
                sensors=["camera"],
                embodied=False,
                true_id=truth.id,
                true_box=truth.box or [],
                object_categories=sorted({o.category for o in objects}),
            )
        made += 1


def _weight_image_items(n: int, start_seed: int) -> Iterator[Item]:
    queries = [q.query for q in paper_queries("weight_image") if q.query] or ["the heaviest item"]
    for made in range(n):
        seed = start_seed + made
        config = SceneConfig(layout="triplet", seed=seed, width=WIDTH, height=HEIGHT)
        objects = scene_info(config).objects
        truth = max(objects, key=lambda o: o.mass_kg)
        yield Item(
            id=f"weight_image-{made:03d}",
            task="weight_image",
            query=queries[made % len(queries)],
            form="superlative",
            phrasing="paper",
            layout="triplet",
            seed=seed,
            sensors=["camera"],
            embodied=False,
            true_id=truth.id,
            true_box=truth.box or [],
            object_categories=sorted({o.category for o in objects}),
        )


register_task(
    Task(
        name="location",
        size=100,
        seed_base=10_000,
        build=_location_items,
        methods=("ovd", "attr-api", "vlm", "pa-api"),
        paper={"ovd": (("OVD (GLIP)", 0.35),), "attr-api": (("OVD+GPT-3.5", 0.60), ("OVD+GPT-4", 0.82))},
        why='Arrangements of one category in a row, a column or a grid: "the second mug from the right", '
        '"top right banana". The truth is the object at that row and column of the arrangement.',
        tags=frozenset({"image", "arrangement"}),
    )
)
register_task(
    Task(
        name="size",
        size=100,
        seed_base=20_000,
        build=_size_items,
        methods=("ovd", "attr-api", "vlm", "pa-api"),
        paper={
            "ovd": (("OVD (GLIP)", 0.445), ("OVD, superlative", 0.501)),
            "attr-api": (("OVD+GPT-3.5", 0.82), ("OVD+GPT-3.5, superlative", 0.80), ("OVD+GPT-4", 0.84)),
        },
        why="A row of one category with one odd one out in size, each query asked in its superlative "
        '("the tallest scissors") and its absolute form ("the tall scissors"). The truth is the rank of '
        "the objects' physical sizes.",
        tags=frozenset({"image", "arrangement"}),
        forms=("superlative", "absolute"),
    )
)
register_task(
    Task(
        name="weight_image",
        size=100,
        seed_base=30_000,
        build=_weight_image_items,
        methods=("ovd", "vqa", "vqa+llm", "attr-api", "vlm"),
        paper={
            "ovd": (("OVD (GLIP)", 0.42), ("OVD, superlative", 0.36)),
            "vqa": (("VQA (BLIP-2)", 0.54), ("VQA, superlative", 0.36)),
            "vqa+llm": (("VQA+GPT-3.5", 0.84), ("VQA+GPT-4", 0.93)),
        },
        why='Three objects in one still image, "the heaviest item": no robot, no sensor. The truth is the '
        "largest mass in the scene.",
        tags=frozenset({"image"}),
    )
)
