"""Writing the program of a reading: readable Python defining `execute_command(image, robot)`, the same
kind of program an LLM writes against the API, sensor-aware (measured with the robot's sensors when it has
them, a stated visual proxy or the paper's VQA + language-model chain otherwise).
"""

from __future__ import annotations

import json
from collections.abc import Sequence

from attribot.errors import InputError
from attribot.planning.rules.families import FAMILY_REGISTRY
from attribot.planning.rules.forms import (
    Among,
    DistanceQuery,
    Level,
    LineSpec,
    ObjectSpec,
    ParsedQuery,
    Region,
    Request,
    Understood,
    UnsupportedQuery,
    measured_sense,
)
from attribot.planning.rules.helpers import source as helper_source
from attribot.planning.rules.understand import kinds_of

GROUP_KINDS = 20
"""A plural noun with this many common kinds under it in WordNet names a group ("vegetables", "fruits",
"tools"), whose kinds are looked for with it; one with fewer ("bottles": flask, jug) names objects of its
own, and its kinds are looked for only where none is found by its name."""

# ---- the program writer --------------------------------------------------------------------------------

_ORDINAL_NAMES = {1: "1st", 2: "2nd", 3: "3rd"}


def _nth(k: int) -> str:
    return _ORDINAL_NAMES.get(k, f"{k}th") if not 10 < k % 100 < 14 else f"{k}th"


def _q(text: str) -> str:
    """A Python string literal (double quotes), its letters as written ("°C", "café")."""
    return json.dumps(text, ensure_ascii=False)


class _Writer:
    """Collects the lines of `execute_command` with their indentation."""

    def __init__(self, query: str) -> None:
        self.helpers: list[str] = []
        self.body: list[str] = [f"# Query: {_q(query)}", "# Written by the offline rules planner."]
        self.uses_math = False
        self.query = query
        self.frame: Request | None = None  # a scope, narrowing or action around the reading
        self.sensors: Sequence[str] = ("camera",)
        self.embodied = False
        self.act: str | None = None  # the helper call that acts on the chosen object: "bring(robot, {})"
        self.premeasured: str | None = None  # the distances of `candidates`, measured before the robot moved
        self.applied: set[str] = set()  # the parts of the frame written ("exclude", "after")

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


def _name_lists(names: Sequence[str], most: int = 280) -> list[str]:
    """Names joined with commas for `find`, in lists of at most `most` characters (find takes 300)."""
    lists: list[str] = []
    for name in names:
        if lists and len(lists[-1]) + 2 + len(name) <= most:
            lists[-1] += ", " + name
        else:
            lists.append(name)
    return lists


class _Indented:
    """The writer of a block's body: each line one level in."""

    def __init__(self, outer: _Writer) -> None:
        self.outer = outer

    def line(self, text: str = "") -> None:
        self.outer.line("    " + text)

    def helper(self, name: str) -> None:
        self.outer.helper(name)


def _find_names(w: _Writer | _Indented, var: str, names: Sequence[str]) -> None:
    """`var`: the objects found by any of `names`, asked in lists `find` takes, each object once (two
    names may find one object: an orange is a citrus)."""
    lists = _name_lists(names)
    if len(lists) == 1:
        w.line(f"{var} = image.find({_q(lists[0])})")
        return
    w.helper("same_box")
    w.line(f"{var} = []")
    for listed in lists:
        w.line(f"for patch in image.find({_q(listed)}):")
        w.line(f"    if not any(same_box(patch, other) for other in {var}):")
        w.line(f"        {var}.append(patch)")


def _find(w: _Writer, obj: ObjectSpec, var: str = "candidates") -> None:
    """`var = image.find(noun)`, the colour filter, and the "none found" error."""
    kinds = kinds_of(obj.noun) if obj.noun.endswith("s") and " " not in obj.noun else ()
    if len(kinds) >= GROUP_KINDS:
        w.line(f"# {obj.noun} name a group: it and the kinds of it WordNet lists, looked for by name")
        _find_names(w, var, (obj.noun, *kinds))
    else:
        w.line(f"{var} = image.find({_q(obj.noun)})")
    if 0 < len(kinds) < GROUP_KINDS:
        w.line(f"if len({var}) == 0:")
        w.line(f"    # none by that name: the kinds of {obj.noun} WordNet lists, looked for by name")
        _find_names(_Indented(w), var, kinds)
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
        _write_scope(w, var, frame.scope, obj, frame.level)
    if frame is not None and frame.region is not None:
        _write_region(w, var, frame.region, obj, frame.scope)
    if frame is not None and frame.among is not None and var == "candidates":
        _write_among(w, frame.among)
    if frame is not None and frame.exclude and var == "candidates":
        _write_exclusion(w, frame.exclude, obj)
    if frame is not None and frame.after is not None and var == "candidates":
        _write_after(w, frame.after)


