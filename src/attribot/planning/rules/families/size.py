"""Size: the largest or smallest by a dimension of the box, in the world when the rangefinder measures it."""

from __future__ import annotations

from collections.abc import Sequence

from attribot.planning.rules.families import FAMILY_REGISTRY, Family
from attribot.planning.rules.forms import (
    SizeQuery,
)
from attribot.planning.rules.normalise import (
    _COMPARATIVE,
    _ORD,
    _SIZE,
    _SIZE_WORDS,
    _SUPERLATIVE,
    _object,
    _ordinal,
    rx,
)
from attribot.planning.rules.write import (
    _count_message,
    _find,
    _nth,
    _sorted,
    _Writer,
)


def _parse_size(text: str) -> SizeQuery | None:
    match = rx(
        r"(?:(?P<ord>"
        + _ORD
        + r")\s+)?(?:(?P<deg>most|least)\s+)?(?P<adj>"
        + _SIZE_WORDS
        + r")(?:\s+(?P<rest>.+))?"
    ).fullmatch(text)
    if match is None:
        match = rx(
            r"(?P<rest>.+?)\s+(?:that|which|who)\s+(?:is|are)\s+(?:the\s+)?(?:(?P<ord>" + _ORD + r")\s+)?"
            r"(?:(?P<deg>most|least)\s+)?(?P<adj>" + _SIZE_WORDS + r")(?:\s+one)?"
        ).fullmatch(text)
    if match is None:
        return None
    adjective = match["adj"]
    base = _SUPERLATIVE.get(adjective) or _COMPARATIVE.get(adjective) or adjective
    measure, largest = _SIZE[base]
    if match["deg"] == "least":
        largest = not largest
    rank = 1
    if match["ord"]:
        rank, from_end = _ordinal(match["ord"])
        if from_end:  # "the second to last tallest": count from the other end
            largest = not largest
    obj = _object(match["rest"] or "")
    if obj is None:
        return None
    return SizeQuery(
        obj=obj,
        adjective=" ".join(w for w in (match["deg"], adjective) if w),
        measure=measure,  # type: ignore[arg-type]
        largest=largest,
        rank=rank,
    )


_MEASURES = {
    "area": ("patch.width * patch.height", "the area of its box"),
    "height": ("patch.height", "the height of its box"),
    "width": ("patch.width", "the width of its box"),
    "length": (
        "max(patch.width, patch.height)",
        "the longer side of its box, so that long and short follow the object's orientation",
    ),
    "thickness": (
        "min(patch.width, patch.height)",
        "the shorter side of its box, so that thin and thick follow the object's orientation",
    ),
}


def _write_size(w: _Writer, q: SizeQuery, sensors: Sequence[str], embodied: bool) -> None:
    _find(w, q.obj)
    key, meaning = _MEASURES[q.measure]
    w.line(f'# "{q.adjective}" is measured as {meaning}')
    if q.adjective in _SIZE:
        w.line(f'# the absolute form ("the {q.adjective} {q.obj.phrase}") names the one that stands out')
    order = "largest" if q.largest else "smallest"
    superlative = {v: k for k, v in _SUPERLATIVE.items()}
    base = q.adjective.split()[-1]
    base = _SUPERLATIVE.get(base) or _COMPARATIVE.get(base) or base
    word = superlative.get(base, base) if " " not in q.adjective else q.adjective
    if embodied and "distance" in sensors:
        # a near object looks big: pixels times the measured distance are a size in the world
        power, squared = (" ** 2", " squared") if q.measure == "area" else ("", "")
        w.line(f"# in the world, not in the picture: times the measured distance{squared}")
        key = f"{key} * robot.measure_distance(patch){power}"
    w.line(f"# order them from the {order} and take the {_nth(q.rank)}")
    w.line(f"ordered = {_sorted('candidates', key, q.largest)}")
    if q.rank > 1:
        w.fail(
            f"len(ordered) < {q.rank}",
            _count_message(
                f"asked for the {_nth(q.rank)} {word} {q.obj.phrase}, but only ",
                "len(ordered)",
                " were found",
            ),
        )
    if embodied and "distance" in sensors:
        # the answer's value is the size asked, in metres: never the distance used to scale it
        w.line(f"chosen = ordered[{q.rank - 1}]")
        w.line("width, height = chosen.size_at(robot.measure_distance(chosen))")
        if w.act is not None:
            w.line("chosen = " + w.act.format("chosen"))
        w.line(f'return {{"object": chosen, "value": {_SIZE_VALUES[q.measure]}, "unit": "m"}}')
        return
    w.line(f"return ordered[{q.rank - 1}]")


_SIZE_VALUES = {
    "area": "max(width, height)",
    "length": "max(width, height)",
    "thickness": "min(width, height)",
    "height": "height",
    "width": "width",
}


FAMILY_REGISTRY.register("size")(
    Family(
        examples=(
            "the third tallest item",
            "the smallest red apple",
            "the long carrot",
            "which cup is the tallest",
        ),
        readers=((50, lambda r: _parse_size(r.plain)),),
        forms=(SizeQuery,),
        write=lambda w, q: _write_size(w, q, w.sensors, w.embodied),
    )
)
