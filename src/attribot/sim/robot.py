"""The simulated mobile manipulator, added to an `MjSpec`.

A holonomic base (like the RoboMaster EP: planar x, y and yaw joints driven by velocity actuators), a mast
with a pan-tilt head carrying the camera and a rangefinder along its optical axis, and a lift with a
telescoping arm and a two-finger gripper (like a Hello Robot Stretch). A force/torque sensor sits at the
wrist, between the arm and the gripper, so that it feels the weight of whatever the gripper holds.

Robot frame: x forward, y left, z up. Head convention (as `Embodiment.set_head`): pan about the base's up
axis, left positive; tilt about the panned left axis, up positive; at (0, 0) the optical axis points
along the base's forward axis. The camera's optical centre lies on both head axes, so pointing by
geometry has no parallax.

Only the base collides (with furniture, walls and floor objects); the arm and gripper pass through
things, and a grasp is a weld constraint made when the closing fingers touch an object. The weight the
wrist sensor reads still comes from the physics: the weld carries the object's load into the wrist.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from attribot.sim.robot_geometry import GEOMETRY, JOINTS, RobotGeometry

__all__ = [
    "RobotGeometry",
    "GEOMETRY",
    "add_robot",
    "JOINTS",
    "camera_quat",
    "position_actuator",
    "rangefinder_sensor",
    "velocity_actuator",
]


_GRAY = (0.35, 0.36, 0.38, 1.0)
_DARK = (0.12, 0.12, 0.13, 1.0)
_ACCENT = (0.95, 0.55, 0.10, 1.0)
_LIGHT = (0.85, 0.86, 0.88, 1.0)


def camera_quat() -> np.ndarray:
    """Orientation of a MuJoCo camera (looks along -z, y up) whose optical axis is the body's +x."""
    mat = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # columns: camera x, y, z
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, mat.ravel())
    return q


def _box(
    body: mujoco.MjsBody,
    half: tuple[float, float, float],
    pos: tuple[float, float, float],
    rgba: tuple[float, ...],
    collide: bool = False,
    name: str = "",
) -> mujoco.MjsGeom:
    g = body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=list(half), pos=list(pos), rgba=list(rgba))
    if name:
        g.name = name
    # bit 2 = robot; it collides with the world (bit 1) only
    g.contype, g.conaffinity = (2, 1) if collide else (0, 0)
    g.group = 1
    return g


