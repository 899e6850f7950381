"""A RoboMaster-EP-like robot, added to an `MjSpec`: the EP's body as its bridge driver states it
(`attribot.bridge.robomaster_body.EP_BODY`).

A holonomic base (planar x, y and yaw joints driven by velocity actuators, as the mast robot's) with the EP's
320 x 240 mm chassis, and the EP's two-link arm on top of it: the upper arm on the shoulder, the forearm on
the elbow, and the end bracket on the wrist, held level (the EP's parallel linkage does it with rods; here
the wrist's servo is commanded to cancel the other two). The camera rides on the forearm, so it rises, dips
and pitches with the arm; the gripper (two fingers, about 10 cm open) hangs under the bracket; the ToF
sensor sits between the fingers' roots, its beam level along the fingers; a force sensor at
the bracket (the EP has none: it stands for the load cell of docs/bridge-protocol.md) feels what the
gripper holds. There is no camera head and no depth camera.

Joint angles: `upper_arm` is the upper arm's elevation above the base's forward axis, `elbow` the forearm's
angle from the upper arm (so the forearm's elevation is their sum) and `wrist` the bracket's angle from the
forearm. As with the mast robot, only the base collides; the arm and gripper pass through things and a grasp
is a weld made when the closing fingers touch an object.

The module registers the body as "ep" in `attribot.sim.bodies.BODIES`, so that only a scene that asks for
this robot imports it (and the bridge's record of the EP it reads).
"""

from __future__ import annotations

import math

import mujoco

from attribot.bridge.robomaster_body import EP_BODY, EP_CAMERA_HFOV_DEG, EP_RANGE_MAX_M
from attribot.control.body import BodyGeometry, TwoLinkArm
from attribot.errors import InputError
from attribot.sim.bodies import BODIES, SimBody
from attribot.sim.catalog import Category
from attribot.sim.robot import camera_quat, position_actuator, rangefinder_sensor, velocity_actuator
from attribot.sim.shapes import build_shape

__all__ = [
    "EP",
    "EP_JOINTS",
    "CAMERA",
    "RANGE_MAX",
    "add_ep_robot",
    "arm_targets",
    "arm_joint_states",
    "camera_tilt",
]

EP = BodyGeometry.from_dict(EP_BODY)
EP_JOINTS = ("base_x", "base_y", "base_yaw", "upper_arm", "elbow", "wrist", "finger_l", "finger_r")
CAMERA = "arm_camera"
RANGE_MAX = EP_RANGE_MAX_M

_DARK = (0.10, 0.10, 0.11, 1.0)
_GRAY = (0.30, 0.31, 0.33, 1.0)
_METAL = (0.55, 0.56, 0.58, 1.0)
_ACCENT = (0.15, 0.55, 0.95, 1.0)  # the EP's blue-lit armour
_PITCH_UP_Y = (0.0, -1.0, 0.0)  # hinges about -y: positive angles raise what they carry


def _arm() -> TwoLinkArm:
    assert EP.arm is not None
    return EP.arm


def _geom(
    body: mujoco.MjsBody,
    kind: mujoco.mjtGeom,
    size: tuple[float, ...],
    pos: tuple[float, float, float],
    rgba: tuple[float, ...],
    mass: float,
    name: str = "",
) -> mujoco.MjsGeom:
    g = body.add_geom(type=kind, size=list(size), pos=list(pos), rgba=list(rgba))
    if name:
        g.name = name
    g.contype = g.conaffinity = 0  # only the base's hidden box collides
    g.group = 1
    g.mass = mass
    return g


def _pitch(angle: float) -> list[float]:
    """A quaternion that pitches a body's +x up by `angle` (about -y)."""
    return [math.cos(angle / 2), 0.0, -math.sin(angle / 2), 0.0]


def _add_base(root: mujoco.MjsBody) -> None:
    bx, by = EP.base_half
    hull = root.add_geom(
        type=mujoco.mjtGeom.mjGEOM_BOX, size=[bx, by, 0.045], pos=[0, 0, 0.085], rgba=[0, 0, 0, 0]
    )
    hull.name = "robot_base"
    hull.contype, hull.conaffinity = 2, 1  # bit 2 = robot; it collides with the world (bit 1) only
    hull.group = 3  # not drawn, not cast against
    hull.mass = 2.4
    box = mujoco.mjtGeom.mjGEOM_BOX
    _geom(root, box, (bx - 0.005, by - 0.045, 0.035), (0, 0, 0.09), _DARK, 0.5)
    _geom(root, box, (bx, by - 0.04, 0.004), (0, 0, 0.127), _ACCENT, 0.05)
    _geom(root, box, (0.05, 0.045, 0.02), (-0.1, 0, 0.14), _GRAY, 0.2)  # the intelligent controller
    for sx in (-1, 1):
        for sy in (-1, 1):
            _geom(
                root,
                mujoco.mjtGeom.mjGEOM_CYLINDER,
                (0.05, 0.0225),
                (sx * 0.1, sy * (by - 0.0225), 0.05),
                _GRAY,
                0.2,
            ).quat = [math.cos(math.pi / 4), math.sin(math.pi / 4), 0, 0]
    shoulder_x, shoulder_z = _arm().shoulder
    height = (shoulder_z - 0.13) / 2 + 0.01
    _geom(root, box, (0.04, 0.05, height), (shoulder_x - 0.01, 0, (shoulder_z + 0.13) / 2), _METAL, 0.3)


