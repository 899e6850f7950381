"""Reading a query: the frames around a reading (an action, a yes/no comparison, a surface scope, a
narrowing) come off first, then the families read what is left; the reading must account for the whole
text, and what no family places is refused, naming the words.
"""

from __future__ import annotations

import re

from attribot.lexicon import (
    GENERIC_NOUNS,
    SURFACE_LEVELS,
    SURFACE_WORDS,
    sense_words,
)
from attribot.planning.query import check_query
from attribot.planning.rules.families import Reading, readers
from attribot.planning.rules.families.location import read_line
from attribot.planning.rules.families.yesno import _parse_yes_no
from attribot.planning.rules.forms import (
    MEASURED,
    Among,
    DistanceQuery,
    GroundingQuery,
    Level,
    LocationQuery,
    MeasureQuery,
    ObjectSpec,
    ParsedQuery,
    Region,
    Request,
    SenseQuery,
    Side,
    SizeQuery,
    Understood,
    UnsupportedQuery,
    WeightQuery,
    YesNoQuery,
    measured_sense,
)
from attribot.planning.rules.normalise import (
    _DIST_WORDS,
    _ME,
    _ORD,
    _SIDES,
    _SIZE_WORDS,
    _STOP,
    _WEIGHT_WORDS,
    _named,
    _normalize,
    _object,
    _split_names,
    _strip_article,
    rx,
)
from attribot.sensors import SUPERLATIVE

"""The comparative and "out of" forms of weight and distance queries, compiled once."""


_WHICH_X_IS = re.compile(
    r"(?:which|what)\s+(?P<noun>[a-z]+(?:\s+[a-z]+){0,2})\s+(?:is|are)\s+(?:the\s+)?"
    r"(?P<adj>(?:(?:" + _ORD + r")\s+)?(?:" + _SIZE_WORDS + r"))"
)
_WHICH_X_IS_EXTREME = re.compile(
    r"(?:which|what)\s+(?P<noun>[a-z]+(?:\s+[a-z]+){0,2}?)\s+(?:is|are|sits|stands|lies)\s+(?:the\s+)?"
    r"(?P<adj>leftmost|rightmost|topmost|uppermost|bottommost|lowermost)(?:\s+one)?"
)
_WHICH_X_IS_NTH = re.compile(
    r"(?:which|what)\s+(?P<noun>[a-z]+(?:\s+[a-z]+){0,2}?)\s+(?:is|are)\s+(?:the\s+)?"
    r"(?P<ord>" + _ORD + r"|last)\s+(?P<rest>(?:from|in|on)\s+.+)"
)


_WHICH_X_IS_AT = re.compile(
    r"(?:which|what)\s+(?P<noun>[a-z]+(?:\s+[a-z]+){0,2}?)\s+(?:is|are|sits|stands|lies)\s+"
    r"(?P<rest>(?:(?:on|at|to|in)\s+(?:the\s+)?(?:far\s+)?)?(?:top|bottom|upper|lower)\s+(?:left|right)"
    r"(?:\s+corner)?|(?:on|at|to|in|towards)\s+(?:the\s+)?(?:far\s+)?(?:left|right|top|bottom|middle|centre|center)"
    r"(?:\s+(?:side|part|edge))?)"
)
# "the mug that is second from the left" asks "which mug is second from the left"
_X_THAT_IS = re.compile(r"^(?:the\s+)?(?P<noun>[a-z]+(?:\s+[a-z]+){0,2}?)\s+(?:that|which)\s+(?:is|are)\s+")


# "the lightest one" is "the lightest": "one" stands for the object, not for an object called "one"
_ADJECTIVE_ONE = re.compile(r"\b(" + _WEIGHT_WORDS + "|" + _DIST_WORDS + r")\s+ones?$")


