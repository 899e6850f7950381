"""The MuJoCo model of a planned scene: the room, its walls, lights and furniture, the objects with their
looks, the robot's body and a camera that watches the room (`build_model`).

Apart from `attribot.sim.scene`, which plans a scene (and checks what a config asks of a layout) with no
MuJoCo, so that a config is checked without loading the simulator.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from attribot.errors import InputError
from attribot.sim.bodies import body_named
from attribot.sim.catalog import COLORS
from attribot.sim.looks import BODY_GROUP, LOOK_STYLES, add_looks, look_of, variant_of
from attribot.sim.scene_plan import ROOM_HALF, SHELF_LOW, WALL_HEIGHT, Furniture, PlacedObject, ScenePlan
from attribot.sim.shapes import MATERIALS
from attribot.sim.textures import add_materials

__all__ = ["build_model", "ROOM_CAMERA"]


def _rgba(rgb: tuple[float, float, float], a: float = 1.0) -> list[float]:
    return [*rgb, a]


_WALL_T = 0.05  # half the walls' thickness
_WALLS = (
    (
        "wall_front",
        (ROOM_HALF + _WALL_T, 0, WALL_HEIGHT / 2),
        (_WALL_T, ROOM_HALF + 2 * _WALL_T, WALL_HEIGHT / 2),
    ),
    (
        "wall_back",
        (-ROOM_HALF - _WALL_T, 0, WALL_HEIGHT / 2),
        (_WALL_T, ROOM_HALF + 2 * _WALL_T, WALL_HEIGHT / 2),
    ),
    ("wall_left", (0, ROOM_HALF + _WALL_T, WALL_HEIGHT / 2), (ROOM_HALF, _WALL_T, WALL_HEIGHT / 2)),
    ("wall_right", (0, -ROOM_HALF - _WALL_T, WALL_HEIGHT / 2), (ROOM_HALF, _WALL_T, WALL_HEIGHT / 2)),
)
"""Each wall's name, centre and half-size, just outside the floor."""

_SKIRTING = (
    ("skirt_front", (ROOM_HALF - 0.005, 0, 0.05), (0.006, ROOM_HALF, 0.05)),
    ("skirt_left", (0, ROOM_HALF - 0.005, 0.05), (ROOM_HALF, 0.006, 0.05)),
    ("skirt_right", (0, -ROOM_HALF + 0.005, 0.05), (ROOM_HALF, 0.006, 0.05)),
)
"""Each skirting board's name, centre and half-size (none on the back wall)."""


def _add_room(spec: mujoco.MjSpec) -> None:
    """The floor, walls and skirting boards, the sky, and the room's lights."""
    _add_room_textures(spec)
    wb = spec.worldbody
    floor = wb.add_geom(
        name="floor",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[ROOM_HALF, ROOM_HALF, 0.05],
        material="floor_mat",
    )
    floor.contype = floor.conaffinity = 1
    _add_walls(wb)
    _add_lights(wb)


def _add_room_textures(spec: mujoco.MjSpec) -> None:
    """The floor's checker texture and material, and the sky's gradient."""
    spec.add_texture(
        name="floor_tex",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=[0.72, 0.66, 0.58],
        rgb2=[0.64, 0.58, 0.50],
        width=256,
        height=256,
    )
    mat = spec.add_material(name="floor_mat", texrepeat=[8, 8], reflectance=0.15)
    mat.textures[int(mujoco.mjtTextureRole.mjTEXROLE_RGB)] = "floor_tex"
    spec.add_texture(
        name="sky",
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=[0.6, 0.7, 0.85],
        rgb2=[0.2, 0.25, 0.35],
        width=64,
        height=64,
    )


def _add_walls(wb: mujoco.MjsBody) -> None:
    """The walls, which things collide with, and the skirting boards, which they do not."""
    for contype, rgba, boards in (
        (1, [0.86, 0.84, 0.78, 1.0], _WALLS),
        (0, [0.45, 0.40, 0.35, 1.0], _SKIRTING),
    ):
        for name, pos, size in boards:
            g = wb.add_geom(
                name=name, type=mujoco.mjtGeom.mjGEOM_BOX, size=list(size), pos=list(pos), rgba=rgba
            )
            g.contype = g.conaffinity = contype


