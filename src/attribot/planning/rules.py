"""The offline planner: a deterministic parser for the query families of the paper.

It reads location, size, weight and distance queries (see `FAMILIES`) and writes the same kind of program
an LLM writes against the API: `find` the objects the query names, then order or measure them. Rows and
columns are found by clustering box centres, not by cutting the image into equal bands (the failure the
paper reports for GPT-3.5). "long" and "short" follow the object's orientation (the longer box side).
Weight and distance are measured with the robot's sensors when it has them; otherwise the program uses
the paper's VQA + language-model chain (weight) or a visual proxy that it states in a comment
(distance). A query outside these families raises `UnsupportedQuery`, which lists what is supported: the
planner never guesses.
"""

from __future__ import annotations

import json
import re
import unicodedata
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from attribot.errors import InputError
from attribot.lexicon import (
    COLOR_ALIASES,
    COLOR_WORDS,
    DEICTIC_WORDS,
    FAR_WORDS,
    GENERIC_NOUNS,
    NEAR_WORDS,
    SIZE_ADJECTIVES,
    SIZE_COMPARATIVES,
    SIZE_SUPERLATIVES,
    SURFACE_WORDS,
    WEIGHT_HEAVY,
    WEIGHT_LIGHT,
    paraphrased,
)
from attribot.planning.base import PLANNERS, Attempt, Plan, PlanRequest, check_query

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = [
    "FAMILIES",
    "UnsupportedQuery",
    "ObjectSpec",
    "LineSpec",
    "Pick",
    "LocationQuery",
    "SizeQuery",
    "WeightQuery",
    "DistanceQuery",
    "GroundingQuery",
    "MeasureQuery",
    "OddQuery",
    "YesNoQuery",
    "Among",
    "Request",
    "ParsedQuery",
    "parse_query",
    "write_program",
    "rules_program",
    "RulesPlanner",
]

FAMILIES: dict[str, tuple[str, ...]] = {
    "location": (
        "the second dog from the right",
        "top right cocktail",
        "the second umbrella from the left in the second to last row",
        "the pill in the middle of the right column",
    ),
    "size": (
        "the third tallest item",
        "the smallest red apple",
        "the long carrot",
        "which cup is the tallest",
    ),
    "weight": (
        "the heaviest item",
        "Out of the laptop, the chair and the credit card, which one is the most lightweight?",
        "Which object weighs the most?",
        "the lightest of the apple, the phone and the kettle",
    ),
    "distance": (
        "Is the laptop or the tv closer to me?",
        "the closest chair",
        "Out of the mugs, which one is closer to me?",
        "Which object is farthest away from the robot?",
    ),
    "odd one out": ("the odd one out", "Which object does not belong?", "the odd mug out"),
    "grounding": ("Where is the mug?", "find the red apple", "point at the remote control", "the red mug"),
    "measurement": (
        "How far away is the lamp?",
        "How heavy is the apple?",
        "How much does the book weigh?",
        "What's the distance to the book?",
        "How big is the toaster?",
    ),
    "yes/no": ("Is the kettle heavier than the backpack?", "Is the book to the left of the mug?"),
    "scope": ("What's the heaviest thing on the counter?", "Which object is on the floor?"),
    "action": ("bring me the lightest cup on the table", "Put the tomato on the counter"),
    "composition": ("the second lightest mug", "the heaviest of the two closest objects"),
}
"""The families the rules planner reads, each with example phrasings."""


class UnsupportedQuery(InputError):
    """The rules planner cannot read the query; the message lists the families it supports."""

    def __init__(self, query: str, reason: str | None = None) -> None:
        why = f": {reason}" if reason else ""
        super().__init__(
            f"the rules planner cannot read the query {query!r}{why}",
            "ask within the supported families (location, size, weight, distance, odd one out, measurement), "
            "e.g. 'the heaviest mug on the table', or use the llm planner (--planner llm)",
        )
        self.query = query
        self.reason = reason


# ---- the parsed form ---------------------------------------------------------------------------------

Side = Literal["left", "right", "top", "bottom"]


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
class Among:
    """The candidates narrowed to the k at one end of another attribute: "of the two closest"."""

    attribute: Literal["weight", "distance"]
    most: bool  # the heaviest or the nearest end
    k: int


@dataclass(frozen=True)
class Request:
    """A reading with a frame around it: a surface it is scoped to ("on the table"), a narrowing ("of the
    two closest"), an action on the chosen object ("bring me", "put ... on the counter")."""

    inner: LocationQuery | SizeQuery | WeightQuery | DistanceQuery | GroundingQuery | OddQuery
    scope: str | None = None  # a surface kind of `attribot.lexicon.SURFACE_WORDS`
    among: Among | None = None
    action: Literal["pick", "put"] | None = None
    target: str | None = None  # what "put" puts the object on: a surface kind or an object's name


ParsedQuery = (
    LocationQuery
    | SizeQuery
    | WeightQuery
    | DistanceQuery
    | GroundingQuery
    | MeasureQuery
    | OddQuery
    | YesNoQuery
    | Request
)


# ---- the parser ----------------------------------------------------------------------------------------

_ORDINAL_WORDS = {
    w: i + 1
    for i, w in enumerate(
        "first second third fourth fifth sixth seventh eighth ninth tenth eleventh twelfth thirteenth "
        "fourteenth fifteenth sixteenth seventeenth eighteenth nineteenth twentieth".split()
    )
}
_ORD = (
    r"(?:(?:second|third|fourth|fifth|\d+(?:st|nd|rd|th))\s+(?:to|from)\s+(?:the\s+)?last|penultimate|last|"
    + "|".join(_ORDINAL_WORDS)
    + r"|\d+(?:st|nd|rd|th))"
)
_SIDES: dict[str, Side] = {
    "left": "left",
    "right": "right",
    "top": "top",
    "upper": "top",
    "bottom": "bottom",
    "lower": "bottom",
}
_OPPOSITE: dict[str, Side] = {"left": "right", "right": "left", "top": "bottom", "bottom": "top"}

# size adjectives: word -> (measure, largest)
_SIZE = SIZE_ADJECTIVES
_SUPERLATIVE = SIZE_SUPERLATIVES
_COMPARATIVE = SIZE_COMPARATIVES
_SIZE_WORDS = "|".join(sorted([*_SIZE, *_SUPERLATIVE, *_COMPARATIVE], key=len, reverse=True))
_WEIGHT_HEAVY = WEIGHT_HEAVY
_WEIGHT_LIGHT = WEIGHT_LIGHT
_WEIGHT_WORDS = "|".join(sorted(_WEIGHT_HEAVY | _WEIGHT_LIGHT, key=len, reverse=True))
_NEAR = NEAR_WORDS
_FAR = FAR_WORDS
_DIST_WORDS = "|".join(sorted(_NEAR | _FAR, key=len, reverse=True))
_ME = r"(?:\s+(?:to|from)\s+(?:me|you|us|the\s+robot|the\s+camera))?"

# words that cannot be part of an object's name here: left over from a phrase the parser did not read
_STOP = {
    "from",
    "row",
    "rows",
    "column",
    "columns",
    "left",
    "right",
    "top",
    "bottom",
    "middle",
    "center",
    "centre",
    "is",
    "are",
    "which",
    "what",
    "where",
    "who",
    "how",
    "why",
    "or",
    "than",
    "and",
    "me",
    "you",
    "in",
    "on",
    "at",
    "to",
    "the",
    "a",
    "an",
    "not",
    "no",
    "leftmost",
    "rightmost",
    "topmost",
    "bottommost",
    "most",
    "least",
    "very",
    "side",
    "corner",
    "between",
    "next",
    "near",
    "behind",
    "under",
    "above",
    "below",
    "beside",
    "inside",
    "if",
    "does",
    "do",
    "there",
    "any",
    "all",
    "every",
    # verbs and persons of a sentence around a name, never part of it
    "would",
    "be",
    "will",
    "should",
    "might",
    "need",
    "want",
    "see",
    "think",
    "i",
    "we",
    "by",
    "has",
    "have",
    "seems",
    # verbs of a request and joining words, never part of a name
    "put",
    "onto",
    "into",
    "bring",
    "give",
    "tell",
    "weigh",
    "weighs",
    *_ORDINAL_WORDS,
    "last",
    "penultimate",
    *_SIZE,
    *_SUPERLATIVE,
    *_COMPARATIVE,
    "heaviest",
    "heavier",
    "heavy",
    "lightest",
    "lighter",
    "lightweight",
    *_NEAR,
    *_FAR,
    "distant",
}


_LEAD = (
    r"^(?:please\s+)?(?:(?:can|could)\s+you\s+)?(?:find|show(?:\s+me)?|point\s+(?:to|at)|select|pick\s+up|pick|get|"
    r"give\s+me|locate|detect|identify|where\s+(?:is|are)|grab|look\s+(?:at|for)|i\s+am\s+looking\s+for|"
    r"show\s+me\s+where|where\s+can\s+i\s+find|help\s+me\s+find)\s+"
)


def _normalize(query: str) -> tuple[str, bool, str] | None:
    """Lower case, accents folded, punctuation to spaces, polite or imperative openings ("find", "where
    is") and articles dropped, and whether there was such an opening; None when the text holds letters
    outside a-z (another script), which the planner cannot read. The third item is the text before the
    opening was dropped, which the frames (actions) read."""
    text = unicodedata.normalize("NFKD", query.lower().replace("\u2019", "'").replace("-", " "))
    text = "".join(ch for ch in text if not unicodedata.combining(ch))
    if any(ch.isalpha() and not ("a" <= ch <= "z") for ch in text):
        return None
    text = re.sub(r"[^a-z0-9',\s]", " ", text)
    text = " ".join(text.split()).strip(" ,")
    for short, full in _CONTRACTIONS:
        if short in text:
            text = text.replace(short, full)
    text = _COURTESY.sub(" ", text)
    text = " ".join(text.split()).strip(" ,")
    text = paraphrased(text)
    # the opening carries no meaning for the attribute families; alone with a name, it asks where it is
    stripped = re.sub(_LEAD, "", text)
    return _strip_article(stripped), stripped != text, text


