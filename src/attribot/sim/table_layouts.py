"""The layouts of objects on one table before a fixed camera: `arrangement` (a row, a column or a grid of one
kind of object, with one odd one out) and `triplet` (three objects of clearly increasing weight).

Each object's truth carries what the layout decided: an arrangement's `row` and `col` as seen in the image
(row 0 at the top, col 0 at the left), a triplet's `weight_rank` (0 = lightest). A body whose gripper
reaches only the floor gets its triplet there (`room_layouts.floor_triplet`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from attribot.errors import InputError
from attribot.sim.catalog import Category
from attribot.sim.robot_geometry import GEOMETRY
from attribot.sim.room_layouts import floor_triplet
from attribot.sim.scene_plan import (
    LAYOUTS,
    PlacedObject,
    ScenePlan,
    SceneRequest,
    aim_head,
    camera_position,
    category_pool,
    face_towards,
    make_furniture,
    make_object,
    object_center,
    object_count,
)

__all__ = ["NoRoomOnTable", "arrangement", "triplet"]


_TABLE_FRONT = GEOMETRY.base_half[0] + 0.05  # gap between the robot and the table's near edge


_TABLE_MAX = (1.9, 1.2)  # the widest and deepest table a grid is put on (m)


class NoRoomOnTable(InputError):
    """An arrangement's objects do not fit on the largest table in the pattern asked for (three large bowls
    in a column): a generator that draws arrangements by seed takes the next seed."""


def _grid(
    objs: list[PlacedObject], rows: int, cols: int
) -> tuple[list[list[PlacedObject | None]], list[float], list[float]]:
    """Objects row-major on a grid, the width of each column and the depth of each row (m)."""
    grid = [
        [objs[r * cols + c] if r * cols + c < len(objs) else None for c in range(cols)] for r in range(rows)
    ]
    col_w = [
        max(2 * o.shape.footprint_radius for o in (grid[r][c] for r in range(rows)) if o is not None) + 0.04
        for c in range(cols)
    ]
    row_d = [
        max(
            2 * o.shape.footprint_radius + (1.2 * o.shape.height if rows > 1 else 0.0)
            for o in grid[r]
            if o is not None
        )
        + 0.04
        for r in range(rows)
    ]
    return grid, col_w, row_d


def _fits_table(objs: list[PlacedObject], rows: int, cols: int) -> bool:
    """Whether the objects fit on the largest table in `rows` x `cols`."""
    _, col_w, row_d = _grid(objs, rows, cols)
    return sum(col_w) <= _TABLE_MAX[0] and sum(row_d) <= _TABLE_MAX[1]


def _row_plan(
    rng: np.random.Generator, layout: str, objs: list[PlacedObject], rows: int, cols: int
) -> ScenePlan:
    """Put objects (row-major, row 0 farthest) on a grid centred on a table sized to fit, before the robot.

    Columns are as wide as their widest object; rows are deep enough that an object does not hide the one
    behind it from the head camera (which looks down at about 40 degrees).
    """
    grid, col_w, row_d = _grid(objs, rows, cols)
    need_w, need_d = sum(col_w), sum(row_d)
    if not _fits_table(objs, rows, cols):
        max_w, max_d = _TABLE_MAX
        raise NoRoomOnTable(
            f"{len(objs)} objects in {rows} row(s) x {cols} column(s) do not fit on the table "
            f"(need {need_w:.2f} m x {need_d:.2f} m, at most {max_w:.2f} m x {max_d:.2f} m)",
            "ask for fewer objects, or smaller categories",
        )
    depth, width = max(need_d + 0.1, 0.5), max(need_w + 0.16, 0.8)
    table = make_furniture("table", _TABLE_FRONT + depth / 2, 0.0, (depth, width, 0.72))
    robot = (0.0, float(-GEOMETRY.mast_xy[1]), 0.0)  # camera straight in front of the table's centre line
    cam = camera_position(robot)
    x_edges = table.x + need_d / 2 - np.concatenate([[0.0], np.cumsum(row_d)])  # row 0 at the far side
    y_edges = table.y + need_w / 2 - np.concatenate([[0.0], np.cumsum(col_w)])  # col 0 at the left (+y)
    for r in range(rows):
        for c in range(cols):
            o = grid[r][c]
            if o is None:
                continue
            o.x = float((x_edges[r] + x_edges[r + 1]) / 2)
            o.y = float((y_edges[c] + y_edges[c + 1]) / 2)
            o.z = table.size[2]
            o.surface = table.name
            o.extras.update(row=r, col=c)
            face_towards(o, (cam[0], cam[1]), rng, 0.25)
    centers = np.array([object_center(o) for o in objs])
    target = (centers.min(axis=0) + centers.max(axis=0)) / 2
    pan, tilt = aim_head(cam, robot[2], target)
    return ScenePlan(layout, [table], objs, robot, (pan, tilt))


def _small(c: Category) -> bool:
    return c.placement == "surface" and c.size_range_m[1] <= 0.22


@LAYOUTS.register("arrangement", aliases=("grid", "o3"))
def arrangement(rng: np.random.Generator, request: SceneRequest) -> ScenePlan:
    """Rows, columns or grids of one kind of object with one odd one out.

    Options: pattern "row" | "column" | "grid" (default: drawn), odd "category" | "size" | "color"
    (default: drawn), size_variation (default 0.08: each size within +-8% of the common size).
    """
    pattern = request.option("pattern", str(rng.choice(["row", "column", "grid"])), ("row", "column", "grid"))
    default_n = {"row": 5, "column": 3, "grid": 8}[pattern]
    n = object_count(request, default_n, 3, 20, f"an arrangement ({pattern})")
    rows, cols = _pattern_shape(pattern, n)
    pool = category_pool(request, _small)
    main = pool[int(rng.integers(len(pool)))] if not request.categories else pool[0]
    odd_kind = _odd_kind(rng, request, main)
    variation = _size_variation(request)
    lo, hi = main.size_range_m
    common = float(rng.uniform(lo, hi))
    color = str(main.colors[int(rng.integers(len(main.colors)))])
    odd_index = int(rng.integers(n))
    objs: list[PlacedObject] = []
    for i in range(n):
        size = common * (1 + float(rng.uniform(-variation, variation)))
        cat, col = main, color
        if i == odd_index:
            cat, size, col = _odd_one(rng, request, pool, odd_kind, (main, size, color), common)
        o = make_object(rng, i, cat, size=size, color=col)
        o.extras.update(odd_one_out=(i == odd_index), odd_kind=odd_kind if i == odd_index else "")
        objs.append(o)
    if not _fits_table(objs, rows, cols):
        pattern, rows, cols = _fitting_pattern(objs, pattern, "pattern" in request.options)
    return _row_plan(rng, "arrangement", objs, rows, cols)


def _odd_kind(rng: np.random.Generator, request: SceneRequest, main: Category) -> str:
    """What sets the odd one out apart (option "odd", or drawn); refused when the request cannot show it."""
    odd_kinds = ["category", "size"] + (["color"] if len(main.colors) > 1 else [])
    odd_kind: str = request.option("odd", str(rng.choice(odd_kinds)), ("category", "size", "color"))
    if request.categories and len(request.categories) > 1 and odd_kind != "category":
        raise InputError(
            f"an arrangement with odd={odd_kind} shows one category; the other "
            f"{len(request.categories) - 1} given would be ignored",
            "name one category, or add --option odd=category (the others become the odd one out)",
        )
    if odd_kind == "color" and len(main.colors) < 2:
        raise InputError(
            f"{main.name} comes in one colour only, so it cannot have an odd colour", "use odd=size"
        )
    return odd_kind


def _size_variation(request: SceneRequest) -> float:
    """The option size_variation: how far each size may differ from the common size, as a fraction."""
    variation = float(request.option("size_variation", 0.08))
    if not 0 <= variation <= 0.3:
        raise InputError(f"size_variation={variation} is out of range", "give a fraction between 0 and 0.3")
    return variation


def _odd_one(
    rng: np.random.Generator,
    request: SceneRequest,
    pool: list[Category],
    odd_kind: str,
    usual: tuple[Category, float, str],
    common: float,
) -> tuple[Category, float, str]:
    """The odd one out's category, size and colour: those of the others (`usual`) but for `odd_kind`."""
    main, size, color = usual
    if odd_kind == "size":
        return main, common * (1.6 if rng.uniform() < 0.5 else 0.6), color
    if odd_kind == "category":
        cat = _odd_category(rng, request, pool, main)
        size = float(np.clip(common, *cat.size_range_m))
        return cat, size, str(cat.colors[int(rng.integers(len(cat.colors)))])
    return main, size, str(rng.choice([c for c in main.colors if c != color]))