def parse_query(query: str, *, checked: bool = False) -> ParsedQuery:
    """The parsed form of `query`; raises `UnsupportedQuery` (or `InputError` for empty/overlong text).
    `checked`: the query has passed `check_query` already (a planner's request), and is not checked again.

    The query is read as typed first; only when that is refused does the language front end
    (`understand.mend`) mend its words (misspellings, synonyms, word forms) for a second reading, which
    comes back as an `Understood` with what was read as what. A refusal names the words it could not place
    and what they could mean."""
    from attribot.planning.rules.understand import mend, unread

    original = query if checked else check_query(query)
    try:
        as_typed: ParsedQuery | None = _parse_as_typed(original)
    except UnsupportedQuery:
        as_typed = None
    if as_typed is not None and not unread(original):
        return as_typed
    mended = mend(original, refused=as_typed is None)
    if mended is None:
        if as_typed is not None:
            return as_typed
        try:
            return _parse_as_typed(original)
        except UnsupportedQuery as refused:
            raise _with_meanings(refused, original, ()) from None
    try:
        inner = _parse_as_typed(mended.text)
    except UnsupportedQuery as again:
        if as_typed is not None:
            return as_typed
        raise _with_meanings(again, original, mended.notes) from None
    return Understood(inner, mended.notes)


def _with_meanings(refused: UnsupportedQuery, original: str, notes: tuple[str, ...]) -> UnsupportedQuery:
    """The refusal, with what was read as what and what the words no dictionary holds could mean."""
    from attribot.planning.rules.understand import could_mean

    said = [*notes, could_mean(original)]
    extra = "; ".join(s for s in said if s)
    return UnsupportedQuery(original, f"{refused.reason} ({extra})" if extra else refused.reason)


def _parse_as_typed(query: str) -> ParsedQuery:
    """The parsed form of a checked query as typed. The frames around a reading come off first (an action,
    a yes/no comparison, a surface scope, a narrowing such as "of the two closest"), then the families read
    what is left."""
    original = query
    normalized = _normalize(original)
    if normalized is None:
        raise UnsupportedQuery(original, "it has letters outside the English alphabet")
    text, opened, full, question = normalized
    if not text:
        raise UnsupportedQuery(original, "it has no words the planner reads")
    action, target, acted = _take_action(full)
    if action == "measure":
        return acted  # type: ignore[return-value]
    if action is not None:
        text, opened = _strip_article(str(acted)), True
    yes_no = _parse_yes_no(text, question)
    if yes_no is not None:
        if action is not None:
            raise UnsupportedQuery(original, "it asks to act and a yes/no question at once; ask one")
        return yes_no
    scope, level, text = _take_scope(text)
    among, text = _take_among(text)
    exclude, text = _take_exclusion(text, original)
    after, text = _take_after(text, original)
    region: Region | None = None
    if scope is not None and _ONLY_FRAME.fullmatch(text):
        inner: ParsedQuery = GroundingQuery(ObjectSpec("object"))  # "which object is on the floor?"
    else:
        whole = normalized.text if scope is None and among is None and not exclude and after is None else text
        inner, scope, region = _parse_placed(text, whole, scope, opened, original, question)
    if all(part is None for part in (scope, among, action, region, after)) and not exclude:
        return inner
    if (exclude or after is not None) and isinstance(inner, YesNoQuery | MeasureQuery):
        raise UnsupportedQuery(original, "it leaves out or orders objects for a question about named ones")
    if isinstance(inner, Request | YesNoQuery | MeasureQuery | Understood) or (
        isinstance(inner, SenseQuery) and (inner.ask != "which" or inner.named)
    ):
        raise UnsupportedQuery(original, "it frames a question the planner reads only on its own")
    if among is not None and not isinstance(inner, WeightQuery | DistanceQuery | SizeQuery):
        raise UnsupportedQuery(original, "it narrows the candidates for a choice it does not read")
    if region is not None and isinstance(inner, LocationQuery):
        raise UnsupportedQuery(original, "it places the object twice; say its place once")
    return Request(
        inner,
        scope=scope,
        among=among,
        action=action,  # type: ignore[arg-type]
        target=target,
        region=region,
        level=level,
        exclude=exclude,
        after=after,
    )


def _parse_placed(
    text: str, whole: str, scope: str | None, opened: bool, original: str, question: bool
) -> tuple[ParsedQuery, str | None, Region | None]:
    """The families' reading of `text`, else of what is left with a side, row or column around a choice
    taken off ("the heaviest mug in the top row"): read only where the text does not read without it, so
    that no position the families read is taken from them. Returns the reading, the scope and the region."""
    try:
        return _parse_family(text, opened, original, whole, question), scope, None
    except UnsupportedQuery as refused:
        region, rest, surface = _take_region(text)
        if region is None or (surface is not None and scope is not None):
            raise refused from None
        try:
            return _parse_family(rest, opened, original, rest, question), scope or surface, region
        except UnsupportedQuery:
            raise refused from None


