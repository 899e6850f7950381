"""Seeded scenes: a room, furniture, objects and the robot, planned by a layout.

A layout is a function `(rng, request) -> ScenePlan` registered in `LAYOUTS`. It decides everything that
is random (furniture, categories, colours, sizes, masses, positions, the robot's pose and head angles)
from one `numpy.random.Generator` seeded with the scene's seed, so the same layout and seed give the same
plan, the same model and the same pixels. `attribot.sim.model.build_model(plan)` turns a plan into a
compiled `MjModel`; this module imports no MuJoCo, so that a `SceneConfig` is checked against the layouts
(`check_request`, run by its validator) without loading the simulator.

Layouts (the stand-ins for the paper's experiments):
- `arrangement`: a row, a column or a grid of the same kind of object on a table, with controlled size
  variation and one odd one out (another category, size or colour), seen from a fixed camera. Each
  object's truth carries its `row` and `col` as seen in the image (row 0 at the top, col 0 at the left).
- `triplet`: three objects of clearly increasing weight side by side on a table, in a shuffled order;
  the truth carries each object's `weight_rank` (0 = lightest).
- `household`: a room with two or three pieces of furniture and 2 to 6 candidate objects at different
  distances from the robot, all in the robot camera's first view.

The robot is the mast robot (`attribot.sim.robot`) unless the request names another registered body
(`attribot.sim.bodies`). A body whose gripper reaches only the floor (the RoboMaster-EP-like one,
`SceneRequest(robot="ep")`) gets `household` and `triplet` scenes with the candidates on the floor, ones
its gripper can hold, where it can drive straight to each (it has no depth camera to see its way); a layout
not made for it (`arrangement`, a grid seen from above) is refused. The other layouts are drawn for the
mast robot's head and camera.

Objects rest on their surface: each is placed with its lowest point on the surface, without overlapping
another object's footprint, and the world lets them settle before the first frame.

What no camera sees is drawn after the layout, from a generator of its own (so that a layout's draws, and
every scene planned before these states existed, stay as they were): the room's temperature and each
object's temperature, stiffness and, for a container, how full it is (its mass is then its empty mass plus
its contents). See `attribot.sim.catalog` for the states each category can be in.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from attribot.config import MAX_OBJECTS, MAX_SEED, SCENE_CHECKS, SceneConfig
from attribot.errors import InputError
from attribot.lexicon import temperature_state
from attribot.registry import Registry
from attribot.sim.bodies import SimBody, body_named
from attribot.sim.catalog import (
    RIGID_N_PER_MM,
    ROOM_TEMPERATURE_C,
    Category,
    categories,
    get_category,
)
from attribot.sim.robot_geometry import GEOMETRY
from attribot.sim.shapes import Shape, build_shape

__all__ = [
    "Surface",
    "Furniture",
    "PlacedObject",
    "ScenePlan",
    "SceneRequest",
    "LAYOUTS",
    "plan_scene",
    "check_request",
    "scene_request",
    "NoRoomOnTable",
    "MAX_OBJECTS",
    "LAYOUT_OPTIONS",
    "check_seed",
    "resolve_categories",
    "camera_position",
    "object_center",
]

ROOM_HALF = 3.0  # the room is 6 m x 6 m, centred on the origin
WALL_HEIGHT = 2.4


@dataclass(frozen=True)
class Surface:
    """An axis-aligned rectangle at height z on which objects can rest; `avoid` are rectangles to keep off."""

    name: str
    x0: float
    y0: float
    x1: float
    y1: float
    z: float
    avoid: tuple[tuple[float, float, float, float], ...] = ()


@dataclass(frozen=True)
class Furniture:
    """A table, counter, coffee table or shelf: centre (x, y), size (depth x, width y, height), colour."""

    kind: str
    name: str
    x: float
    y: float
    size: tuple[float, float, float]
    rgba: tuple[float, float, float, float]

    def footprint(self, margin: float = 0.0) -> tuple[float, float, float, float]:
        dx, dy = self.size[0] / 2 + margin, self.size[1] / 2 + margin
        return (self.x - dx, self.y - dy, self.x + dx, self.y + dy)

    def surfaces(self) -> list[Surface]:
        x0, y0, x1, y1 = self.footprint(-0.03)
        top = Surface(f"{self.name}", x0, y0, x1, y1, self.size[2])
        if self.kind == "shelf":
            return [top, Surface(f"{self.name}_low", x0, y0, x1, y1, SHELF_LOW)]
        return [top]


SHELF_LOW = 0.42
"""The height of a shelf's lower board (m)."""