def _odd_category(
    rng: np.random.Generator, request: SceneRequest, pool: list[Category], main: Category
) -> Category:
    """A category other than `main` for the odd one out: from the other categories asked for, if any."""
    others = [
        c
        for c in (
            pool[1:]
            if request.categories and len(pool) > 1
            else category_pool(SceneRequest(vocabulary=request.vocabulary), _small)
        )
        if c.name != main.name
    ]
    if not others:
        raise InputError(
            f"an arrangement with odd=category needs a second category besides {main.name}",
            "use --option odd=size or odd=color, or draw from more categories",
        )
    return others[int(rng.integers(len(others)))]


_PATTERNS = ("row", "grid", "column")


def _pattern_shape(pattern: str, n: int) -> tuple[int, int]:
    """(rows, columns) of `n` objects in a row, a column or a grid."""
    if pattern == "row":
        return 1, n
    if pattern == "column":
        return n, 1
    rows = 2 if n <= 10 else 3 if n <= 15 else 4
    return rows, math.ceil(n / rows)


def _fitting_pattern(objs: list[PlacedObject], pattern: str, asked: bool) -> tuple[str, int, int]:
    """A pattern the objects fit on the table in, when the one drawn does not (a column of three large
    objects is too deep); when the pattern was asked for, an error that says what fits instead."""
    fitting = [p for p in _PATTERNS if p != pattern and _fits_table(objs, *_pattern_shape(p, len(objs)))]
    if fitting and not asked:
        return fitting[0], *_pattern_shape(fitting[0], len(objs))
    what_fits = [f"--option pattern={p}" for p in fitting]
    fewer = [k for k in range(len(objs) - 1, 2, -1) if _fits_table(objs[:k], *_pattern_shape(pattern, k))]
    if fewer:
        what_fits.append(f"--objects {fewer[0]}")
    rows, cols = _pattern_shape(pattern, len(objs))
    _, col_w, row_d = _grid(objs, rows, cols)
    raise NoRoomOnTable(
        f"{len(objs)} objects ({objs[0].category.name}) in a {pattern} ({rows} row(s) x {cols} column(s)) do "
        f"not fit on the table (need {sum(col_w):.2f} m x {sum(row_d):.2f} m, at most "
        f"{_TABLE_MAX[0]:.2f} m x {_TABLE_MAX[1]:.2f} m)",
        f"these fit: {' or '.join(what_fits)}" if what_fits else "choose a smaller category",
    )


