"""The senses beyond the paper's: temperature (an infrared thermometer), softness (a squeeze) and fullness
(weighing a container). Which object is at one end ("which mug is hot?", "the softest ball", "which bottle
is empty?", "the coldest can"), whether one object is in a state or more so than another ("is the kettle
hot?", "is the mug hotter than the kettle?"), and how much ("how hot is the kettle?" in degrees Celsius).

A state word means a threshold (`attribot.lexicon.SENSE_STATES`, the one place it is kept), stated in the
program: hot is 40 degC or more, warm 30, cold 12 or less, cool 18; soft is under 1 N/mm of squeeze, firm 1
or more, hard 5 or more; full is more than half full, empty less than half. "Which mug is hot?" chooses the
hottest and says so when even that one is not hot.
"""

from __future__ import annotations

from attribot.errors import InputError
from attribot.lexicon import SENSE_STATES, SENSE_WORDS
from attribot.planning.rules.families import FAMILY_REGISTRY, Family, Reading
from attribot.planning.rules.families.attributes import _find_all, _write_extreme_loop
from attribot.planning.rules.forms import SenseQuery
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

__all__ = ["parse_sense"]

_SENSOR = {
    "temperature": ("temperature", "°C", "the camera cannot see how hot something is"),
    "stiffness": ("grip", "N/mm", "the camera cannot feel how hard something is"),
    "fullness": ("force", "full", "an empty and a full container look the same"),
}
"""Each sense: (the sensor that settles it, its unit, why the camera alone cannot)."""

_WORDS = "|".join(sorted(SENSE_WORDS, key=len, reverse=True))
_NOUN = r"[a-z]+(?:\s+[a-z]+){0,2}?"
_OF_THE = r"(?:\s+of\s+(?:the|these|those|all\s+the)(?:\s+(?:two|three|four|five))?)"
_POSSESSIVE = r"(?:my|your|our|this|that)\s+"
_IS = r"\s+(?:is|are)\s+"
_STILL = r"(?:\s+(?:feels?|seems?|looks?))?\s+(?:still\s+|now\s+|very\s+|really\s+|too\s+)?"
_HOW = {
    "temperature": ("hot", "warm", "cold", "cool"),
    "stiffness": ("soft", "hard", "firm", "stiff", "squishy"),
    "fullness": ("full", "empty"),
}
_QUANTITY = {
    "temperature": "temperature",
    "stiffness": "stiffness|softness|hardness|firmness",
    "fullness": "fullness|fill\\s+level|level",
}


def parse_sense(r: Reading) -> SenseQuery | None:
    """The reading of a sense's question, or None when the text names no sense word (or asks otherwise)."""
    text = r.text
    if not any(word in text for word in ("hot", "warm", "cold", "cool", "chill", "boil", "soft", "hard",
                                          "firm", "stiff", "squ", "spong", "rigid", "full", "fill",
                                          "empt", "temperature")):  # fmt: skip
        return None
    return _how(text) or _whether(text, r.question) or _named_choice(text) or _which(text)


def _sense(word: str) -> tuple[str, bool, str]:
    return SENSE_WORDS[" ".join(word.split())]


def _how(text: str) -> SenseQuery | None:
    """ "how hot is the kettle", "what is the temperature of the mug", "what temperature is the can"."""
    for attribute, words in _HOW.items():
        match = rx(
            r"(?:(?:tell\s+me|say|give\s+me|what\s+is)\s+)?(?:how\s+(?P<adj>" + "|".join(words) + r")" + _IS
            + r"(?P<obj>.+)|(?:the\s+)?(?:" + _QUANTITY[attribute] + r")\s+of\s+(?P<obj2>.+)"
            r"|what\s+(?:" + _QUANTITY[attribute] + r")\s+(?:is|are)\s+(?P<obj3>.+))"
        ).fullmatch(text)  # fmt: skip
        if match is None:
            continue
        obj = _named(_owned(match["obj"] or match["obj2"] or match["obj3"]))
        if obj is None:
            return None
        word = match["adj"] or attribute
        more = SENSE_WORDS[word][1] if word in SENSE_WORDS else True
        return SenseQuery((obj,), attribute, more, "how", word)  # type: ignore[arg-type]
    return None


def _owned(text: str) -> str:
    """A name without the article or possessive before it: "my coffee mug" is the coffee mug."""
    return rx(r"^" + _POSSESSIVE).sub("", _strip_article(text))