_CONTRACTIONS = (
    ("doesn't", "does not"),
    ("don't", "do not"),
    ("isn't", "is not"),
    ("aren't", "are not"),
    ("where's", "where is"),
    ("what's", "what is"),
    ("which's", "which is"),
    ("i'm", "i am"),
    ("you're", "you are"),
)
# courtesy carries no meaning: "please", "for me", "thanks", and "I'm looking for" is "find"
_COURTESY = re.compile(
    r"\bplease\b|\b(?:thanks|thank\s+you)\b|\bfor\s+me\b(?!\s+to)|\bkindly\b"
    r"|^(?:hey|hi|hello|ok|okay)(?:\s+(?:robot|there|attribot))?\s*,?"
)


def _strip_article(text: str) -> str:
    return re.sub(r"^(?:the|a|an|some)\s+", "", text.strip(" ,")).strip(" ,")


def _ordinal(text: str) -> tuple[int, bool]:
    """(k, counted from the far end) of an ordinal: "second" (2, False), "second to last" (2, True)."""
    text = " ".join(text.split())
    if text == "last":
        return 1, True
    if text == "penultimate":
        return 2, True
    match = re.fullmatch(r"(\w+)\s+(?:to|from)\s+(?:the\s+)?last", text)
    if match:
        return _ordinal(match.group(1))[0], True
    if text in _ORDINAL_WORDS:
        return _ORDINAL_WORDS[text], False
    match = re.fullmatch(r"(\d+)(?:st|nd|rd|th)", text)
    if match:
        return int(match.group(1)), False
    raise ValueError(text)


# "of these", "among the three", "out of them": the candidate set is what is in view, any object
_COUNT_WORDS = r"(?:two|three|four|five|six)"
_CANDIDATE_SET = re.compile(
    r"^(?:of|among|out\s+of|from)\s+(?:them|all"
    r"|(?:these|those|(?:all\s+)?the)(?:\s+" + _COUNT_WORDS + r")?(?:\s+(?:ones|items|objects|things))?)$"
)
_HERE = re.compile(r"\s+(?:here|there|around|in\s+view|in\s+front\s+of\s+(?:me|you|us|the\s+robot))$")
_HERE_ENDINGS = ("here", "there", "around", "view", "me", "you", "us", "robot")
_SET_OPENINGS = ("of ", "among ", "out of ", "from ")
# words that never name an object: left over from a phrase the parser did not place ("of these")
_NOT_A_NAME = DEICTIC_WORDS | {"of"}


def _object(phrase: str) -> ObjectSpec | None:
    """The object named by what is left of a phrase, or None when the rest is not a plain name."""
    phrase = _strip_article(phrase)
    phrase = re.sub(r"\s+(?:in|of|from)\s+(?:the\s+)?(?:image|picture|photo|frame|scene|view)$", "", phrase)
    if phrase.endswith(_HERE_ENDINGS):  # the cheap test first: _object runs for every family tried
        phrase = _HERE.sub("", phrase)
    if phrase.startswith(_SET_OPENINGS) and _CANDIDATE_SET.match(phrase):
        return ObjectSpec("object")
    words = phrase.split()
    if any(w in _NOT_A_NAME for w in words):
        return None
    if not words:
        return ObjectSpec("object")
    if len(words) > 6 or any(not re.fullmatch(r"[a-z0-9']+", w) or w in _STOP for w in words):
        return None
    if all(w.isdigit() for w in words):
        return None
    colors = tuple(w for w in words[:-1] if COLOR_ALIASES.get(w, w) in COLOR_WORDS)
    noun_words = [w for w in words if w not in colors] if colors else words
    if not noun_words:
        return None
    noun = " ".join(noun_words)
    if noun in ("items", "objects", "things", "ones"):
        noun = noun[:-1]
    return ObjectSpec(noun=noun, colors=colors)


def _take(pattern: str, text: str) -> tuple[re.Match[str] | None, str]:
    """The first match of `pattern` and the text with it cut out."""
    match = re.search(pattern, text)
    if match is None:
        return None, text
    return match, " ".join((text[: match.start()] + " " + text[match.end() :]).split())


def _parse_location(text: str) -> LocationQuery | None:
    text = re.sub(r"\s+(?:of|in)\s+(?:the\s+)?(?:image|picture|photo|frame|scene)\b", "", text)
    line: LineSpec | None = None
    pick: Pick | None = None
    middle_of = False

    # rows and columns: "in the middle of the second row from the top", "at the second to last row"
    which = (
        _ORD
        + r"|top|bottom|upper|lower|middle|center|centre|central|left|right"
        + r"|leftmost|rightmost|topmost|bottommost"
    )
    match, text = _take(
        r"\b(?:(?:in|on|at|of|from|within|along)\s+)?(?:the\s+)?(?P<mid>(?:very\s+)?(?:middle|center|centre)\s+of\s+"
        r"(?:the\s+)?)?(?P<which>" + which + r")\s+(?P<kind>rows?|lines?|columns?|cols?)"
        r"(?:\s+(?:starting\s+|counting\s+)?from\s+(?:the\s+)?(?P<side>top|bottom|left|right))?\b",
        text,
    )
    if match:
        kind: Literal["row", "column"] = "column" if match["kind"].startswith("col") else "row"
        word = match["which"]
        side = match["side"]
        if word in ("middle", "center", "centre", "central"):
            line = LineSpec(kind, middle=True)
        elif word in ("top", "upper", "topmost", "bottom", "lower", "bottommost"):
            if kind != "row":
                return None
            line = LineSpec(kind, 1, from_end=word in ("bottom", "lower", "bottommost"))
        elif word in ("left", "leftmost", "right", "rightmost"):
            if kind != "column":
                return None
            line = LineSpec(kind, 1, from_end=word in ("right", "rightmost"))
        else:
            k, from_end = _ordinal(word)
            if side is not None:
                expected = ("top", "bottom") if kind == "row" else ("left", "right")
                if side not in expected:
                    return None
                from_end = from_end != (side == expected[1])
            line = LineSpec(kind, k, from_end=from_end)
        if _k_invalid(line):
            return None
        middle_of = match["mid"] is not None

    # corners: "top right cocktail", "the egg in the bottom left corner"
    corner, text = _take(
        r"\b(?:(?:at|in|on)\s+the\s+)?(top|upper|bottom|lower)\s+(left|right)(?:\s+corner)?\b", text
    )
    # extremes: "leftmost", "at the very bottom", "with the highest altitude"
    extreme: Side | None = None
    match, text = _take(r"\bwith\s+the\s+(highest|lowest)\s+(?:altitude|position|height)\b", text)
    if match:
        extreme = "top" if match[1] == "highest" else "bottom"
    if extreme is None:
        match, text = _take(
            r"\b(?:at|on|in|to)\s+the\s+(?:very|far|furthest|farthest)\s+(top|bottom|left|right)\b", text
        )
        if match:
            extreme = _SIDES[match[1]]
    if extreme is None:
        match, text = _take(
            r"\b(leftmost|rightmost|topmost|uppermost|bottommost|lowermost|highest|lowest)\b", text
        )
        if match:
            extremes: dict[str, Side] = {
                "leftmost": "left",
                "rightmost": "right",
                "topmost": "top",
                "uppermost": "top",
                "highest": "top",
                "bottommost": "bottom",
                "lowermost": "bottom",
                "lowest": "bottom",
            }
            extreme = extremes[match[1]]
    # ordinal with a direction: "second dog from the right", "second from the left dog head"
    direction: Side | None = None
    ordinal: tuple[int, bool] | None = None
    match, text = _take(
        r"\b(?:starting\s+|counting\s+)?from\s+(?:the\s+)?(left|right|top|bottom)(?:\s+side)?\b", text
    )
    if match:
        direction = _SIDES[match[1]]
    match, text = _take(r"^(?:the\s+)?(" + _ORD + r")\b", text)
    if match:
        ordinal = _ordinal(match[1])
    elif direction is not None:
        return None  # "from the left" with no ordinal: nothing to count
    # positions: "at the bottom", "on the right", "in the middle"
    position: str | None = None
    match, text = _take(
        r"\b(?:at|on|in|to|towards)\s+(?:the\s+)?(top|bottom|left|right|middle|center|centre)(?:\s+(?:side|part|edge))?\b",
        text,
    )
    if match:
        position = {"center": "middle", "centre": "middle"}.get(match[1], match[1])
    # a leading "middle", "right", "top" used as an adjective: "middle window", "right eye"
    middle_adj = False
    side_adj: Side | None = None
    match, text = _take(r"^(?:the\s+)?(middle|center|centre|central)\b", text)
    if match:
        middle_adj = True
    else:
        match, text = _take(r"^(?:the\s+)?(left|right|top|bottom|upper|lower)\s+(?=\S)", text)
        if match:
            side_adj = _SIDES[match[1]]

    # what is chosen within the group
    if ordinal is not None:
        k, from_end = ordinal
        start: Side = direction or ("top" if line is not None and line.kind == "column" else "left")
        pick = Pick("ordinal", _OPPOSITE[start] if from_end else start, k)
    elif extreme is not None:
        pick = Pick("ordinal", extreme, 1)
    elif middle_of or middle_adj:
        pick = Pick("middle")  # the axis follows the line, below
    elif side_adj is not None:
        pick = Pick("ordinal", side_adj, 1)
    if corner is not None:
        vertical, horizontal = _SIDES[corner[1]], _SIDES[corner[2]]
        if line is not None or (pick is not None and pick.kind != "middle"):
            return None  # "second top right X": more than one way to read it
        line = LineSpec("row", 1, from_end=vertical == "bottom")
        pick = Pick("ordinal", horizontal, 1)
    if position is not None:
        if pick is None:
            pick = Pick("central") if position == "middle" else Pick("ordinal", position, 1)  # type: ignore[arg-type]
        elif line is None:
            line = {
                "top": LineSpec("row", 1),
                "bottom": LineSpec("row", 1, from_end=True),
                "left": LineSpec("column", 1),
                "right": LineSpec("column", 1, from_end=True),
                "middle": LineSpec("row", middle=True),
            }[position]
        else:
            return None
    if pick is None:
        if line is None:
            return None
        pick = Pick("only")
    if pick.kind == "middle":
        if line is None:
            pick = Pick("central")
        else:
            pick = Pick("middle", axis="x" if line.kind == "row" else "y")
    if pick.kind == "ordinal" and line is not None:
        # an ordinal along the line's own cross axis ("topmost X in the top row") is no choice at all
        cross = ("top", "bottom") if line.kind == "row" else ("left", "right")
        if pick.side in cross and pick.k > 1:
            return None
    obj = _object(text)
    if obj is None or pick.k < 1:
        return None
    return LocationQuery(obj=obj, line=line, pick=pick)


