"""Writing the program of a reading: readable Python defining `execute_command(image, robot)`, the same
kind of program an LLM writes against the API, sensor-aware (measured with the robot's sensors when it has
them, a stated visual proxy or the paper's VQA + language-model chain otherwise).
"""

from __future__ import annotations

import json
from collections.abc import Sequence

from attribot.errors import InputError
from attribot.planning.rules.forms import (
    Among,
    DistanceQuery,
    GroundingQuery,
    LocationQuery,
    MeasureQuery,
    ObjectSpec,
    OddQuery,
    ParsedQuery,
    Request,
    SizeQuery,
    WeightQuery,
    YesNoQuery,
)
from attribot.planning.rules.helpers import source as helper_source
from attribot.planning.rules.normalise import (
    _COMPARATIVE,
    _SIZE,
    _SUPERLATIVE,
)

# ---- the program writer --------------------------------------------------------------------------------

_ORDINAL_NAMES = {1: "1st", 2: "2nd", 3: "3rd"}


def _nth(k: int) -> str:
    return _ORDINAL_NAMES.get(k, f"{k}th") if not 10 < k % 100 < 14 else f"{k}th"


def _q(text: str) -> str:
    """A Python string literal (double quotes)."""
    return json.dumps(text)


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

    def helper(self, name: str) -> None:
        """Define the helper `name` of `attribot.planning.rules.helpers` in the program (once)."""
        text = helper_source(name)
        if text not in self.helpers:
            self.helpers.append(text)

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


def _write_scope(w: _Writer, var: str, scope: str, obj: ObjectSpec) -> None:
    """Keep the patches of `var` that stand on the surface `scope` (on none of the furniture: the floor)."""
    w.helper("on_surface")
    w.helper("on_any")
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
        w.helper("group_into_lines")
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


def _write_odd(w: _Writer, q: OddQuery, sensors: Sequence[str], embodied: bool) -> None:
    w.helper("the_one_unlike_the_rest")
    w.helper("size_outlier")
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
            w.helper("bring" if parsed.action == "pick" else "put_it_on")
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