@dataclass
class PlacedObject:
    """One object of a plan: what it is, how it looks, its hidden mass, and where it rests."""

    key: int
    id: str
    category: Category
    color: str
    size_m: float
    mass_kg: float
    variant: str
    shape: Shape
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0  # height of the surface it rests on
    yaw: float = 0.0
    surface: str = ""
    extras: dict[str, Any] = field(default_factory=dict)
    mass_share: float = 0.5  # where in its (variant's) mass range the mass was drawn, 0 to 1
    temperature_c: float = 21.0  # what an infrared thermometer reads on its surface
    thermal: str = "room"  # the word for its temperature (lexicon.temperature_state): hot, cold, room...
    stiffness_n_per_mm: float = RIGID_N_PER_MM  # force per millimetre of gripper closure
    softness: str = "rigid"  # its softness state ("soft", "firm", "hard", "rigid")
    fill: float | None = None  # a container's contents, as a share of its capacity (None: no container)


@dataclass
class ScenePlan:
    """Everything random about a scene, decided by a layout from the seed."""

    layout: str
    furniture: list[Furniture]
    objects: list[PlacedObject]
    robot: tuple[float, float, float]  # base x, y, yaw
    head: tuple[float, float]  # pan, tilt
    seed: int = 0  # set by plan_scene, the one place that knows it (a layout sees only its generator)
    arm: tuple[float, float] = (0.2, 0.0)  # lift, extension: low and retracted, out of the camera's way
    width: int = 640
    height: int = 480
    robot_kind: str = (
        "mast"  # the robot body's name (`attribot.sim.bodies`), set by plan_scene from the request
    )
    room_temperature_c: float = 21.0


@dataclass(frozen=True)
class SceneRequest:
    """What the caller asked for: object count, categories (None: the layout chooses), layout options, the
    robot body's name (`attribot.sim.bodies`: "mast" or "ep"), and the vocabulary: the names of the only
    categories the layout may draw from (None: every category it draws), its own rules (pickable, small
    enough) applied within them."""

    n_objects: int | None = None
    categories: tuple[Category, ...] | None = None
    options: dict[str, Any] = field(default_factory=dict)
    robot: str = "mast"
    vocabulary: frozenset[str] | None = None

    def drawable(self, cat: Category) -> bool:
        """Whether the layout may draw `cat` unasked: a category layouts draw, within the vocabulary."""
        return cat.drawn and (self.vocabulary is None or cat.name in self.vocabulary)

    @property
    def body(self) -> SimBody:
        """The robot body the scene is drawn for."""
        return body_named(self.robot)

    def option(self, name: str, default: Any, choices: Sequence[Any] | None = None) -> Any:
        value = self.options.get(name, default)
        if choices is not None and value not in choices:
            raise InputError(
                f"layout option {name}={value!r} is not allowed",
                f"choose one of: {', '.join(map(str, choices))}",
            )
        return value


Layout = Callable[[np.random.Generator, SceneRequest], ScenePlan]
LAYOUTS: Registry[Layout] = Registry("layout")


# --- helpers ------------------------------------------------------------------------------------------


def _make_object(
    rng: np.random.Generator,
    key: int,
    cat: Category,
    *,
    size: float | None = None,
    color: str | None = None,
    variant: str | None = None,
) -> PlacedObject:
    lo, hi = cat.size_range_m
    if size is None:
        size = float(rng.uniform(lo, hi))
    frac = 0.5 if hi <= lo else min(max((size - lo) / (hi - lo), 0.0), 1.0)
    if color is None:
        color = str(cat.colors[int(rng.integers(len(cat.colors)))])
    if cat.mass_variants:
        names = [v[0] for v in cat.mass_variants]
        if variant is None:
            variant = names[int(rng.integers(len(names)))]
        mlo, mhi = dict(cat.mass_variants)[variant]
    else:
        variant = ""
        mlo, mhi = cat.mass_range_kg
    # bigger objects of a kind tend to be heavier, with some spread
    u = 0.6 * frac + 0.4 * float(rng.uniform())
    mass = round(mlo + (mhi - mlo) * u, 4)
    obj_id = f"{cat.name.replace(' ', '_')}_{key}"
    placed = PlacedObject(
        key, obj_id, cat, color, round(size, 4), mass, variant, build_shape(cat.shape, size)
    )
    placed.mass_share = u
    return placed


