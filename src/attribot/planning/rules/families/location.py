"""Location: the k-th object from a side, in a row or column found by clustering box centres."""

from __future__ import annotations

import re
from typing import Literal

from attribot.planning.rules.families import FAMILY_REGISTRY, Family
from attribot.planning.rules.forms import (
    LineSpec,
    LocationQuery,
    Pick,
    Side,
)
from attribot.planning.rules.normalise import (
    _OPPOSITE,
    _ORD,
    _SIDES,
    _object,
    _ordinal,
    _take,
)
from attribot.planning.rules.write import (
    _count_message,
    _find,
    _nth,
    _sorted,
    _Writer,
    write_line,
)


class _NoReading(Exception):
    """The phrase has a location word but no one way to read it: the family reads nothing."""


def _parse_location(text: str) -> LocationQuery | None:
    text = re.sub(r"\s+(?:of|in)\s+(?:the\s+)?(?:image|picture|photo|frame|scene)\b", "", text)
    try:
        line, middle_of, text = _take_line(text)
        corner, text = _take(
            r"\b(?:(?:at|in|on)\s+the\s+)?(top|upper|bottom|lower)\s+(left|right)(?:\s+corner)?\b", text
        )
        extreme, text = _take_extreme(text)
        ordinal, direction, text = _take_ordinal(text)
        position, middle_adj, side_adj, text = _take_position(text)
        pick = _first_pick(ordinal, direction, line, extreme, middle_of or middle_adj, side_adj)
        line, pick = _with_corner(corner, line, pick)
        line, pick = _with_position(position, line, pick)
        pick = _final_pick(line, pick)
    except _NoReading:
        return None
    obj = _object(text)
    if obj is None or pick.k < 1:
        return None
    return LocationQuery(obj=obj, line=line, pick=pick)


_LINE_WHICH = (
    _ORD
    + r"|top|bottom|upper|lower|middle|center|centre|central|left|right|leftmost|rightmost|topmost|bottommost"
)


def _take_line(text: str) -> tuple[LineSpec | None, bool, str]:
    """Rows and columns: "in the middle of the second row from the top", "at the second to last row";
    the line, whether its middle is meant, and the rest of the text."""
    match, text = _take(
        r"\b(?:(?:in|on|at|of|from|within|along)\s+)?(?:the\s+)?(?P<mid>(?:very\s+)?(?:middle|center|centre)\s+of\s+"
        r"(?:the\s+)?)?(?P<which>" + _LINE_WHICH + r")\s+(?P<kind>rows?|lines?|columns?|cols?)"
        r"(?:\s+(?:starting\s+|counting\s+)?from\s+(?:the\s+)?(?P<side>top|bottom|left|right))?\b",
        text,
    )
    if not match:
        return None, False, text
    kind: Literal["row", "column"] = "column" if match["kind"].startswith("col") else "row"
    line = _line_of(kind, match["which"], match["side"])
    if _k_invalid(line):
        raise _NoReading()
    return line, match["mid"] is not None, text


def read_line(text: str) -> LineSpec | None:
    """The row or column `text` names as a whole ("top row", "second column from the right"), or None."""
    try:
        line, middle_of, rest = _take_line(text)
    except _NoReading:
        return None
    return line if line is not None and not middle_of and not rest.strip() else None


def _line_of(kind: Literal["row", "column"], word: str, side: str | None) -> LineSpec:
    if word in ("middle", "center", "centre", "central"):
        return LineSpec(kind, middle=True)
    if word in ("top", "upper", "topmost", "bottom", "lower", "bottommost"):
        if kind != "row":
            raise _NoReading()
        return LineSpec(kind, 1, from_end=word in ("bottom", "lower", "bottommost"))
    if word in ("left", "leftmost", "right", "rightmost"):
        if kind != "column":
            raise _NoReading()
        return LineSpec(kind, 1, from_end=word in ("right", "rightmost"))
    k, from_end = _ordinal(word)
    if side is not None:
        expected = ("top", "bottom") if kind == "row" else ("left", "right")
        if side not in expected:
            raise _NoReading()
        from_end = from_end != (side == expected[1])
    return LineSpec(kind, k, from_end=from_end)


_EXTREMES: dict[str, Side] = {
    "leftmost": "left",
    "rightmost": "right",
    "topmost": "top",
    "uppermost": "top",
    "highest": "top",
    "bottommost": "bottom",
    "lowermost": "bottom",
    "lowest": "bottom",
}


def _take_extreme(text: str) -> tuple[Side | None, str]:
    """Extremes: "leftmost", "at the very bottom", "with the highest altitude"."""
    match, text = _take(r"\bwith\s+the\s+(highest|lowest)\s+(?:altitude|position|height)\b", text)
    if match:
        return ("top" if match[1] == "highest" else "bottom"), text
    match, text = _take(
        r"\b(?:at|on|in|to)\s+the\s+(?:very|far|furthest|farthest)\s+(top|bottom|left|right)\b", text
    )
    if match:
        return _SIDES[match[1]], text
    match, text = _take(
        r"\b(leftmost|rightmost|topmost|uppermost|bottommost|lowermost|highest|lowest)\b", text
    )
    return (_EXTREMES[match[1]] if match else None), text


