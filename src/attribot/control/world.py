"""What the servo controller uses of a world, as a protocol: exactly the calls it makes and nothing more.

This layer knows no world (embodiments sit above it), so the protocol is structural: `MujocoWorld`, the
bridge's `BridgeWorld` and `Ai2ThorWorld` satisfy it by having these members (tests/test_conformance.py
checks that they do), and so does any test fake that has them. A world that cannot do one of them raises
`UnsupportedAction` from it, as `attribot.embodiments.base.Embodiment` does.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Protocol, runtime_checkable

import numpy as np

from attribot.control.body import BodyGeometry
from attribot.frame import CameraInfo, Frame

__all__ = ["BasePose", "ServoWorld", "head_angles"]


class BasePose(Protocol):
    """The base's pose in the world: metres and radians (yaw about up, from the world's x axis)."""

    @property
    def x(self) -> float: ...

    @property
    def y(self) -> float: ...

    @property
    def yaw(self) -> float: ...


@runtime_checkable
class ServoWorld(Protocol):
    """A world or robot as the servo controller drives it: frames, its own joints and pose, its sensors,
    and commands to its head, base, arm and gripper; never the simulator's objects."""

    name: str

    def capabilities(self) -> Collection[str]:
        """What the robot has (camera, head, base, pose, arm, gripper, distance, force...)."""
        ...

    def camera_info(self) -> CameraInfo:
        """The camera's pinhole intrinsics."""
        ...

    def observe(self) -> Frame:
        """A new frame: RGB, and depth when the robot has it."""
        ...

    def step(self, seconds: float) -> None:
        """Let `seconds` pass (sim time in the simulator, wall time on a robot)."""
        ...

    def set_head(self, pan: float, tilt: float) -> None:
        """Command the camera head's pan and tilt, radians (left and up positive)."""
        ...

    def command_base(self, vx: float, vy: float, wz: float) -> None:
        """Command the base's velocity in its own frame: m/s forward and left, rad/s about up."""
        ...

    def set_arm(self, lift: float, extension: float) -> None:
        """Command the lift's height and the arm's extension, metres."""
        ...

    def grasp(self) -> bool:
        """Close the gripper; whether it closed on something."""
        ...

    def release(self) -> None:
        """Open the gripper."""
        ...

    def read_distance(self) -> float:
        """The rangefinder along the optical axis, metres (inf when it sees nothing)."""
        ...

    def read_force(self) -> np.ndarray:
        """The wrist's force, newtons, (3,) in the world frame."""
        ...

    def joint_states(self) -> dict[str, float]:
        """Joint positions by name: head_pan and head_tilt (a head), lift and arm (the grip point's height
        and extension), upper_arm and forearm (an arm that carries the camera), gripper."""
        ...

    def base_pose(self) -> BasePose:
        """The base's pose by odometry."""
        ...

    def body(self) -> BodyGeometry:
        """Where the camera is for each pose of the joints and how far the arm reaches."""
        ...


def head_angles(world: ServoWorld) -> tuple[float, float]:
    """The head's `(pan, tilt)` now, radians."""
    js = world.joint_states()
    return float(js["head_pan"]), float(js["head_tilt"])