def _whether(text: str, question: bool = False) -> SenseQuery | None:
    """ "is the kettle hot", "is the kettle still hot", "is the mug hotter than the kettle"; asked as a
    question, the same without the verb first ("mug hot?", "the bottle is empty?")."""
    state = r"(?P<adj>" + _WORDS + r")(?:\s+than\s+(?P<b>.+?))?"
    match = rx(r"(?:is|are|does|do)\s+(?P<a>.+?)" + _STILL + state).fullmatch(text)
    if match is None and question:
        match = rx(r"(?P<a>.+?)(?:\s+(?:is|are))?" + _STILL + state).fullmatch(text)
    if match is None:
        return None
    attribute, more, form = _sense(match["adj"])
    first = _named(_owned(match["a"]))
    if first is None:
        return None
    if match["b"] is not None:
        second = _named(_owned(match["b"]))
        if second is None or form == "absolute":
            return None
        return SenseQuery((first, second), attribute, more, "whether", match["adj"], named=True)  # type: ignore[arg-type]
    if form != "absolute" or match["adj"] not in SENSE_STATES:
        return None
    return SenseQuery((first,), attribute, more, "whether", match["adj"])  # type: ignore[arg-type]


def _named_choice(text: str) -> SenseQuery | None:
    """ "which is hotter, the kettle or the mug", "out of the can, the bottle and the mug, which one is the
    coldest", "is the mug or the kettle warmer", "the coldest of the can and the bottle"."""
    which = r"(?:which|what)(?:\s+one|\s+item|\s+object|\s+thing)?(?:\s+of\s+(?:them|these|those))?"
    for form in (
        which + r"\s+(?:is|are)\s+(?:the\s+)?(?P<adj>" + _WORDS + r"),?\s+(?:(?:out\s+)?of\s+|between\s+)?"
        r"(?P<list>.+)",
        r"(?:out\s+of|of|among|between|from)\s+(?P<list>.+?),?\s+" + which + r"\s+(?:is|are)\s+(?:the\s+)?"
        r"(?P<adj>" + _WORDS + r")",
        r"(?:is|are)\s+(?P<list>.+?\s+or\s+.+?)\s+(?P<adj>" + _WORDS + r")",
        # "the mug or the kettle, which is hotter"
        r"(?P<list>.+?\s+or\s+.+?),?\s+" + which + r"\s+(?:is|are)\s+(?:the\s+)?(?P<adj>" + _WORDS + r")",
        r"(?P<adj>" + _WORDS + r")\s+(?:one\s+)?(?:of|among|out\s+of)\s+"
        r"(?P<list>.+?(?:,|\s+and\s+|\s+or\s+).+)",
    ):
        match = rx(form).fullmatch(text)
        if match is None:
            continue
        objects = _split_names(_strip_article(match["list"]))
        if objects is None or len(objects) < 2:
            continue
        attribute, more, _ = _sense(match["adj"])
        return SenseQuery(objects, attribute, more, "which", match["adj"], named=True)  # type: ignore[arg-type]
    return None


def _which(text: str) -> SenseQuery | None:
    """ "which mug is hot", "which of the balls is the softest one", "the hottest mug", "the second
    coldest can", "the kettle that is hot", "what is the coldest object", "find the hot kettle"."""
    forms = (
        r"(?:which|what)(?:\s+one)?" + _OF_THE + r"?(?:\s+(?P<noun>" + _NOUN + r"))?\s+(?:is|are)\s+"
        r"(?:the\s+)?(?:(?P<ord>" + _ORD + r")\s+)?(?P<adj>" + _WORDS + r")(?:\s+(?:one|ones))?",
        r"(?:which|what)\s+(?:is|are)\s+(?:the\s+)?(?:(?P<ord>" + _ORD + r")\s+)?(?P<adj>" + _WORDS + r")"
        r"(?:\s+(?P<noun>" + _NOUN + r"))?",
        r"(?:the\s+)?(?:(?P<ord>" + _ORD + r")\s+)?(?P<adj>" + _WORDS + r")(?:\s+(?P<noun>" + _NOUN + r"))?",
        r"(?P<noun>" + _NOUN + r")\s+(?:that|which)\s+(?:is|are)\s+(?:the\s+)?(?P<adj>" + _WORDS + r")",
    )
    for form in forms:
        match = rx(form).fullmatch(text)
        if match is None:
            continue
        obj = _object(_owned(match["noun"] or ""))
        if obj is None:
            continue
        attribute, more, _ = _sense(match["adj"])
        rank, from_end = _ordinal(match["ord"]) if match.groupdict().get("ord") else (1, False)
        return SenseQuery((obj,), attribute, more != from_end, "which", match["adj"], rank=rank)  # type: ignore[arg-type]
    return None


