"""Weight and distance: superlatives, comparisons of named objects, and the reading by meaning
(the attribute word wherever it stands, the candidates from what is left).
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence

from attribot.errors import InputError
from attribot.lexicon import sense_words
from attribot.planning.rules.families import FAMILY_REGISTRY, Family
from attribot.planning.rules.forms import (
    DistanceQuery,
    ObjectSpec,
    ParsedQuery,
    SizeQuery,
    UnsupportedQuery,
    WeightQuery,
    measured_sense,
)
from attribot.planning.rules.normalise import (
    _CANDIDATE_SET,
    _COMPARATIVE,
    _COUNT_WORDS,
    _DIST_WORDS,
    _FAR,
    _ME,
    _NEAR,
    _ORD,
    _SIZE,
    _SUPERLATIVE,
    _WEIGHT_HEAVY,
    _WEIGHT_LIGHT,
    _WEIGHT_WORDS,
    _object,
    _ordinal,
    _split_names,
    _strip_article,
    rx,
)
from attribot.planning.rules.write import (
    _count_message,
    _find,
    _nth,
    _q,
    _sorted,
    _Writer,
)
from attribot.sensors import ABSOLUTE

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
    if len(cues) > 1:
        raise UnsupportedQuery(
            original, f"it asks about {' and '.join(repr(c.group(0)) for c in cues)} at once; ask one thing"
        )
    cue = cues[0]
    attribute = _attribute(cue["adj"])
    objects, named = _candidates(
        text[: cue.start()] + " " + text[cue.end() :], attribute, cue["adj"], original
    )
    rank, from_end = _ordinal(cue["ord"]) if cue["ord"] else (1, False)
    if attribute == "size":
        if named:
            raise UnsupportedQuery(original, "it compares the size of named objects, which it does not read")
        return _size_query(objects[0], cue["adj"], cue["deg"], rank, from_end)
    if rank != 1 and named:
        raise UnsupportedQuery(original, f"it asks for a rank ({cue['ord']!r}) among named objects")
    adjective, degree = cue["adj"], cue["deg"]
    if attribute == "weight":
        heavy = adjective in _WEIGHT_HEAVY
        if degree in ("least", "less") and sense_words(("weight",))[adjective][2] == ABSOLUTE:
            heavy = not heavy  # "the least heavy" is the lightest
        return WeightQuery(objects=objects, heaviest=heavy != from_end, named=named, rank=rank)
    return DistanceQuery(objects=objects, nearest=(adjective in _NEAR) != from_end, named=named, rank=rank)


def _candidates(
    rest: str, attribute: str, adjective: str, original: str
) -> tuple[tuple[ObjectSpec, ...], bool]:
    """What the query is about, once its attribute word and frame are taken away: the named objects it
    compares (and True), or the one kind of object it chooses among (and False)."""
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
        if objects is None or len(objects) < 2:
            raise UnsupportedQuery(
                original,
                f"found the {attribute} word {adjective!r} but could not read {rest!r} as names to compare",
            )
        return tuple(objects), True
    single = _object(rest)
    if single is None:
        raise UnsupportedQuery(
            original, f"found the {attribute} word {adjective!r} but could not place {rest!r}"
        )
    return (single,), False


def _size_query(obj: ObjectSpec, adjective: str, degree: str | None, rank: int, from_end: bool) -> SizeQuery:
    base = _SUPERLATIVE.get(adjective) or _COMPARATIVE.get(adjective) or adjective
    measure, largest = _SIZE[base]
    if degree in ("least", "less"):
        largest = not largest
    return SizeQuery(
        obj=obj,
        adjective=" ".join(w for w in (degree, adjective) if w),
        measure=measure,  # type: ignore[arg-type]
        largest=largest != from_end,
        rank=rank,
    )


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
    if w.frame is not None and w.frame.after is not None and rank == 1 and "after" not in w.applied:
        # "the next heaviest after the toaster": the one just past it in the order
        w.line(
            f"order = sorted(range(len(candidates)), key=lambda index: {values}[index]"
            + (", reverse=True)" if largest else ")")
        )
        w.line("position = order.index(reference)")
        w.fail(
            "position + 1 >= len(order)",
            _q(f"nothing comes after the {w.frame.after.phrase}: it is the last in the order"),
        )
        w.line("return candidates[order[position + 1]]")
        w.applied.add("after")
        return
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
    word = measured_sense("weight").superlative(q.heaviest)
    if "force" in sensors and embodied:
        _write_weighed(w, q)
        return
    if q.rank > 1 and (q.named or q.objects[0].generic):
        raise InputError(
            f"asked for the {_nth(q.rank)} {word} one, and without a force sensor the "
            "language model can only name the extreme one",
            "give the robot the sensor (--sensors camera,force) on the simulator or a robot",
        )
    w.line(
        "# no force sensor: weight cannot be measured, so it is reasoned about (the paper's VQA + LLM chain)"
    )
    obj = q.objects[0]
    if q.named:
        _write_weight_of_names(w, [o.phrase for o in q.objects], word)
    elif obj.generic and not obj.colors and w.frame is None:
        _write_weight_of_items(w, word)
    elif obj.generic:
        _write_weight_of_candidates(w, obj, word)
    else:
        _write_weight_by_size(w, q, obj, word)


def _write_weighed(w: _Writer, q: WeightQuery) -> None:
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


def _write_weight_of_names(w: _Writer, names: list[str], word: str) -> None:
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


def _write_weight_of_items(w: _Writer, word: str) -> None:
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
    w.fail("len(matches) == 0", '"the language model chose " + name + ", which the detector does not find"')
    w.line("return matches[0]")


def _write_weight_of_candidates(w: _Writer, obj: ObjectSpec, word: str) -> None:
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


def _write_weight_by_size(w: _Writer, q: WeightQuery, obj: ObjectSpec, word: str) -> None:
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
    if "distance" in sensors and embodied and w.premeasured is not None:
        w.line(f"distances = {w.premeasured}  # measured before the robot moved")
        _write_extreme_loop(w, "distances", not q.nearest, q.rank)
        return
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


FAMILY_REGISTRY.register("weight")(
    Family(
        examples=(
            "the heaviest item",
            "Out of the laptop, the chair and the credit card, which one is the most lightweight?",
            "Which object weighs the most?",
            "the lightest of the apple, the phone and the kettle",
        ),
        readers=(
            (10, lambda r: _parse_compare(r.text)),
            (60, lambda r: _parse_superlative(r.plain)),
            (90, lambda r: _read_by_meaning(r.whole, r.original)),
        ),
        forms=(WeightQuery,),
        write=lambda w, q: _write_weight(w, q, w.sensors, w.embodied),
    )
)
FAMILY_REGISTRY.register("distance")(
    Family(
        examples=(
            "Is the laptop or the tv closer to me?",
            "the closest chair",
            "Out of the mugs, which one is closer to me?",
            "Which object is farthest away from the robot?",
        ),
        forms=(DistanceQuery,),
        write=lambda w, q: _write_distance(w, q, w.sensors, w.embodied),
    )
)