def _pick(rng: np.random.Generator, states: Sequence[tuple[str, Any]]) -> tuple[str, Any]:
    """One of `states`, equally likely; one draw whatever their number."""
    u = float(rng.uniform())
    return states[min(int(u * len(states)), len(states) - 1)]


def _draw_hidden_states(plan: ScenePlan, seed: int, attempt: int) -> None:
    """The room's temperature, and each object's temperature, stiffness and fill (see the module docstring),
    from generators of their own: one for the room, one per object, so that an object's states do not
    depend on the others'."""
    room = float(np.random.default_rng([seed, attempt, 0x7E3]).uniform(*ROOM_TEMPERATURE_C))
    plan.room_temperature_c = round(room, 2)
    for o in plan.objects:
        rng = np.random.default_rng([seed, attempt, o.key, 0x7E3])
        cat = o.category
        _, span = _pick(rng, cat.temperatures) if cat.temperatures else ("room", None)
        near_room = room + float(rng.normal(0.0, 0.3))  # drawn always: the next draws keep their place
        o.temperature_c = round(float(rng.uniform(*span)) if span is not None else near_room, 2)
        # its word by the thresholds the planner reads, not the state's name: a kettle not switched on
        # is at the room's temperature, never "cold"
        o.thermal = temperature_state(o.temperature_c)
        o.softness, stiff = _pick(rng, cat.stiffness) if cat.stiffness else ("rigid", None)
        share = float(rng.uniform())
        o.stiffness_n_per_mm = (
            RIGID_N_PER_MM if stiff is None else round(stiff[0] + (stiff[1] - stiff[0]) * share, 3)
        )
        if not cat.container or cat.empty_kg is None:
            continue
        if cat.mass_variants:  # its mass variant is how full it is (a jar drawn "full")
            o.fill = 1.0 if o.variant == "full" else 0.0
            continue
        _, o.fill = _pick(rng, cat.fill_states)
        if plan.layout == "triplet":  # its weights rise with the category by construction: kept empty
            o.fill = 0.0
        lo, hi = cat.empty_kg
        o.mass_kg = round(lo + (hi - lo) * o.mass_share + o.fill * cat.capacity_kg, 4)


def _face(obj: PlacedObject, towards: tuple[float, float], rng: np.random.Generator, jitter: float) -> None:
    """Turn the object so that its front (-x side) faces the point `towards`, with some random yaw."""
    ang = math.atan2(towards[1] - obj.y, towards[0] - obj.x)
    obj.yaw = float(ang + math.pi + rng.uniform(-jitter, jitter))


def _fits(
    x: float, y: float, r: float, surface: Surface, placed: list[tuple[float, float, float]], gap: float
) -> bool:
    if not (surface.x0 + r <= x <= surface.x1 - r and surface.y0 + r <= y <= surface.y1 - r):
        return False
    for ax0, ay0, ax1, ay1 in surface.avoid:
        if ax0 - r < x < ax1 + r and ay0 - r < y < ay1 + r:
            return False
    return all(math.hypot(x - px, y - py) >= r + pr + gap for px, py, pr in placed)


def _pool(request: SceneRequest, predicate: Callable[[Category], bool]) -> list[Category]:
    if request.categories:
        pool = list(request.categories)
    else:
        pool = [c for c in categories() if request.drawable(c) and predicate(c)]
    if not pool:
        if request.vocabulary is not None and not request.categories:
            names = sorted(request.vocabulary)
            raise InputError(
                f"none of the {len(names)} categories this scene may draw from fits this layout "
                f"({', '.join(names[:6])}{', ...' if len(names) > 6 else ''})",
                "choose another layout, or draw from more categories",
            )
        raise InputError("no object category fits this layout", "choose other categories")
    return pool


def _aim(cam: np.ndarray, base_yaw: float, target: np.ndarray) -> tuple[float, float]:
    """Head (pan, tilt) that points the optical axis from `cam` at `target`."""
    d = target - cam
    pan = math.remainder(math.atan2(d[1], d[0]) - base_yaw, math.tau)
    tilt = math.atan2(d[2], math.hypot(d[0], d[1]))
    lo, hi = GEOMETRY.tilt_range
    return pan, min(max(tilt, lo), hi)


def camera_position(robot: tuple[float, float, float]) -> np.ndarray:
    """World position of the optical centre for a base pose (it sits on the pan/tilt axes)."""
    x, y, yaw = robot
    mx, my = GEOMETRY.mast_xy
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([x + c * mx - s * my, y + s * mx + c * my, GEOMETRY.head_height])


