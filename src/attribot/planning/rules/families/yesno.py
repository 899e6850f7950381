"""Yes/no comparisons: whether one named object has more of an attribute than another, answered yes
or no with both values and the one that is.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from attribot.lexicon import sense_words
from attribot.planning.rules.families import FAMILY_REGISTRY, Family
from attribot.planning.rules.forms import (
    MEASURED,
    YesNoQuery,
)
from attribot.planning.rules.normalise import (
    _ME,
    _named,
    _strip_article,
)
from attribot.planning.rules.write import (
    _find,
    _q,
    _Writer,
)
from attribot.sensors import COMPARATIVE, sense_of

_YES_NO_WORDS = {
    # the measured senses' comparatives, from their records: "heavier", "closer", "more distant"
    **{
        w: (quantity, more)
        for w, (quantity, more, form) in sense_words(MEASURED).items()
        if form == COMPARATIVE
    },
    **{w: ("size", True) for w in ("bigger", "larger")},
    **{w: ("size", False) for w in ("smaller",)},
}
_YES_NO_ADJ = (
    r"(?P<adj>"
    + "|".join(sorted(_YES_NO_WORDS, key=len, reverse=True))
    + r")"
    + _ME
    + r"\s+than\s+(?P<b>.+?)"
    + _ME
)
_YES_NO = re.compile(r"(?:is|are|does|do|would|will)\s+(?P<a>.+?)\s+(?:(?:is|are|be)\s+)?" + _YES_NO_ADJ)
# asked with a question mark and no verb before the names: "tissue box heavier than the hammer?", "the mug
# is heavier than the plate?"
_YES_NO_STATED = re.compile(r"(?P<a>.+?)\s+(?:(?:is|are)\s+)?" + _YES_NO_ADJ)
_SIDE = r"(?:(?:on|to)\s+the\s+)?(?P<side>left|right)\s+(?:of|from)\s+(?P<b>.+)"
_YES_NO_SIDE = re.compile(r"(?:is|are)\s+(?P<a>.+?)\s+" + _SIDE)
_YES_NO_SIDE_STATED = re.compile(r"(?P<a>.+?)\s+(?:(?:is|are)\s+)?" + _SIDE)


def _parse_yes_no(text: str, question: bool = False) -> YesNoQuery | None:
    """ "is the kettle heavier than the backpack", "is the book to the left of the mug"; asked as a
    question, the same without the verb before the names ("kettle closer than the vase?")."""
    match = _YES_NO.fullmatch(text) or (_YES_NO_STATED.fullmatch(text) if question else None)
    if match is not None:
        attribute, more = _YES_NO_WORDS[match["adj"]]
        word = match["adj"]
    else:
        match = _YES_NO_SIDE.fullmatch(text) or (_YES_NO_SIDE_STATED.fullmatch(text) if question else None)
        if match is None:
            return None
        attribute, more, word = "position", match["side"] == "right", f"to the {match['side']} of"
    first, second = _named(_strip_article(match["a"])), _named(_strip_article(match["b"]))
    if first is None or second is None:
        return None
    return YesNoQuery(first, second, attribute, more, word)  # type: ignore[arg-type]


_YES_NO_TERMS = {
    # attribute: (sensor, unit, word for more, word for less); a sense's from its record (`_terms`)
    "size": ("distance", "m", "bigger", "smaller"),
    "position": ("camera", "px", "further right", "further left"),
}


def _write_yes_no(w: _Writer, q: YesNoQuery, sensors: Sequence[str], embodied: bool) -> None:
    _find(w, q.first, "firsts")
    _find(w, q.second, "seconds")
    w.line("first = firsts[0]  # find lists the best match first")
    w.line("second = seconds[0]")
    sensor, unit, more_word, less_word = _terms(q.attribute)
    if sensor == "camera" or (embodied and sensor in sensors):
        _write_measured_values(w, q.attribute)
    else:
        _write_estimated_values(w, q)
        unit = ""
    _write_verdict(w, q, unit, more_word, less_word)


def _terms(attribute: str) -> tuple[str, str, str, str]:
    """The sensor that settles `attribute`, its unit, and the words for more and for less of it: a sense's
    from its record ("force", "kg", "heavier", "lighter"), size's and position's from `_YES_NO_TERMS`."""
    found = sense_of(attribute)
    if found is None:
        return _YES_NO_TERMS[attribute]
    sensor, sense = found
    return sensor.name, sense.unit, sense.comparative(True), sense.comparative(False)


def _write_measured_values(w: _Writer, attribute: str) -> None:
    """`values`: the two objects' attribute, measured with the sensor (or read from the picture)."""
    if attribute == "weight":
        w.line("# weigh both: the force sensor reads only what the gripper holds")
        w.line("values = []")
        w.line("for patch in [first, second]:")
        w.line("    robot.go_to_object(patch)")
        w.line("    robot.pick_up(patch)")
        w.line("    values.append(robot.measure_weight(patch))")
        w.line("    robot.put_down()")
    elif attribute == "distance":
        w.line("values = []")
        w.line("for patch in [first, second]:")
        w.line("    robot.focus_on_patch(patch)")
        w.line("    values.append(robot.measure_distance(patch))")
    elif attribute == "size":
        w.line("# sizes in metres: each box's pixels times its measured distance over the focal length")
        w.line("values = []")
        w.line("for patch in [first, second]:")
        w.line("    width, height = patch.size_at(robot.measure_distance(patch))")
        w.line("    values.append(max(width, height))")
    else:  # position
        w.line("# left and right in the picture: the centres of the boxes, in pixels from the left edge")
        w.line("values = [first.horizontal_center, second.horizontal_center]")


def _write_estimated_values(w: _Writer, q: YesNoQuery) -> None:
    """`values` with no sensor for the attribute: reasoned about or a visual proxy, in no unit."""
    if q.attribute == "weight":
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
    elif q.attribute == "distance":
        w.line(
            "# no distance sensor: a visual proxy, not a measurement; on one floor or table, the box whose"
        )
        w.line("# bottom edge is higher in the picture is farther (y grows upward)")
        w.line("values = [first.lower, second.lower]")
    else:
        w.line("# no distance sensor: the box areas in pixels (a visual proxy; a near object looks bigger)")
        w.line("values = [first.area, second.area]")


def _write_verdict(w: _Writer, q: YesNoQuery, unit: str, more_word: str, less_word: str) -> None:
    """The yes or no, the object that is more (or less), and a sentence with both values."""
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


FAMILY_REGISTRY.register("yes/no")(
    Family(
        examples=("Is the kettle heavier than the backpack?", "Is the book to the left of the mug?"),
        readers=(),
        forms=(YesNoQuery,),
        write=lambda w, q: _write_yes_no(w, q, w.sensors, w.embodied),
    )
)