def _k_invalid(line: LineSpec) -> bool:
    return not line.middle and line.index < 1


def _parse_size(text: str) -> SizeQuery | None:
    match = re.fullmatch(
        r"(?:(?P<ord>"
        + _ORD
        + r")\s+)?(?:(?P<deg>most|least)\s+)?(?P<adj>"
        + _SIZE_WORDS
        + r")(?:\s+(?P<rest>.+))?",
        text,
    )
    if match is None:
        match = re.fullmatch(
            r"(?P<rest>.+?)\s+(?:that|which|who)\s+(?:is|are)\s+(?:the\s+)?(?:(?P<ord>" + _ORD + r")\s+)?"
            r"(?:(?P<deg>most|least)\s+)?(?P<adj>" + _SIZE_WORDS + r")(?:\s+one)?",
            text,
        )
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


def _split_names(text: str) -> tuple[ObjectSpec, ...] | None:
    parts = [p for p in re.split(r"\s*,\s*(?:and\s+|or\s+)?|\s+(?:and|or)\s+", text) if p.strip()]
    specs: list[ObjectSpec] = []
    for part in parts:
        spec = _object(part)
        if spec is None or spec.generic:  # a list names objects: "one" or "item" is no name
            return None
        if spec not in specs:
            specs.append(spec)
    return tuple(specs) or None


_COMPARE_WORDS = _WEIGHT_WORDS + "|" + _DIST_WORDS
_COMPARE_FORMS = [
    re.compile(form)
    for form in (
        # "Is the laptop or the tv closer to me?"
        r"(?:is|are)\s+(?P<list>.+?\s+or\s+.+?)\s+(?P<adj>" + _COMPARE_WORDS + r")" + _ME,
        # "Out of the laptop, chair and card, which one is the most lightweight?"
        r"(?:out\s+of|of|among|amongst|between|from)\s+(?P<list>.+?),?\s+which(?:\s+one|\s+item|\s+object)?"
        r"(?:\s+of\s+(?:them|these|those))?\s+(?:is|are)\s+(?:the\s+)?(?P<adj>" + _COMPARE_WORDS + r")" + _ME,
        # "Which one is closer to me, the laptop or the tv?"
        r"which(?:\s+one|\s+item|\s+object)?\s+(?:is|are)\s+(?:the\s+)?(?P<adj>"
        + _COMPARE_WORDS
        + r")"
        + _ME
        + r",?\s+(?:(?:out\s+)?of\s+|among\s+|between\s+)?(?P<list>.+)",
        # "Which one is the heaviest?", "Which mug is the closest to me?"
        r"which(?:\s+one|\s+(?P<noun>[a-z]+(?:\s+[a-z]+)?))?\s+(?:is|are)\s+(?:the\s+)?(?P<adj>"
        + _COMPARE_WORDS
        + r")"
        + _ME,
        # "the lightest of the apple, the phone and the kettle" (a list: two names or more)
        r"(?:the\s+)?(?P<adj>" + _COMPARE_WORDS + r")" + _ME + r"(?:\s+one)?\s+(?:of|among|out\s+of|from)\s+"
        r"(?P<list>.+?(?:,|\s+and\s+|\s+or\s+).+?)" + _ME,
        # "the X or the Y: which is closer?"
        r"(?P<list>.+?\s+or\s+.+?),?\s+which(?:\s+one)?\s+is\s+(?P<adj>" + _COMPARE_WORDS + r")" + _ME,
        # "Is the apple heavier than the book?", "Is the lamp closer to me than the chair?": the program
        # answers with the one that is (the apple, or else the book)
        r"(?:is|are)\s+(?P<first>.+?)\s+(?P<adj>"
        + _COMPARE_WORDS
        + r")"
        + _ME
        + r"\s+than\s+(?P<second>.+?)"
        + _ME,
    )
]
"""The comparative and "out of" forms of weight and distance queries, compiled once."""


def _parse_compare(text: str) -> WeightQuery | DistanceQuery | None:
    """The comparative and "out of" forms of weight and distance queries."""
    for form in _COMPARE_FORMS:
        match = form.fullmatch(text)
        if match is None:
            continue
        adjective = match["adj"]
        listed = match.groupdict().get("list")
        if match.groupdict().get("first") is not None:
            listed = f"{match['first']} or {match['second']}"
        if listed is not None and _CANDIDATE_SET.match("of " + listed):
            # "Out of these objects, which one...": the set is what is in view, not a list of names
            listed, match_noun = None, "object"
        else:
            match_noun = None
        if listed is not None:
            objects = _split_names(_strip_article(listed))
            if objects is None:  # e.g. "to me" read as a list by an earlier form: try the next form
                continue
            named = True
        else:
            noun = match_noun or match.groupdict().get("noun")
            spec = _object(noun) if noun else ObjectSpec("object")
            if spec is None:
                continue
            objects, named = (spec,), False
        if adjective in _NEAR or adjective in _FAR:
            return DistanceQuery(objects=objects, nearest=adjective in _NEAR, named=named)
        return WeightQuery(objects=objects, heaviest=adjective in _WEIGHT_HEAVY, named=named)
    return None


def _parse_superlative(text: str) -> WeightQuery | DistanceQuery | None:
    """ "the heaviest item", "the light box", "the closest chair", "the mug nearest to me"."""
    words = _WEIGHT_WORDS + "|" + _DIST_WORDS
    match = re.fullmatch(r"(?P<adj>" + words + r")(?:\s+(?P<rest>.+?))?" + _ME, text) or re.fullmatch(
        r"(?P<rest>.+?)\s+(?:that\s+is\s+|which\s+is\s+)?(?:the\s+)?(?P<adj>" + words + r")" + _ME, text
    )
    if match is None:
        return None
    obj = _object(match["rest"] or "")
    if obj is None:
        return None
    adjective = match["adj"]
    if adjective in _NEAR or adjective in _FAR:
        return DistanceQuery(objects=(obj,), nearest=adjective in _NEAR)
    return WeightQuery(objects=(obj,), heaviest=adjective in _WEIGHT_HEAVY)


_MEASURE_FORMS: tuple[tuple[str, Literal["distance", "weight", "size", "height", "width"]], ...] = (
    (r"how\s+(?:far(?:\s+away)?|close|near)" + _ME + r"\s+(?:is|are)\s+(?P<obj>.+?)" + _ME, "distance"),
    (r"(?:what\s+is\s+)?(?:the\s+)?distance\s+(?:to|of)\s+(?P<obj>.+?)" + _ME, "distance"),
    (r"how\s+heavy\s+(?:is|are)\s+(?P<obj>.+)", "weight"),
    (r"how\s+much\s+(?:does|do)\s+(?P<obj>.+?)\s+weigh", "weight"),
    (r"what\s+(?:does|do)\s+(?P<obj>.+?)\s+weigh", "weight"),
    (r"(?:what\s+is\s+)?(?:the\s+)?(?:weight|mass)\s+of\s+(?P<obj>.+)", "weight"),
    (r"how\s+(?:big|large|long)\s+(?:is|are)\s+(?P<obj>.+)", "size"),
    (r"how\s+(?:tall|high)\s+(?:is|are)\s+(?P<obj>.+)", "height"),
    (r"how\s+(?:wide|broad)\s+(?:is|are)\s+(?P<obj>.+)", "width"),
    (r"what\s+size\s+(?:is|are)\s+(?P<obj>.+)", "size"),
    (r"(?:what\s+is\s+)?(?:the\s+)?(?:size|length)\s+of\s+(?P<obj>.+)", "size"),
    (r"(?:what\s+is\s+)?(?:the\s+)?height\s+of\s+(?P<obj>.+)", "height"),
    (r"(?:what\s+is\s+)?(?:the\s+)?width\s+of\s+(?P<obj>.+)", "width"),
)


_PRONOUNS = DEICTIC_WORDS


def _named(text: str) -> ObjectSpec | None:
    """A specific object's name: not generic ("the item"), not a pronoun ("it": nothing to refer to)."""
    obj = _object(text)
    if obj is None or obj.generic or obj.noun in _PRONOUNS:
        return None
    return obj


