"""The robot bodies the simulator builds and drives, as registered records (`SceneConfig(robot=...)`).

A `SimBody` holds what differs from one body to another, so that the world, its scenes and the embodiment
read a field instead of comparing the robot's name: how it is built into the MuJoCo model, its joints and
camera, what it reports of its arm and head, its geometry as a controller is told it, what it has (a camera
head, a depth camera) and its scenes' limits (whether its gripper reaches only the floor, the layouts made
for it, what it can hold). The mast robot (`attribot.sim.robot`) is registered here, the RoboMaster-EP-like
one where it is built (`attribot.sim.robot_ep`, imported only for a scene that asks for it); another body is
one more registration, and a built-in one a line in `BODIES`' homes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from attribot.control.body import BodyGeometry
from attribot.errors import InputError
from attribot.registry import Registry
from attribot.sim.catalog import Category
from attribot.sim.robot_geometry import GEOMETRY, JOINTS

if TYPE_CHECKING:
    import mujoco

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


BODIES: Registry[SimBody] = Registry(
    "robot body", homes={"mast": "attribot.sim.bodies", "ep": "attribot.sim.robot_ep"}
)
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

_MAST = GEOMETRY


def _mast_rest(head: tuple[float, float], arm: tuple[float, float], open_: float) -> dict[str, float]:
    (pan, tilt), (lift, extension) = head, arm
    return {"head_pan": pan, "head_tilt": tilt, "lift": lift, "arm": extension, "finger_l": open_,
            "finger_r": open_}  # fmt: skip


def _build_mast(spec: mujoco.MjSpec, width: int, height: int) -> None:
    from attribot.sim.robot import (
        add_robot,  # MuJoCo's code, loaded when a model is built, not to check a config
    )

    add_robot(spec)


BODIES.register("mast")(
    SimBody(
        name="mast",
        called="the mast robot",
        joints=JOINTS,
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
        build=_build_mast,
        rest=_mast_rest,
        arm=lambda lift, extension: {"lift": lift, "arm": extension},
        reported=dict,
        head_angles=lambda q: (q["head_pan"], q["head_tilt"]),
    )
)