def _take_ordinal(text: str) -> tuple[tuple[int, bool] | None, Side | None, str]:
    """An ordinal with a direction: "second dog from the right", "second from the left dog head"."""
    direction: Side | None = None
    match, text = _take(
        r"\b(?:starting\s+|counting\s+)?from\s+(?:the\s+)?(left|right|top|bottom)(?:\s+side)?\b", text
    )
    if match:
        direction = _SIDES[match[1]]
    match, text = _take(r"^(?:the\s+)?(" + _ORD + r")\b", text)
    if match:
        return _ordinal(match[1]), direction, text
    if direction is not None:
        raise _NoReading()  # "from the left" with no ordinal: nothing to count
    return None, None, text


def _take_position(text: str) -> tuple[str | None, bool, Side | None, str]:
    """Positions ("at the bottom", "on the right", "in the middle") and a leading "middle", "right" or
    "top" used as an adjective ("middle window", "right eye")."""
    position: str | None = None
    match, text = _take(
        r"\b(?:at|on|in|to|towards)\s+(?:the\s+)?(top|bottom|left|right|middle|center|centre)"
        r"(?:\s+(?:side|part|edge))?\b",
        text,
    )
    if match:
        position = {"center": "middle", "centre": "middle"}.get(match[1], match[1])
    match, text = _take(r"^(?:the\s+)?(middle|center|centre|central)\b", text)
    if match:
        return position, True, None, text
    match, text = _take(r"^(?:the\s+)?(left|right|top|bottom|upper|lower)\s+(?=\S)", text)
    return position, False, (_SIDES[match[1]] if match else None), text


def _first_pick(
    ordinal: tuple[int, bool] | None,
    direction: Side | None,
    line: LineSpec | None,
    extreme: Side | None,
    middle: bool,
    side_adj: Side | None,
) -> Pick | None:
    """What is chosen within the group, from the words read so far."""
    if ordinal is not None:
        k, from_end = ordinal
        start: Side = direction or ("top" if line is not None and line.kind == "column" else "left")
        return Pick("ordinal", _OPPOSITE[start] if from_end else start, k)
    if extreme is not None:
        return Pick("ordinal", extreme, 1)
    if middle:
        return Pick("middle")  # the axis follows the line, in _final_pick
    if side_adj is not None:
        return Pick("ordinal", side_adj, 1)
    return None


def _with_corner(
    corner: re.Match[str] | None, line: LineSpec | None, pick: Pick | None
) -> tuple[LineSpec | None, Pick | None]:
    if corner is None:
        return line, pick
    vertical, horizontal = _SIDES[corner[1]], _SIDES[corner[2]]
    if line is not None or (pick is not None and pick.kind != "middle"):
        raise _NoReading()  # "second top right X": more than one way to read it
    return LineSpec("row", 1, from_end=vertical == "bottom"), Pick("ordinal", horizontal, 1)


_POSITION_LINES = {
    "top": LineSpec("row", 1),
    "bottom": LineSpec("row", 1, from_end=True),
    "left": LineSpec("column", 1),
    "right": LineSpec("column", 1, from_end=True),
    "middle": LineSpec("row", middle=True),
}


def _with_position(
    position: str | None, line: LineSpec | None, pick: Pick | None
) -> tuple[LineSpec | None, Pick | None]:
    if position is None:
        return line, pick
    if pick is None:
        return line, (Pick("central") if position == "middle" else Pick("ordinal", position, 1))  # type: ignore[arg-type]
    if line is None:
        return _POSITION_LINES[position], pick
    raise _NoReading()


def _final_pick(line: LineSpec | None, pick: Pick | None) -> Pick:
    if pick is None:
        if line is None:
            raise _NoReading()
        return Pick("only")
    if pick.kind == "middle":
        return Pick("central") if line is None else Pick("middle", axis="x" if line.kind == "row" else "y")
    if pick.kind == "ordinal" and line is not None:
        # an ordinal along the line's own cross axis ("topmost X in the top row") is no choice at all
        cross = ("top", "bottom") if line.kind == "row" else ("left", "right")
        if pick.side in cross and pick.k > 1:
            raise _NoReading()
    return pick


def _k_invalid(line: LineSpec) -> bool:
    return not line.middle and line.index < 1


_SORT_KEYS = {
    "left": ("patch.horizontal_center", False, "from the left"),
    "right": ("patch.horizontal_center", True, "from the right"),
    "top": ("patch.vertical_center", True, "from the top (y grows upward)"),
    "bottom": ("patch.vertical_center", False, "from the bottom (y grows upward)"),
}


def _write_location(w: _Writer, q: LocationQuery) -> None:
    _find(w, q.obj)
    group = write_line(w, q.line, q.obj.phrase) if q.line is not None else "candidates"
    pick = q.pick
    if pick.kind == "ordinal":
        _write_ordinal(w, q, group)
    elif pick.kind == "middle":
        key = "patch.horizontal_center" if pick.axis == "x" else "patch.vertical_center"
        along = "left to right" if pick.axis == "x" else "top to bottom"
        w.line(f"# the middle one of the {group}, counted {along}")
        w.line(f"ordered = {_sorted(group, key, pick.axis == 'y')}")
        w.line("return ordered[len(ordered) // 2]")
    elif pick.kind == "central":
        _write_central(w)
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


def _write_ordinal(w: _Writer, q: LocationQuery, group: str) -> None:
    pick = q.pick
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


def _write_central(w: _Writer) -> None:
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


FAMILY_REGISTRY.register("location")(
    Family(
        examples=(
            "the second dog from the right",
            "top right cocktail",
            "the second umbrella from the left in the second to last row",
            "the pill in the middle of the right column",
            "the object furthest to the left",
        ),
        readers=((40, lambda r: _parse_location(r.plain)),),
        forms=(LocationQuery,),
        write=lambda w, q: _write_location(w, q),
    )
)
