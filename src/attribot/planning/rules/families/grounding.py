"""Grounding: a named object and nothing more ("Where is the mug?")."""

from __future__ import annotations

from attribot.planning.rules.families import FAMILY_REGISTRY, Family
from attribot.planning.rules.forms import (
    GroundingQuery,
)
from attribot.planning.rules.normalise import (
    _named,
)
from attribot.planning.rules.write import (
    _find,
    _Writer,
)


def _parse_grounding(text: str, opened: bool) -> GroundingQuery | None:
    """What is left of "Where is the mug?", "find the red apple" once the opening is dropped: a name. A bare
    name with a colour ("the red mug") names one object too; a bare name alone ("the dog") is not read:
    with several dogs in view it asks for an attribute it does not name."""
    obj = _named(text)
    if obj is None or not (opened or obj.colors):
        return None
    return GroundingQuery(obj)


def _write_grounding(w: _Writer, q: GroundingQuery) -> None:
    _find(w, q.obj)
    w.line("# find lists the best match first")
    w.line("return candidates[0]")


FAMILY_REGISTRY.register("grounding")(
    Family(
        examples=("Where is the mug?", "find the red apple", "point at the remote control", "the red mug"),
        readers=((70, lambda r: _parse_grounding(r.plain, r.opened)),),
        forms=(GroundingQuery,),
        write=lambda w, q: _write_grounding(w, q),
    )
)