def _add_gripper(bracket: mujoco.MjsBody) -> None:
    arm = _arm()
    gx, gz = arm.grip
    box = mujoco.mjtGeom.mjGEOM_BOX
    _geom(bracket, box, (0.015, 0.02, 0.03), (0.0, 0, gz / 2), _METAL, 0.05)  # the bracket plate
    _geom(bracket, box, (0.015, 0.058, 0.015), (gx - 0.045, 0, gz), _DARK, 0.1)  # the palm
    open_ = EP.finger_open
    for side, name in ((1, "finger_l"), (-1, "finger_r")):
        f = bracket.add_body(name=name, pos=[gx - 0.03, 0, gz])
        f.add_joint(
            name=name,
            type=mujoco.mjtJoint.mjJNT_SLIDE,
            axis=[0, side, 0],
            range=[0.0, open_],
            damping=5.0,
            armature=0.05,
        )
        _geom(f, box, (0.03, 0.006, 0.016), (0.03, side * 0.006, 0), _ACCENT, 0.03, name=f"{name}_pad")
    bracket.add_site(name="grip_site", pos=[gx, 0, gz], size=[0.006] * 3, group=4)
    probe = bracket.add_geom(
        name="grip_probe",
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=[0.004, 0, 0],
        pos=[gx, 0, gz],
        rgba=[1, 0, 0, 0],
    )
    probe.contype = probe.conaffinity = 0
    probe.group = 5
    probe.mass = 0.001
    rx, rz = arm.rangefinder
    # the ToF measures along the site's +z: turn z onto the bracket's forward axis (+x)
    bracket.add_site(
        name="range_site",
        pos=[gx + rx, 0, gz + rz],
        quat=[math.cos(math.pi / 4), 0, math.sin(math.pi / 4), 0],
        size=[0.005] * 3,
        group=4,
    )
    _geom(bracket, box, (0.008, 0.012, 0.01), (gx + rx - 0.008, 0, gz + rz), (0.2, 0.2, 0.25, 1.0), 0.01)


def add_ep_robot(spec: mujoco.MjSpec, width: int, height: int) -> None:
    """Add the EP-like robot to `spec` at the world origin; its start pose is set in the data. `width` and
    `height`: the camera's pixels (its horizontal field of view is the EP driver's)."""
    arm = _arm()
    root = spec.worldbody.add_body(name="robot", pos=[0, 0, 0])
    root.add_joint(name="base_x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0], armature=1.0)
    root.add_joint(name="base_y", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 1, 0], armature=1.0)
    root.add_joint(name="base_yaw", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1], armature=0.3)
    _add_base(root)
    upper_len, fore_len = arm.links
    cap = mujoco.mjtGeom.mjGEOM_CAPSULE

    def link(parent: mujoco.MjsBody, name: str, pos: list[float], rng: tuple[float, float]) -> mujoco.MjsBody:
        b = parent.add_body(name=name, pos=pos)
        b.gravcomp = 1.0  # the servos hold the arm's own weight without sag
        b.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(_PITCH_UP_Y), range=list(rng),
                    damping=8.0, armature=0.02)  # fmt: skip
        return b

    upper = link(root, "upper_arm", [arm.shoulder[0], arm.y, arm.shoulder[1]], arm.upper_range)
    _geom(upper, cap, (0.012, upper_len / 2), (upper_len / 2, 0, 0), _METAL, 0.06).quat = _pitch(math.pi / 2)
    elbow_lo, elbow_hi = -arm.bend_range[1], -arm.bend_range[0]
    fore = link(upper, "elbow", [upper_len, 0, 0], (elbow_lo, elbow_hi))
    _geom(fore, cap, (0.011, fore_len / 2), (fore_len / 2, 0, 0), _DARK, 0.08).quat = _pitch(math.pi / 2)
    along, up = arm.camera
    cam = fore.add_body(name="camera_mount", pos=[along, 0, up], quat=_pitch(arm.camera_pitch))
    _geom(cam, mujoco.mjtGeom.mjGEOM_BOX, (0.02, 0.022, 0.015), (-0.022, 0, 0), _DARK, 0.03)
    fovy = 2 * math.degrees(math.atan(math.tan(math.radians(EP_CAMERA_HFOV_DEG) / 2) * height / width))
    cam.add_camera(name=CAMERA, pos=[0, 0, 0], quat=list(camera_quat()), fovy=fovy)
    lo, hi = arm.fore_range
    bracket = link(fore, "wrist", [fore_len, 0, 0], (-hi, -lo))  # grasps weld objects to the bracket
    bracket.add_site(name="ft_site", pos=[0, 0, 0], size=[0.01] * 3, group=4)
    _add_gripper(bracket)
    _add_actuators(spec)
    _add_sensors(spec)


