"""The RoboMaster EP's body, as its bridge driver states it in the hello (and as the simulator's EP-like robot
is built): where the camera on the arm is for each pose of the arm, how far the gripper reaches, how big
the chassis is. Metres and radians, in the base frame (x forward, y left, z up, origin on the floor under
the chassis's centre); the fields are those of `attribot.control.body.BodyGeometry`.

Sources (docs/bridge-protocol.md, "The RoboMaster EP's body", says which number comes from which, and how a
lab measures the ones no document gives):
- DJI's documented figures: the arm's end point moves 0.22 m horizontally and 0.15 m vertically, on 2
  axes; the gripper opens about 10 cm (SDK docs, docs/source/extension_module/robotic_arm_and_gripper.rst);
  the ToF sensor measures 0.1 to 10 m in a 20-degree cone (extension_module/ir_distance_sensor.rst and the
  EP's specifications); the chassis is 320 x 240 mm (the EP's specifications); `robotic_arm.moveto(x, y)`
  takes the end point in millimetres, x forward and y up (src/robomaster/robotic_arm.py).
- Estimated, not documented: the two links (0.12 m each), the servo limits and the arm's zero pose from the
  RoboMaster simulator that reproduces the SDK (jeguzzi/robomaster_sim, include/robot/arm.hpp and
  src/robot/arm.cpp); the shoulder, the camera's mount on the forearm and the gripper's fingertips from
  the EP's description (jeguzzi/robomaster_ros, robomaster_description/urdf/arm.urdf.xacro,
  camera.urdf.xacro, gripper.urdf.xacro). The ToF's place is ours: on the gripper, between the fingers'
  roots, looking along them (the beam is then at the grip point's height).

Python 3.8 and the standard library only: the robot's computer imports it.
"""

from __future__ import annotations

from typing import Any

__all__ = ["EP_BODY", "EP_ARM", "to_sdk_mm", "from_sdk_mm", "EP_CAMERA_HFOV_DEG", "EP_RANGE_MAX_M"]

_SHOULDER = (0.0104, 0.156)  # the upper arm's axis: 0.1253 m (arm platform) + 0.0307 m above the floor
_LINK = 0.12  # each link of the parallel arm
_GRIP = (0.07, -0.04)  # between the fingertips, from the forearm's tip (the bracket's axis)

EP_ARM: dict[str, Any] = {
    "shoulder": _SHOULDER,
    "links": (_LINK, _LINK),
    # the servos' limits, as link elevations: upper arm 8.7 to 103.7 degrees, forearm -127.7 to 17.3,
    # and the parallel link keeps upper - fore between 46.9 and 136.4 degrees
    "upper_range": (0.152, 1.810),
    "fore_range": (-2.229, 0.302),
    "bend_range": (0.819, 2.381),
    "grip": _GRIP,
    "camera": (-0.017, 0.044),  # on the forearm, just ahead of the elbow and 4.4 cm above it
    "camera_pitch": 0.41,  # looking 23.5 degrees above the forearm: 5 degrees down at the zero pose
    "rangefinder": (-0.02, 0.0),  # between the fingers' roots, looking along them
    "y": 0.0,
}

_REACH_MIN = 0.19  # the grip point's x at extension 0: the ToF just ahead of the chassis's front

EP_BODY: dict[str, Any] = {
    "camera_xyz": (0.0205, 0.0, 0.323),  # at the zero pose of the arm
    "arm_xy": (_SHOULDER[0], 0.0),
    "reach0": _REACH_MIN - _SHOULDER[0],
    "arm_range": (0.0, 0.065),  # grip x from 0.19 to 0.255 m: within reach from 0.03 to 0.22 m up
    "lift_range": (0.03, 0.22),
    "base_half": (0.16, 0.12),
    "finger_open": 0.05,
    "arm": EP_ARM,
    "rest": (0.1787, 0.0),  # the zero pose (the SDK's power-on pose): both servos at 0
}

EP_CAMERA_HFOV_DEG = 96.0  # the driver's calibrated default (DJI states 120 degrees for the photo)
EP_RANGE_MAX_M = 10.0  # the ToF's documented range


def to_sdk_mm(lift: float, extension: float) -> tuple[float, float]:
    """`robotic_arm.moveto` coordinates (x forward, y up, millimetres) of the grip point at `lift` metres
    up and `extension` metres out: the SDK moves the forearm's tip, measured from the shoulder."""
    x = EP_BODY["arm_xy"][0] + EP_BODY["reach0"] + extension - _GRIP[0] - _SHOULDER[0]
    z = lift - _GRIP[1] - _SHOULDER[1]
    return x * 1000.0, z * 1000.0


def from_sdk_mm(x_mm: float, y_mm: float) -> tuple[float, float]:
    """The grip point's (lift, extension) in metres from the arm's reported position (millimetres)."""
    x = x_mm / 1000.0 + _SHOULDER[0] + _GRIP[0]
    z = y_mm / 1000.0 + _SHOULDER[1] + _GRIP[1]
    return z, x - EP_BODY["arm_xy"][0] - EP_BODY["reach0"]