def object_center(obj: PlacedObject) -> np.ndarray:
    """World position of the centre of the object's bounding box as planned."""
    lo, hi = np.asarray(obj.shape.lo), np.asarray(obj.shape.hi)
    c = (lo + hi) / 2
    cy, sy = math.cos(obj.yaw), math.sin(obj.yaw)
    return np.array([obj.x + cy * c[0] - sy * c[1], obj.y + sy * c[0] + cy * c[1], obj.z - lo[2] + c[2]])


def _table(name: str, x: float, y: float, size: tuple[float, float, float], kind: str = "table") -> Furniture:
    colors = {
        "table": (0.62, 0.45, 0.30, 1),
        "counter": (0.85, 0.84, 0.80, 1),
        "coffee_table": (0.40, 0.28, 0.18, 1),
        "shelf": (0.70, 0.55, 0.38, 1),
    }
    return Furniture(kind, name, x, y, size, colors[kind])


def _apparent_pixels(o: PlacedObject, cam: np.ndarray) -> float:
    """Rough visible area of an object, in pixels of a 320x240 image, seen from `cam` (top and front)."""
    lx, ly, lz = np.asarray(o.shape.hi) - np.asarray(o.shape.lo)
    c = object_center(o)
    d = float(np.linalg.norm(c - cam))
    elev = math.asin(min(abs(cam[2] - c[2]) / d, 1.0))
    area = lx * ly * math.sin(elev) + max(lx, ly) * lz * math.cos(elev)
    f = 120 / math.tan(math.radians(GEOMETRY.fovy_deg) / 2)
    return 0.7 * area / d**2 * f**2


def _gap(a: Furniture, b: Furniture) -> float:
    """Free distance between two pieces of furniture along the axis where they are farthest apart."""
    ax0, ay0, ax1, ay1 = a.footprint()
    bx0, by0, bx1, by1 = b.footprint()
    return max(bx0 - ax1, ax0 - bx1, by0 - ay1, ay0 - by1)


def _count(request: SceneRequest, default: int, lo: int, hi: int, what: str) -> int:
    n = default if request.n_objects is None else request.n_objects
    if not lo <= n <= hi:
        if lo == hi:
            raise InputError(f"{what} takes exactly {lo} objects, not {n}", "leave out --objects")
        raise InputError(
            f"{what} takes {lo} to {hi} objects, not {n}", f"ask for between {lo} and {hi} objects"
        )
    return n


# --- arrangement and triplet: objects on one table in front of a fixed camera -------------------------

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
    table = _table("table", _TABLE_FRONT + depth / 2, 0.0, (depth, width, 0.72))
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
            _face(o, (cam[0], cam[1]), rng, 0.25)
    centers = np.array([object_center(o) for o in objs])
    target = (centers.min(axis=0) + centers.max(axis=0)) / 2
    pan, tilt = _aim(cam, robot[2], target)
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
    n = _count(request, default_n, 3, 20, f"an arrangement ({pattern})")
    rows, cols = _pattern_shape(pattern, n)
    pool = _pool(request, _small)
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
        o = _make_object(rng, i, cat, size=size, color=col)
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
            else _pool(SceneRequest(vocabulary=request.vocabulary), _small)
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
    _count(request, 3, 3, 3, "a triplet")
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
        pool = sorted(_pool(SceneRequest(vocabulary=request.vocabulary), ok), key=lambda c: c.typical_mass_kg)
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
        o = _make_object(rng, slot, chosen[int(idx)])
        o.extras.update(weight_rank=int(idx))
        objs.append(o)
    if request.body.on_floor:
        return _floor_triplet(rng, objs, request.body)
    return _row_plan(rng, "triplet", objs, 1, 3)


# --- household: furniture around the room, candidates at different distances ---------------------------