def _parse_family(text: str, opened: bool, original: str, whole: str, question: bool = False) -> ParsedQuery:
    """The families' readings of a text with no frame around it: the first reader, in their order, whose
    reading accounts for the whole text; refused, naming the words none placed, when there is none."""
    if text.endswith((" one", " ones")):
        text = _ADJECTIVE_ONE.sub(r"\1", text)
    text = _which_for_that(text)
    reading = Reading(text, _plain(text), opened, whole, original, question)
    for reader in readers():
        parsed = reader(reading)
        if parsed is not None:
            return parsed
    raise UnsupportedQuery(original, _unplaced(whole))


def _plain(text: str) -> str:
    """The text as the position and superlative readers read it: "which is the second dog" is "the second
    dog", "which cup is the tallest" is "the tallest cup"."""
    text = _strip_article(rx(r"^(?:which|what)\s+(?:one\s+)?(?:is|are)\s+").sub("", text))
    text = _which_for_that(text)
    if not text.startswith(("which ", "what ")):
        return text
    # "which cup is the tallest" asks for "the tallest cup"
    which = _WHICH_X_IS.fullmatch(text)
    if which is not None and _object(which["noun"]) is not None:
        text = f"{which['adj']} {which['noun']}"
    # "which thing is leftmost" asks for "the leftmost thing"
    extreme = _WHICH_X_IS_EXTREME.fullmatch(text) if text.startswith(("which ", "what ")) else None
    if extreme is not None and _object(extreme["noun"]) is not None:
        text = f"{extreme['adj']} {extreme['noun']}"
    # "which thing is on the right side" asks for "the thing on the right side"
    at = _WHICH_X_IS_AT.fullmatch(text) if text.startswith(("which ", "what ")) else None
    if at is not None and _object(at["noun"]) is not None:
        text = f"{at['noun']} {at['rest']}"
    # "which cup is second from the left" asks for "the second cup from the left"
    place = _WHICH_X_IS_NTH.fullmatch(text) if text.startswith(("which ", "what ")) else None
    if place is not None and _object(place["noun"]) is not None:
        text = f"{place['ord']} {place['noun']} {place['rest']}"
    return text


def _which_for_that(text: str) -> str:
    """ "the mug that is second from the left" said as "which mug is second from the left"."""
    relative = _X_THAT_IS.match(text)
    if relative is None or _object(relative["noun"]) is None:
        return text
    return f"which {relative['noun']} is {text[relative.end() :]}"


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
# "bring the cup to the table": to a surface or an object, it is put there (not handed over)
_ACT_BRING = re.compile(
    _OPENING + r"(?:bring|take|carry|move|get)(?:\s+me|\s+us)?\s+(?P<rest>.+?)\s+(?:over\s+)?"
    r"(?:to|onto|on\s+to)\s+(?:the\s+)?(?P<target>[a-z ]+?)$"
)
# "bring me the mug closest to the table" relates the mug to the table: not a destination
_RELATING = re.compile(r"\b(?:closest|nearest|farthest|furthest|next|close|near|far|closer|nearer|farther)$")
_ACT_MEASURE = re.compile(
    _OPENING + r"(?:(?:pick\s+up|lift|grab|take|go\s+to|drive\s+to|approach)\s+)(?P<obj>.+?)\s+and\s+"
    r"(?:(?:tell\s+me\s+|say\s+|find\s+out\s+|report\s+)?(?P<what>how\s+much\s+(?:it|they)\s+weighs?|"
    r"its\s+(?:weight|mass)|how\s+heavy\s+(?:it|they)\s+(?:is|are)|weigh\s+(?:it|them)|"
    r"how\s+far(?:\s+away)?\s+(?:it|they)\s+(?:is|are|was|were)|its\s+distance))$"
)