def velocity_actuator(spec: mujoco.MjSpec, joint: str, kv: float, force: float) -> None:
    """A velocity servo on `joint` with gain `kv`, its force limited to +/- `force`."""
    a = spec.add_actuator(name=joint, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    a.set_to_velocity(kv=kv)
    a.forcelimited = True
    a.forcerange = [-force, force]


def position_actuator(
    spec: mujoco.MjSpec, joint: str, kp: float, ctrl: tuple[float, float], force: float
) -> None:
    """A position servo on `joint` with gain `kp`, its target within `ctrl`, its force within +/- `force`."""
    a = spec.add_actuator(name=joint, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    a.set_to_position(kp=kp)
    a.ctrllimited = True
    a.ctrlrange = list(ctrl)
    a.forcelimited = True
    a.forcerange = [-force, force]


def rangefinder_sensor(spec: mujoco.MjSpec) -> None:
    """The rangefinder along the site "range_site", reporting the distance it reads."""
    rf = spec.add_sensor(
        name="rangefinder",
        type=mujoco.mjtSensor.mjSENS_RANGEFINDER,
        objtype=mujoco.mjtObj.mjOBJ_SITE,
        objname="range_site",
    )
    if hasattr(mujoco, "mjtRayDataField"):  # MuJoCo >= 3.4 asks which ray data to report: the distance
        rf.intprm[0] = 1 << int(mujoco.mjtRayDataField.mjRAYDATA_DIST)


def add_robot(spec: mujoco.MjSpec, geometry: RobotGeometry = GEOMETRY) -> None:
    """Add the robot to `spec` at the world origin; its start pose is set in the data (base_x/y/yaw)."""
    root = spec.worldbody.add_body(name="robot", pos=[0, 0, 0])
    _add_base(root, geometry)
    _add_mast(root, geometry)
    _add_head(root, geometry)
    wrist = _add_lift_and_arm(root, geometry)
    _add_gripper(wrist, geometry)
    _add_actuators(spec, geometry)
    _add_sensors(spec)


def _add_base(root: mujoco.MjsBody, g: RobotGeometry) -> None:
    """The holonomic base: planar x, y and yaw joints, the colliding body box, its top plate and wheels."""
    root.add_joint(name="base_x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0], armature=1.0)
    root.add_joint(name="base_y", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 1, 0], armature=1.0)
    root.add_joint(name="base_yaw", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1], armature=0.5)
    bx, by = g.base_half
    base = _box(root, (bx, by, 0.06), (0, 0, 0.09), _DARK, collide=True, name="robot_base")
    base.mass = 18.0
    _box(root, (bx * 0.98, by * 0.98, 0.01), (0, 0, 0.155), _ACCENT)
    for sx in (-1, 1):
        for sy in (-1, 1):
            w = root.add_geom(
                type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                size=[0.05, 0.02],
                pos=[sx * (bx - 0.05), sy * (by + 0.02), 0.05],
                quat=[math.cos(math.pi / 4), math.sin(math.pi / 4), 0, 0],
                rgba=list(_GRAY),
            )
            w.contype = w.conaffinity = 0
            w.group = 1
            w.mass = 0.3


def _add_mast(root: mujoco.MjsBody, g: RobotGeometry) -> None:
    """The mast from the base's top up to just below the head."""
    mx, my = g.mast_xy
    mast = _box(
        root,
        (0.025, 0.025, (g.head_height - 0.2) / 2),
        (mx, my, 0.16 + (g.head_height - 0.2) / 2 - 0.06),
        _LIGHT,
    )
    mast.mass = 2.0


def _add_head(root: mujoco.MjsBody, g: RobotGeometry) -> None:
    """The pan-tilt head on top of the mast, with the camera and the rangefinder at the axes' crossing."""
    # pan about z, tilt about -y (up positive)
    mx, my = g.mast_xy
    pan = root.add_body(name="head_pan", pos=[mx, my, g.head_height])
    pan.add_joint(
        name="head_pan",
        type=mujoco.mjtJoint.mjJNT_HINGE,
        axis=[0, 0, 1],
        range=list(g.pan_range),
        damping=2.0,
        armature=0.05,
    )
    _box(pan, (0.03, 0.03, 0.02), (-0.06, 0, -0.06), _DARK).mass = 0.3  # behind and below: out of view
    tilt = pan.add_body(name="head_tilt", pos=[0, 0, 0])
    # the head's servos hold their weight (as a servo with an integrator would): no steady-state sag
    pan.gravcomp = 1.0
    tilt.gravcomp = 1.0
    tilt.add_joint(
        name="head_tilt",
        type=mujoco.mjtJoint.mjJNT_HINGE,
        axis=[0, -1, 0],
        range=list(g.tilt_range),
        damping=2.0,
        armature=0.05,
    )
    _box(tilt, (0.035, 0.07, 0.025), (-0.045, 0, 0), _DARK).mass = 0.4
    _box(tilt, (0.002, 0.012, 0.012), (-0.009, 0.03, 0.0), (0.2, 0.2, 0.5, 1.0))
    tilt.add_camera(name="head_camera", pos=[0, 0, 0], quat=list(camera_quat()), fovy=g.fovy_deg)
    # rangefinder measures along the site's +z: turn z onto the optical axis (+x)
    tilt.add_site(
        name="range_site",
        pos=[0, 0, 0],
        quat=[math.cos(math.pi / 4), 0, math.sin(math.pi / 4), 0],
        size=[0.005, 0.005, 0.005],
        group=4,
    )


def _add_lift_and_arm(root: mujoco.MjsBody, g: RobotGeometry) -> mujoco.MjsBody:
    """The lift carriage on the mast and the telescoping arm forward from it; returns the wrist body."""
    mx, my = g.mast_xy
    lo, hi = g.lift_range
    carriage = root.add_body(name="carriage", pos=[mx, my, 0])
    carriage.add_joint(
        name="lift",
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=[0, 0, 1],
        range=[lo, hi],
        damping=300.0,
        armature=2.0,
    )
    _box(carriage, (0.045, 0.045, 0.05), (0, 0, 0), _GRAY).mass = 1.0
    sleeve_len = g.arm_reach0 - 0.06
    _box(carriage, (sleeve_len / 2, 0.025, 0.02), (0.04 + sleeve_len / 2, 0, 0), _LIGHT).mass = 0.6
    arm = carriage.add_body(name="arm_link", pos=[0, 0, 0])
    arm.add_joint(
        name="arm",
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=[1, 0, 0],
        range=list(g.arm_range),
        damping=150.0,
        armature=1.0,
    )
    _box(arm, (sleeve_len / 2, 0.02, 0.015), (0.06 + sleeve_len / 2, 0, 0), _GRAY).mass = 0.5
    return arm.add_body(name="wrist", pos=[g.arm_reach0, 0, 0])


def _add_gripper(wrist: mujoco.MjsBody, g: RobotGeometry) -> None:
    """The wrist's force/torque site and housing, two sliding fingers, and the grip point between them."""
    wrist.add_site(name="ft_site", pos=[0, 0, 0], size=[0.01, 0.01, 0.01], group=4)
    _box(wrist, (0.02, 0.03, 0.03), (0.0, 0, 0), _DARK).mass = 0.2
    _box(wrist, (0.01, 0.075, 0.02), (0.025, 0, 0), _GRAY).mass = 0.1
    for side, name in ((1, "finger_l"), (-1, "finger_r")):
        f = wrist.add_body(name=name, pos=[0.035, 0, 0])
        f.add_joint(
            name=name,
            type=mujoco.mjtJoint.mjJNT_SLIDE,
            axis=[0, side, 0],
            range=list(g.finger_range),
            damping=5.0,
            armature=0.05,
        )
        _box(f, (0.045, 0.006, 0.022), (0.045, side * 0.006, 0), _ACCENT, name=f"{name}_pad").mass = 0.05
    wrist.add_site(name="grip_site", pos=[g.grip_offset, 0, 0], size=[0.008, 0.008, 0.008], group=4)
    # an invisible probe between the fingertips: grasping measures distances from it, it touches nothing
    probe = wrist.add_geom(
        name="grip_probe",
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=[0.004, 0, 0],
        pos=[g.grip_offset, 0, 0],
        rgba=[1, 0, 0, 0],
    )
    probe.contype = probe.conaffinity = 0
    probe.group = 5
    probe.mass = 0.001


def _add_actuators(spec: mujoco.MjSpec, g: RobotGeometry) -> None:
    """Velocity servos on the base's joints, position servos on the head, lift, arm and fingers."""
    for joint, kv, force in (("base_x", 400.0, 400.0), ("base_y", 400.0, 400.0), ("base_yaw", 80.0, 150.0)):
        velocity_actuator(spec, joint, kv, force)
    for joint, kp, ctrl, force in (
        ("head_pan", 30.0, g.pan_range, 20.0),
        ("head_tilt", 30.0, g.tilt_range, 20.0),
        ("lift", 6000.0, g.lift_range, 600.0),
        ("arm", 2500.0, g.arm_range, 300.0),
        ("finger_l", 300.0, g.finger_range, 30.0),
        ("finger_r", 300.0, g.finger_range, 30.0),
    ):
        position_actuator(spec, joint, kp, ctrl, force)


def _add_sensors(spec: mujoco.MjSpec) -> None:
    """The rangefinder, then the wrist's force and torque at "ft_site"."""
    rangefinder_sensor(spec)
    for name, kind in (
        ("wrist_force", mujoco.mjtSensor.mjSENS_FORCE),
        ("wrist_torque", mujoco.mjtSensor.mjSENS_TORQUE),
    ):
        spec.add_sensor(name=name, type=kind, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="ft_site")
