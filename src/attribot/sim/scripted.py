"""Privileged scripted manipulation for the simulator.

These functions read the simulator's state to compute targets (where an object is, which side of the
furniture to stand at, how far to extend the arm) and then move the robot only through its real
commands: base velocities, head, lift, arm and gripper targets, and time steps. Tests use them, and the
API's simulator controller uses them for `go_to_object`, `pick_up` and `put_down`.

`world` is a `MujocoWorld` (or a bare `SimWorld`); `object_id` is an object id as in the frame truth
(e.g. "mug_2").
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from attribot.errors import AttribotError, UnknownName
from attribot.gridpath import Cell, astar, shortcut
from attribot.sim.robot_geometry import GEOMETRY
from attribot.sim.scene_plan import Furniture
from attribot.sim.world import SimWorld

__all__ = ["ManipulationError", "approach_object", "pick_object", "place_back", "drive_to", "in_reach"]

_STAND_OFF = 0.05  # gap between the base's front and the furniture's edge
_LIFT_CLEAR = 0.08  # how far a picked object is raised
_REST = (0.2, 0.0)  # lift and extension when nothing is being done
_SCENERY = np.array([1, 0, 0, 0, 0, 0], np.uint8)  # geom group 0: room, furniture, objects (not the robot)


class ManipulationError(AttribotError):
    """A scripted motion could not be done: out of reach, blocked, nothing held."""


def _sim(world: Any) -> SimWorld:
    return world if isinstance(world, SimWorld) else world.sim


def _key(sim: SimWorld, object_id: str | int) -> int:
    if isinstance(object_id, (int, np.integer)) and int(object_id) in sim.objects:
        return int(object_id)
    if object_id in sim.key_of_id:
        return sim.key_of_id[str(object_id)]
    raise UnknownName(f"no object {object_id!r} in this scene", f"choose one of: {', '.join(sim.key_of_id)}")


def _settle(world: Any, seconds: float = 0.8) -> None:
    world.step(seconds)


# --- driving --------------------------------------------------------------------------------------

_CELL = 0.05  # grid resolution of the path planner, metres


def _blocked_grid(sim: SimWorld, goal: np.ndarray, start: np.ndarray) -> tuple[np.ndarray, float]:
    """Occupancy grid of the room: furniture inflated by the robot's radius (start and goal cells free)."""
    half = 3.0
    n = int(round(2 * half / _CELL))
    occ = np.zeros((n, n), bool)
    radius = math.hypot(*GEOMETRY.base_half) + 0.02
    centres = (np.arange(n) + 0.5) * _CELL - half
    for f in sim.plan.furniture:
        x0, y0, x1, y1 = f.footprint(radius)
        occ[np.ix_((centres > x0) & (centres < x1), (centres > y0) & (centres < y1))] = True
    wall = int(math.ceil((radius + 0.02) / _CELL))
    occ[:wall, :] = occ[-wall:, :] = occ[:, :wall] = occ[:, -wall:] = True
    for p in (start, goal):  # standing close to furniture is allowed where the motion starts and ends
        i, j = _cell(p, half)
        occ[max(i - 1, 0) : i + 2, max(j - 1, 0) : j + 2] = False
    return occ, half


