"""The senses beyond the paper's: temperature (an infrared thermometer), softness (a squeeze), fullness
(weighing a container), and any sense a lab registers with its words (`attribot.sensors`). Which object is at
one end ("which mug is hot?", "the softest ball", "which bottle is empty?", "the coldest can"), whether one
object is in a state or more so than another ("is the kettle hot?", "is the mug hotter than the kettle?"),
and how much ("how hot is the kettle?" in degrees Celsius).

Everything this family knows of a sense is read from its record: its words and their directions, the
thresholds its state words mean, its nouns, its unit, the sensor and the method that read it and what a
reading needs. A state word means a threshold, stated in the program: hot is 40 degC or more, warm 30, cold
12 or less, cool 18; soft is under 1 N/mm of squeeze, firm 1 or more, hard 5 or more; full is more than half
full, empty less than half. "Which mug is hot?" chooses the hottest and says so when even that one is not
hot. Weight and distance are senses too, read by their own family (`attributes`).
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass

from attribot.errors import InputError
from attribot.lexicon import sense_states, sense_words
from attribot.planning.rules.families import FAMILY_REGISTRY, Family, Reading
from attribot.planning.rules.families.attributes import _find_all, _write_extreme_loop
from attribot.planning.rules.forms import MEASURED, SenseQuery
from attribot.planning.rules.normalise import (
    _ORD,
    _named,
    _object,
    _ordinal,
    _split_names,
    _strip_article,
    rx,
)
from attribot.planning.rules.write import _find, _q, _Writer
from attribot.sensors import Need, Sense, Sensor, program_steps, sense_of, senses

__all__ = ["parse_sense"]

_NOUN = r"[a-z]+(?:\s+[a-z]+){0,2}?"
_OF_THE = r"(?:\s+of\s+(?:the|these|those|all\s+the)(?:\s+(?:two|three|four|five))?)"
_POSSESSIVE = r"(?:my|your|our|this|that)\s+"
_IS = r"\s+(?:is|are)\s+"
_STILL = r"(?:\s+(?:feels?|seems?|looks?))?\s+(?:still\s+|now\s+|very\s+|really\s+|too\s+)?"


@dataclass(frozen=True)
class _Vocabulary:
    """The words of the senses this family reads (all but `MEASURED`), as the parsers use them."""

    words: dict[str, tuple[str, bool, str]]  # word -> (quantity, more, form)
    alternation: str  # every word, longest first, for a regex
    how: dict[str, tuple[str, ...]]  # quantity -> its absolute words ("how hot is ...")
    nouns: dict[str, str]  # quantity -> its nouns as a regex alternation ("the temperature of ...")
    cues: tuple[str, ...]  # what a text must hold for this family to read it


def _vocabulary() -> _Vocabulary:
    own = tuple(sense for _, sense in senses() if sense.quantity not in MEASURED)
    return _built(own)


@functools.lru_cache(maxsize=8)
def _built(own: tuple[Sense, ...]) -> _Vocabulary:
    words = sense_words(tuple(s.quantity for s in own))
    how = {s.quantity: tuple(w for w, (_, form) in s.words.items() if form == "absolute") for s in own}
    nouns = {s.quantity: "|".join(r"\s+".join(map(re.escape, n.split())) for n in s.nouns) for s in own}
    cues = tuple(sorted({w.split()[-1][:4] for w in words} | {n.split()[0] for s in own for n in s.nouns}))
    return _Vocabulary(
        words, "|".join(map(re.escape, sorted(words, key=len, reverse=True))), how, nouns, cues
    )


def parse_sense(r: Reading) -> SenseQuery | None:
    """The reading of a sense's question, or None when the text names no sense word (or asks otherwise)."""
    text = r.text
    vocabulary = _vocabulary()
    if not any(cue in text for cue in vocabulary.cues):
        return None
    return (
        _how(text, vocabulary)
        or _whether(text, vocabulary, r.question)
        or _named_choice(text, vocabulary)
        or _which(text, vocabulary)
    )