def _triplet_ok(c: Category) -> bool:
    return c.placement == "surface" and not c.deceptive and c.size_range_m[1] <= 0.45 and c.pickable


@LAYOUTS.register("triplet", aliases=("weights",))
def triplet(rng: np.random.Generator, request: SceneRequest) -> ScenePlan:
    """Three objects of clearly increasing weight (each range entirely above the last, typical mass at
    least 3 times the last), side by side in a shuffled order."""
    object_count(request, 3, 3, 3, "a triplet")
    if request.categories:
        chosen = sorted(request.categories, key=lambda c: c.typical_mass_kg)
        if len(chosen) != 3:
            raise InputError(
                f"a triplet takes exactly 3 categories, got {len(chosen)}", "name three categories"
            )
        for a, b in zip(chosen, chosen[1:], strict=False):
            if not a.mass_range_kg[1] < b.mass_range_kg[0]:
                raise InputError(
                    f"{a.name} and {b.name} overlap in weight",
                    "choose categories of clearly different weight",
                )
    else:
        holds = request.body.holds
        ok: Callable[[Category], bool] = lambda c: _triplet_ok(c) and holds(c)  # noqa: E731
        pool = sorted(
            category_pool(SceneRequest(vocabulary=request.vocabulary), ok), key=lambda c: c.typical_mass_kg
        )
        for _ in range(1000):
            first = pool[int(rng.integers(len(pool)))]
            chosen = [first]
            while len(chosen) < 3:
                prev = chosen[-1]
                nxt = [
                    c
                    for c in pool
                    if c.mass_range_kg[0] > prev.mass_range_kg[1]
                    and c.typical_mass_kg >= 3 * prev.typical_mass_kg
                ]
                if not nxt:
                    break
                chosen.append(nxt[int(rng.integers(len(nxt)))])
            if len(chosen) == 3:
                break
        else:
            raise InputError(
                "no three catalog categories of clearly increasing weight were drawn in 1000 tries",
                "name three categories with --categories",
            )
    order = rng.permutation(3)
    objs = []
    for slot, idx in enumerate(order):
        o = make_object(rng, slot, chosen[int(idx)])
        o.extras.update(weight_rank=int(idx))
        objs.append(o)
    if request.body.on_floor:
        return floor_triplet(rng, objs, request.body)
    return _row_plan(rng, "triplet", objs, 1, 3)
