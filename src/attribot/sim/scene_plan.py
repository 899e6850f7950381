"""What a scene plan is, and what every layout draws it with.

A plan (`ScenePlan`) holds everything random about a scene: its furniture and the `Surface`s they offer,
its objects (`PlacedObject`: category, colour, size, hidden mass, where it rests) and the robot's pose. A
layout (`LAYOUTS`: `table_layouts.py`, `room_layouts.py`) draws one from a generator and a `SceneRequest`;
`scene.plan_scene` runs it. The helpers below are the steps layouts share: drawing an object of a category,
fitting it on a surface, aiming the head, sizing what the camera sees.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from attribot.errors import InputError
from attribot.registry import Registry
from attribot.sim.bodies import SimBody, body_named
from attribot.sim.catalog import RIGID_N_PER_MM, Category, categories
from attribot.sim.robot_geometry import GEOMETRY
from attribot.sim.shapes import Shape, build_shape

__all__ = [
    "ROOM_HALF",
    "WALL_HEIGHT",
    "SHELF_LOW",
    "Surface",
    "Furniture",
    "PlacedObject",
    "ScenePlan",
    "SceneRequest",
    "Layout",
    "LAYOUTS",
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
LAYOUTS: Registry[Layout] = Registry(
    "layout",
    homes={
        "arrangement": "attribot.sim.table_layouts",
        "grid": "attribot.sim.table_layouts",
        "o3": "attribot.sim.table_layouts",
        "triplet": "attribot.sim.table_layouts",
        "weights": "attribot.sim.table_layouts",
        "household": "attribot.sim.room_layouts",
        "room": "attribot.sim.room_layouts",
    },
)
"""The layouts by name; a built-in one is imported when its name is first looked up."""


# --- what every layout draws with -------------------------------------------------------------------


def make_object(
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


def face_towards(
    obj: PlacedObject, towards: tuple[float, float], rng: np.random.Generator, jitter: float
) -> None:
    """Turn the object so that its front (-x side) faces the point `towards`, with some random yaw."""
    ang = math.atan2(towards[1] - obj.y, towards[0] - obj.x)
    obj.yaw = float(ang + math.pi + rng.uniform(-jitter, jitter))


def fits_on_surface(
    x: float, y: float, r: float, surface: Surface, placed: list[tuple[float, float, float]], gap: float
) -> bool:
    if not (surface.x0 + r <= x <= surface.x1 - r and surface.y0 + r <= y <= surface.y1 - r):
        return False
    for ax0, ay0, ax1, ay1 in surface.avoid:
        if ax0 - r < x < ax1 + r and ay0 - r < y < ay1 + r:
            return False
    return all(math.hypot(x - px, y - py) >= r + pr + gap for px, py, pr in placed)


def category_pool(request: SceneRequest, predicate: Callable[[Category], bool]) -> list[Category]:
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


def aim_head(cam: np.ndarray, base_yaw: float, target: np.ndarray) -> tuple[float, float]:
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


def make_furniture(
    name: str, x: float, y: float, size: tuple[float, float, float], kind: str = "table"
) -> Furniture:
    colors = {
        "table": (0.62, 0.45, 0.30, 1),
        "counter": (0.85, 0.84, 0.80, 1),
        "coffee_table": (0.40, 0.28, 0.18, 1),
        "shelf": (0.70, 0.55, 0.38, 1),
    }
    return Furniture(kind, name, x, y, size, colors[kind])


def apparent_pixels(o: PlacedObject, cam: np.ndarray) -> float:
    """Rough visible area of an object, in pixels of a 320x240 image, seen from `cam` (top and front)."""
    lx, ly, lz = np.asarray(o.shape.hi) - np.asarray(o.shape.lo)
    c = object_center(o)
    d = float(np.linalg.norm(c - cam))
    elev = math.asin(min(abs(cam[2] - c[2]) / d, 1.0))
    area = lx * ly * math.sin(elev) + max(lx, ly) * lz * math.cos(elev)
    f = 120 / math.tan(math.radians(GEOMETRY.fovy_deg) / 2)
    return 0.7 * area / d**2 * f**2


def furniture_gap(a: Furniture, b: Furniture) -> float:
    """Free distance between two pieces of furniture along the axis where they are farthest apart."""
    ax0, ay0, ax1, ay1 = a.footprint()
    bx0, by0, bx1, by1 = b.footprint()
    return max(bx0 - ax1, ax0 - bx1, by0 - ay1, ay0 - by1)


def object_count(request: SceneRequest, default: int, lo: int, hi: int, what: str) -> int:
    n = default if request.n_objects is None else request.n_objects
    if not lo <= n <= hi:
        if lo == hi:
            raise InputError(f"{what} takes exactly {lo} objects, not {n}", "leave out --objects")
        raise InputError(
            f"{what} takes {lo} to {hi} objects, not {n}", f"ask for between {lo} and {hi} objects"
        )
    return n