def _take_action(text: str) -> tuple[str | None, str | None, object]:
    """("pick" or "put", the target, the rest of the text) of a request to act ("put the X on the Y",
    "bring the X to the Y" put it there); ("measure", None, the measurement) of "pick up the X and tell me
    how much it weighs"; (None, None, text) otherwise."""
    match = _ACT_MEASURE.fullmatch(text)
    if match is not None:
        obj = _named(_strip_article(match["obj"]))
        if obj is not None:
            weight = any(w in match["what"] for w in ("weigh", "heavy", "mass"))
            return "measure", None, MeasureQuery(obj, "weight" if weight else "distance")
    for form in (_ACT_PUT, _ACT_BRING):
        match = form.fullmatch(text)
        if match is None or (form is _ACT_BRING and _RELATING.search(match["rest"])):
            continue
        target = _strip_article(match["target"])
        kind = SURFACE_WORDS.get(target)
        spec = None if kind is not None else _named(target)
        if kind is not None or spec is not None:
            return "put", kind or (spec.phrase if spec else None), match["rest"]
    match = _ACT_PICK.fullmatch(text)
    if match is not None:
        return "pick", None, match["rest"]
    return None, None, text


_SCOPE = re.compile(
    r"\s*\b(?:(?:that|which)\s+(?:is|are)\s+|(?:is|are)\s+)?(?:(?:sitting|standing|lying|placed|resting|kept|"
    r"left)\s+)?(?:on|upon|on\s+top\s+of)\s+(?:the\s+)?(?:(?P<level>" + "|".join(SURFACE_LEVELS) + r")\s+)?"
    r"(?P<surface>" + _SURFACE + r")\b"
)
# what is left of "which object is on the floor?" once the scope is taken: the question alone
_ONLY_FRAME = re.compile(
    r"(?:(?:which|what)(?:\s+(?:one|thing|object|item)s?)?(?:\s+(?:is|are))?(?:\s+there)?"
    r"|(?:what|which\s+(?:one|thing|object|item)s?)\s+(?:do|can)\s+you\s+see"
    r"|(?:the\s+)?(?:object|thing|item)s?)?"
)


def _take_scope(text: str) -> tuple[str | None, Level | None, str]:
    """The surface a query is scoped to ("the heaviest thing on the counter"), the board of a shelf ("on the
    bottom shelf"), and the text without them. Furniture named as a place is a scope, never the answer; a
    level of anything but a shelf ("the top table") is not read."""
    match = _SCOPE.search(text)
    if match is None:
        return None, None, text
    kind = SURFACE_WORDS[match["surface"]]
    level = SURFACE_LEVELS[match["level"]] if match["level"] else None
    if level is not None and kind != "shelf":
        return None, None, text
    rest = " ".join((text[: match.start()] + " " + text[match.end() :]).split()).strip(" ,")
    return kind, level, rest


# "on the left side (of the table)", "in the right half", "on the left": a side of the view or of a surface
_SIDE_REGION = re.compile(
    r"\s*\b(?:(?:that|which)\s+(?:is|are)\s+|(?:is|are)\s+)?(?:(?:sitting|standing|lying|placed)\s+)?"
    r"(?:on|at|to|in|towards)\s+(?:the\s+)?(?:far\s+)?(?P<side>left|right)(?:[\s-]+hand)?"
    r"(?:\s+(?:side|half|part|end))?(?:\s+of\s+(?:the\s+)?(?P<surface>" + _SURFACE + r"))?\b"
    r"|\s*\b(?:in|on)\s+the\s+(?P<half>top|bottom|upper|lower)\s+(?:half|part)\b"
)
# "in the top row", "in the second column from the right", "of the middle row"
_LINE_REGION = re.compile(
    r"\s*\b(?:(?:that|which)\s+(?:is|are)\s+|(?:is|are)\s+)?(?:in|on|of|along|within|from)\s+(?:the\s+)?"
    r"(?P<line>[a-z]+(?:\s+to\s+last)?\s+(?:rows?|columns?|cols?)(?:\s+from\s+(?:the\s+)?"
    r"(?:top|bottom|left|right))?)\b"
)


