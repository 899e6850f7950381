"""The parsed form of a query: what the families read, and the refusal that names what they could not.

Every reading is a frozen dataclass; `Request` frames one with a surface scope, a narrowing or an action.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from attribot.errors import InputError
from attribot.lexicon import (
    GENERIC_NOUNS,
)
from attribot.sensors import Sense, sense_of

MEASURED = ("weight", "distance")
"""The senses (`attribot.sensors`) that the weight and distance family reads into queries of their own
(`WeightQuery`, `DistanceQuery`, a narrowing `Among`, a yes/no comparison) and writes programs for; the
`senses` family reads the others. Their words, ends and units are read from their records."""


def measured_sense(quantity: str) -> Sense:
    """The record of the measured sense `quantity` (one of `MEASURED`: built in, always registered)."""
    found = sense_of(quantity)
    assert found is not None, quantity
    return found[1]


class UnsupportedQuery(InputError):
    """The rules planner cannot read the query; the message lists the families it supports."""

    def __init__(self, query: str, reason: str | None = None) -> None:
        why = f": {reason}" if reason else ""
        super().__init__(
            f"the rules planner cannot read the query {query!r}{why}",
            "ask within the supported families (location, size, weight, distance, odd one out, measurement, "
            "temperature, softness, fullness), "
            "e.g. 'the heaviest mug on the table', or use the llm planner (--planner llm)",
        )
        self.query = query
        self.reason = reason


# ---- the parsed form ---------------------------------------------------------------------------------

Side = Literal["left", "right", "top", "bottom"]
Level = Literal["top", "bottom"]


@dataclass(frozen=True)
class ObjectSpec:
    """What to look for: the query's own noun ("item", "object", "thing" mean any), and colour words."""

    noun: str
    colors: tuple[str, ...] = ()

    @property
    def generic(self) -> bool:
        return self.noun in GENERIC_NOUNS

    @property
    def phrase(self) -> str:
        return " ".join((*self.colors, self.noun))


@dataclass(frozen=True)
class LineSpec:
    """A row (counted from the top) or a column (counted from the left), or the middle one."""

    kind: Literal["row", "column"]
    index: int = 1  # 1-based
    from_end: bool = False  # counted from the bottom (rows) or the right (columns)
    middle: bool = False


@dataclass(frozen=True)
class Pick:
    """How to choose within a group: the k-th from a side, the middle along an axis, or the most central."""

    kind: Literal["ordinal", "middle", "central", "only"]
    side: Side | None = None
    k: int = 1
    axis: Literal["x", "y"] | None = None


@dataclass(frozen=True)
class LocationQuery:
    obj: ObjectSpec
    line: LineSpec | None
    pick: Pick


@dataclass(frozen=True)
class SizeQuery:
    obj: ObjectSpec
    adjective: str  # as written, for comments
    measure: Literal["area", "height", "width", "length", "thickness"]
    largest: bool
    rank: int = 1


@dataclass(frozen=True)
class WeightQuery:
    objects: tuple[ObjectSpec, ...]  # one spec, or the named candidates of "Out of the X, Y and Z"
    heaviest: bool
    named: bool = False  # the candidates were listed by name
    rank: int = 1  # "the second lightest": 2


@dataclass(frozen=True)
class DistanceQuery:
    objects: tuple[ObjectSpec, ...]
    nearest: bool
    named: bool = False
    rank: int = 1


@dataclass(frozen=True)
class GroundingQuery:
    """A named object and nothing more: "Where is the mug?", "find the red apple"."""

    obj: ObjectSpec


@dataclass(frozen=True)
class MeasureQuery:
    """One named object's distance or weight: "How far away is the lamp?", "How heavy is the apple?"."""

    obj: ObjectSpec
    quantity: Literal["distance", "weight", "size", "height", "width"]


@dataclass(frozen=True)
class OddQuery:
    """The one object unlike the others: "the odd one out", "which object does not belong?"."""

    obj: ObjectSpec


@dataclass(frozen=True)
class YesNoQuery:
    """Whether one named object has more (or less) of an attribute than another: "Is the kettle heavier
    than the backpack?", "Is the book to the left of the mug?". The answer says yes or no, with both
    values and which one has more."""

    first: ObjectSpec
    second: ObjectSpec
    attribute: Literal["weight", "distance", "size", "position"]
    more: bool  # asks whether `first` is heavier, farther, bigger, further right than `second`
    word: str  # as written: "heavier", "closer", "to the left of"


@dataclass(frozen=True)
class SenseQuery:
    """A question about what only a sense beyond the camera settles: temperature (an infrared
    thermometer), stiffness (a squeeze; softness is less of it), fullness (weighing a container), or any
    sense a lab registers (`attribot.sensors`): `attribute` is its quantity.

    ask: "which" chooses among `objects` (one kind, or the named ones) the one at the end asked ("which mug
    is hot?", "the softest ball"); "whether" answers yes or no, about one object's state ("is the kettle
    hot?": `word` is the state) or about two named objects ("is the kettle hotter than the mug?"); "how"
    measures one named object ("how hot is the kettle?")."""

    objects: tuple[ObjectSpec, ...]
    attribute: str
    more: bool  # the end asked: hotter, harder (stiffer), fuller
    ask: Literal["which", "whether", "how"]
    word: str  # as written: "hot", "softest", "hotter"
    named: bool = False  # the candidates were listed by name
    rank: int = 1  # "the second coldest can": 2


@dataclass(frozen=True)
class Among:
    """The candidates narrowed to the k at one end of another attribute: "of the two closest"."""

    attribute: Literal["weight", "distance"]
    most: bool  # the heaviest or the nearest end
    k: int


@dataclass(frozen=True)
class Region:
    """A part of the view a choice is scoped to: a side ("on the left side", "in the right half") or a row or
    column ("in the top row", "in the second column")."""

    side: Side | None = None
    line: LineSpec | None = None

    @property
    def words(self) -> str:
        """How a side is said, for comments and messages ("on the left side")."""
        return f"on the {self.side} side"


@dataclass(frozen=True)
class Request:
    """A reading with a frame around it: a surface it is scoped to ("on the table"), a narrowing ("of the
    two closest"), an action on the chosen object ("bring me", "put ... on the counter")."""

    inner: LocationQuery | SizeQuery | WeightQuery | DistanceQuery | GroundingQuery | OddQuery | SenseQuery
    scope: str | None = None  # a surface kind of `attribot.lexicon.SURFACE_WORDS`
    region: Region | None = None  # a side, row or column of the view (of the surface, with a scope)
    among: Among | None = None
    action: Literal["pick", "put"] | None = None
    target: str | None = None  # what "put" puts the object on: a surface kind or an object's name
    level: Level | None = None  # the board of a shelf the scope is ("on the bottom shelf")
    exclude: tuple[ObjectSpec, ...] = ()  # left out of the candidates ("apart from the kettle")
    after: ObjectSpec | None = (
        None  # the choice is the next one after it in the order ("next heaviest after")
    )


@dataclass(frozen=True)
class Understood:
    """A reading of a query whose words the language front end mended first: the reading, and what was read
    as what ("reading 'botle' as 'bottle'"), which the program says."""

    inner: ParsedQuery
    notes: tuple[str, ...]


ParsedQuery = (
    LocationQuery
    | SizeQuery
    | WeightQuery
    | DistanceQuery
    | GroundingQuery
    | MeasureQuery
    | OddQuery
    | YesNoQuery
    | SenseQuery
    | Request
    | Understood
)