def _add_lights(wb: mujoco.MjsBody) -> None:
    """A shadow-casting ceiling light, and a fill light from the back of the room without shadows."""
    wb.add_light(
        name="ceiling",
        pos=[0, 0, WALL_HEIGHT - 0.05],
        dir=[0.1, 0.05, -1],
        diffuse=[0.55, 0.55, 0.55],
        specular=[0.1, 0.1, 0.1],
        castshadow=True,
        cutoff=80,
        attenuation=[1, 0, 0],
    )
    wb.add_light(
        name="fill",
        pos=[-2.5, -1.0, 2.0],
        dir=[1, 0.3, -0.6],
        diffuse=[0.3, 0.3, 0.3],
        specular=[0, 0, 0],
        castshadow=False,
        cutoff=90,
    )


def _add_furniture(spec: mujoco.MjSpec, f: Furniture, looks: str = "detailed") -> None:
    body = spec.worldbody.add_body(name=f"furniture:{f.name}", pos=[f.x, f.y, 0])
    wood = looks != "primitive" and f.kind != "counter"  # grain on wooden tops and boards (drawn only)
    dx, dy, h = f.size[0] / 2, f.size[1] / 2, f.size[2]
    rgba = list(f.rgba)
    dark = [f.rgba[0] * 0.6, f.rgba[1] * 0.6, f.rgba[2] * 0.6, 1.0]

    def box(half: tuple[float, float, float], pos: tuple[float, float, float], color: list[float]) -> None:
        g = body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=list(half), pos=list(pos), rgba=color)
        if wood:
            g.material = "look_wood"
        g.contype = g.conaffinity = 1
        g.friction = [1.0, 0.01, 0.001]

    top = 0.02
    if f.kind in ("table", "coffee_table"):
        box((dx, dy, top), (0, 0, h - top), rgba)
        leg = 0.03
        for sx in (-1, 1):
            for sy in (-1, 1):
                box(
                    (leg, leg, (h - 2 * top) / 2),
                    (sx * (dx - leg - 0.02), sy * (dy - leg - 0.02), (h - 2 * top) / 2),
                    dark,
                )
    elif f.kind == "counter":
        box((dx, dy, (h - 2 * top) / 2), (0, 0, (h - 2 * top) / 2), dark)
        box((dx + 0.01, dy + 0.01, top), (0, 0, h - top), rgba)
        box((0.003, dy * 0.9, h * 0.35), (-dx - 0.002, 0, h * 0.45), [0.9, 0.9, 0.88, 1])
    else:  # shelf: open towards -x, a top, a middle board, a back and two sides
        box((dx, dy, top), (0, 0, h - top), rgba)
        box((dx, dy, top), (0, 0, SHELF_LOW - top), rgba)
        box((dx, dy, top), (0, 0, 0.05), rgba)
        box((0.01, dy, h / 2), (dx - 0.01, 0, h / 2), dark)
        for sy in (-1, 1):
            box((dx, 0.015, h / 2), (0, sy * (dy - 0.015), h / 2), dark)


def _add_object(
    spec: mujoco.MjSpec, o: PlacedObject, looks: str = "detailed", meshes: set[str] | None = None
) -> None:
    """The object's body parts (which carry its mass), its look, and one invisible collision box.

    Contacts are made by the box alone: it rests flat and steady on any surface, collides cheaply, and
    keeps visible parts from overlapping another object's. Being fully transparent, it is ignored by the
    rangefinder and by rendering. With `looks="detailed"` the body parts move to `BODY_GROUP` (cast
    against, not drawn) and the look (`attribot.sim.looks`) is drawn over them without mass or contacts;
    with `looks="primitive"` the body parts are what is drawn.
    """
    main = COLORS[o.color]
    body = spec.worldbody.add_body(
        name=f"obj:{o.id}",
        pos=[o.x, o.y, o.z - o.shape.lo[2] + 0.0005],
        quat=[math.cos(o.yaw / 2), 0, 0, math.sin(o.yaw / 2)],
    )
    body.add_freejoint(name=f"obj:{o.id}")
    parts = [p for p in o.shape.parts if not p.hidden]
    vol = sum(p.volume() for p in parts)
    hull_mass = 1e-4 * o.mass_kg
    types = {
        "box": mujoco.mjtGeom.mjGEOM_BOX,
        "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
        "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
        "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
        "ellipsoid": mujoco.mjtGeom.mjGEOM_ELLIPSOID,
    }
    for p in parts:
        rgb = main if p.role == "main" else MATERIALS[p.role]
        size = list(p.size) + [0.0] * (3 - len(p.size))
        g = body.add_geom(type=types[p.kind], size=size, pos=list(p.pos), quat=list(p.quat), rgba=_rgba(rgb))
        g.mass = (o.mass_kg - hull_mass) * p.volume() / vol
        g.group = 0 if looks == "primitive" else BODY_GROUP
        g.contype = g.conaffinity = 0
    if looks != "primitive":
        variant = variant_of(o.id, 3)
        shared = meshes if meshes is not None else set()
        add_looks(spec, body, look_of(o.category.shape, o.shape, o.size_m, variant), main, shared)
    lo, hi = np.asarray(o.shape.lo), np.asarray(o.shape.hi)
    hull = body.add_geom(
        name=f"hull:{o.id}",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=list((hi - lo) / 2),
        pos=list((hi + lo) / 2),
        rgba=[0.5, 0.5, 0.5, 0.0],
    )
    hull.mass = hull_mass
    hull.group = 3
    hull.contype = hull.conaffinity = 1
    hull.condim = 3
    hull.friction = [1.0, 0.005, 0.0001]