@LAYOUTS.register("household", aliases=("room",))
def household(rng: np.random.Generator, request: SceneRequest) -> ScenePlan:
    """A room with 2-3 pieces of furniture and 2-6 candidate objects (up to 12 on request) at distances
    from the robot that differ by at least `min_gap` metres (option, default 0.15)."""
    if request.body.on_floor:
        return _floor_household(rng, request)
    n = _count(request, int(rng.integers(2, 7)), 1, 12, "a household scene")
    min_gap = float(request.option("min_gap", 0.15))
    robot = _robot_start(rng)
    cam = camera_position(robot)
    furniture = _household_furniture(rng, robot[0], robot[1])
    surfaces = [s for f in furniture for s in f.surfaces()]
    floor = _standing_floor(robot[0], furniture)
    picks = _draw_categories(rng, _pool(request, lambda c: c.pickable), n)
    objs = [_make_object(rng, i, c) for i, c in enumerate(picks)]
    placed: dict[str, list[tuple[float, float, float]]] = {}
    dists: list[float] = []
    for o in objs:
        choices = [floor] if o.category.placement == "floor" else surfaces
        if not _place_in_view(rng, o, choices, robot, cam, placed, dists, min_gap):
            raise InputError(
                f"cannot place {n} objects in a household scene with distances {min_gap} m apart "
                f"(object {o.key}, a {o.category.name}, found no free spot)",
                "ask for fewer objects, smaller categories, or a smaller min_gap",
            )
    return ScenePlan("household", furniture, objs, robot, _household_head(cam, robot, objs))


def _robot_start(rng: np.random.Generator) -> tuple[float, float, float]:
    """The base pose (x, y, yaw) a household scene starts the robot at: the back of the room, facing +x."""
    return (
        -2.0 + float(rng.uniform(-0.2, 0.2)),
        float(rng.uniform(-0.3, 0.3)),
        float(rng.uniform(-0.12, 0.12)),
    )


def _household_furniture(rng: np.random.Generator, rx: float, ry: float) -> list[Furniture]:
    """Two or three pieces of furniture before the robot at (rx, ry), with room to drive between them."""
    for _ in range(200):
        furniture = _draw_furniture(rng, rx, ry)
        if _room_to_drive(furniture):
            return furniture
    # never seen: each draw fits about half the time
    raise InputError("no furniture layout with room to drive fits in 200 draws", "try another seed")


def _draw_furniture(rng: np.random.Generator, rx: float, ry: float) -> list[Furniture]:
    """A coffee table, a table to one side and a counter or shelf at the back; two or three of them."""
    slots = [
        ("coffee_table", (rx + rng.uniform(0.85, 1.0), ry + rng.uniform(-0.25, 0.25)), (0.45, 0.8, 0.45)),
        (
            "table",
            (rx + rng.uniform(1.55, 1.9), ry + rng.choice([-1, 1]) * rng.uniform(0.85, 1.1)),
            (0.7, 0.9, 0.75),
        ),
        (
            str(rng.choice(["counter", "shelf"])),
            (rx + rng.uniform(2.3, 2.6), ry + rng.uniform(-0.5, 0.5)),
            (0.45, 1.2, 0.9),
        ),
    ]
    keep = sorted(rng.choice(3, size=int(rng.integers(2, 4)), replace=False).tolist())
    return [
        _table(f"{kind}_{i}", float(x), float(y), size, kind)
        for i, (kind, (x, y), size) in enumerate(slots)
        if i in keep
    ]


def _room_to_drive(furniture: list[Furniture]) -> bool:
    """Whether the pieces stand 0.6 m apart and 0.6 m off the walls."""
    return all(_gap(a, b) >= 0.6 for i, a in enumerate(furniture) for b in furniture[i + 1 :]) and all(
        max(abs(v) for v in f.footprint()) < ROOM_HALF - 0.6 for f in furniture
    )


def _standing_floor(rx: float, furniture: list[Furniture]) -> Surface:
    """The floor before the robot at x `rx`, off the standing room at each piece of furniture."""
    return Surface(
        "floor",
        rx + 0.75,
        -ROOM_HALF + 0.3,
        ROOM_HALF - 0.3,
        ROOM_HALF - 0.3,
        0.0,
        tuple(f.footprint(0.55) for f in furniture),
    )


def _draw_categories(rng: np.random.Generator, pool: list[Category], n: int) -> list[Category]:
    """`n` categories from `pool`: each once in a shuffled order while the pool has enough, else drawn."""
    order = rng.permutation(len(pool)).tolist()
    return [
        pool[order[i % len(pool)]] if len(pool) >= n else pool[int(rng.integers(len(pool)))] for i in range(n)
    ]


def _place_in_view(
    rng: np.random.Generator,
    o: PlacedObject,
    choices: list[Surface],
    robot: tuple[float, float, float],
    cam: np.ndarray,
    placed: dict[str, list[tuple[float, float, float]]],
    dists: list[float],
    min_gap: float,
) -> bool:
    """Put `o` at a free spot on one of `choices`, in the first view and at a distance from the camera
    `min_gap` off the others' (`dists`); record it in `placed` and `dists`. False when 400 draws find none."""
    r = o.shape.footprint_radius
    for _ in range(400):
        s = choices[int(rng.integers(len(choices)))]
        x, y = _draw_spot(rng, s, robot)
        if not _fits(x, y, r, s, placed.get(s.name, []), 0.04):
            continue
        o.x, o.y, o.z, o.surface = x, y, s.z, s.name
        _face(o, (cam[0], cam[1]), rng, 0.4)
        d = _distance_in_view(o, s, robot, cam, dists, min_gap)
        if d is None:
            continue
        placed.setdefault(s.name, []).append((x, y, r))
        dists.append(d)
        return True
    return False