def _how(text: str, v: _Vocabulary) -> SenseQuery | None:
    """ "how hot is the kettle", "what is the temperature of the mug", "what temperature is the can"."""
    for attribute, words in v.how.items():
        quantity = v.nouns[attribute] or re.escape(attribute)
        adjectives = "|".join(map(re.escape, words))
        match = rx(
            r"(?:(?:tell\s+me|say|give\s+me|what\s+is)\s+)?(?:how\s+(?P<adj>" + adjectives
            + r")" + _IS + r"(?P<obj>.+)|(?:the\s+)?(?:" + quantity + r")\s+of\s+(?P<obj2>.+)"
            r"|what\s+(?:" + quantity + r")\s+(?:is|are)\s+(?P<obj3>.+))"
        ).fullmatch(text)  # fmt: skip
        if match is None:
            continue
        obj = _named(_owned(match["obj"] or match["obj2"] or match["obj3"]))
        if obj is None:
            return None
        word = match["adj"] or attribute
        more = v.words[word][1] if word in v.words else True
        return SenseQuery((obj,), attribute, more, "how", word)
    return None


def _owned(text: str) -> str:
    """A name without the article or possessive before it: "my coffee mug" is the coffee mug."""
    return rx(r"^" + _POSSESSIVE).sub("", _strip_article(text))


def _whether(text: str, v: _Vocabulary, question: bool = False) -> SenseQuery | None:
    """ "is the kettle hot", "is the kettle still hot", "is the mug hotter than the kettle"; asked as a
    question, the same without the verb first ("mug hot?", "the bottle is empty?")."""
    state = r"(?P<adj>" + v.alternation + r")(?:\s+than\s+(?P<b>.+?))?"
    match = rx(r"(?:is|are|does|do)\s+(?P<a>.+?)" + _STILL + state).fullmatch(text)
    if match is None and question:
        match = rx(r"(?P<a>.+?)(?:\s+(?:is|are))?" + _STILL + state).fullmatch(text)
    if match is None:
        return None
    attribute, more, form = v.words[" ".join(match["adj"].split())]
    first = _named(_owned(match["a"]))
    if first is None:
        return None
    if match["b"] is not None:
        second = _named(_owned(match["b"]))
        if second is None or form == "absolute":
            return None
        return SenseQuery((first, second), attribute, more, "whether", match["adj"], named=True)
    if form != "absolute" or match["adj"] not in sense_states():
        return None
    return SenseQuery((first,), attribute, more, "whether", match["adj"])


def _named_choice(text: str, v: _Vocabulary) -> SenseQuery | None:
    """ "which is hotter, the kettle or the mug", "out of the can, the bottle and the mug, which one is the
    coldest", "is the mug or the kettle warmer", "the coldest of the can and the bottle"."""
    which = r"(?:which|what)(?:\s+one|\s+item|\s+object|\s+thing)?(?:\s+of\s+(?:them|these|those))?"
    words = v.alternation
    for form in (
        which + r"\s+(?:is|are)\s+(?:the\s+)?(?P<adj>" + words + r"),?\s+(?:(?:out\s+)?of\s+|between\s+)?"
        r"(?P<list>.+)",
        r"(?:out\s+of|of|among|between|from)\s+(?P<list>.+?),?\s+" + which + r"\s+(?:is|are)\s+(?:the\s+)?"
        r"(?P<adj>" + words + r")",
        r"(?:is|are)\s+(?P<list>.+?\s+or\s+.+?)\s+(?P<adj>" + words + r")",
        # "the mug or the kettle, which is hotter"
        r"(?P<list>.+?\s+or\s+.+?),?\s+" + which + r"\s+(?:is|are)\s+(?:the\s+)?(?P<adj>" + words + r")",
        r"(?P<adj>" + words + r")\s+(?:one\s+)?(?:of|among|out\s+of)\s+"
        r"(?P<list>.+?(?:,|\s+and\s+|\s+or\s+).+)",
    ):
        match = rx(form).fullmatch(text)
        if match is None:
            continue
        objects = _split_names(_strip_article(match["list"]))
        if objects is None or len(objects) < 2:
            continue
        attribute, more, _ = v.words[" ".join(match["adj"].split())]
        return SenseQuery(objects, attribute, more, "which", match["adj"], named=True)
    return None


