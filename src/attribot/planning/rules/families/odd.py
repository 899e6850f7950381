"""The odd one out: by kind, then colour, then size."""

from __future__ import annotations

import re
from collections.abc import Sequence

from attribot.planning.rules.families import FAMILY_REGISTRY, Family
from attribot.planning.rules.forms import (
    ObjectSpec,
    OddQuery,
)
from attribot.planning.rules.normalise import (
    _object,
)
from attribot.planning.rules.write import (
    _count_message,
    _find,
    _Writer,
)

_OTHERS = r"(?:all\s+)?the\s+(?:others|rest|other\s+(?:ones|objects|items|things))"
_ODD = re.compile(
    r"(?:(?:which|what)\s+(?:(?:one|object|item|thing)\s+)?(?:is\s+)?)?(?:the\s+)?odd\s+(?P<a>[a-z]+(?:\s+[a-z]+)?\s+)?out"
    r"|(?:the\s+)?odd\s+one"
    r"|(?:(?:which|what)\s+(?:is\s+)?)?(?:the\s+)?odd\s+(?:one|item|object|thing)"
    r"|(?:(?:which|what|the)\s+)?(?P<b>[a-z]+)\s+(?:that\s+)?(?:does\s+not|doesn't|doesnt)\s+(?:belong|fit(?:\s+in)?)"
    r"(?:\s+(?:here|with\s+" + _OTHERS + r"|among\s+" + _OTHERS + r"))?"
    r"|(?:which|what|the)\s+(?P<d>[a-z]+)?\s*(?:that\s+)?(?:sticks|stands)\s+out(?:\s+(?:from|among)\s+"
    + _OTHERS
    + r")?"
    r"|(?:which|what|the)\s+(?P<e>[a-z]+)\s+(?:that\s+)?is\s+(?:not\s+like|unlike)\s+"
    + _OTHERS
    + r"|(?:which|what|the)\s+(?P<c>[a-z]+)\s+(?:that\s+)?is\s+(?:the\s+)?(?:different|odd)(?:\s+one)?"
    r"(?:\s+(?:from|than)\s+(?:all\s+)?the\s+(?:others|rest))?"
)


def _parse_odd(text: str) -> OddQuery | None:
    """ "the odd one out", "the odd mug out", "which object does not belong", "which one is different"."""
    match = _ODD.fullmatch(text)
    if match is None:
        return None
    noun = (match["a"] or match["b"] or match["c"] or match["d"] or match["e"] or "object").strip()
    obj = ObjectSpec("object") if noun in ("one", "ones") else _object(noun)
    return None if obj is None else OddQuery(obj)


def _write_odd(w: _Writer, q: OddQuery, sensors: Sequence[str], embodied: bool) -> None:
    w.helper("the_one_unlike_the_rest")
    w.helper("size_outlier")
    w.uses_math = True
    _find(w, q.obj)
    w.fail(
        "len(candidates) < 3",
        _count_message(
            "the odd one out needs three objects or more, and the image shows ", "len(candidates)", ""
        ),
    )
    w.line("# unlike the rest by kind first, then by colour, then by size (as an arrangement makes them)")
    w.line('kinds = [c.visual_query("What is this?") for c in candidates]')
    w.line("odd = the_one_unlike_the_rest(kinds)")
    w.line("if odd is None:")
    w.line('    colours = [c.visual_query("What color is this?") for c in candidates]')
    w.line("    odd = the_one_unlike_the_rest(colours)")
    w.line("if odd is None:")
    if embodied and "distance" in sensors:
        w.line("    # a size apart from perspective: the size in pixels times the measured distance")
        w.line("    sizes = [math.sqrt(c.area) * robot.measure_distance(c) for c in candidates]")
        w.line("    middle = sorted(sizes)[len(sizes) // 2]")
        w.line("    misfits = [abs(math.log(size / middle)) for size in sizes]")
        w.line("    odd = misfits.index(max(misfits))")
    else:
        w.line("    # no distance sensor: the size in pixels against the perspective of the others")
        w.line("    odd = size_outlier(candidates)")
    w.line("return candidates[odd]")


FAMILY_REGISTRY.register("odd one out")(
    Family(
        examples=("the odd one out", "Which object does not belong?", "the odd mug out"),
        readers=((30, lambda r: _parse_odd(r.text)),),
        forms=(OddQuery,),
        write=lambda w, q: _write_odd(w, q, w.sensors, w.embodied),
    )
)