def _parse_measure(text: str) -> MeasureQuery | WeightQuery | DistanceQuery | None:
    """ "How far away is the lamp?", "How much does the apple weigh?": one named object's measurement; "How
    far is the closest chair?": the chosen object, measured."""
    for form, quantity in _MEASURE_FORMS:
        match = re.fullmatch(form, text)
        if match is None:
            continue
        obj = _named(match["obj"])
        if obj is not None:
            return MeasureQuery(obj, quantity)
        # "How far is the closest chair?": the closest chair, whose measured distance the answer gives
        chosen = _parse_superlative(_strip_article(match["obj"]))
        wanted = DistanceQuery if quantity == "distance" else WeightQuery
        return chosen if isinstance(chosen, wanted) else None
    return None


def _parse_grounding(text: str, opened: bool) -> GroundingQuery | None:
    """What is left of "Where is the mug?", "find the red apple" once the opening is dropped: a name. A bare
    name with a colour ("the red mug") names one object too; a bare name alone ("the dog") is not read:
    with several dogs in view it asks for an attribute it does not name."""
    obj = _named(text)
    if obj is None or not (opened or obj.colors):
        return None
    return GroundingQuery(obj)


_WHICH_X_IS = re.compile(
    r"(?:which|what)\s+(?P<noun>[a-z]+(?:\s+[a-z]+){0,2})\s+(?:is|are)\s+(?:the\s+)?"
    r"(?P<adj>(?:(?:" + _ORD + r")\s+)?(?:" + _SIZE_WORDS + r"))"
)
_WHICH_X_IS_EXTREME = re.compile(
    r"(?:which|what)\s+(?P<noun>[a-z]+(?:\s+[a-z]+){0,2}?)\s+(?:is|are)\s+(?:the\s+)?"
    r"(?P<adj>leftmost|rightmost|topmost|uppermost|bottommost|lowermost)(?:\s+one)?"
)
_WHICH_X_IS_NTH = re.compile(
    r"(?:which|what)\s+(?P<noun>[a-z]+(?:\s+[a-z]+){0,2}?)\s+(?:is|are)\s+(?:the\s+)?"
    r"(?P<ord>" + _ORD + r"|last)\s+(?P<rest>(?:from|in|on)\s+.+)"
)
_OTHERS = r"(?:all\s+)?the\s+(?:others|rest|other\s+(?:ones|objects|items|things))"
_ODD = re.compile(
    r"(?:(?:which|what)\s+(?:(?:one|object|item|thing)\s+)?(?:is\s+)?)?(?:the\s+)?odd\s+(?P<a>[a-z]+(?:\s+[a-z]+)?\s+)?out"
    r"|(?:the\s+)?odd\s+one"
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


# ---- reading by meaning: the attribute wherever it stands, the candidates from what is left -----------

_CUE = re.compile(
    r"\b(?:(?P<ord>" + _ORD + r")\s+)?(?:(?P<deg>most|least|more|less)\s+)?(?P<adj>"
    + "|".join(sorted([*_SIZE, *_SUPERLATIVE, *_COMPARATIVE, *_WEIGHT_HEAVY, *_WEIGHT_LIGHT, *_NEAR, *_FAR],
                      key=len, reverse=True))
    + r")\b(?:\s+away)?"
)  # fmt: skip
_POLITE = re.compile(
    r"^(?:please\s+)?(?:(?:can|could|would)\s+you\s+)?(?:please\s+)?"
    r"(?:tell\s+me|let\s+me\s+know|do\s+you\s+know|i\s+(?:want|would\s+like|d\s+like)\s+to\s+know"
    r"|i\s+(?:need|want)|i\s+am\s+looking\s+for|get\s+me|bring\s+me|hand\s+me)\s+"
)
_FRAME = re.compile(
    r"\b(?:which|what|is|are|of|among|amongst|out|from|between|the|a|an|one|ones|all|these|those|them|"
    r"here|currently|visible|present|" + _COUNT_WORDS + r"|[2-6])\b"
)
_PLACE = re.compile(
    r"\b(?:in|on)\s+(?:the\s+)?(?:image|picture|photo|frame|scene|view|room)\b|\bin\s+view\b"
    r"|\bin\s+front\s+of\s+(?:me|you|us|the\s+robot|the\s+camera)\b"
    r"|\b(?:that\s+|which\s+)?(?:you|i|we)\s+(?:can\s+)?see\b"
    r"|\b(?:do|would)\s+you\s+(?:think|say)\b|\b(?:would|will|might|could)\s+be\b|\b(?:does|do|did)\b"
)
# "heavier than the others" is the heaviest
_THAN_THE_REST = re.compile(
    r"\bthan\s+(?:all\s+)?(?:the\s+|any\s+)?(?:others?|rest|other\s+(?:objects?|items?|things?|ones?))\b"
)
_ME_ANYWHERE = re.compile(r"\b(?:to|from)\s+(?:me|you|us|the\s+robot|the\s+camera)\b")


def _attribute(adjective: str) -> str:
    if adjective in _WEIGHT_HEAVY or adjective in _WEIGHT_LIGHT:
        return "weight"
    if adjective in _NEAR or adjective in _FAR:
        return "distance"
    return "size"


def _read_by_meaning(text: str, original: str) -> ParsedQuery | None:
    """The attribute (weight, distance, size and its dimension), its direction and rank wherever they stand,
    and the candidates from what is left once the question's frame ("which of the three ... is") is taken
    away: what the family forms above did not read. None when there is no attribute word; a refusal that
    names what it could not place when the rest is not names."""
    cues = list(_CUE.finditer(text))
    if not cues:
        return None
    attributes = {_attribute(c["adj"]) for c in cues}
    if len(cues) > 1:
        raise UnsupportedQuery(
            original, f"it asks about {' and '.join(repr(c.group(0)) for c in cues)} at once; ask one thing"
        )
    cue = cues[0]
    attribute = attributes.pop()
    adjective, degree = cue["adj"], cue["deg"]
    rest = text[: cue.start()] + " " + text[cue.end() :]
    rest = _POLITE.sub("", rest.strip())
    distance_from_me = _ME_ANYWHERE.search(rest) is not None
    rest = _PLACE.sub(" ", _ME_ANYWHERE.sub(" ", _THAN_THE_REST.sub(" ", rest)))
    rest = " ".join(_FRAME.sub(" ", rest).split()).strip(" ,")
    rest = re.sub(r"\s*,\s*", ", ", rest)
    if distance_from_me and attribute != "distance":
        raise UnsupportedQuery(
            original, f"found the {attribute} word {adjective!r} with 'to me', which it does not relate"
        )
    if re.search(r"(?:,|\band\b|\bor\b|\bthan\b)", rest):
        objects = _split_names(re.sub(r"\s+than\s+", " or ", rest))
        named = True
        if objects is None or len(objects) < 2:
            raise UnsupportedQuery(
                original,
                f"found the {attribute} word {adjective!r} but could not read {rest!r} as names to compare",
            )
    else:
        single = _object(rest)
        if single is None:
            raise UnsupportedQuery(
                original, f"found the {attribute} word {adjective!r} but could not place {rest!r}"
            )
        objects, named = (single,), False
    rank, from_end = _ordinal(cue["ord"]) if cue["ord"] else (1, False)
    if attribute == "size":
        if named:
            raise UnsupportedQuery(original, "it compares the size of named objects, which it does not read")
        base = _SUPERLATIVE.get(adjective) or _COMPARATIVE.get(adjective) or adjective
        measure, largest = _SIZE[base]
        if degree in ("least", "less"):
            largest = not largest
        return SizeQuery(
            obj=objects[0],
            adjective=" ".join(w for w in (degree, adjective) if w),
            measure=measure,  # type: ignore[arg-type]
            largest=largest != from_end,
            rank=rank,
        )
    if rank != 1 and named:
        raise UnsupportedQuery(original, f"it asks for a rank ({cue['ord']!r}) among named objects")
    if attribute == "weight":
        heavy = adjective in _WEIGHT_HEAVY
        if degree in ("least", "less") and adjective in ("heavy", "light", "lightweight"):
            heavy = not heavy
        return WeightQuery(objects=objects, heaviest=heavy != from_end, named=named, rank=rank)
    return DistanceQuery(objects=objects, nearest=(adjective in _NEAR) != from_end, named=named, rank=rank)


# "the lightest one" is "the lightest": "one" stands for the object, not for an object called "one"
_ADJECTIVE_ONE = re.compile(r"\b(" + _WEIGHT_WORDS + "|" + _DIST_WORDS + r")\s+ones?$")


def parse_query(query: str) -> ParsedQuery:
    """The parsed form of `query`; raises `UnsupportedQuery` (or `InputError` for empty/overlong text).

    The frames around a reading come off first (an action, a yes/no comparison, a surface scope, a
    narrowing such as "of the two closest"), then the families read what is left."""
    original = check_query(query)
    normalized = _normalize(original)
    if normalized is None:
        raise UnsupportedQuery(original, "it has letters outside the English alphabet")
    text, opened, full = normalized
    if not text:
        raise UnsupportedQuery(original, "it has no words the planner reads")
    action, target, acted = _take_action(full)
    if action == "measure":
        return acted  # type: ignore[return-value]
    if action is not None:
        text, opened = _strip_article(str(acted)), True
    yes_no = _parse_yes_no(text)
    if yes_no is not None:
        if action is not None:
            raise UnsupportedQuery(original, "it asks to act and a yes/no question at once; ask one")
        return yes_no
    scope, text = _take_scope(text)
    among, text = _take_among(text)
    if scope is not None and _ONLY_FRAME.fullmatch(text):
        inner: ParsedQuery = GroundingQuery(ObjectSpec("object"))  # "which object is on the floor?"
    else:
        inner = _parse_family(
            text, opened, original, normalized[0] if scope is None and among is None else text
        )
    if scope is None and among is None and action is None:
        return inner
    if isinstance(inner, Request | YesNoQuery | MeasureQuery):
        raise UnsupportedQuery(original, "it frames a question the planner reads only on its own")
    if among is not None and not isinstance(inner, WeightQuery | DistanceQuery | SizeQuery):
        raise UnsupportedQuery(original, "it narrows the candidates for a choice it does not read")
    return Request(inner, scope=scope, among=among, action=action, target=target)  # type: ignore[arg-type]


def _parse_family(text: str, opened: bool, original: str, whole: str) -> ParsedQuery:
    """The families' readings of a text with no frame around it."""
    if text.endswith((" one", " ones")):
        text = _ADJECTIVE_ONE.sub(r"\1", text)
    parsed = _parse_compare(text) or _parse_measure(text) or _parse_odd(text)
    if parsed is not None:
        return parsed
    # "which is the second dog from the right" asks for the same as "the second dog from the right"
    text = _strip_article(re.sub(r"^(?:which|what)\s+(?:one\s+)?(?:is|are)\s+", "", text))
    # "which cup is the tallest" asks for "the tallest cup"
    which = _WHICH_X_IS.fullmatch(text) if text.startswith(("which ", "what ")) else None
    if which is not None and _object(which["noun"]) is not None:
        text = f"{which['adj']} {which['noun']}"
    # "which thing is leftmost" asks for "the leftmost thing"
    extreme = _WHICH_X_IS_EXTREME.fullmatch(text) if text.startswith(("which ", "what ")) else None
    if extreme is not None and _object(extreme["noun"]) is not None:
        text = f"{extreme['adj']} {extreme['noun']}"
    # "which cup is second from the left" asks for "the second cup from the left"
    place = _WHICH_X_IS_NTH.fullmatch(text) if text.startswith(("which ", "what ")) else None
    if place is not None and _object(place["noun"]) is not None:
        text = f"{place['ord']} {place['noun']} {place['rest']}"
    for parser in (_parse_location, _parse_size, _parse_superlative):
        reading = parser(text)
        if reading is not None:
            return reading
    grounding = _parse_grounding(text, opened)
    if grounding is not None:
        return grounding
    by_meaning = _read_by_meaning(whole, original)
    if by_meaning is not None:
        return by_meaning
    raise UnsupportedQuery(original, _unplaced(whole))


def _unplaced(text: str) -> str:
    """The words of a refused text that no family reads, named for the refusal."""
    known = _STOP | _FRAME_WORDS | GENERIC_NOUNS | set(SURFACE_WORDS)
    rest = [w for w in text.split() if w not in known]
    return f"it could not place {' '.join(rest or text.split())!r}"


_FRAME_WORDS = {"of", "one", "ones", "it", "this", "that", "with", "for", "can", "could", "please"}


# ---- frames around a reading: actions, yes/no, scopes, narrowings ---------------------------------------

_SURFACE = "|".join(sorted(SURFACE_WORDS, key=len, reverse=True))
_OPENING = r"^(?:(?:can|could|would|will)\s+you\s+)?"
_ACT_PICK = re.compile(
    _OPENING + r"(?:bring|give|hand|fetch|get|grab|take|pick\s+up)(?:\s+me|\s+us)?(?:\s+over)?\s+(?P<rest>.+)"
)
_ACT_PUT = re.compile(
    _OPENING + r"(?:put|place|move|set)\s+(?P<rest>.+)\s+(?:on|onto|on\s+to|on\s+top\s+of)\s+(?:the\s+)?"
    r"(?P<target>[a-z ]+?)$"
)
_ACT_MEASURE = re.compile(
    _OPENING + r"(?:(?:pick\s+up|lift|grab|take|go\s+to|drive\s+to|approach)\s+)(?P<obj>.+?)\s+and\s+"
    r"(?:(?:tell\s+me\s+|say\s+|find\s+out\s+|report\s+)?(?P<what>how\s+much\s+(?:it|they)\s+weighs?|"
    r"its\s+(?:weight|mass)|how\s+heavy\s+(?:it|they)\s+(?:is|are)|weigh\s+(?:it|them)|"
    r"how\s+far(?:\s+away)?\s+(?:it|they)\s+(?:is|are|was|were)|its\s+distance))$"
)


def _take_action(text: str) -> tuple[str | None, str | None, object]:
    """("pick" or "put", the target, the rest of the text) of a request to act; ("measure", None, the
    measurement) of "pick up the X and tell me how much it weighs"; (None, None, text) otherwise."""
    match = _ACT_MEASURE.fullmatch(text)
    if match is not None:
        obj = _named(_strip_article(match["obj"]))
        if obj is not None:
            weight = any(w in match["what"] for w in ("weigh", "heavy", "mass"))
            return "measure", None, MeasureQuery(obj, "weight" if weight else "distance")
    match = _ACT_PUT.fullmatch(text)
    if match is not None:
        target = _strip_article(match["target"])
        kind = SURFACE_WORDS.get(target)
        spec = None if kind is not None else _named(target)
        if kind is not None or spec is not None:
            return "put", kind or (spec.phrase if spec else None), match["rest"]
    match = _ACT_PICK.fullmatch(text)
    if match is not None:
        return "pick", None, match["rest"]
    return None, None, text


_YES_NO_WORDS = {
    **{w: ("weight", True) for w in ("heavier", "more heavy")},
    **{w: ("weight", False) for w in ("lighter", "less heavy")},
    **{w: ("distance", False) for w in ("closer", "nearer")},
    **{w: ("distance", True) for w in ("farther", "further", "more distant")},
    **{w: ("size", True) for w in ("bigger", "larger")},
    **{w: ("size", False) for w in ("smaller",)},
}
_YES_NO = re.compile(
    r"(?:is|are|does|do)\s+(?P<a>.+?)\s+(?:(?:is|are)\s+)?(?P<adj>"
    + "|".join(sorted(_YES_NO_WORDS, key=len, reverse=True))
    + r")"
    + _ME
    + r"\s+than\s+(?P<b>.+?)"
    + _ME
)
_YES_NO_SIDE = re.compile(
    r"(?:is|are)\s+(?P<a>.+?)\s+(?:(?:on|to)\s+the\s+)?(?P<side>left|right)\s+(?:of|from)\s+(?P<b>.+)"
)


def _parse_yes_no(text: str) -> YesNoQuery | None:
    """ "is the kettle heavier than the backpack", "is the book to the left of the mug"."""
    match = _YES_NO.fullmatch(text)
    if match is not None:
        attribute, more = _YES_NO_WORDS[match["adj"]]
        word = match["adj"]
    else:
        match = _YES_NO_SIDE.fullmatch(text)
        if match is None:
            return None
        attribute, more, word = "position", match["side"] == "right", f"to the {match['side']} of"
    first, second = _named(_strip_article(match["a"])), _named(_strip_article(match["b"]))
    if first is None or second is None:
        return None
    return YesNoQuery(first, second, attribute, more, word)  # type: ignore[arg-type]


_SCOPE = re.compile(
    r"\s*\b(?:(?:that|which)\s+(?:is|are)\s+|(?:is|are)\s+)?(?:(?:sitting|standing|lying|placed|resting|kept|"
    r"left)\s+)?(?:on|upon|on\s+top\s+of)\s+(?:the\s+)?(?P<surface>" + _SURFACE + r")\b"
)
# what is left of "which object is on the floor?" once the scope is taken: the question alone
_ONLY_FRAME = re.compile(
    r"(?:(?:which|what)(?:\s+(?:one|thing|object|item)s?)?(?:\s+(?:is|are))?(?:\s+there)?"
    r"|(?:what|which\s+(?:one|thing|object|item)s?)\s+(?:do|can)\s+you\s+see"
    r"|(?:the\s+)?(?:object|thing|item)s?)?"
)


def _take_scope(text: str) -> tuple[str | None, str]:
    """The surface a query is scoped to ("the heaviest thing on the counter") and the text without it."""
    match = _SCOPE.search(text)
    if match is None:
        return None, text
    rest = " ".join((text[: match.start()] + " " + text[match.end() :]).split()).strip(" ,")
    return SURFACE_WORDS[match["surface"]], rest


_NUMBER_WORDS = {"two": 2, "three": 3, "four": 4, "five": 5, "2": 2, "3": 3, "4": 4, "5": 5}
_AMONG_WORDS = {
    **{w: ("distance", True) for w in ("closest", "nearest")},
    **{w: ("distance", False) for w in ("farthest", "furthest", "most distant")},
    **{w: ("weight", True) for w in ("heaviest",)},
    **{w: ("weight", False) for w in ("lightest",)},
}
_AMONG_ADJ = "|".join(sorted(_AMONG_WORDS, key=len, reverse=True))
_AMONG = re.compile(
    r"\b(?:of|among|out\s+of|from)\s+(?:the\s+)?(?P<k>two|three|four|five|[2-5])\s+(?:"
    r"(?P<adj>" + _AMONG_ADJ + r")(?:\s+(?P<noun>[a-z]+))?|(?P<noun2>[a-z]+)\s+(?:that\s+are\s+)?"
    r"(?:the\s+)?(?P<adj2>" + _AMONG_ADJ + r"))" + _ME + r"\b"
)


def _take_among(text: str) -> tuple[Among | None, str]:
    """ "the heaviest of the two closest objects": the narrowing, and the text with "of the objects"."""
    match = _AMONG.search(text)
    if match is None:
        return None, text
    adjective = match["adj"] or match["adj2"]
    noun = match["noun"] or match["noun2"] or "objects"
    if noun in ("to", "from", "away", "one", "ones"):
        noun = "objects"
    attribute, most = _AMONG_WORDS[adjective]
    among = Among(attribute, most, _NUMBER_WORDS[match["k"]])  # type: ignore[arg-type]
    rest = text[: match.start()] + f" of the {noun} " + text[match.end() :]
    return among, " ".join(rest.split()).strip(" ,")


# ---- the program writer --------------------------------------------------------------------------------

_ORDINAL_NAMES = {1: "1st", 2: "2nd", 3: "3rd"}


def _nth(k: int) -> str:
    return _ORDINAL_NAMES.get(k, f"{k}th") if not 10 < k % 100 < 14 else f"{k}th"


def _q(text: str) -> str:
    """A Python string literal (double quotes)."""
    return json.dumps(text)


_GROUP_HELPER = '''
def group_into_lines(patches, kind):
    """Group patches into rows (kind "row", top row first) or columns (kind "column", left first).

    Rows and columns follow the objects, not equal bands of the image: box centres are sorted across the
    lines, and a new line starts wherever two neighbouring centres are further apart than half the
    median box size in that direction.
    """
    if kind == "row":
        # y grows upward, so the top row has the largest vertical_center
        ordered = sorted(patches, key=lambda patch: -patch.vertical_center)
        positions = [-patch.vertical_center for patch in ordered]
        sizes = sorted([patch.height for patch in ordered])
    else:
        ordered = sorted(patches, key=lambda patch: patch.horizontal_center)
        positions = [patch.horizontal_center for patch in ordered]
        sizes = sorted([patch.width for patch in ordered])
    gap = 0.5 * sizes[len(sizes) // 2]
    lines = [[ordered[0]]]
    for index in range(1, len(ordered)):
        if positions[index] - positions[index - 1] > gap:
            lines.append([])
        lines[-1].append(ordered[index])
    return lines
'''.lstrip("\n")

_SORT_KEYS = {
    "left": ("patch.horizontal_center", False, "from the left"),
    "right": ("patch.horizontal_center", True, "from the right"),
    "top": ("patch.vertical_center", True, "from the top (y grows upward)"),
    "bottom": ("patch.vertical_center", False, "from the bottom (y grows upward)"),
}


class _Writer:
    """Collects the lines of `execute_command` with their indentation."""

    def __init__(self, query: str) -> None:
        self.helpers: list[str] = []
        self.body: list[str] = [f"# Query: {_q(query)}", "# Written by the offline rules planner."]
        self.uses_math = False
        self.frame: Request | None = None  # a scope, narrowing or action around the reading
        self.sensors: Sequence[str] = ("camera",)
        self.embodied = False
        self.act: str | None = None  # the helper call that acts on the chosen object: "bring(robot, {})"

    def line(self, text: str = "") -> None:
        stripped = text.lstrip()
        if self.act is not None and stripped.startswith("return ") and not stripped.startswith("return {"):
            indent = text[: len(text) - len(stripped)]
            text = indent + "return " + self.act.format(stripped[len("return ") :])
        self.body.append(text)

    def helper(self, source: str) -> None:
        if source not in self.helpers:
            self.helpers.append(source)

    def fail(self, condition: str, message_expr: str) -> None:
        self.line(f"if {condition}:")
        if len(message_expr) <= 80:
            self.line(f"    raise ValueError({message_expr})")
        else:  # keep the program readable: the message on its own line
            self.line("    raise ValueError(")
            self.line(f"        {message_expr}")
            self.line("    )")

    def source(self) -> str:
        parts = []
        if self.uses_math:
            parts.append("import math\n")
        parts.extend(h + "\n" for h in self.helpers)
        body = "\n".join(("    " + b) if b else "" for b in self.body)
        parts.append("def execute_command(image, robot):\n" + body + "\n")
        return "\n".join(parts)


def _sorted(group: str, key: str, reverse: bool) -> str:
    return f"sorted({group}, key=lambda patch: {key}{', reverse=True' if reverse else ''})"


def _count_message(before: str, count: str, after: str) -> str:
    """The expression of an error message with a count in it: "before" + str(count) + "after"."""
    return f"{_q(before)} + str({count}) + {_q(after)}"


def _find(w: _Writer, obj: ObjectSpec, var: str = "candidates") -> None:
    """`var = image.find(noun)`, the colour filter, and the "none found" error."""
    w.line(f"{var} = image.find({_q(obj.noun)})")
    for color in obj.colors:
        w.line(f"# keep the {color} ones: detectors are surer of categories than of colours, so ask VQA")
        w.line("kept = []")
        w.line(f"for patch in {var}:")
        w.line(f'    if {_q(color)} in patch.visual_query("What color is this object?").lower():')
        w.line("        kept.append(patch)")
        w.line(f"{var} = kept")
    w.fail(f"len({var}) == 0", _q(f"no {obj.phrase} found in the image"))
    frame = w.frame
    if frame is not None and frame.scope is not None:
        _write_scope(w, var, frame.scope, obj)
    if frame is not None and frame.among is not None and var == "candidates":
        _write_among(w, frame.among)


_ON_SURFACE_HELPER = '''
def on_surface(patch, surface):
    """True when the patch stands on the surface: the middle of its bottom edge lies inside the surface's box
    (an object's foot is where it rests; y grows upward)."""
    x = patch.horizontal_center
    return surface.left <= x <= surface.right and surface.lower <= patch.lower <= surface.upper


def on_any(patch, surfaces):
    for surface in surfaces:
        if on_surface(patch, surface):
            return True
    return False
'''.lstrip("\n")


def _write_scope(w: _Writer, var: str, scope: str, obj: ObjectSpec) -> None:
    """Keep the patches of `var` that stand on the surface `scope` (on none of the furniture: the floor)."""
    w.helper(_ON_SURFACE_HELPER)
    if scope == "floor":
        w.line("# on the floor: standing on none of the furniture")
        w.line('furniture = image.find("table") + image.find("counter") + image.find("shelf")')
        w.line("kept = []")
        w.line(f"for patch in {var}:")
        w.line("    if not on_any(patch, furniture):")
        w.line("        kept.append(patch)")
    else:
        w.line(f"# on the {scope}: the detector finds furniture too; keep what stands on it")
        w.line(f"surfaces = image.find({_q(scope)})")
        w.fail("len(surfaces) == 0", _q(f"no {scope} found in the image"))
        w.line("kept = []")
        w.line(f"for patch in {var}:")
        w.line("    if on_any(patch, surfaces):")
        w.line("        kept.append(patch)")
    w.line(f"{var} = kept")
    w.fail(f"len({var}) == 0", _q(f"no {obj.phrase} found on the {scope}"))


def _write_among(w: _Writer, among: Among) -> None:
    """Narrow `candidates` to the k at one end of another attribute ("of the two closest")."""
    end = {("distance", True): "nearest", ("distance", False): "farthest"}.get(
        (among.attribute, among.most), "heaviest" if among.most else "lightest"
    )
    w.line(f"# first the {among.k} {end}")
    w.fail(
        f"len(candidates) < {among.k}",
        _count_message(f"asked among the {among.k} {end}, but only ", "len(candidates)", " were found"),
    )
    measured = w.embodied and ("distance" if among.attribute == "distance" else "force") in w.sensors
    if among.attribute == "distance" and measured:
        w.line("narrowing = []")
        w.line("for patch in candidates:")
        w.line("    robot.focus_on_patch(patch)")
        w.line("    narrowing.append(robot.measure_distance(patch))")
        reverse = not among.most
    elif among.attribute == "distance":
        w.line("# no distance sensor: lower in the picture is nearer (a visual proxy, not a measurement)")
        w.line("narrowing = [patch.lower for patch in candidates]")
        reverse = not among.most
    elif measured:
        w.line("narrowing = []")
        w.line("for patch in candidates:")
        w.line("    robot.go_to_object(patch)")
        w.line("    robot.pick_up(patch)")
        w.line("    narrowing.append(robot.measure_weight(patch))")
        w.line("    robot.put_down()")
        reverse = among.most
    else:
        w.line(
            "# no force sensor: the bigger box is taken as the heavier (a visual proxy, not a measurement)"
        )
        w.line("narrowing = [patch.area for patch in candidates]")
        reverse = among.most
    w.line(
        "order = sorted(range(len(candidates)), key=lambda index: narrowing[index]"
        + (", reverse=True)" if reverse else ")")
    )
    w.line(f"candidates = [candidates[index] for index in order[:{among.k}]]")


def _write_location(w: _Writer, q: LocationQuery) -> None:
    _find(w, q.obj)
    group = "candidates"
    if q.line is not None:
        w.helpers.append(_GROUP_HELPER)
        kind, plural = q.line.kind, q.line.kind + "s"
        first = "top" if kind == "row" else "left"
        last = "bottom" if kind == "row" else "right"
        w.line(f"{plural} = group_into_lines(candidates, {_q(kind)})")
        if q.line.middle:
            w.line(f"# the middle {kind}; with an even number of {plural}, the one just past the centre")
            w.line(f"{kind} = {plural}[len({plural}) // 2]")
        else:
            k = q.line.index
            side = last if q.line.from_end else first
            if k > 1:
                w.fail(
                    f"len({plural}) < {k}",
                    _count_message(
                        f"asked for the {_nth(k)} {kind} from the {side}, but the {q.obj.phrase}s form only ",
                        f"len({plural})",
                        f" {kind}(s)",
                    ),
                )
            index = f"len({plural}) - {k}" if q.line.from_end else str(k - 1)
            w.line(f"# the {_nth(k)} {kind} from the {side}")
            w.line(f"{kind} = {plural}[{index}]")
        group = kind
    pick = q.pick
    if pick.kind == "ordinal":
        assert pick.side is not None
        key, reverse, words = _SORT_KEYS[pick.side]
        w.line(f"# order them {words} and take the {_nth(pick.k)}")
        w.line(f"ordered = {_sorted(group, key, reverse)}")
        where = f" in that {group}" if group != "candidates" else ""
        if pick.k > 1:
            w.fail(
                f"len(ordered) < {pick.k}",
                _count_message(
                    f"asked for the {_nth(pick.k)} {q.obj.phrase} {words.split(' (')[0]}{where}, but only ",
                    "len(ordered)",
                    " were found",
                ),
            )
        w.line(f"return ordered[{pick.k - 1}]")
    elif pick.kind == "middle":
        key = "patch.horizontal_center" if pick.axis == "x" else "patch.vertical_center"
        along = "left to right" if pick.axis == "x" else "top to bottom"
        w.line(f"# the middle one of the {group}, counted {along}")
        w.line(f"ordered = {_sorted(group, key, pick.axis == 'y')}")
        w.line("return ordered[len(ordered) // 2]")
    elif pick.kind == "central":
        w.uses_math = True
        w.line("# the one nearest the centre of the group (the middle of the span of their box centres)")
        w.line("xs = [patch.horizontal_center for patch in candidates]")
        w.line("ys = [patch.vertical_center for patch in candidates]")
        w.line("centre_x = (min(xs) + max(xs)) / 2")
        w.line("centre_y = (min(ys) + max(ys)) / 2")
        w.line(
            "return min(candidates, key=lambda patch: math.hypot(patch.horizontal_center - centre_x, "
            "patch.vertical_center - centre_y))"
        )
    else:  # "only": the line alone names the object
        w.fail(
            f"len({group}) > 1",
            _count_message(
                "there are ",
                f"len({group})",
                f" {q.obj.phrase}s in that {group}; say which one, e.g. the 2nd from the left",
            ),
        )
        w.line(f"return {group}[0]")


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


def _find_all(w: _Writer, objects: Sequence[ObjectSpec]) -> None:
    """Candidates from several named objects ("the laptop or the tv"): every patch of each."""
    if len(objects) == 1:
        _find(w, objects[0])
        return
    w.line("candidates = []")
    for index, obj in enumerate(objects):
        var = f"found{index + 1}"
        _find(w, obj, var)
        w.line(f"candidates = candidates + {var}")


def _write_extreme_loop(w: _Writer, values: str, largest: bool, rank: int = 1) -> None:
    if rank > 1:
        w.line(
            f"order = sorted(range(len(candidates)), key=lambda index: {values}[index]"
            + (", reverse=True)" if largest else ")")
        )
        w.fail(
            f"len(order) < {rank}",
            _count_message(f"asked for the {_nth(rank)} one, but only ", "len(order)", " were found"),
        )
        w.line(f"return candidates[order[{rank - 1}]]")
        return
    better = ">" if largest else "<"
    w.line("best = 0")
    w.line("for index in range(1, len(candidates)):")
    w.line(f"    if {values}[index] {better} {values}[best]:")
    w.line("        best = index")
    w.line("return candidates[best]")


def _write_weight(w: _Writer, q: WeightQuery, sensors: Sequence[str], embodied: bool) -> None:
    word = "heaviest" if q.heaviest else "lightest"
    if "force" in sensors and embodied:
        _find_all(w, q.objects)
        w.line("# weigh each one: the force sensor reads only what the gripper holds,")
        w.line("# so go to the object, pick it up, weigh it and put it back down")
        w.line("weights = []")
        w.line("for patch in candidates:")
        w.line("    robot.go_to_object(patch)")
        w.line("    robot.pick_up(patch)")
        w.line("    weights.append(robot.measure_weight(patch))")
        w.line("    robot.put_down()")
        _write_extreme_loop(w, "weights", q.heaviest, q.rank)
        return
    if q.rank > 1 and (q.named or q.objects[0].generic):
        raise InputError(
            f"asked for the {_nth(q.rank)} {word.replace('est', 'est')} one, and without a force sensor the "
            "language model can only name the extreme one",
            "give the robot the sensor (--sensors camera,force) on the simulator or a robot",
        )
    w.line(
        "# no force sensor: weight cannot be measured, so it is reasoned about (the paper's VQA + LLM chain)"
    )
    if q.named:
        names = [o.phrase for o in q.objects]
        # longest names first, so that "remote control" is matched before "remote"
        w.line(f"names = {json.dumps(sorted(names, key=len, reverse=True))}")
        question = (
            f"Out of these items: {', '.join(names)}, which one is more likely to be the {word} one? "
            "Answer with the name of one item only."
        )
        w.line(f"answer = image.language_query({_q(question)}).lower()")
        w.line("# map the answer back to one of the named objects (whole words only: a pen is no pencil)")
        w.line('words = " " + " ".join(answer.replace(".", " ").replace(",", " ").split()) + " "')
        w.line("for name in names:")
        w.line('    if " " + name + " " in words:')
        w.line("        matches = image.find(name)")
        w.line("        if len(matches) > 0:")
        w.line("            return matches[0]")
        w.line('raise ValueError("the language model answered " + answer + ", none of the named objects")')
        return
    obj = q.objects[0]
    if obj.generic and not obj.colors and w.frame is None:
        w.line('items = image.visual_query("What are the items in this image?")')
        w.line('question = "Out of these items: " + items')
        w.line(f'question = question + ", which one is more likely to be the {word} one?"')
        w.line('answer = image.language_query(question + " Answer with the name of one item only.")')
        w.line('name = answer.strip().strip(".").lower()')
        w.line('if name.startswith("the "):')
        w.line("    name = name[4:]")
        w.line('if name == "" or name == "unknown":')
        w.line(f'    raise ValueError("the language model could not tell which item is the {word} one")')
        w.line("matches = image.find(name)")
        w.line("if len(matches) > 0:")
        w.line("    return matches[0]")
        w.line("return name")
        return
    if obj.generic:
        # "the heaviest red item": name each candidate with VQA, then ask the language model
        _find(w, obj)
        w.line("# name each candidate with VQA, then ask the language model which is usually " + word)
        w.line("names = []")
        w.line("for patch in candidates:")
        w.line('    names.append(patch.visual_query("What is this?").strip().lower())')
        w.line('question = "Out of these items: " + ", ".join(names)')
        w.line(f'question = question + ", which one is more likely to be the {word} one?"')
        w.line('answer = image.language_query(question + " Answer with the name of one item only.").lower()')
        w.line("for index in range(len(names)):")
        w.line("    if names[index] in answer:")
        w.line("        return candidates[index]")
        w.line('raise ValueError("the language model answered " + answer + ", none of the items seen")')
        return
    # several objects of one kind: language knowledge cannot tell them apart, so size stands in for weight
    _find(w, obj)
    w.line("# objects of one kind: with no force sensor, the biggest box is taken as the heaviest")
    w.line("# (a visual proxy, not a measurement)")
    w.line(f"ordered = {_sorted('candidates', 'patch.width * patch.height', q.heaviest)}")
    if q.rank > 1:
        w.fail(
            f"len(ordered) < {q.rank}",
            _count_message(
                f"asked for the {_nth(q.rank)} {word} one, but only ", "len(ordered)", " were found"
            ),
        )
    w.line(f"return ordered[{q.rank - 1}]")


def _write_distance(w: _Writer, q: DistanceQuery, sensors: Sequence[str], embodied: bool) -> None:
    _find_all(w, q.objects)
    if "distance" in sensors and embodied:
        w.line("# measure each: turn the camera (and the distance sensor with it) onto the object first")
        w.line("distances = []")
        w.line("for patch in candidates:")
        w.line("    robot.focus_on_patch(patch)")
        w.line("    distances.append(robot.measure_distance(patch))")
        _write_extreme_loop(w, "distances", not q.nearest, q.rank)
        return
    w.line(
        "# no distance sensor: a visual proxy, not a measurement. Objects standing on the same floor or table"
    )
    w.line("# sit lower in the picture the closer they are, so the box whose bottom edge is lowest is taken")
    w.line("# as the closest (y grows upward: a smaller `lower` is lower in the picture)")
    w.line(f"ordered = {_sorted('candidates', 'patch.lower', not q.nearest)}")
    if q.rank > 1:
        w.fail(
            f"len(ordered) < {q.rank}",
            _count_message(f"asked for the {_nth(q.rank)} one, but only ", "len(ordered)", " were found"),
        )
    w.line(f"return ordered[{q.rank - 1}]")


def _write_grounding(w: _Writer, q: GroundingQuery) -> None:
    _find(w, q.obj)
    w.line("# find lists the best match first")
    w.line("return candidates[0]")


_MEASURING = {
    "distance": ("distance", "camera,distance", "Is the lamp or the chair closer to me?"),
    "weight": ("force", "camera,force", "Is the apple or the book heavier?"),
    "size": ("distance", "camera,distance", "Which is bigger, the lamp or the chair?"),
    "height": ("distance", "camera,distance", "Which is taller, the lamp or the chair?"),
    "width": ("distance", "camera,distance", "Which is wider, the lamp or the chair?"),
}


def _write_measure(w: _Writer, q: MeasureQuery, query: str, sensors: Sequence[str], embodied: bool) -> None:
    sensor, flag, comparison = _MEASURING[q.quantity]
    if sensor not in sensors or not embodied:
        # no proxy gives a number: a comparison can be estimated from the picture, a measurement cannot
        where = "the robot has no " + sensor + " sensor" if embodied else "a still image has no robot"
        why = (
            ", and the camera alone sees pixels, not metres"
            if q.quantity in ("size", "height", "width")
            else ""
        )
        raise InputError(
            f"{query!r} asks for a measured {q.quantity}, and {where}{why}",
            f"give the robot the sensor (--sensors {flag}) on the simulator or a robot, or ask a comparison "
            f"such as {comparison!r}, which the camera alone can estimate",
        )
    _find(w, q.obj)
    w.line("patch = candidates[0]  # find lists the best match first")
    if q.quantity in ("size", "height", "width"):
        w.line("# a size in metres: the box's pixels times the measured distance over the focal length")
        w.line("robot.focus_on_patch(patch)")
        w.line("width, height = patch.size_at(robot.measure_distance(patch))")
        value = {"size": "max(width, height)", "height": "height", "width": "width"}[q.quantity]
        w.line(f'return {{"object": patch, "value": {value}, "unit": "m"}}')
        return
    if q.quantity == "distance":
        w.line("# turn the camera (and the distance sensor with it) onto the object, then measure")
        w.line("robot.focus_on_patch(patch)")
        w.line("robot.measure_distance(patch)")
    else:
        w.line("# the force sensor reads only what the gripper holds: pick it up, weigh it, put it back")
        w.line("robot.go_to_object(patch)")
        w.line("robot.pick_up(patch)")
        w.line("robot.measure_weight(patch)")
        w.line("robot.put_down()")
    w.line("# the answer reports the object with the value measured on it")
    w.line("return patch")


_ODD_HELPER = '''
def the_one_unlike_the_rest(values):
    """The index of the only value that differs from all the others, which agree; None otherwise."""
    for index in range(len(values)):
        rest = values[:index] + values[index + 1 :]
        if values[index] not in rest and len(set(rest)) == 1:
            return index
    return None


def size_outlier(patches):
    """The index of the patch whose size least fits the others. Apparent size shrinks with distance, which
    on a table grows with height in the image, so each patch is compared with the line through the others'
    sizes against their vertical centres (their median when they share one row)."""
    worst, worst_index = -1.0, 0
    for index in range(len(patches)):
        others = patches[:index] + patches[index + 1 :]
        ys = [p.lower for p in others]
        sizes = [math.sqrt(p.area) for p in others]
        mean_y, mean_size = sum(ys) / len(ys), sum(sizes) / len(sizes)
        spread = sum((y - mean_y) ** 2 for y in ys)
        if spread > 1.0:
            slope = sum((y - mean_y) * (z - mean_size) for y, z in zip(ys, sizes)) / spread
            expected = mean_size + slope * (patches[index].lower - mean_y)
        else:
            expected = sorted(sizes)[len(sizes) // 2]
        misfit = abs(math.log(math.sqrt(patches[index].area) / max(expected, 1.0)))
        if misfit > worst:
            worst, worst_index = misfit, index
    return worst_index
'''.lstrip("\n")


def _write_odd(w: _Writer, q: OddQuery, sensors: Sequence[str], embodied: bool) -> None:
    w.helpers.append(_ODD_HELPER)
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


_ACT_HELPERS = {
    "pick": '''
def bring(robot, patch):
    """Go to the chosen object, pick it up and hold it: the request is done, and the answer names it."""
    robot.go_to_object(patch)
    robot.pick_up(patch)
    return patch
'''.lstrip("\n"),
    "put": '''
def put_it_on(robot, patch, target):
    """Go to the chosen object, pick it up and put it on the target; the answer names the object."""
    robot.go_to_object(patch)
    robot.pick_up(patch)
    robot.put_on(target)
    return patch
'''.lstrip("\n"),
}

_YES_NO_TERMS = {
    # attribute: (sensor, unit, word for more, word for less)
    "weight": ("force", "kg", "heavier", "lighter"),
    "distance": ("distance", "m", "farther", "closer"),
    "size": ("distance", "m", "bigger", "smaller"),
    "position": ("camera", "px", "further right", "further left"),
}


def _write_yes_no(w: _Writer, q: YesNoQuery, sensors: Sequence[str], embodied: bool) -> None:
    _find(w, q.first, "firsts")
    _find(w, q.second, "seconds")
    w.line("first = firsts[0]  # find lists the best match first")
    w.line("second = seconds[0]")
    sensor, unit, more_word, less_word = _YES_NO_TERMS[q.attribute]
    measured = sensor == "camera" or (embodied and sensor in sensors)
    if q.attribute == "weight" and measured:
        w.line("# weigh both: the force sensor reads only what the gripper holds")
        w.line("values = []")
        w.line("for patch in [first, second]:")
        w.line("    robot.go_to_object(patch)")
        w.line("    robot.pick_up(patch)")
        w.line("    values.append(robot.measure_weight(patch))")
        w.line("    robot.put_down()")
    elif q.attribute == "distance" and measured:
        w.line("values = []")
        w.line("for patch in [first, second]:")
        w.line("    robot.focus_on_patch(patch)")
        w.line("    values.append(robot.measure_distance(patch))")
    elif q.attribute == "size" and measured:
        w.line("# sizes in metres: each box's pixels times its measured distance over the focal length")
        w.line("values = []")
        w.line("for patch in [first, second]:")
        w.line("    width, height = patch.size_at(robot.measure_distance(patch))")
        w.line("    values.append(max(width, height))")
    elif q.attribute == "position":
        w.line("# left and right in the picture: the centres of the boxes, in pixels from the left edge")
        w.line("values = [first.horizontal_center, second.horizontal_center]")
    elif q.attribute == "weight":
        w.line("# no force sensor: weight is reasoned about (the paper's VQA + LLM chain), not measured")
        names = [q.first.phrase, q.second.phrase]
        question = (
            f"Out of these items: {', '.join(names)}, which one is more likely to be the heaviest one? "
            "Answer with the name of one item only."
        )
        w.line(f"answer = image.language_query({_q(question)}).lower()")
        w.line(f"if {_q(q.second.noun)} in answer and {_q(q.first.noun)} not in answer:")
        w.line("    values = [0, 1]")
        w.line(f"elif {_q(q.first.noun)} in answer:")
        w.line("    values = [1, 0]")
        w.line("else:")
        w.line('    raise ValueError("the language model could not tell which is heavier: " + answer)')
        unit = ""
    elif q.attribute == "distance":
        w.line(
            "# no distance sensor: a visual proxy, not a measurement; on one floor or table, the box whose"
        )
        w.line("# bottom edge is higher in the picture is farther (y grows upward)")
        w.line("values = [first.lower, second.lower]")
        unit = ""
    else:
        w.line("# no distance sensor: the box areas in pixels (a visual proxy; a near object looks bigger)")
        w.line("values = [first.area, second.area]")
        unit = ""
    op = ">" if q.more else "<"
    w.line(f"yes = values[0] {op} values[1]")
    w.line(f"# the one that is {more_word if q.more else less_word}, with the values of both")
    w.line(f"winner = first if values[0] {op} values[1] else second")
    first, second = _q(q.first.phrase), _q(q.second.phrase)
    if unit:
        w.line(f'shown = [" (" + str(round(value, 3)) + " {unit})" for value in values]')
    else:
        w.line('shown = ["", ""]')
    w.line("if values[0] > values[1]:")
    w.line(f'    text = "the " + {first} + shown[0] + " is {more_word} than the " + {second} + shown[1]')
    w.line("elif values[0] < values[1]:")
    w.line(f'    text = "the " + {first} + shown[0] + " is {less_word} than the " + {second} + shown[1]')
    w.line("else:")
    w.line(f'    text = "the " + {first} + shown[0] + " and the " + {second} + shown[1] + " are the same"')
    w.line("value = values[0] if winner is first else values[1]")
    if unit:
        w.line(f'return {{"yes": yes, "object": winner, "value": value, "unit": "{unit}", "text": text}}')
    else:
        w.line('return {"yes": yes, "object": winner, "text": text}')


def write_program(
    parsed: ParsedQuery, query: str, sensors: Sequence[str] = ("camera",), embodied: bool = False
) -> str:
    """The program for a parsed query: readable Python defining `execute_command(image, robot)`."""
    w = _Writer(query)
    w.sensors, w.embodied = sensors, embodied
    if isinstance(parsed, Request):
        w.frame = parsed
        if parsed.action is not None:
            if not embodied:
                raise InputError(
                    f"{query!r} asks the robot to act, and a still image has no robot",
                    "ask it in the simulator or on a robot, or ask only which object it means",
                )
            w.helper(_ACT_HELPERS[parsed.action])
            if parsed.action == "put":
                target = parsed.target or "table"
                w.line(f"# where it goes: the {target}")
                w.line(f"targets = image.find({_q(target)})")
                w.fail("len(targets) == 0", _q(f"no {target} found in the image"))
                w.line("target = targets[0]")
                w.act = "put_it_on(robot, {}, target)"
            else:
                w.act = "bring(robot, {})"
        parsed = parsed.inner
    if isinstance(parsed, YesNoQuery):
        _write_yes_no(w, parsed, sensors, embodied)
    elif isinstance(parsed, LocationQuery):
        _write_location(w, parsed)
    elif isinstance(parsed, SizeQuery):
        _write_size(w, parsed, sensors, embodied)
    elif isinstance(parsed, WeightQuery):
        _write_weight(w, parsed, sensors, embodied)
    elif isinstance(parsed, DistanceQuery):
        _write_distance(w, parsed, sensors, embodied)
    elif isinstance(parsed, MeasureQuery):
        _write_measure(w, parsed, query, sensors, embodied)
    elif isinstance(parsed, OddQuery):
        _write_odd(w, parsed, sensors, embodied)
    else:
        _write_grounding(w, parsed)
    return w.source()


def rules_program(query: str, sensors: Sequence[str] = ("camera",), embodied: bool = False) -> str:
    """Parse `query` and write its program in one step."""
    return write_program(parse_query(query), check_query(query), sensors, embodied)


class RulesPlanner:
    """The offline, deterministic planner. It ignores feedback: the same query gives the same program."""

    name = "rules"
    max_tries = 1

    def plan(self, request: PlanRequest, feedback: Sequence[Attempt] = ()) -> Plan:
        return Plan(program=rules_program(request.query, request.sensors, request.embodied))


@PLANNERS.register("rules")
def _build_rules(settings: Settings) -> RulesPlanner:
    return RulesPlanner()