def _write_exclusion(w: _Writer, exclude: tuple[ObjectSpec, ...], obj: ObjectSpec) -> None:
    """Leave the named objects out of `candidates` ("apart from the kettle")."""
    w.helper("same_box")
    names = " and the ".join(spec.phrase for spec in exclude)
    w.line(f"# apart from the {names}: every one found by that name is left out")
    w.line("left_out = []")
    for spec in exclude:
        w.line(f"left_out = left_out + image.find({_q(spec.phrase)})")
    w.line("kept = []")
    w.line("for patch in candidates:")
    w.line("    if not any(same_box(patch, other) for other in left_out):")
    w.line("        kept.append(patch)")
    w.line("candidates = kept")
    w.fail("len(candidates) == 0", _q(f"no {obj.phrase} found apart from the {names}"))
    w.applied.add("exclude")


def _write_after(w: _Writer, after: ObjectSpec) -> None:
    """Find the object the choice comes after ("next heaviest after the toaster"), among `candidates`."""
    w.helper("same_box")
    w.line(f"# the next one after the {after.phrase} in the order: find it among the candidates")
    w.line(f"references = image.find({_q(after.phrase)})")
    w.fail("len(references) == 0", _q(f"no {after.phrase} found in the image"))
    w.line("reference = -1")
    w.line("for index, patch in enumerate(candidates):")
    w.line("    if reference < 0 and same_box(patch, references[0]):")
    w.line("        reference = index")
    w.fail("reference < 0", _q(f"the {after.phrase} is not one of the objects compared"))


def _write_scope(w: _Writer, var: str, scope: str, obj: ObjectSpec, level: Level | None = None) -> None:
    """Keep the patches of `var` that stand on the surface `scope` (on none of the furniture: the floor), on
    one board of it with a `level` ("the bottom shelf")."""
    w.helper("on_surface")
    w.helper("on_any")
    if scope == "floor":
        w.line("# on the floor: standing on none of the furniture")
        w.line('furniture = image.find("table") + image.find("counter") + image.find("shelf")')
        w.line("kept = []")
        w.line(f"for patch in {var}:")
        w.line("    if not on_any(patch, furniture):")
        w.line("        kept.append(patch)")
    elif level is not None:
        w.helper("on_level")
        w.line(f"# on the {level} {scope}: standing on the {scope}, on its {level} board")
        w.line(f"surfaces = image.find({_q(scope)})")
        w.fail("len(surfaces) == 0", _q(f"no {scope} found in the image"))
        w.line("kept = []")
        w.line(f"for patch in {var}:")
        w.line("    for surface in surfaces:")
        w.line(f"        if on_surface(patch, surface) and on_level(patch, surface, {_q(level)}):")
        w.line("            kept.append(patch)")
        w.line("            break")
    else:
        w.line(f"# on the {scope}: the detector finds furniture too; keep what stands on it")
        w.line(f"surfaces = image.find({_q(scope)})")
        w.fail("len(surfaces) == 0", _q(f"no {scope} found in the image"))
        w.line("kept = []")
        w.line(f"for patch in {var}:")
        w.line("    if on_any(patch, surfaces):")
        w.line("        kept.append(patch)")
    w.line(f"{var} = kept")
    place = f"{level} {scope}" if level is not None else scope
    w.fail(f"len({var}) == 0", _q(f"no {obj.phrase} found on the {place}"))


