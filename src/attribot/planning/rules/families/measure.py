"""Measurements: one named object's distance, weight or size, with the sensor that settles it."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

from attribot.errors import InputError
from attribot.planning.rules.families import FAMILY_REGISTRY, Family
from attribot.planning.rules.families.attributes import (
    _parse_superlative,
)
from attribot.planning.rules.forms import (
    DistanceQuery,
    MeasureQuery,
    WeightQuery,
)
from attribot.planning.rules.normalise import (
    _ME,
    _named,
    _strip_article,
    rx,
)
from attribot.planning.rules.write import (
    _find,
    _Writer,
)

_MEASURE_FORMS: tuple[tuple[str, Literal["distance", "weight", "size", "height", "width"]], ...] = (
    (r"how\s+(?:far(?:\s+away)?|close|near)" + _ME + r"\s+(?:is|are)\s+(?P<obj>.+?)" + _ME, "distance"),
    (r"(?:what\s+is\s+)?(?:the\s+)?distance\s+(?:to|of)\s+(?P<obj>.+?)" + _ME, "distance"),
    (r"how\s+heavy\s+(?:is|are)\s+(?P<obj>.+)", "weight"),
    (r"how\s+much\s+(?:does|do)\s+(?P<obj>.+?)\s+weigh", "weight"),
    (r"what\s+(?:does|do)\s+(?P<obj>.+?)\s+weigh", "weight"),
    (r"weigh\s+(?P<obj>.+)", "weight"),  # "weigh the tin (for me)"
    (r"(?:what\s+is\s+)?(?:the\s+)?(?:weight|mass)\s+of\s+(?P<obj>.+)", "weight"),
    (r"how\s+(?:big|large|long)\s+(?:is|are)\s+(?P<obj>.+)", "size"),
    (r"how\s+(?:tall|high)\s+(?:is|are)\s+(?P<obj>.+)", "height"),
    (r"how\s+(?:wide|broad)\s+(?:is|are)\s+(?P<obj>.+)", "width"),
    (r"what\s+size\s+(?:is|are)\s+(?P<obj>.+)", "size"),
    (r"(?:what\s+is\s+)?(?:the\s+)?(?:size|length)\s+of\s+(?P<obj>.+)", "size"),
    (r"(?:what\s+is\s+)?(?:the\s+)?height\s+of\s+(?P<obj>.+)", "height"),
    (r"(?:what\s+is\s+)?(?:the\s+)?width\s+of\s+(?P<obj>.+)", "width"),
    # embedded: "(tell me) how far away the bowl is", "how much the kettle weighs"
    (r"how\s+(?:far(?:\s+away)?|close|near)\s+(?P<obj>.+?)\s+(?:is|are)" + _ME, "distance"),
    (r"how\s+heavy\s+(?P<obj>.+?)\s+(?:is|are)", "weight"),
    (r"how\s+much\s+(?P<obj>.+?)\s+weighs?", "weight"),
    (r"how\s+(?:big|large)\s+(?P<obj>.+?)\s+(?:is|are)", "size"),
)


_MEASURE_OPENINGS = (
    "how ",
    "what ",
    "the ",
    "distance ",
    "weight ",
    "mass ",
    "size ",
    "length ",
    "height ",
    "width ",
    "weigh ",
)
"""Every form of `_MEASURE_FORMS` starts with one of these."""


def _parse_measure(text: str) -> MeasureQuery | WeightQuery | DistanceQuery | None:
    """ "How far away is the lamp?", "How much does the apple weigh?": one named object's measurement; "How
    far is the closest chair?": the chosen object, measured."""
    if not text.startswith(_MEASURE_OPENINGS):  # the cheap test first: most queries are no measurement
        return None
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


FAMILY_REGISTRY.register("measurement")(
    Family(
        examples=(
            "How far away is the lamp?",
            "How heavy is the apple?",
            "How much does the book weigh?",
            "What's the distance to the book?",
            "How big is the toaster?",
        ),
        readers=((20, lambda r: _parse_measure(r.text)),),
        forms=(MeasureQuery,),
        write=lambda w, q: _write_measure(w, q, w.query, w.sensors, w.embodied),
    )
)