def _draw_spot(
    rng: np.random.Generator, s: Surface, robot: tuple[float, float, float]
) -> tuple[float, float]:
    """A point on `s`; on the floor, one in front of the robot and within view."""
    rx = robot[0]
    if s.name == "floor":
        x = float(rng.uniform(rx + 0.9, rx + 2.8))
        return x, float(robot[1] + rng.uniform(-0.9, 0.9) * (x - rx) * 0.45)
    return float(rng.uniform(s.x0, s.x1)), float(rng.uniform(s.y0, s.y1))


def _distance_in_view(
    o: PlacedObject,
    s: Surface,
    robot: tuple[float, float, float],
    cam: np.ndarray,
    dists: list[float],
    min_gap: float,
) -> float | None:
    """The camera's distance to `o` as placed on `s`, or None where it does not do: too tall for a lower
    shelf, within `min_gap` of another candidate's distance, too small to see, or out of the field of view."""
    # lower shelf: keep objects short enough to stand under the top board
    if s.name.endswith("_low") and o.shape.height - o.shape.lo[2] > 0.9 - SHELF_LOW - 0.16:
        return None
    d = float(np.linalg.norm(object_center(o) - cam))
    if any(abs(d - e) < min_gap for e in dists):
        return None
    # big enough to see from here, whatever the image size: thin things (pencils) stay near
    if _apparent_pixels(o, cam) < 60:
        return None
    # in the horizontal field of view of a head turned towards the candidates' middle
    half_h = math.radians(GEOMETRY.fovy_deg) / 2
    if abs(math.remainder(math.atan2(o.y - robot[1], o.x - robot[0]) - robot[2], math.tau)) > half_h * 1.1:
        return None
    return d


def _household_head(
    cam: np.ndarray, robot: tuple[float, float, float], objs: list[PlacedObject]
) -> tuple[float, float]:
    """Head (pan, tilt) towards the candidates' middle, tilted so the nearest and farthest are in view."""
    centers = np.array([object_center(o) for o in objs])
    lo, hi = centers.min(axis=0), centers.max(axis=0)
    pan, _ = _aim(cam, robot[2], (lo + hi) / 2)
    tilts = [math.atan2(c[2] - cam[2], math.hypot(c[0] - cam[0], c[1] - cam[1])) for c in centers]
    return pan, float(np.clip((min(tilts) + max(tilts)) / 2, *GEOMETRY.tilt_range))


# --- a body whose gripper reaches only the floor (the RoboMaster-EP-like robot): candidates there ------


def _corridor(body: SimBody) -> float:
    """Half the width the base sweeps driving straight, with a margin."""
    return body.geometry.base_half[1] + 0.06


def _floor_camera(robot: tuple[float, float, float], body: SimBody) -> np.ndarray:
    """World position of the body's camera with its arm at rest, for a base pose."""
    x, y, yaw = robot
    cx, cy, cz = body.geometry.camera_xyz
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([x + c * cx - s * cy, y + s * cx + c * cy, cz])