def _which(text: str, v: _Vocabulary) -> SenseQuery | None:
    """ "which mug is hot", "which of the balls is the softest one", "the hottest mug", "the second
    coldest can", "the kettle that is hot", "what is the coldest object", "find the hot kettle"."""
    words = v.alternation
    forms = (
        r"(?:which|what)(?:\s+one)?" + _OF_THE + r"?(?:\s+(?P<noun>" + _NOUN + r"))?\s+(?:is|are)\s+"
        r"(?:the\s+)?(?:(?P<ord>"
        + _ORD
        + r")\s+)?(?P<neg>not\s+)?(?P<adj>"
        + words
        + r")(?:\s+(?:one|ones))?",
        r"(?:which|what)\s+(?:is|are)\s+(?:the\s+)?(?:(?P<ord>" + _ORD + r")\s+)?(?P<adj>" + words + r")"
        r"(?:\s+(?P<noun>" + _NOUN + r"))?",
        r"(?:the\s+)?(?:(?P<ord>" + _ORD + r")\s+)?(?P<adj>" + words + r")(?:\s+(?P<noun>" + _NOUN + r"))?",
        r"(?P<noun>"
        + _NOUN
        + r")\s+(?:that|which)\s+(?:is|are)\s+(?P<neg>not\s+)?(?:the\s+)?(?P<adj>"
        + words
        + r")",
    )
    for form in forms:
        match = rx(form).fullmatch(text)
        if match is None:
            continue
        obj = _object(_owned(match["noun"] or ""))
        if obj is None:
            continue
        attribute, more, form = v.words[" ".join(match["adj"].split())]
        rank, from_end = _ordinal(match["ord"]) if match.groupdict().get("ord") else (1, False)
        if match.groupdict().get("neg"):
            # "which cup is not full": a state denied, the other end chosen; a degree denied ("not the
            # fullest") or an ordinal with it asks something else
            if form != "absolute" or rank != 1:
                continue
            return SenseQuery((obj,), attribute, not more, "which", "not " + match["adj"])
        return SenseQuery((obj,), attribute, more != from_end, "which", match["adj"], rank=rank)
    return None


# ---- programs ------------------------------------------------------------------------------------------


def _sense(attribute: str) -> tuple[Sensor, Sense]:
    found = sense_of(attribute)
    if found is None:  # the sense was taken out of the registry after the query was read
        raise InputError(
            f"no registered sensor measures {attribute}", "register its sensor (attribot.sensors)"
        )
    return found


def _write_sense(w: _Writer, q: SenseQuery) -> None:
    sensor, sense = _sense(q.attribute)
    if sensor.name not in w.sensors or not w.embodied:
        where = f"the robot has no {sensor.name} sensor" if w.embodied else "a still image has no robot"
        why = f": {sense.why}" if sense.why else ""
        raise InputError(
            f"{w.query!r} asks about {q.attribute}, which only a sensor settles, and {where}{why}",
            f"give the robot the sensor (--sensors camera,{sensor.name}) on the simulator or a robot",
        )
    if q.ask == "how":
        _write_how(w, q)
    elif q.ask == "whether" and q.named:
        _write_compare(w, q)
    elif q.ask == "whether":
        _write_state(w, q)
    else:
        _write_which(w, q)


def _write_measure(w: _Writer | _Indented, attribute: str, patch: str, into: str) -> None:
    """Lines that measure `attribute` of `patch` into `into` (a list to append to, or a name to set), first
    arranging what the reading needs."""
    sense = _sense(attribute)[1]
    keep = f"{into}.append({{}})" if into.endswith("s") else f"{into} = {{}}"
    before, after = program_steps(sense.needs, patch)
    for line in (*before, keep.format(f"robot.{sense.method}({patch})"), *after):
        w.line(line)


_READ = {
    Need.NOTHING: "read with the {} sensor",
    Need.AIM: "the {} sensor reads what the camera is centred on",
    Need.REACH: "read with the {} sensor, next to the object",
    Need.GRASP: "read with the {} sensor, the object held in the gripper",
}


def _intro(w: _Writer, attribute: str) -> None:
    sensor, sense = _sense(attribute)
    w.line(f"# {attribute}: {_READ[sense.needs].format(sensor.name)}")


def _shown(sense: Sense, value: str) -> str:
    """The program's expression that shows `value` (an expression) as the sense shows a reading."""
    scaled = value if sense.scale == 1.0 else f"{sense.scale:g} * {value}"
    number = f"round({scaled})" if sense.digits == 0 else f"round({scaled}, {sense.digits})"
    suffix = f" {sense.unit}" if sense.suffix is None else sense.suffix
    return f"str({number}) + {_q(suffix)}"


