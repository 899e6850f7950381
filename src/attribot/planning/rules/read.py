"""Reading a query: the frames around a reading (an action, a yes/no comparison, a surface scope, a
narrowing) come off first, then the families read what is left; the reading must account for the whole
text, and what no family places is refused, naming the words.
"""

from __future__ import annotations

import re
from typing import Literal

from attribot.lexicon import (
    GENERIC_NOUNS,
    SURFACE_WORDS,
)
from attribot.planning.base import check_query
from attribot.planning.rules.forms import (
    Among,
    DistanceQuery,
    GroundingQuery,
    LineSpec,
    LocationQuery,
    MeasureQuery,
    ObjectSpec,
    OddQuery,
    ParsedQuery,
    Pick,
    Request,
    Side,
    SizeQuery,
    UnsupportedQuery,
    WeightQuery,
    YesNoQuery,
)
from attribot.planning.rules.normalise import (
    _CANDIDATE_SET,
    _COMPARATIVE,
    _COUNT_WORDS,
    _DIST_WORDS,
    _FAR,
    _ME,
    _NEAR,
    _OPPOSITE,
    _ORD,
    _SIDES,
    _SIZE,
    _SIZE_WORDS,
    _STOP,
    _SUPERLATIVE,
    _WEIGHT_HEAVY,
    _WEIGHT_LIGHT,
    _WEIGHT_WORDS,
    _named,
    _normalize,
    _object,
    _ordinal,
    _split_names,
    _strip_article,
    _take,
    rx,
)


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
    match = rx(r"(?P<adj>" + words + r")(?:\s+(?P<rest>.+?))?" + _ME).fullmatch(text) or rx(
        r"(?P<rest>.+?)\s+(?:that\s+is\s+|which\s+is\s+)?(?:the\s+)?(?P<adj>" + words + r")" + _ME
    ).fullmatch(text)
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


def _parse_measure(text: str) -> MeasureQuery | WeightQuery | DistanceQuery | None:
    """ "How far away is the lamp?", "How much does the apple weigh?": one named object's measurement; "How
    far is the closest chair?": the chosen object, measured."""
    for form, quantity in _MEASURE_FORMS:
        match = rx(form).fullmatch(text)
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
    if rx(r"(?:,|\band\b|\bor\b|\bthan\b)").search(rest):
        objects = _split_names(rx(r"\s+than\s+").sub(" or ", rest))
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