# ---- programs ------------------------------------------------------------------------------------------


def _write_sense(w: _Writer, q: SenseQuery) -> None:
    sensor, _, why = _SENSOR[q.attribute]
    if sensor not in w.sensors or not w.embodied:
        where = f"the robot has no {sensor} sensor" if w.embodied else "a still image has no robot"
        raise InputError(
            f"{w.query!r} asks about {q.attribute}, which only a sensor settles, and {where}: {why}",
            f"give the robot the sensor (--sensors camera,{sensor}) on the simulator or a robot",
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
    """Lines that measure `attribute` of `patch` into `into` (a list to append to, or a name to set)."""
    keep = f"{into}.append({{}})" if into.endswith("s") else f"{into} = {{}}"
    if attribute == "temperature":
        w.line(f"robot.focus_on_patch({patch})")
        w.line(keep.format(f"robot.measure_temperature({patch})"))
        return
    method = "measure_stiffness" if attribute == "stiffness" else "measure_fullness"
    w.line(f"robot.go_to_object({patch})")
    w.line(f"robot.pick_up({patch})")
    w.line(keep.format(f"robot.{method}({patch})"))
    w.line("robot.put_down()")


def _intro(w: _Writer, attribute: str) -> None:
    w.line(
        {
            "temperature": "# temperature: the infrared thermometer reads what the camera is centred on",
            "stiffness": "# softness: squeeze each one in the gripper (newtons per millimetre: low is soft)",
            "fullness": "# how full: weigh each one and take away the mass of such a container when empty",
        }[attribute]
    )


def _write_which(w: _Writer, q: SenseQuery) -> None:
    _find_all(w, q.objects)
    _intro(w, q.attribute)
    w.line("values = []")
    w.line("for patch in candidates:")
    body = _Indented(w)
    _write_measure(body, q.attribute, "patch", "values")
    state = SENSE_STATES.get(q.word)
    if state is not None and q.rank == 1:  # "which mug is hot?": say so when even the hottest is not
        threshold, op = state
        end = "max" if q.more else "min"
        unit = _SENSOR[q.attribute][1]
        w.line(f"if not {end}(values) {op} {threshold}:")
        w.line(f'    reads = str(round({end}(values), 2)) + " {unit}"')
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


def _write_how(w: _Writer, q: SenseQuery) -> None:
    _write_one(w, q)
    unit = _SENSOR[q.attribute][1]
    if q.attribute == "stiffness":
        w.line('word = "soft" if value < 1.0 else ("firm" if value < 5.0 else "hard")')
        text = f'{_q("the " + q.objects[0].phrase)} + " gives " + str(round(value, 2)) + " N/mm: " + word'
    elif q.attribute == "fullness":
        text = f'{_q("the " + q.objects[0].phrase)} + " is " + str(round(100 * value)) + "% full"'
    else:
        text = f'{_q("the " + q.objects[0].phrase)} + " reads " + str(round(value, 1)) + " °C"'
    w.line(f"text = {text}")
    w.line(f'return {{"object": patch, "value": value, "unit": "{unit}", "text": text}}')


def _write_state(w: _Writer, q: SenseQuery) -> None:
    _write_one(w, q)
    threshold, op = SENSE_STATES[q.word]
    unit = _SENSOR[q.attribute][1]
    if q.attribute == "fullness":
        shown = 'str(round(100 * value)) + "% full"'
    else:
        shown = f'str(round(value, 2)) + " {unit}"'
    w.line(f"yes = value {op} {threshold}  # {q.word}: {op} {threshold} {unit}")
    w.line(f'verdict = "{q.word}" if yes else "not {q.word}"')
    w.line(f'text = {_q("the " + q.objects[0].phrase)} + " reads " + {shown} + ": " + verdict')
    w.line(f'return {{"yes": yes, "object": patch, "value": value, "unit": "{unit}", "text": text}}')


def _write_compare(w: _Writer, q: SenseQuery) -> None:
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
    unit = _SENSOR[q.attribute][1]
    w.line(f"yes = values[0] {op} values[1]")
    w.line("winner = first if yes else second")
    w.line(f'shown = [" (" + str(round(value, 2)) + " {unit})" for value in values]')
    w.line(f'word = "{q.word}" if yes else "not {q.word}"')
    w.line(f'text = {_q("the " + first.phrase)} + shown[0] + " is " + word + " than the "')
    w.line(f"text = text + {_q(second.phrase)} + shown[1]")
    w.line("value = values[0] if winner is first else values[1]")
    w.line(f'return {{"yes": yes, "object": winner, "value": value, "unit": "{unit}", "text": text}}')


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
