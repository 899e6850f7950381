"""Ground truth about a simulated world's objects, for perception oracles, scoring and scene info.

Which geoms of the compiled model are which object or surface, where each object is and what it stands on,
whether the first view sees it, and `SceneInfo`, what `attribot scene info` prints. The functions that take
a `SimWorld` read its public attributes only; `attribot.sim.world` re-exports the records.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import mujoco
import numpy as np
from pydantic import BaseModel

from attribot.frame import Frame
from attribot.sim.looks import BODY_GROUP
from attribot.sim.scene_plan import Furniture, PlacedObject

if TYPE_CHECKING:
    from attribot.sim.world import SimWorld

__all__ = [
    "ObjectInfo",
    "RobotInfo",
    "SceneInfo",
    "MIN_VISIBLE_PIXELS",
    "box_from_mask",
    "name2id",
    "index_objects",
    "index_surfaces",
    "object_bounds",
    "support_of",
    "top_of",
    "in_view",
    "scene_info",
]

MIN_VISIBLE_PIXELS = 20  # fewer visible pixels than this and an object counts as not in view


class ObjectInfo(BaseModel):
    """Truth about one object, as `attribot scene info` prints it (metres, kilograms, pixels)."""

    id: str
    key: int
    category: str
    color: str
    mass_kg: float
    position: list[float]
    box: list[float] | None
    visible_pixels: int
    pickable: bool
    size_m: float
    variant: str = ""
    deceptive: bool = False
    distance_m: float
    surface: str = ""
    row: int | None = None
    col: int | None = None
    odd_one_out: bool | None = None
    odd_kind: str | None = None
    weight_rank: int | None = None
    # what no camera sees (`attribot.sim.catalog`): the world's own state, which the new senses read
    temperature_c: float | None = None  # its surface temperature
    thermal: str = ""  # the word for its temperature (`attribot.lexicon.temperature_state`)
    stiffness_n_per_mm: float | None = None  # force per millimetre of gripper closure
    softness: str = ""  # soft, firm, hard, rigid
    fill: float | None = None  # a container's contents as a share of its capacity (None: no container)
    contents_kg: float | None = None  # the mass of those contents


class RobotInfo(BaseModel):
    base: list[float]  # x, y, yaw
    camera_position: list[float]
    head: list[float]  # pan, tilt


class SceneInfo(BaseModel):
    """What `attribot scene info` prints: the scene's truth in the world frame and the camera's pixels."""

    layout: str
    seed: int
    image_size: list[int]
    objects: list[ObjectInfo]
    robot: RobotInfo
    furniture: list[str]
    room_temperature_c: float | None = None


def box_from_mask(mask: np.ndarray) -> tuple[float, float, float, float] | None:
    """xyxy pixel box (x1, y1 exclusive) around the True pixels of a mask, or None when empty."""
    ys, xs = np.nonzero(mask)
    if xs.size == 0:
        return None
    return float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1)


def name2id(model: mujoco.MjModel, kind: mujoco.mjtObj, name: str) -> int:
    """The id of the `kind` named `name` in `model`; a RuntimeError when it has none."""
    i = mujoco.mj_name2id(model, kind, name)
    if i < 0:
        raise RuntimeError(f"the model has no {kind.name} {name!r}")
    return i


def index_objects(
    model: mujoco.MjModel, objects: Sequence[PlacedObject]
) -> tuple[dict[int, int], dict[int, list[int]], dict[int, int], np.ndarray]:
    """Each object's body, body parts and grasp weld by key, and each geom's object key (-1 for the rest)."""
    body_of: dict[int, int] = {}
    geoms_of: dict[int, list[int]] = {}
    weld_of: dict[int, int] = {}
    geom_key = np.full(model.ngeom, -1, np.int32)
    for o in objects:
        b = name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"obj:{o.id}")
        body_of[o.key] = b
        gs = [g for g in range(model.ngeom) if model.geom_bodyid[g] == b]
        # the body parts (drawn or not), never the look drawn over them nor the collision box
        geoms_of[o.key] = [g for g in gs if model.geom_group[g] in (0, BODY_GROUP)]
        geom_key[gs] = o.key
        if o.category.pickable:
            weld_of[o.key] = name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, f"grasp:{o.id}")
    return body_of, geoms_of, weld_of, geom_key


def index_surfaces(
    model: mujoco.MjModel, furniture: Sequence[Furniture]
) -> tuple[tuple[str, ...], np.ndarray]:
    """The surfaces' names (the furniture's, then "floor") and each geom's index into them (-1 elsewhere)."""
    names = (*(f.name for f in furniture), "floor")
    geom_surface = np.full(model.ngeom, -1, np.int16)
    for i, f in enumerate(furniture):
        b = name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"furniture:{f.name}")
        geom_surface[model.geom_bodyid == b] = i
    geom_surface[name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")] = len(furniture)
    return names, geom_surface


def object_bounds(model: mujoco.MjModel, data: mujoco.MjData, geoms: Sequence[int]) -> np.ndarray:
    """World axis-aligned bounds (2, 3) of `geoms`."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for g in geoms:
        r = np.abs(data.geom_xmat[g].reshape(3, 3)) @ _half_extents(model, g)
        lo = np.minimum(lo, data.geom_xpos[g] - r)
        hi = np.maximum(hi, data.geom_xpos[g] + r)
    return np.stack([lo, hi])


def _half_extents(m: mujoco.MjModel, g: int) -> np.ndarray:
    s = m.geom_size[g]
    t = m.geom_type[g]
    if t == mujoco.mjtGeom.mjGEOM_SPHERE:
        return np.array([s[0]] * 3)
    if t == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return np.array([s[0], s[0], s[1]])
    if t == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return np.array([s[0], s[0], s[1] + s[0]])
    return np.array(s[:3])


def support_of(furniture: Sequence[Furniture], bounds: np.ndarray, tol: float) -> str | None:
    """The surface that an object with world `bounds` stands on, as `SimWorld.support_of` says."""
    lo, hi = bounds
    x, y = (lo[:2] + hi[:2]) / 2
    for f in furniture:
        x0, y0, x1, y1 = f.footprint()
        if not (x0 <= x <= x1 and y0 <= y <= y1):
            continue
        for surface in f.surfaces():
            if abs(lo[2] - surface.z) <= tol:
                return surface.name
    return "floor" if abs(lo[2]) <= tol else None


def top_of(world: SimWorld, key: int, x: float, y: float) -> float | None:
    """Height of the object's upper surface at world (x, y) by a ray cast downward, or None if missed."""
    lo, hi = world.object_bounds(key)
    start = np.array([x, y, hi[2] + 0.05])
    geom = np.array([-1], np.int32)
    down = np.array([0.0, 0.0, -1.0])
    dist = mujoco.mj_ray(world.model, world.data, start, down, world.ray_groups, 1, -1, geom)
    if geom[0] < 0 or world.geom_key[geom[0]] != key:
        return None
    return float(start[2] - dist)


def in_view(world: SimWorld, key: int, margin: float = 0.04) -> bool:
    """True when rays from the optical centre reach the object first and its centre is in the image."""
    cam, rot = world.camera_pose()
    info = world.camera_info()
    lo, hi = world.object_bounds(key)
    centre = (lo + hi) / 2
    top = np.array([centre[0], centre[1], hi[2] - 0.01 * (hi[2] - lo[2])])
    p = rot.T @ (centre - cam)  # camera frame: x right, y up, z backward
    if p[2] >= -0.05:
        return False
    u = info.cx + info.fx * p[0] / -p[2]
    v = info.cy - info.fy * p[1] / -p[2]
    if not (
        margin * info.width <= u <= (1 - margin) * info.width
        and margin * info.height <= v <= (1 - margin) * info.height
    ):
        return False
    head = int(world.model.cam_bodyid[world.camera_id])  # the camera's own housing is not in the way
    seen = 0
    for target in (centre, top):
        vec = target - cam
        geom = np.array([-1], np.int32)
        direction = vec / np.linalg.norm(vec)
        mujoco.mj_ray(world.model, world.data, cam, direction, world.ray_groups, 1, head, geom)
        seen += int(geom[0] >= 0 and world.geom_key[geom[0]] == key)
    return seen >= 1


def scene_info(world: SimWorld, frame: Frame | None = None) -> SceneInfo:
    """The truth of the scene now, with boxes from the segmentation of `frame` (or a fresh frame)."""
    frame = frame or world.observe()
    cam, _ = world.camera_pose()
    x, y, yaw = world.base_pose()
    return SceneInfo(
        layout=world.plan.layout,
        seed=world.plan.seed,
        image_size=[world.width, world.height],
        objects=[_object_info(world, o, frame, cam) for o in world.plan.objects],
        robot=RobotInfo(
            base=[round(x, 4), round(y, 4), round(yaw, 4)],
            camera_position=[round(float(v), 4) for v in cam],
            head=[round(v, 4) for v in world.head()],
        ),
        furniture=[f.name for f in world.plan.furniture],
        room_temperature_c=world.plan.room_temperature_c,
    )


def _object_info(world: SimWorld, o: PlacedObject, frame: Frame, cam: np.ndarray) -> ObjectInfo:
    """The truth about `o` now, its box from the segmentation of `frame`, its distance from `cam`."""
    mask = frame.segmentation == o.key if frame.segmentation is not None else np.zeros((1, 1), bool)
    n_px = int(mask.sum())
    box = box_from_mask(mask) if n_px >= MIN_VISIBLE_PIXELS else None
    pos = world.object_position(o.key)
    extras = {k: v for k, v in o.extras.items() if k in ObjectInfo.model_fields}
    return ObjectInfo(
        id=o.id,
        key=o.key,
        category=o.category.name,
        color=o.color,
        mass_kg=round(float(world.model.body_mass[world.body_of[o.key]]), 4),
        position=[round(float(v), 4) for v in pos],
        box=list(box) if box else None,
        visible_pixels=n_px,
        pickable=o.category.pickable,
        size_m=o.size_m,
        variant=o.variant,
        deceptive=o.category.deceptive,
        distance_m=round(float(np.linalg.norm(pos - cam)), 4),
        surface=o.surface,
        temperature_c=o.temperature_c,
        thermal=o.thermal,
        stiffness_n_per_mm=o.stiffness_n_per_mm,
        softness=o.softness,
        fill=o.fill,
        contents_kg=None if o.fill is None else round(o.fill * o.category.capacity_kg, 4),
        **extras,
    )