def _write_region(w: _Writer, var: str, region: Region, obj: ObjectSpec, scope: str | None) -> None:
    """Keep the patches of `var` in a side of the picture (of the surface they stand on, with a scope), or
    in one of the rows or columns they form."""
    if region.line is not None:
        kept = write_line(w, region.line, obj.phrase, var)
        w.line(f"{var} = {kept}")
        return
    w.helper("on_side")
    side = str(region.side)
    if scope is not None and scope != "floor":
        w.line(f"# {region.words} of the {scope}: that side of the middle of the {scope} it stands on")
        w.line("kept = []")
        w.line(f"for patch in {var}:")
        w.line("    for surface in surfaces:")
        w.line(f"        if on_surface(patch, surface) and on_side(patch, {_q(side)}, surface):")
        w.line("            kept.append(patch)")
        w.line("            break")
    else:
        w.line(f"# {region.words}: that side of the middle of the picture")
        w.line("kept = []")
        w.line(f"for patch in {var}:")
        w.line(f"    if on_side(patch, {_q(side)}, image):")
        w.line("        kept.append(patch)")
    w.line(f"{var} = kept")
    where = f"{region.words} of the {scope}" if scope not in (None, "floor") else region.words
    w.fail(f"len({var}) == 0", _q(f"no {obj.phrase} found {where}"))


def write_line(w: _Writer, line: LineSpec, phrase: str, var: str = "candidates") -> str:
    """The rows or columns the patches of `var` form, and the one asked for taken; returns the name of the
    variable it is kept in."""
    w.helper("group_into_lines")
    kind, plural = line.kind, line.kind + "s"
    first = "top" if kind == "row" else "left"
    last = "bottom" if kind == "row" else "right"
    w.line(f"{plural} = group_into_lines({var}, {_q(kind)})")
    if line.middle:
        w.line(f"# the middle {kind}; with an even number of {plural}, the one just past the centre")
        w.line(f"{kind} = {plural}[len({plural}) // 2]")
        return kind
    k = line.index
    side = last if line.from_end else first
    if k > 1:
        w.fail(
            f"len({plural}) < {k}",
            _count_message(
                f"asked for the {_nth(k)} {kind} from the {side}, but the {phrase}s form only ",
                f"len({plural})",
                f" {kind}(s)",
            ),
        )
    index = f"len({plural}) - {k}" if line.from_end else str(k - 1)
    w.line(f"# the {_nth(k)} {kind} from the {side}")
    w.line(f"{kind} = {plural}[{index}]")
    return kind


def _write_among(w: _Writer, among: Among) -> None:
    """Narrow `candidates` to the k at one end of another attribute ("of the two closest")."""
    sense = measured_sense(among.attribute)
    end = sense.superlative(among.most == sense.most)
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
        frame = w.frame
        if frame is not None and isinstance(frame.inner, DistanceQuery) and "distance" in w.sensors:
            # weighing drives the robot about, after which the boxes no longer say where to look: measure
            # the distances the choice needs first, from here
            w.line("# distances first: weighing moves the robot, and the boxes are this view's")
            w.line("distances_here = []")
            w.line("for patch in candidates:")
            w.line("    robot.focus_on_patch(patch)")
            w.line("    distances_here.append(robot.measure_distance(patch))")
            w.premeasured = "distances_here"
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
    if w.premeasured is not None:
        w.line(f"{w.premeasured} = [{w.premeasured}[index] for index in order[:{among.k}]]")


def write_program(
    parsed: ParsedQuery, query: str, sensors: Sequence[str] = ("camera",), embodied: bool = False
) -> str:
    """The program for a parsed query: readable Python defining `execute_command(image, robot)`."""
    w = _Writer(query)
    w.sensors, w.embodied, w.query = sensors, embodied, query
    if isinstance(parsed, Understood):
        # what was read as what is said: in the program, and printed with its answer
        for note in parsed.notes:
            w.line(f"# {note[0].upper()}{note[1:]}")
        w.line(f"print({_q('Understood the query ' + '; '.join(parsed.notes) + '.')})")
        parsed = parsed.inner
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
    for _, family in FAMILY_REGISTRY.items():
        if family.write is not None and isinstance(parsed, family.forms):
            family.write(w, parsed)
            break
    else:
        raise TypeError(f"no family writes a {type(parsed).__name__}")
    frame = w.frame
    if frame is not None and (
        (frame.exclude and "exclude" not in w.applied)
        or (frame.after is not None and "after" not in w.applied)
    ):
        # a part of the question this program would not honour: no answer rather than a wrong one
        raise UnsupportedQuery(
            query,
            "it leaves objects out or asks for the next in an order, which the "
            "planner writes only for a choice it measures among the objects found",
        )
    return w.source()
