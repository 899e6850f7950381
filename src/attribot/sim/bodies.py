"""The robot bodies the simulator builds and drives, as registered records (`SceneConfig(robot=...)`).

A `SimBody` holds what differs from one body to another, so that the world, its scenes and the embodiment
read a field instead of comparing the robot's name: how it is built into the MuJoCo model, its joints and
camera, what it reports of its arm and head, its geometry as a controller is told it, what it has (a camera
head, a depth camera) and its scenes' limits (whether its gripper reaches only the floor, the layouts made
for it, what it can hold). The mast robot (`attribot.sim.robot`) and the RoboMaster-EP-like one
(`attribot.sim.robot_ep`) are registered here; another body is one more registration.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import mujoco

from attribot.control.body import BodyGeometry
from attribot.errors import InputError
from attribot.registry import Registry
from attribot.sim import robot, robot_ep
from attribot.sim.catalog import Category
from attribot.sim.shapes import build_shape

__all__ = ["SimBody", "BODIES", "body_named"]


@dataclass(frozen=True)
class SimBody:
    """One robot body (see the module docstring).

    name: what `SceneConfig(robot=...)` takes; called: how a sentence names it ("the EP-like robot");
    joints: its joints, each with an actuator of the same name; camera: the MuJoCo camera it sees through;
    geometry: its body as a controller is told it; range_max: its rangefinder's reach, metres; head and
    depth: whether it has a pan-tilt camera head and a depth camera; beam_in_view: whether frames draw its
    rangefinder's beam (the mast robot's runs along the optical axis and shows as nothing; the EP's camera
    must not see its ToF's); scripted: whether the simulator's privileged scripts can move it;
    build(spec, width, height): adds it to a model; rest(head, arm, finger_open): its joint targets at the
    start of a scene, from the plan's head and arm; arm(lift, extension): the joint targets that put its grip
    point there; reported(q): what it reports of its joints (q: positions by joint, fingers left out);
    head_angles(q): its camera's pan and tilt.

    Its scenes: on_floor, its gripper reaches only the floor (the layouts put its candidates there);
    layouts: the layouts made for it (None: all), and why the others are not (layouts_why); holds: whether
    its gripper can hold a category, and what to choose instead (holds_fix).
    """

    name: str
    called: str
    joints: tuple[str, ...]
    camera: str
    geometry: BodyGeometry
    range_max: float
    head: bool
    depth: bool
    beam_in_view: bool
    scripted: bool
    build: Callable[[mujoco.MjSpec, int, int], None]
    rest: Callable[[tuple[float, float], tuple[float, float], float], dict[str, float]]
    arm: Callable[[float, float], dict[str, float]]
    reported: Callable[[dict[str, float]], dict[str, float]]
    head_angles: Callable[[dict[str, float]], tuple[float, float]]
    on_floor: bool = False
    layouts: tuple[str, ...] | None = None
    layouts_why: str = ""
    holds: Callable[[Category], bool] = lambda category: True
    holds_fix: str = ""

    @property
    def finger_open(self) -> float:
        """Each finger's distance from the centre line, fully open (metres)."""
        return self.geometry.finger_open


BODIES: Registry[SimBody] = Registry("robot body")
"""Every robot body the simulator builds, under its name."""


def body_named(name: str) -> SimBody:
    """The body registered as `name`; an unknown one is an `InputError` naming the registered ones."""
    if name not in BODIES:
        raise InputError(
            f"unknown robot {name!r}",
            f"choose one of: {', '.join(BODIES.names())} (the bodies attribot.sim.bodies registers)",
        )
    return BODIES.get(name)


# ---- the mast robot: a pan-tilt head on a mast, a telescoping arm on a lift -------------------------

_MAST = robot.GEOMETRY


def _mast_rest(head: tuple[float, float], arm: tuple[float, float], open_: float) -> dict[str, float]:
    (pan, tilt), (lift, extension) = head, arm
    return {"head_pan": pan, "head_tilt": tilt, "lift": lift, "arm": extension, "finger_l": open_,
            "finger_r": open_}  # fmt: skip


BODIES.register("mast")(
    SimBody(
        name="mast",
        called="the mast robot",
        joints=robot.JOINTS,
        camera="head_camera",
        geometry=BodyGeometry(
            camera_xyz=(_MAST.mast_xy[0], _MAST.mast_xy[1], _MAST.head_height),
            arm_xy=_MAST.mast_xy,
            reach0=_MAST.arm_reach0 + _MAST.grip_offset,
            arm_range=_MAST.arm_range,
            lift_range=_MAST.lift_range,
            base_half=_MAST.base_half,
            finger_open=_MAST.finger_range[1],
        ),
        range_max=_MAST.range_max,
        head=True,
        depth=True,
        beam_in_view=True,
        scripted=True,
        build=lambda spec, width, height: robot.add_robot(spec),
        rest=_mast_rest,
        arm=lambda lift, extension: {"lift": lift, "arm": extension},
        reported=dict,
        head_angles=lambda q: (q["head_pan"], q["head_tilt"]),
    )
)


# ---- the RoboMaster-EP-like robot: its camera on a two-link arm, a gripper that reaches the floor ----


def _ep_arm(lift: float, extension: float) -> dict[str, float]:
    if not (math.isfinite(lift) and math.isfinite(extension)):
        raise InputError(f"arm target {(lift, extension)} is not finite", "give finite numbers")
    return robot_ep.arm_targets(lift, extension)


def _ep_reported(q: dict[str, float]) -> dict[str, float]:
    """The base's joints, and the arm as the EP reports it: its links' elevations and its grip point."""
    return {n: v for n, v in q.items() if n.startswith("base")} | robot_ep.arm_joint_states(q)


def _ep_holds(c: Category) -> bool:
    """What the EP's gripper (about 10 cm open) can hold and its beam (at least 3 cm up) can find: pickable,
    at most 9 cm from its centre to its farthest edge at its largest, at least 3.5 cm tall at its smallest."""
    if not c.pickable:
        return False
    lo, hi = c.size_range_m
    small, big = build_shape(c.shape, lo), build_shape(c.shape, hi)
    return big.footprint_radius <= 0.09 and small.hi[2] - small.lo[2] >= 0.035


BODIES.register("ep")(
    SimBody(
        name="ep",
        called="the EP-like robot",
        joints=robot_ep.EP_JOINTS,
        camera=robot_ep.CAMERA,
        geometry=robot_ep.EP,
        range_max=robot_ep.RANGE_MAX,
        head=False,
        depth=False,
        beam_in_view=False,
        scripted=False,
        build=robot_ep.add_ep_robot,
        rest=lambda head, arm, open_: {
            **robot_ep.arm_targets(*robot_ep.EP.rest),  # the arm in its zero pose, the camera looking ahead
            "finger_l": open_,
            "finger_r": open_,
        },
        arm=_ep_arm,
        reported=_ep_reported,
        head_angles=lambda q: (0.0, robot_ep.camera_tilt(q)),  # it has no pan
        on_floor=True,
        layouts=("household", "triplet"),
        layouts_why="its grid is seen from above, on a table the EP's gripper does not reach",
        holds=_ep_holds,
        holds_fix="choose narrower categories that stand at least 3.5 cm tall (a can, a mug, an apple, ...)",
    )
)