def _cell(p: np.ndarray, half: float) -> tuple[int, int]:
    n = int(round(2 * half / _CELL))
    return (int(np.clip((p[0] + half) // _CELL, 0, n - 1)), int(np.clip((p[1] + half) // _CELL, 0, n - 1)))


def _path(sim: SimWorld, start: np.ndarray, goal: np.ndarray) -> list[np.ndarray]:
    """Waypoints from start to goal around furniture: A* on a 5 cm grid, shortened by line of sight."""
    occ, half = _blocked_grid(sim, goal, start)
    s, g = _cell(start, half), _cell(goal, half)

    # leaving the furniture margin the robot starts in: the start cell region was cleared above, and the
    # planner may step out of it through blocked cells only in its first moves
    def cost(c: Cell) -> float | None:
        if not occ[c]:
            return 1.0
        return 3.0 if abs(c[0] - s[0]) + abs(c[1] - s[1]) <= 8 else None

    cells = astar(occ.shape, s, g, cost)
    if cells is None:
        raise ManipulationError(
            "no path for the base between the furniture to the target", "choose another target"
        )
    keep = shortcut(occ, cells)
    pts = [np.array([(c[0] + 0.5) * _CELL - half, (c[1] + 0.5) * _CELL - half]) for c in keep[1:-1]]
    return pts + [goal]


def drive_to(
    world: Any,
    x: float,
    y: float,
    yaw: float,
    *,
    tol: float = 0.01,
    yaw_tol: float = 0.01,
    timeout_s: float = 40.0,
) -> None:
    """Drive the base to the world pose `(x, y, yaw)` with velocity commands, around furniture."""
    sim = _sim(world)
    start = np.array(sim.base_pose()[:2])
    waypoints = _path(sim, start, np.array([x, y]))
    dt, t = 0.05, 0.0
    for i, wp in enumerate(waypoints):
        last = i == len(waypoints) - 1
        while True:
            bx, by, byaw = sim.base_pose()
            ex, ey = wp[0] - bx, wp[1] - by
            dist = math.hypot(ex, ey)
            # turn to the final heading on the last leg, else face the direction of travel
            want = yaw if (last or dist < 0.05) else math.atan2(ey, ex)
            eyaw = math.remainder(want - byaw, math.tau)
            if dist < (tol if last else 0.08) and (not last or abs(eyaw) < yaw_tol):
                break
            c, s = math.cos(byaw), math.sin(byaw)
            fx, fy = c * ex + s * ey, -s * ex + c * ey  # the error in the robot frame
            gain = 1.5
            speed = min(0.6, gain * dist)
            scale = speed / dist if dist > 1e-9 else 0.0
            world.command_base(fx * scale, fy * scale, float(np.clip(2.5 * eyaw, -1.5, 1.5)))
            world.step(dt)
            t += dt
            if t > timeout_s:
                world.command_base(0.0, 0.0, 0.0)
                raise ManipulationError(
                    f"the base did not reach ({x:.2f}, {y:.2f}) within {timeout_s:.0f} s "
                    f"(stopped at {bx:.2f}, {by:.2f})",
                    "something blocks the way; choose another target",
                )
    world.command_base(0.0, 0.0, 0.0)
    world.step(0.3)


# --- approaching and picking -------------------------------------------------------------------------


def _standing_pose(sim: SimWorld, key: int) -> tuple[float, float, float, float]:
    """Base pose `(x, y, yaw)` from which the arm reaches object `key`, and the arm extension it needs."""
    g = GEOMETRY
    obj = sim.objects[key]
    pos = sim.object_position(key)
    bx, by, _ = sim.base_pose()
    furniture = {f.name: f for f in sim.plan.furniture}
    name = obj.surface[:-4] if obj.surface.endswith("_low") else obj.surface
    reach0 = g.mast_xy[0] + g.arm_reach0 + g.grip_offset  # grip point x at zero extension
    if name in furniture:
        n, ext = _furniture_side(sim, furniture[name], pos, (bx, by), reach0)
    else:  # on the floor: come at it from the robot's side, or turned as little as needed to stand clear
        n, ext = _floor_side(sim, key, pos, (bx, by), reach0)
    if ext > g.arm_range[1]:
        raise ManipulationError(
            f"{obj.id} is {ext - g.arm_range[1]:.2f} m beyond the arm's reach "
            f"from any side of its {name or 'place'}",
            "choose an object nearer the edge",
        )
    ext = max(ext, 0.02)
    yaw = math.atan2(-n[1], -n[0])
    # the arm runs at lateral offset mast_y in the base frame: shift the base so the arm lines up
    cos_yaw, sin_yaw = math.cos(yaw), math.sin(yaw)
    lx, ly = reach0 + ext, g.mast_xy[1]
    return (
        float(pos[0] - (cos_yaw * lx - sin_yaw * ly)),
        float(pos[1] - (sin_yaw * lx + cos_yaw * ly)),
        yaw,
        ext,
    )


def _furniture_side(
    sim: SimWorld, furniture: Furniture, pos: np.ndarray, base_xy: tuple[float, float], reach0: float
) -> tuple[np.ndarray, float]:
    """The outward normal of the side of `furniture` to stand at for the object at `pos`, and the arm
    extension needed from there; `reach0` is the grip point's x in the base frame at zero extension."""
    g = GEOMETRY
    x0, y0, x1, y1 = furniture.footprint()
    # stand at the side of the furniture nearest the object, among those the robot can stand at
    sides = [
        (np.array([-1.0, 0.0]), pos[0] - x0),
        (np.array([1.0, 0.0]), x1 - pos[0]),
        (np.array([0.0, -1.0]), pos[1] - y0),
        (np.array([0.0, 1.0]), y1 - pos[1]),
    ]
    if furniture.kind == "shelf":
        sides = sides[:1]  # shelves open towards -x
    room = 3.0 - 0.3
    radius = math.hypot(*g.base_half) + 0.03
    others = [f.footprint(radius) for f in sim.plan.furniture if f.name != furniture.name]
    feasible = []
    for n, depth in sides:
        along = depth + _STAND_OFF + g.base_half[0]  # object to base centre along the normal
        centre = pos[:2] + n * along
        clear = not any(r[0] < centre[0] < r[2] and r[1] < centre[1] < r[3] for r in others)
        if abs(centre[0]) < room and abs(centre[1]) < room and clear:
            feasible.append((depth, math.hypot(centre[0] - base_xy[0], centre[1] - base_xy[1]), n, along))
    if not feasible:
        raise ManipulationError(
            f"no side of the {furniture.name} leaves room for the robot", "move the furniture"
        )
    _, _, n, along = min(feasible, key=lambda f: (f[0] > 0.5, f[0] + 0.5 * f[1]))
    return n, float(along - reach0)


def _floor_side(
    sim: SimWorld, key: int, pos: np.ndarray, base_xy: tuple[float, float], reach0: float
) -> tuple[np.ndarray, float]:
    """The direction from the object `key` on the floor (at `pos`) to where the base stands, turned as
    little as needed from the robot's side to stand clear of the furniture, and the arm extension needed."""
    g = GEOMETRY
    radius = float(np.max(np.abs(sim.object_bounds(key)[:, :2] - pos[:2])))
    along = max(reach0 + 0.1, g.base_half[0] + 0.06 + radius)
    towards = math.atan2(base_xy[1] - pos[1], base_xy[0] - pos[0])
    clearance = math.hypot(*g.base_half) + 0.03
    blocked = [f.footprint(clearance) for f in sim.plan.furniture]
    for turn in (0.0, 0.5, -0.5, 1.0, -1.0, 1.6, -1.6, 2.2, -2.2, math.pi):
        n = np.array([math.cos(towards + turn), math.sin(towards + turn)])
        c = pos[:2] + n * along
        if (
            abs(c[0]) < 2.7
            and abs(c[1]) < 2.7
            and not any(r[0] < c[0] < r[2] and r[1] < c[1] < r[3] for r in blocked)
        ):
            return n, float(along - reach0)
    raise ManipulationError(
        f"no free spot to stand at next to {sim.objects[key].id}", "choose another object"
    )


def in_reach(world: Any, object_id: str | int, tol: float = 0.03) -> float | None:
    """The arm extension that puts the grip point at the object from where the base stands, or None."""
    sim = _sim(world)
    key = _key(sim, object_id)
    pos = sim.object_position(key)
    bx, by, byaw = sim.base_pose()
    c, s = math.cos(byaw), math.sin(byaw)
    dx, dy = pos[0] - bx, pos[1] - by
    fx, fy = c * dx + s * dy, -s * dx + c * dy
    g = GEOMETRY
    ext = fx - (g.mast_xy[0] + g.arm_reach0 + g.grip_offset)
    if abs(fy - g.mast_xy[1]) > tol or not g.arm_range[0] <= ext <= g.arm_range[1]:
        return None
    return float(ext)


def _look_at(world: Any, sim: SimWorld, target: np.ndarray) -> None:
    cam, _ = sim.camera_pose()
    d = target - cam
    _, _, yaw = sim.base_pose()
    world.set_head(
        math.remainder(math.atan2(d[1], d[0]) - yaw, math.tau), math.atan2(d[2], math.hypot(d[0], d[1]))
    )


def approach_object(world: Any, object_id: str | int) -> None:
    """Drive to where the arm reaches the object, facing it, and look at it."""
    sim = _sim(world)
    key = _key(sim, object_id)
    x, y, yaw, _ = _standing_pose(sim, key)
    world.set_arm(*_REST)
    drive_to(world, x, y, yaw)
    _look_at(world, sim, sim.object_position(key))
    _settle(world, 0.6)


def _grip_height(sim: SimWorld, key: int) -> float:
    """Halfway up the object's material under the centre of its bounding box (a laptop: its base)."""
    lo, hi = sim.object_bounds(key)
    c = (lo + hi) / 2
    top = sim.top_of(key, c[0], c[1])
    z = (lo[2] + (top if top is not None else hi[2])) / 2
    return float(np.clip(z, *GEOMETRY.lift_range))


def _headroom(sim: SimWorld, key: int) -> float:
    """How far the object can be raised (at most _LIFT_CLEAR) before it meets what is above it (a shelf)."""
    lo, hi = sim.object_bounds(key)
    free = math.inf
    for fx in (0.1, 0.5, 0.9):
        for fy in (0.1, 0.5, 0.9):
            p = np.array([lo[0] + fx * (hi[0] - lo[0]), lo[1] + fy * (hi[1] - lo[1]), hi[2]])
            geom = np.array([-1], np.int32)
            d = mujoco.mj_ray(
                sim.model, sim.data, p, np.array([0.0, 0.0, 1.0]), _SCENERY, 1, sim.body_of[key], geom
            )
            if geom[0] >= 0:
                free = min(free, d)
    return float(np.clip(free - 0.02, 0.005, _LIFT_CLEAR))


def pick_object(world: Any, object_id: str | int) -> bool:
    """Approach (if needed), tare the wrist sensor, grasp the object and lift it clear. True when held."""
    sim = _sim(world)
    key = _key(sim, object_id)
    if sim.held == key:
        return True
    if sim.held is not None:
        raise ManipulationError(f"the gripper already holds {sim.objects[sim.held].id}", "put it down first")
    if not sim.objects[key].category.pickable:
        raise ManipulationError(
            f"{sim.objects[key].id} is not something the robot can pick up", "choose a smaller object"
        )
    ext = in_reach(world, key)
    if ext is None:
        approach_object(world, key)
        ext = in_reach(world, key)
        if ext is None:
            raise ManipulationError(
                f"{sim.objects[key].id} is still out of reach after approaching it",
                "the object may have moved; try again",
            )
    z = _grip_height(sim, key)
    sim.set_gripper(GEOMETRY.finger_range[1])
    world.set_arm(z, 0.0)
    _settle(world, 1.0)
    world.set_arm(z, ext)
    _settle(world, 1.0)
    world.tare_force()
    before = (sim.base_pose(), z, ext)
    if not world.grasp():
        sim.set_gripper(GEOMETRY.finger_range[1])
        world.set_arm(z, 0.0)
        _settle(world, 0.8)
        world.set_arm(*_REST)
        _settle(world, 0.5)
        return False
    world.set_arm(z + _headroom(sim, key), ext)
    _settle(world, 1.5)
    sim.pick_record = before
    return True


def place_back(world: Any) -> None:
    """Put the held object down where it was picked up, and retract the arm."""
    sim = _sim(world)
    if sim.held is None:
        raise ManipulationError("the gripper holds nothing to put down", "pick an object up first")
    (bx, by, byaw), z, ext = sim.pick_record or (sim.base_pose(), _REST[0], 0.0)
    cx, cy, cyaw = sim.base_pose()
    if math.hypot(cx - bx, cy - by) > 0.01 or abs(math.remainder(cyaw - byaw, math.tau)) > 0.02:
        drive_to(world, bx, by, byaw)
    world.set_arm(z + 0.005, ext)
    _settle(world, 1.2)
    world.release()
    world.set_arm(z + _LIFT_CLEAR, ext)
    _settle(world, 0.6)
    world.set_arm(z + _LIFT_CLEAR, 0.0)
    _settle(world, 0.8)
    world.set_arm(*_REST)
    _settle(world, 0.8)
