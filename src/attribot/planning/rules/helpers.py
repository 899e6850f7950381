"""The functions the rules planner's programs define and call, as real code: ruff and mypy check them here,
tests call them, and `source` copies them into a program with their annotations dropped (a program is
plain Python against the API; see `attribot.api`).

Each takes patches and a robot as the API gives them (`Patch` and `Robot` below name what they use);
y grows upward in patches, as in the API.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import cache
from typing import Protocol

__all__ = [
    "group_into_lines",
    "the_one_unlike_the_rest",
    "size_outlier",
    "on_surface",
    "on_any",
    "on_side",
    "on_level",
    "bring",
    "put_it_on",
    "same_box",
    "source",
]


class Patch(Protocol):
    """What the helpers read of an ImagePatch."""

    left: float
    lower: float
    right: float
    upper: float
    width: float
    height: float
    horizontal_center: float
    vertical_center: float
    area: float


class Robot(Protocol):
    """What the helpers ask of the Robot."""

    def go_to_object(self, patch: Patch) -> None: ...

    def pick_up(self, patch: Patch) -> None: ...

    def put_on(self, patch: Patch) -> None: ...


def group_into_lines(patches: Sequence[Patch], kind: str) -> list[list[Patch]]:
    """Group patches into rows (kind "row", top row first) or columns (kind "column", left first).

    Rows and columns follow the objects, not equal bands of the image: box centres are sorted across the
    lines, and a new line starts wherever two neighbouring centres are further apart than half the
    median box size in that direction.
    """
    if kind == "row":
        # y grows upward, so the top row has the largest vertical_center
        ordered = sorted(patches, key=lambda patch: -patch.vertical_center)
        positions = [-patch.vertical_center for patch in ordered]
        sizes = sorted([patch.height for patch in ordered])
    else:
        ordered = sorted(patches, key=lambda patch: patch.horizontal_center)
        positions = [patch.horizontal_center for patch in ordered]
        sizes = sorted([patch.width for patch in ordered])
    gap = 0.5 * sizes[len(sizes) // 2]
    lines = [[ordered[0]]]
    for index in range(1, len(ordered)):
        if positions[index] - positions[index - 1] > gap:
            lines.append([])
        lines[-1].append(ordered[index])
    return lines


def the_one_unlike_the_rest(values: Sequence[str]) -> int | None:
    """The index of the only value that differs from all the others, which agree; None otherwise."""
    for index in range(len(values)):
        rest = list(values[:index]) + list(values[index + 1 :])
        if values[index] not in rest and len(set(rest)) == 1:
            return index
    return None


def size_outlier(patches: Sequence[Patch]) -> int:
    """The index of the patch whose size least fits the others. Apparent size shrinks with distance, which
    on a table grows with height in the image, so each patch is compared with the line through the others'
    sizes against their vertical centres (their median when they share one row)."""
    worst, worst_index = -1.0, 0
    for index in range(len(patches)):
        others = list(patches[:index]) + list(patches[index + 1 :])
        ys = [p.lower for p in others]
        sizes = [math.sqrt(p.area) for p in others]
        mean_y, mean_size = sum(ys) / len(ys), sum(sizes) / len(sizes)
        spread = sum((y - mean_y) ** 2 for y in ys)
        if spread > 1.0:
            slope = sum((y - mean_y) * (z - mean_size) for y, z in zip(ys, sizes, strict=True)) / spread
            expected = mean_size + slope * (patches[index].lower - mean_y)
        else:
            expected = sorted(sizes)[len(sizes) // 2]
        misfit = abs(math.log(math.sqrt(patches[index].area) / max(expected, 1.0)))
        if misfit > worst:
            worst, worst_index = misfit, index
    return worst_index


def on_surface(patch: Patch, surface: Patch) -> bool:
    """True when the patch stands on the surface: the middle of its bottom edge lies inside the surface's box
    (an object's foot is where it rests; y grows upward). The surface itself, or a patch as big as it, is not
    on it: furniture named as a place is never the answer."""
    if patch.width >= 0.8 * surface.width and patch.height >= 0.8 * surface.height:
        return False
    x = patch.horizontal_center
    return surface.left <= x <= surface.right and surface.lower <= patch.lower <= surface.upper


def on_any(patch: Patch, surfaces: Sequence[Patch]) -> bool:
    """True when the patch stands on one of the surfaces."""
    for surface in surfaces:
        if on_surface(patch, surface):
            return True
    return False


def on_level(patch: Patch, shelf: Patch, level: str) -> bool:
    """True when the patch stands on that board ("top" or "bottom") of a shelf it stands on: the top board is
    the upper edge of the shelf's box, a lower board about half way down, so a foot in the upper third of the
    box is on the top board (y grows upward)."""
    depth = (shelf.upper - patch.lower) / max(shelf.height, 1.0)
    return depth < 1 / 3 if level == "top" else depth >= 1 / 3


def on_side(patch: Patch, side: str, whole: Patch) -> bool:
    """True when the patch's centre lies in that half ("left", "right", "top" or "bottom") of `whole`: the
    picture, or the surface it stands on (y grows upward)."""
    if side == "left":
        return patch.horizontal_center < whole.horizontal_center
    if side == "right":
        return patch.horizontal_center > whole.horizontal_center
    if side == "top":
        return patch.vertical_center > whole.vertical_center
    return patch.vertical_center < whole.vertical_center


def bring(robot: Robot, patch: Patch) -> Patch:
    """Go to the chosen object, pick it up and hold it: the request is done, and the answer names it."""
    robot.go_to_object(patch)
    robot.pick_up(patch)
    return patch


def put_it_on(robot: Robot, patch: Patch, target: Patch) -> Patch:
    """Go to the chosen object, pick it up and put it on the target; the answer names the object."""
    robot.go_to_object(patch)
    robot.pick_up(patch)
    robot.put_on(target)
    return patch


def same_box(first: Patch, second: Patch) -> bool:
    """Whether two patches box the same object: their boxes overlap by at least 80% of their union."""
    width = min(first.right, second.right) - max(first.left, second.left)
    height = min(first.upper, second.upper) - max(first.lower, second.lower)
    if width <= 0 or height <= 0:
        return False
    common = width * height
    return common >= 0.8 * (first.area + second.area - common)


@cache
def source(name: str) -> str:
    """The source of the helper `name` as a program defines it: the code above, annotations dropped."""
    import ast
    import inspect

    if name not in __all__ or name == "source":
        raise KeyError(f"no program helper {name!r}")
    tree = ast.parse(inspect.getsource(globals()[name]))
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef):
            node.returns = None
            for arg in (*node.args.args, *node.args.kwonlyargs):
                arg.annotation = None
    return ast.unparse(tree) + "\n"
