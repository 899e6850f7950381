"""The household layout: a room with furniture and candidates at different distances from the robot, all in
the camera's first view; and, for a body whose gripper reaches only the floor (the RoboMaster-EP-like
robot), the household and triplet scenes with the candidates on the floor, where it can drive straight to
each (it has no depth camera to see its way).
"""

from __future__ import annotations

import math

import numpy as np

from attribot.errors import InputError
from attribot.sim.bodies import SimBody
from attribot.sim.catalog import Category
from attribot.sim.robot_geometry import GEOMETRY
from attribot.sim.scene_plan import (
    LAYOUTS,
    ROOM_HALF,
    SHELF_LOW,
    Furniture,
    PlacedObject,
    ScenePlan,
    SceneRequest,
    Surface,
    aim_head,
    apparent_pixels,
    camera_position,
    category_pool,
    face_towards,
    fits_on_surface,
    furniture_gap,
    make_furniture,
    make_object,
    object_center,
    object_count,
)

__all__ = ["household", "floor_triplet"]


@LAYOUTS.register("household", aliases=("room",))
def household(rng: np.random.Generator, request: SceneRequest) -> ScenePlan:
    """A room with 2-3 pieces of furniture and 2-6 candidate objects (up to 12 on request) at distances
    from the robot that differ by at least `min_gap` metres (option, default 0.15)."""
    if request.body.on_floor:
        return _floor_household(rng, request)
    n = object_count(request, int(rng.integers(2, 7)), 1, 12, "a household scene")
    min_gap = float(request.option("min_gap", 0.15))
    robot = _robot_start(rng)
    cam = camera_position(robot)
    furniture = _household_furniture(rng, robot[0], robot[1])
    surfaces = [s for f in furniture for s in f.surfaces()]
    floor = _standing_floor(robot[0], furniture)
    picks = _draw_categories(rng, category_pool(request, lambda c: c.pickable), n)
    objs = [make_object(rng, i, c) for i, c in enumerate(picks)]
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
        make_furniture(f"{kind}_{i}", float(x), float(y), size, kind)
        for i, (kind, (x, y), size) in enumerate(slots)
        if i in keep
    ]


def _room_to_drive(furniture: list[Furniture]) -> bool:
    """Whether the pieces stand 0.6 m apart and 0.6 m off the walls."""
    return all(
        furniture_gap(a, b) >= 0.6 for i, a in enumerate(furniture) for b in furniture[i + 1 :]
    ) and all(max(abs(v) for v in f.footprint()) < ROOM_HALF - 0.6 for f in furniture)


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
        if not fits_on_surface(x, y, r, s, placed.get(s.name, []), 0.04):
            continue
        o.x, o.y, o.z, o.surface = x, y, s.z, s.name
        face_towards(o, (cam[0], cam[1]), rng, 0.4)
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
    if apparent_pixels(o, cam) < 60:
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
    pan, _ = aim_head(cam, robot[2], (lo + hi) / 2)
    tilts = [math.atan2(c[2] - cam[2], math.hypot(c[0] - cam[0], c[1] - cam[1])) for c in centers]
    return pan, float(np.clip((min(tilts) + max(tilts)) / 2, *GEOMETRY.tilt_range))


# --- a body whose gripper reaches only the floor: candidates there ---------------------------------------


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


def floor_triplet(rng: np.random.Generator, objs: list[PlacedObject], body: SimBody) -> ScenePlan:
    """Three objects on the floor 0.8 m before the robot, 26 degrees apart (left to right in their order):
    the way to each passes clear of the others."""
    robot = (0.0, 0.0, 0.0)
    cam = _floor_camera(robot, body)
    for o, bearing in zip(objs, (0.45, 0.0, -0.45), strict=True):
        o.x, o.y, o.z, o.surface = 0.8 * math.cos(bearing), 0.8 * math.sin(bearing), 0.0, "floor"
        face_towards(o, (cam[0], cam[1]), rng, 0.25)
    return ScenePlan("triplet", [], objs, robot, (0.0, 0.0))


def _floor_household(rng: np.random.Generator, request: SceneRequest) -> ScenePlan:
    """A room with a table to one side and a counter or shelf at the back, and 2 to 4 candidates (up to 6
    on request) on the floor between them and the robot, at distances that differ by at least `min_gap`,
    each with a straight way to it that passes clear of the others."""
    body = request.body
    n = object_count(request, int(rng.integers(2, 5)), 1, 6, f"a household scene for {body.called}")
    min_gap = float(request.option("min_gap", 0.15))
    robot = _robot_start(rng)
    rx, ry, _ = robot
    back = str(rng.choice(["counter", "shelf"]))
    side = float(rng.choice([-1.0, 1.0]))
    table_xy = rx + float(rng.uniform(1.5, 1.8)), ry + side * float(rng.uniform(1.1, 1.3))
    back_xy = rx + float(rng.uniform(2.6, 2.8)), ry + float(rng.uniform(-0.4, 0.4))
    furniture = [
        make_furniture("table_0", *table_xy, (0.7, 0.9, 0.75)),
        make_furniture(f"{back}_1", *back_xy, (0.45, 1.2, 0.9), back),
    ]
    picks = _draw_categories(rng, category_pool(request, body.holds), n)
    objs = [make_object(rng, i, c) for i, c in enumerate(picks)]
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
            face_towards(o, (cam[0], cam[1]), rng, 0.4)
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
