"""The low-level contract every world and real robot implements.

An embodiment says what it can do (`capabilities()`) before it is asked. Every method that needs a
capability the embodiment lacks raises `UnsupportedAction` naming it: the defaults below do exactly that,
and an implementation overrides what it supports. Units: metres, radians, seconds, newtons.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np

from attribot.control.body import BodyGeometry
from attribot.errors import UnsupportedAction
from attribot.frame import CameraInfo, Frame
from attribot.registry import Registry
from attribot.sensors import SENSORS, reading_in, sensors_read_in

__all__ = ["Capability", "Pose2D", "Embodiment", "EMBODIMENTS", "UnsupportedAction"]


class Capability(StrEnum):
    CAMERA = "camera"  # RGB frames
    DEPTH = "depth"  # depth layer in frames
    SEGMENTATION = "segmentation"  # segmentation + object truth in frames (simulators)
    BASE = "base"  # holonomic base velocity commands
    HEAD = "head"  # pan/tilt camera head
    ARM = "arm"  # lift and telescoping arm targets
    GRIPPER = "gripper"  # grasp and release
    DISTANCE = "distance"  # rangefinder along the optical axis
    FORCE = "force"  # wrist force/torque sensor
    POSE = "pose"  # base pose and joint states


@dataclass(frozen=True)
class Pose2D:
    """Base pose in the world frame: metres and radians (yaw counter-clockwise from +x)."""

    x: float
    y: float
    yaw: float


class Embodiment:
    """Base class of worlds and robots. Override what you support and list it in `capabilities()`."""

    name: str = "embodiment"

    def capabilities(self) -> frozenset[Capability]:
        return frozenset()

    def sensors(self) -> frozenset[str]:
        """The names of the sensors (`attribot.sensors.SENSORS`) this world offers a robot: by default those
        read through a capability it has (camera, distance, force) and those it has a registered reading of
        (`attribot.sensors.register_reading` under its `name`)."""
        caps = {str(c) for c in self.capabilities()}
        return sensors_read_in(self.name) | frozenset(
            name for name, s in SENSORS.items() if s.capability is not None and s.capability in caps
        )

    def _unsupported(self, capability: Capability, what: str) -> UnsupportedAction:
        return UnsupportedAction(
            f"{self.name} cannot {what}: it has no {capability.value!s} capability",
            f"available here: {', '.join(sorted(c.value for c in self.capabilities())) or 'nothing'}",
        )

    def require(self, capability: Capability, what: str) -> None:
        """Raise `UnsupportedAction` unless this embodiment has `capability`."""
        if capability not in self.capabilities():
            raise self._unsupported(capability, what)

    # --- camera -----------------------------------------------------------------------------------
    def observe(self) -> Frame:
        """The current camera frame, with depth and segmentation where the world has them."""
        raise self._unsupported(Capability.CAMERA, "take a camera frame")

    def camera_info(self) -> CameraInfo:
        raise self._unsupported(Capability.CAMERA, "describe its camera")

    # --- time and motion --------------------------------------------------------------------------
    def step(self, seconds: float) -> None:
        """Advance the world (or wait on a real robot) by `seconds`, holding the last commands."""
        raise self._unsupported(Capability.BASE, "advance time")

    def world_time(self) -> float | None:
        """Seconds of world time since the world was built (simulated seconds in a simulator); None where
        the world keeps no clock of its own (a real robot's time is the wall clock)."""
        return None

    def command_base(self, vx: float, vy: float, wz: float) -> None:
        """Base velocity in the robot frame: forward m/s, left m/s, counter-clockwise rad/s."""
        raise self._unsupported(Capability.BASE, "drive its base")

    def set_head(self, pan: float, tilt: float) -> None:
        """Head targets in radians: pan left positive, tilt up positive."""
        raise self._unsupported(Capability.HEAD, "move a camera head")

    def set_arm(self, lift: float, extension: float) -> None:
        """Arm targets in metres: the grip point's height above the floor (the lift's) and its extension
        beyond where `body().reach_x(0)` puts it."""
        raise self._unsupported(Capability.ARM, "move an arm")

    def grasp(self) -> bool:
        """Close the gripper; True when an object is now held."""
        raise self._unsupported(Capability.GRIPPER, "grasp")

    def release(self) -> None:
        raise self._unsupported(Capability.GRIPPER, "release")

    # --- sensors ----------------------------------------------------------------------------------
    def read_distance(self) -> float:
        """Rangefinder along the camera's optical axis, metres; `inf` when nothing is in range."""
        raise self._unsupported(Capability.DISTANCE, "measure distance")

    def tare_force(self) -> None:
        """Zero the wrist force sensor with what it holds now."""
        raise self._unsupported(Capability.FORCE, "tare a force sensor")

    def read_force(self) -> np.ndarray:
        """Wrist force in newtons, (3,) in the world frame, relative to the last tare."""
        raise self._unsupported(Capability.FORCE, "measure force")

    def read_sensor(self, name: str) -> float:
        """One reading of the sensor `name` (one `sensors()` lists beyond the camera, rangefinder and force
        sensor), in the sensor's unit; what the reading needs (the camera centred on the object, the object
        in the gripper) is the caller's to arrange. By default: the reading registered for this world
        (`attribot.sensors.register_reading`)."""
        read = reading_in(self.name, name)
        if read is not None:
            return float(read(self))
        raise UnsupportedAction(
            f"{self.name} cannot read a {name} sensor: it has none",
            f"its sensors: {', '.join(sorted(self.sensors())) or 'none'}",
        )

    def body(self) -> BodyGeometry:
        """Where the camera sits and how far the arm reaches: what a perception-driven controller needs to
        act on what it sees."""
        raise self._unsupported(Capability.ARM, "state its body geometry")

    def base_pose(self) -> Pose2D:
        raise self._unsupported(Capability.POSE, "report its base pose")

    def joint_states(self) -> dict[str, float]:
        raise self._unsupported(Capability.POSE, "report joint states")

    def snapshot(self) -> Any:
        """The robot's own state now (pose, head, arm, gripper), for `restore`; None where the world cannot
        put its robot back (a real robot: a retry then starts from where it is, and says so)."""
        return None

    def restore(self, snapshot: Any) -> None:
        """Put the robot back into the state of `snapshot`; objects stay where they are."""
        raise self._unsupported(Capability.POSE, "put its robot back where it started")

    def close(self) -> None:
        """Free renderers, sockets and threads. Safe to call twice."""

    def __enter__(self) -> Embodiment:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


EMBODIMENTS: Registry[type[Embodiment]] = Registry(
    "world",
    homes={
        "mujoco": "attribot.embodiments.mujoco",
        "sim": "attribot.embodiments.mujoco",
        "bridge": "attribot.embodiments.bridge",
        "ai2thor": "attribot.embodiments.ai2thor",
    },
)
