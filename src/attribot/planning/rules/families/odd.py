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
    """ "the odd one out", "the odd mug out", "which object does not belong", "which one is different"; any
    other phrasing with a cue of the odd one out ("the oddball", "not like the others", "does not match the
    rest", "stands out") whose other words are the question's frame and at most a name."""
    match = _ODD.fullmatch(text)
    if match is None:
        return _read_odd_by_meaning(text)
    noun = (match["a"] or match["b"] or match["c"] or match["d"] or match["e"] or "object").strip()
    obj = ObjectSpec("object") if noun in _ANY_ONE else _object(noun)
    return None if obj is None else OddQuery(obj)


_ANY_ONE = ("one", "ones", "man")  # "the odd one out", "the odd man out": any object


_ODD_CUE = re.compile(
    r"\bodd\s+(?:(?P<noun>[a-z]+(?:\s+[a-z]+)?)\s+)?out\b|\bodd\s*ball\b|\bodd\s+(?:one|thing|item|object)\b"
    r"|\b(?:is|are)\s+(?:not\s+(?:like|the\s+same\s+as)|unlike|different(?:\s+(?:from|than|to))?)\b"
    r"|\b(?:does|do)\s+not\s+(?:belong|fit(?:\s+in)?|match|go(?:\s+with)?|look\s+like)\b|\b(?:sticks|stands)\s+out\b"
    r"|\bout\s+of\s+place\b"
)
# the question around the cue: "which one ... the others", "spot ...", "one of these ... which one"
_ODD_FRAME = re.compile(
    r"\b(?:which|what|is|are|the|one|that|of|these|those|them|all|here|among|from|with|than|to|as|rest"
    r"|others|other\s+(?:ones|objects|items|things)|spot|pick\s+out|find|show|point\s+(?:at|to))\b"
)


def _read_odd_by_meaning(text: str) -> OddQuery | None:
    cue = _ODD_CUE.search(text)
    if cue is None:
        return None
    rest = _ODD_FRAME.sub(" ", text[: cue.start()] + " " + text[cue.end() :])
    obj = _object(" ".join(rest.split()))
    if cue["noun"] is not None:  # "the odd mug out"
        named = _object(cue["noun"])
        if named is None or (obj is not None and not obj.generic):
            return None
        obj = named
    if obj is None:
        return None
    return OddQuery(ObjectSpec("object") if obj.noun in _ANY_ONE else obj)


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
    measured = embodied and "distance" in sensors
    if measured:
        w.line("by_size = odd is None")
    w.line("if odd is None:")
    if measured:
        w.line("    # a size apart from perspective: the size in pixels times the measured distance")
        w.line("    distances = [robot.measure_distance(c) for c in candidates]")
        w.line("    sizes = [math.sqrt(c.area) * d for c, d in zip(candidates, distances)]")
        w.line("    middle = sorted(sizes)[len(sizes) // 2]")
        w.line("    misfits = [abs(math.log(size / middle)) for size in sizes]")
        w.line("    odd = misfits.index(max(misfits))")
    else:
        w.line("    # no distance sensor: the size in pixels against the perspective of the others")
        w.line("    odd = size_outlier(candidates)")
    w.line("chosen = candidates[odd]")
    if w.act is not None:
        w.line("chosen = " + w.act.format("chosen"))
    # the answer's value is the attribute that decided (a size in metres), or none: never the distance
    # measured on the way
    if measured:
        w.line("if by_size:")
        w.line("    width, height = chosen.size_at(distances[odd])")
        w.line('    return {"object": chosen, "value": max(width, height), "unit": "m"}')
    w.line('return {"object": chosen}')


FAMILY_REGISTRY.register("odd one out")(
    Family(
        examples=("the odd one out", "Which object does not belong?", "the odd mug out"),
        readers=((30, lambda r: _parse_odd(r.text)),),
        forms=(OddQuery,),
        write=lambda w, q: _write_odd(w, q, w.sensors, w.embodied),
    )
)
