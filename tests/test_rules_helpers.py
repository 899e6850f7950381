"""The functions the rules planner's programs define: real code, called here, and the text a program
defines passes the runner's policy and behaves the same."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from attribot.planning.rules import helpers


def patch(left, lower, right, upper):
    return SimpleNamespace(
        left=left,
        lower=lower,
        right=right,
        upper=upper,
        width=right - left,
        height=upper - lower,
        horizontal_center=(left + right) / 2,
        vertical_center=(lower + upper) / 2,
        area=(right - left) * (upper - lower),
    )


def test_rows_follow_the_objects_top_row_first():
    top = [patch(x, 300, x + 40, 340) for x in (0, 100)]
    bottom = [patch(x, 100, x + 40, 140) for x in (0, 100, 200)]
    rows = helpers.group_into_lines(bottom + top, "row")
    assert [len(r) for r in rows] == [2, 3]


def test_on_surface_reads_where_an_object_stands():
    table = patch(100, 0, 400, 200)
    assert helpers.on_surface(patch(150, 120, 180, 170), table)
    assert not helpers.on_surface(patch(450, 120, 480, 170), table)  # beside it
    assert not helpers.on_surface(patch(150, 210, 180, 260), table)  # above its top: behind it
    assert helpers.on_any(patch(150, 120, 180, 170), [patch(0, 0, 50, 50), table])


def test_a_surface_is_never_on_itself():
    shelf = patch(100, 0, 400, 300)
    assert not helpers.on_surface(shelf, shelf), "furniture named as a place is never the answer"


def test_on_level_tells_a_shelfs_top_board_from_a_lower_one():
    shelf = patch(200, 0, 440, 180)  # y up: the top board is the box's upper edge
    on_top = patch(300, 165, 330, 200)  # its foot near the upper edge (measured: within a tenth of the box)
    below = patch(300, 88, 330, 130)  # its foot about half way down (measured: 0.45 to 0.55 of the box)
    assert helpers.on_level(on_top, shelf, "top") and not helpers.on_level(on_top, shelf, "bottom")
    assert helpers.on_level(below, shelf, "bottom") and not helpers.on_level(below, shelf, "top")


def test_the_one_unlike_the_rest():
    assert helpers.the_one_unlike_the_rest(["mug", "apple", "mug"]) == 1
    assert helpers.the_one_unlike_the_rest(["mug", "apple", "pear"]) is None


@pytest.mark.parametrize("name", [n for n in helpers.__all__ if n != "source"])
def test_the_source_a_program_defines_passes_the_policy_and_runs(name):
    from attribot.runner.policy import check_program

    text = helpers.source(name)
    assert ":" not in text.splitlines()[0].split("(", 1)[1].rstrip(":")  # no annotations
    assert (
        check_program("import math\n" + text + "\ndef execute_command(image, robot):\n    return 1\n") is None
    )
    namespace: dict = {"math": __import__("math")}
    exec(compile(text, "<helper>", "exec"), namespace)
    if name == "the_one_unlike_the_rest":
        assert namespace[name](["a", "b", "a"]) == 1


def test_an_unknown_helper_is_an_error():
    with pytest.raises(KeyError):
        helpers.source("open")