ROOM_CAMERA = "room_camera"
"""A fixed third-person camera behind the robot's start, for episode videos (never a robot sensor)."""


def _add_room_camera(spec: mujoco.MjSpec, robot: tuple[float, float, float]) -> None:
    x, y, yaw = robot
    forward = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    left = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
    limit = ROOM_HALF - 0.2
    pos = np.array([x, y, 0.0]) - 1.6 * forward + 0.9 * left
    pos = np.array([np.clip(pos[0], -limit, limit), np.clip(pos[1], -limit, limit), 2.1])
    look = np.array([x, y, 0.5]) + 1.3 * forward
    f = (look - pos) / np.linalg.norm(look - pos)
    right = np.cross(f, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, f)
    spec.worldbody.add_camera(
        name=ROOM_CAMERA, pos=pos.tolist(), xyaxes=[*right.tolist(), *up.tolist()], fovy=70
    )


def build_model(plan: ScenePlan, *, timestep: float = 0.004, looks: str = "detailed") -> mujoco.MjModel:
    """Compile the plan into a model: room, furniture, objects, robot, sensors, a weld per pickable object.

    `looks`: "detailed" (objects that look like their category, `attribot.sim.looks`) or "primitive" (the
    objects' body primitives, as earlier releases drew them); physics and sensing are the same."""
    if looks not in LOOK_STYLES:
        raise InputError(f"unknown object looks {looks!r}", f"choose one of: {', '.join(LOOK_STYLES)}")
    spec = mujoco.MjSpec()
    spec.modelname = f"attribot_{plan.layout}_{plan.seed}"
    spec.compiler.degree = False  # every angle here is in radians (joint ranges included)
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL
    if hasattr(mujoco.mjtEnableBit, "mjENBL_SLEEP"):  # MuJoCo >= 3.4: objects at rest cost nothing
        spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    spec.visual.global_.offwidth = max(plan.width, 64)
    spec.visual.global_.offheight = max(plan.height, 64)
    spec.visual.quality.shadowsize = 2048
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.25, 0.25, 0.25]
    spec.visual.headlight.specular = [0.0, 0.0, 0.0]
    spec.visual.map.znear = 0.005
    spec.visual.map.zfar = 5.0
    spec.stat.extent = 3.0  # clip planes scale with it: near 1.5 cm, far 15 m
    spec.stat.center = [0, 0, 0.8]
    _add_room(spec)
    if looks != "primitive":
        add_materials(spec)
    for f in plan.furniture:
        _add_furniture(spec, f, looks)
    meshes: set[str] = set()
    for o in plan.objects:
        _add_object(spec, o, looks, meshes)
    body_named(plan.robot_kind).build(spec, plan.width, plan.height)
    _add_room_camera(spec, plan.robot)
    for o in plan.objects:
        if o.category.pickable:
            eq = spec.add_equality(
                name=f"grasp:{o.id}",
                type=mujoco.mjtEq.mjEQ_WELD,
                objtype=mujoco.mjtObj.mjOBJ_BODY,
                name1="wrist",
                name2=f"obj:{o.id}",
            )
            eq.active = False
            eq.solref = [0.01, 1.0]
    return spec.compile()