def _take_region(text: str) -> tuple[Region | None, str, str | None]:
    """A side, row or column a choice is scoped to, the text without it, and the surface a side is of."""
    for pattern in (_LINE_REGION, _SIDE_REGION):
        match = pattern.search(text)
        if match is None:
            continue
        rest = " ".join((text[: match.start()] + " " + text[match.end() :]).split()).strip(" ,")
        if pattern is _LINE_REGION:
            line = read_line(match["line"])
            if line is None:
                continue
            return Region(line=line), rest, None
        side: Side = _SIDES[match["side"] or match["half"]]
        surface = SURFACE_WORDS[match["surface"]] if match["surface"] else None
        return Region(side=side), rest, surface
    return None, text, None


_NUMBER_WORDS = {"two": 2, "three": 3, "four": 4, "five": 5, "2": 2, "3": 3, "4": 4, "5": 5}
# the superlatives of the measured senses, each with (its quantity, whether it names the end a ranking leads
# with: "the two closest", "the two heaviest")
_AMONG_WORDS = {
    word: (quantity, more == measured_sense(quantity).most)
    for word, (quantity, more, form) in sense_words(MEASURED).items()
    if form == SUPERLATIVE
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


# ---- exclusions and "the next after": "apart from the kettle", "the next heaviest after the toaster" -----

_LEAVING_OUT = (
    r"(?:apart\s+from|aside\s+from|except(?:\s+for)?|other\s+than|besides|excluding|not\s+counting|ignoring"
    r"|but\s+not)"
)
_EXCLUSION_FIRST = re.compile(r"^" + _LEAVING_OUT + r"\s+(?P<names>[a-z ,]+?)\s*,\s*(?P<rest>.+)$")
_EXCLUSION_LAST = re.compile(r"^(?P<rest>.+?),?\s+" + _LEAVING_OUT + r"\s+(?P<names>[a-z ,]+?)$")
# "which object other than the kettle is the heaviest": the names between the noun and the verb
_EXCLUSION_INSIDE = re.compile(
    r"^(?P<head>.+?)\s+"
    + _LEAVING_OUT
    + r"\s+(?P<names>(?:the\s+)?[a-z]+(?:\s+(?:and|or)\s+(?:the\s+)?[a-z]+)?)"
    r"\s+(?P<tail>(?:is|are)\b.*)$"
)
_LEAVING_CUES = (
    "apart",
    "aside",
    "except",
    "other than",
    "besides",
    "excluding",
    "counting",
    "ignoring",
    "but not",
)


def _take_exclusion(text: str, original: str) -> tuple[tuple[ObjectSpec, ...], str]:
    """The objects a choice leaves out ("apart from the kettle, which is the heaviest", "the heaviest thing
    except the mug and the pot") and the text without them; a name that is no object's is refused."""
    if not any(cue in text for cue in _LEAVING_CUES):
        return (), text
    for pattern in (_EXCLUSION_FIRST, _EXCLUSION_INSIDE, _EXCLUSION_LAST):
        match = pattern.match(text)
        if match is None:
            continue
        names = _split_names(_strip_article(match["names"]))
        if names is None:
            raise UnsupportedQuery(
                original, f"it leaves out {match['names']!r}, which names no object it reads"
            )
        if pattern is _EXCLUSION_INSIDE:
            rest = f"{match['head']} {match['tail']}"
        else:
            rest = match["rest"]
        return names, " ".join(rest.split()).strip(" ,")
    return (), text


_NEXT_AFTER = re.compile(
    r"\bnext\s+(?P<adj>[a-z]+est|most\s+[a-z]+|least\s+[a-z]+)(?P<noun>(?:\s+[a-z]+){0,2}?)\s+"
    r"(?:after|below|behind|down\s+from|than)\s+(?P<name>(?:the\s+)?[a-z]+(?:\s+[a-z]+)?)$"
)


def _take_after(text: str, original: str) -> tuple[ObjectSpec | None, str]:
    """ "which object is the next heaviest after the toaster": the toaster, and "which object is the
    heaviest"."""
    if "next " not in text:
        return None, text
    match = _NEXT_AFTER.search(text)
    if match is None:
        return None, text
    name = _named(_strip_article(match["name"]))
    if name is None:
        raise UnsupportedQuery(original, f"it orders after {match['name']!r}, which names no object it reads")
    rest = text[: match.start()] + match["adj"] + match["noun"]
    return name, " ".join(rest.split()).strip(" ,")