def _write_which(w: _Writer, q: SenseQuery) -> None:
    sense = _sense(q.attribute)[1]
    _find_all(w, q.objects)
    _intro(w, q.attribute)
    w.line("values = []")
    w.line("for patch in candidates:")
    body = _Indented(w)
    _write_measure(body, q.attribute, "patch", "values")
    denied = q.word.startswith("not ")
    state = sense_states().get(q.word.removeprefix("not "))
    end = "max" if q.more else "min"
    if denied and state is not None:
        # "which cup is not full?": the least full, and no answer when even that one is full
        w.line(f"if {end}(values) {state.comparison} {state.threshold}:")
        w.line(f"    reads = {_shown(sense, f'{end}(values)')}")
        w.line(
            f'    raise ValueError("every one of them is {state.word}: the {"most" if q.more else "least"} '
            f'reads " + reads)'
        )
    elif state is not None and q.rank == 1:  # "which mug is hot?": say so when even the hottest is not
        w.line(f"if not {end}(values) {state.comparison} {state.threshold}:")
        w.line(f"    reads = {_shown(sense, f'{end}(values)')}")
        w.line(f'    print("none of them is {q.word}: the {"most" if q.more else "least"} reads " + reads)')
    _write_extreme_loop(w, "values", q.more, q.rank)


class _Indented:
    """The writer of the body of a loop: each line one level in."""

    def __init__(self, outer: _Writer) -> None:
        self.outer = outer

    def line(self, text: str = "") -> None:
        self.outer.line("    " + text)


def _write_one(w: _Writer, q: SenseQuery) -> None:
    _find(w, q.objects[0])
    w.line("patch = candidates[0]  # find lists the best match first")
    _intro(w, q.attribute)
    _write_measure(w, q.attribute, "patch", "value")


def _grade(sense: Sense) -> str:
    """The program's expression naming `value` by the sense's grades ("hot", "soft"), "" without any."""
    expression = _q(sense.ungraded)
    for word in reversed(sense.grades):
        state = sense.state(word)
        assert state is not None  # the record checked it
        expression = f"{_q(word)} if value {state.comparison} {state.threshold} else {expression}"
    return expression


def _write_how(w: _Writer, q: SenseQuery) -> None:
    _write_one(w, q)
    sense = _sense(q.attribute)[1]
    text = f'{_q("the " + q.objects[0].phrase)} + " reads " + {_shown(sense, "value")}'
    if sense.grades:
        w.line(f"word = {_grade(sense)}")
        text += ' + (": " + word if word else "")'
    w.line(f"text = {text}")
    w.line(f'return {{"object": patch, "value": value, "unit": {_q(sense.unit)}, "text": text}}')


def _write_state(w: _Writer, q: SenseQuery) -> None:
    _write_one(w, q)
    sense = _sense(q.attribute)[1]
    state = sense_states()[q.word]
    op, threshold = state.comparison, state.threshold
    w.line(f"yes = value {op} {threshold}  # {q.word}: {op} {threshold} {sense.unit}")
    w.line(f'verdict = "{q.word}" if yes else "not {q.word}"')
    w.line(
        f'text = {_q("the " + q.objects[0].phrase)} + " reads " + {_shown(sense, "value")} + ": " + verdict'
    )
    w.line(f'return {{"yes": yes, "object": patch, "value": value, "unit": {_q(sense.unit)}, "text": text}}')


def _write_compare(w: _Writer, q: SenseQuery) -> None:
    sense = _sense(q.attribute)[1]
    first, second = q.objects[0], q.objects[1]
    _find(w, first, "firsts")
    _find(w, second, "seconds")
    w.line("first = firsts[0]  # find lists the best match first")
    w.line("second = seconds[0]")
    _intro(w, q.attribute)
    w.line("values = []")
    w.line("for patch in [first, second]:")
    _write_measure(_Indented(w), q.attribute, "patch", "values")
    op = ">" if q.more else "<"
    w.line(f"yes = values[0] {op} values[1]")
    w.line("winner = first if yes else second")
    w.line(f'shown = [" (" + {_shown(sense, "value")} + ")" for value in values]')
    w.line(f'word = "{q.word}" if yes else "not {q.word}"')
    w.line(f'text = {_q("the " + first.phrase)} + shown[0] + " is " + word + " than the "')
    w.line(f"text = text + {_q(second.phrase)} + shown[1]")
    w.line("value = values[0] if winner is first else values[1]")
    w.line(f'return {{"yes": yes, "object": winner, "value": value, "unit": {_q(sense.unit)}, "text": text}}')


FAMILY_REGISTRY.register("senses")(
    Family(
        examples=(
            "Which mug is hot?",
            "Is the kettle hot?",
            "the softest ball",
            "Which bottle is empty?",
            "the coldest can",
            "How hot is the kettle?",
        ),
        readers=((15, parse_sense),),
        forms=(SenseQuery,),
        write=_write_sense,
    )
)