def _add_actuators(spec: mujoco.MjSpec) -> None:
    arm = _arm()
    velocity_actuator(spec, "base_x", 120.0, 150.0)
    velocity_actuator(spec, "base_y", 120.0, 150.0)
    velocity_actuator(spec, "base_yaw", 20.0, 40.0)
    position_actuator(spec, "upper_arm", 400.0, arm.upper_range, 40.0)
    position_actuator(spec, "elbow", 400.0, (-arm.bend_range[1], -arm.bend_range[0]), 40.0)
    position_actuator(spec, "wrist", 200.0, (-arm.fore_range[1], -arm.fore_range[0]), 20.0)
    position_actuator(spec, "finger_l", 300.0, (0.0, EP.finger_open), 30.0)
    position_actuator(spec, "finger_r", 300.0, (0.0, EP.finger_open), 30.0)


def _add_sensors(spec: mujoco.MjSpec) -> None:
    rangefinder_sensor(spec)
    for name, kind in (
        ("wrist_force", mujoco.mjtSensor.mjSENS_FORCE),
        ("wrist_torque", mujoco.mjtSensor.mjSENS_TORQUE),
    ):
        spec.add_sensor(name=name, type=kind, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="ft_site")


def arm_targets(lift: float, extension: float) -> dict[str, float]:
    """The joint targets that put the grip point at `lift` metres up and `extension` metres out (as near as
    the arm reaches), the bracket level."""
    upper, fore = _arm().nearest(EP.reach_x(extension), lift)
    return {"upper_arm": upper, "elbow": fore - upper, "wrist": -fore}


def arm_joint_states(q: dict[str, float]) -> dict[str, float]:
    """What the EP-like robot reports of its arm: each link's elevation, and where the grip point is (its
    lift and extension)."""
    upper, fore = q["upper_arm"], q["upper_arm"] + q["elbow"]
    x, z = _arm().grip_point(upper, fore)
    return {"upper_arm": upper, "forearm": fore, "lift": z, "arm": x - EP.reach_x(0.0)}


def camera_tilt(q: dict[str, float]) -> float:
    """The camera's pitch now (it has no pan)."""
    return float(q["upper_arm"] + q["elbow"] + _arm().camera_pitch)


# ---- the RoboMaster-EP-like robot: its camera on a two-link arm, a gripper that reaches the floor ----


def _ep_arm(lift: float, extension: float) -> dict[str, float]:
    if not (math.isfinite(lift) and math.isfinite(extension)):
        raise InputError(f"arm target {(lift, extension)} is not finite", "give finite numbers")
    return arm_targets(lift, extension)


def _ep_reported(q: dict[str, float]) -> dict[str, float]:
    """The base's joints, and the arm as the EP reports it: its links' elevations and its grip point."""
    return {n: v for n, v in q.items() if n.startswith("base")} | arm_joint_states(q)


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
        joints=EP_JOINTS,
        camera=CAMERA,
        geometry=EP,
        range_max=RANGE_MAX,
        head=False,
        depth=False,
        beam_in_view=False,
        scripted=False,
        build=add_ep_robot,
        rest=lambda head, arm, open_: {
            **arm_targets(*EP.rest),  # the arm in its zero pose, the camera looking ahead
            "finger_l": open_,
            "finger_r": open_,
        },
        arm=_ep_arm,
        reported=_ep_reported,
        head_angles=lambda q: (0.0, camera_tilt(q)),  # it has no pan
        on_floor=True,
        layouts=("household", "triplet"),
        layouts_why="its grid is seen from above, on a table the EP's gripper does not reach",
        holds=_ep_holds,
        holds_fix="choose narrower categories that stand at least 3.5 cm tall (a can, a mug, an apple, ...)",
    )
)