def _off_line(p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    """Distance from point p to the segment a-b."""
    ab = np.subtract(b, a)
    t = float(np.clip(np.dot(np.subtract(p, a), ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0))
    return float(np.hypot(*(np.subtract(p, a) - t * ab)))


def _floor_triplet(rng: np.random.Generator, objs: list[PlacedObject], body: SimBody) -> ScenePlan:
    """Three objects on the floor 0.8 m before the robot, 26 degrees apart (left to right in their order):
    the way to each passes clear of the others."""
    robot = (0.0, 0.0, 0.0)
    cam = _floor_camera(robot, body)
    for o, bearing in zip(objs, (0.45, 0.0, -0.45), strict=True):
        o.x, o.y, o.z, o.surface = 0.8 * math.cos(bearing), 0.8 * math.sin(bearing), 0.0, "floor"
        _face(o, (cam[0], cam[1]), rng, 0.25)
    return ScenePlan("triplet", [], objs, robot, (0.0, 0.0))


def _floor_household(rng: np.random.Generator, request: SceneRequest) -> ScenePlan:
    """A room with a table to one side and a counter or shelf at the back, and 2 to 4 candidates (up to 6
    on request) on the floor between them and the robot, at distances that differ by at least `min_gap`,
    each with a straight way to it that passes clear of the others."""
    body = request.body
    n = _count(request, int(rng.integers(2, 5)), 1, 6, f"a household scene for {body.called}")
    min_gap = float(request.option("min_gap", 0.15))
    robot = _robot_start(rng)
    rx, ry, _ = robot
    back = str(rng.choice(["counter", "shelf"]))
    side = float(rng.choice([-1.0, 1.0]))
    table_xy = rx + float(rng.uniform(1.5, 1.8)), ry + side * float(rng.uniform(1.1, 1.3))
    back_xy = rx + float(rng.uniform(2.6, 2.8)), ry + float(rng.uniform(-0.4, 0.4))
    furniture = [
        _table("table_0", *table_xy, (0.7, 0.9, 0.75)),
        _table(f"{back}_1", *back_xy, (0.45, 1.2, 0.9), back),
    ]
    picks = _draw_categories(rng, _pool(request, body.holds), n)
    objs = [_make_object(rng, i, c) for i, c in enumerate(picks)]
    cam = _floor_camera(robot, body)
    placed: list[tuple[float, float, float]] = []
    dists: list[float] = []
    for o in objs:
        r = o.shape.footprint_radius
        for _ in range(400):
            x = rx + float(rng.uniform(0.7, 1.9))
            y = ry + float(rng.uniform(-1.0, 1.0)) * (x - rx) * 0.45
            if not _floor_spot_free(x, y, r, furniture, placed, (rx, ry), _corridor(body)):
                continue
            o.x, o.y, o.z, o.surface = x, y, 0.0, "floor"
            _face(o, (cam[0], cam[1]), rng, 0.4)
            d = float(np.linalg.norm(object_center(o) - cam))
            if any(abs(d - e) < min_gap for e in dists):
                continue
            placed.append((x, y, r))
            dists.append(d)
            break
        else:
            raise InputError(
                f"cannot place {n} objects on the floor for {body.called} with distances {min_gap} m "
                f"apart and a clear way to each (object {o.key}, a {o.category.name}, found no free spot)",
                "ask for fewer objects, or a smaller min_gap",
            )
    return ScenePlan("household", furniture, objs, robot, (0.0, 0.0))


def _floor_spot_free(
    x: float,
    y: float,
    r: float,
    furniture: list[Furniture],
    placed: list[tuple[float, float, float]],
    start: tuple[float, float],
    corridor: float,
) -> bool:
    """Whether an object of radius r at (x, y) keeps off the furniture and the others, off the ways to
    them, and leaves its own way clear of them."""
    for f in furniture:
        x0, y0, x1, y1 = f.footprint(0.45 + r)
        if x0 < x < x1 and y0 < y < y1:
            return False
    for px, py, pr in placed:
        if math.hypot(x - px, y - py) < r + pr + 0.2:
            return False
        if (
            _off_line((x, y), start, (px, py)) < corridor + r
            or _off_line((px, py), start, (x, y)) < corridor + pr
        ):
            return False
    return True


LAYOUT_OPTIONS: dict[str, tuple[str, ...]] = {
    "arrangement": ("pattern", "odd", "size_variation"),
    "triplet": (),
    "household": ("min_gap",),
}
"""The `--option` names each layout reads (by its function's name); any other is refused."""


def check_seed(seed: object) -> int:
    """`seed` as an int when it is a whole number from 0 to 2**32 - 1; otherwise an InputError."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed <= MAX_SEED:
        raise InputError(f"seed {seed!r} is not valid", "give a whole number between 0 and 4294967295")
    return int(seed)


def check_request(layout: str, req: SceneRequest) -> None:
    """Refuse a request `layout` cannot draw, naming the fix: too few objects, an option the layout does not
    read, a layout not made for the robot's body, a category its gripper cannot hold, or one outside the
    vocabulary. `SceneConfig`'s validator and `plan_scene` both ask it."""
    fn = LAYOUTS.get(layout)
    if req.n_objects is not None and req.n_objects < 1:  # the upper bound is each layout's own
        raise InputError(f"{req.n_objects} objects requested", "ask for at least 1 object")
    known = LAYOUT_OPTIONS.get(fn.__name__, ())
    unknown = sorted(set(req.options) - set(known))
    if unknown:
        raise InputError(
            f"the {fn.__name__} layout has no option {', '.join(unknown)} (it would be ignored)",
            f"its options are: {', '.join(known)}" if known else "it takes no --option",
        )
    body = req.body
    if body.layouts is not None and fn.__name__ not in body.layouts:
        raise InputError(
            f"the {fn.__name__} layout is not made for {body.called} ({body.layouts_why})",
            f"use the {' or '.join(body.layouts)} layout with {body.called}",
        )
    unfit = [c.name for c in req.categories or () if not body.holds(c)]
    if unfit:
        raise InputError(f"{body.called}'s gripper cannot hold {', '.join(unfit)}", body.holds_fix)
    if req.vocabulary is not None:
        outside = [c.name for c in req.categories or () if c.name not in req.vocabulary]
        if outside:
            raise InputError(
                f"{', '.join(outside)} is not among the categories this scene may draw from",
                "leave it out of the categories, or draw from a vocabulary that holds it",
            )


def scene_request(config: SceneConfig) -> SceneRequest:
    """What `config` asks of the scene's layout."""
    vocabulary = config.vocabulary
    return SceneRequest(
        config.objects,
        resolve_categories(config.categories),
        dict(config.options),
        config.robot,
        None if vocabulary is None else frozenset(c.name for c in resolve_categories(vocabulary) or ()),
    )


@SCENE_CHECKS.register("drawable")
def _drawable(config: SceneConfig) -> None:
    """A config whose layout cannot draw what it asks (`check_request`) is refused as it is made: the check
    lives here, with the layouts, so that making a config imports no more of the simulator than them."""
    check_request(config.layout, scene_request(config))


def plan_scene(layout: str, seed: int, request: SceneRequest | None = None, attempt: int = 0) -> ScenePlan:
    """The plan of `layout` for `seed` (and `attempt`, for layouts whose plans can be rejected and redrawn):
    same arguments, same plan."""
    check_seed(seed)
    fn = LAYOUTS.get(layout)
    req = request or SceneRequest()
    check_request(layout, req)
    rng = np.random.default_rng(int(seed) if attempt == 0 else [int(seed), int(attempt)])
    plan = fn(rng, req)
    plan.seed = int(seed)
    plan.robot_kind = req.robot
    _draw_hidden_states(plan, int(seed), int(attempt))
    return plan


CROWDED_MIN_GAP = 0.08
"""The spacing of the candidates' distances (m) a household scene falls back to when none of its attempts
places them at the default one: a crowded request of small objects ("three cans") fits only closer together,
on the one table near enough for them to be seen (the spacing the benchmarks' household scenes ask for)."""


def scene_requests(layout: str, request: SceneRequest, attempts: int) -> Iterator[tuple[int, SceneRequest]]:
    """The (attempt, request) pairs a world tries in turn for one seed: the request as asked, then, for a
    household scene whose `min_gap` was not asked for, the same with `CROWDED_MIN_GAP` (so that every seed
    that was placed at the default spacing keeps its scene)."""
    for attempt in range(attempts):
        yield attempt, request
    if LAYOUTS.get(layout) is LAYOUTS.get("household") and "min_gap" not in request.options:
        crowded = replace(request, options={**request.options, "min_gap": CROWDED_MIN_GAP})
        for attempt in range(attempts, 2 * attempts):
            yield attempt, crowded


def what_fits(layout: str, seed: int, request: SceneRequest, attempts: int) -> str:
    """The fix for a request no attempt could place: how many of its objects do fit on this seed, or that
    smaller categories are needed."""
    n = request.n_objects or len(request.categories or ())
    spacing = request.options.get("min_gap", CROWDED_MIN_GAP)
    for k in range(n - 1, 0, -1):
        fewer = replace(
            request,
            n_objects=k,
            categories=request.categories[:k] if request.categories else None,
            options={**request.options, "min_gap": spacing},
        )
        for attempt in range(attempts):
            try:
                plan_scene(layout, seed, fewer, attempt)
            except InputError:
                continue
            return (
                f"at most {k} of these can be placed on seed {seed}: ask for {k} (--objects {k}) or smaller"
            )
    return "none of these objects fits in view on a surface of this layout: choose smaller categories"


def resolve_categories(names: Sequence[str] | None) -> tuple[Category, ...] | None:
    """Categories for names (UnknownName for an unknown one); None stays None."""
    if names is None:
        return None
    cats = tuple(get_category(n) for n in names)
    return cats or None
