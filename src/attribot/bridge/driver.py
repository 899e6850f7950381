"""What a robot gives the bridge: its `Driver` (the robot's own calls, in the bridge's units) and the
`CameraFrame` its camera returns. A robot's driver subclasses `Driver` and overrides what it can do; the
server (`server.py`) wraps every driver in the same safety.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

__all__ = ["CameraFrame", "Driver"]

_ANY_TRAVEL = {
    "lift": (-10.0, 10.0),  # a robot that states no body: still no arm reaches 10 m
    "extension": (-10.0, 10.0),
    "pan": (-math.pi, math.pi),
    "tilt": (-math.pi / 2, math.pi / 2),
}


class CameraFrame:
    """What a driver's camera gives: JPEG bytes, capture time, optional depth / segmentation / objects, and
    optionally where the robot sees its own body (`own_body`: bool [H, W], from its joint angles and model:
    the host's detectors set aside a box on the gripper)."""

    def __init__(
        self,
        jpeg: bytes,
        timestamp: float,
        depth: np.ndarray | None = None,
        segmentation: np.ndarray | None = None,
        objects: list[dict[str, Any]] | None = None,
        own_body: np.ndarray | None = None,
    ) -> None:
        self.jpeg = jpeg
        self.timestamp = timestamp
        self.depth = depth
        self.segmentation = segmentation
        self.objects = objects
        self.own_body = own_body


class Driver:
    """The robot's own calls, in the bridge's units (metres, radians, seconds, newtons).

    `realtime` drivers run on the wall clock (`step` waits); simulated ones advance their clock in `step`.
    A driver lists what it can do in `capabilities()` (the names of `attribot.embodiments.base.Capability`)
    and overrides those calls; `stop()` must halt the base and hold the arm where it is. Sensors beyond the
    camera, the rangefinder and the force sensor (an infrared thermometer, a gripper that measures how hard
    it squeezes, a lab's own: the names of `attribot.sensors`) are listed in `sensors()` and read with
    `read_sensor(name)`; a driver with none lists none, as drivers written before them do.
    """

    name = "driver"
    realtime = True

    def capabilities(self) -> list[str]:
        return []

    def camera(self) -> dict[str, float]:
        """Intrinsics: width, height, fx, fy, cx, cy (pixels)."""
        raise NotImplementedError

    def body(self) -> dict[str, Any] | None:
        """The body geometry a perception-driven controller needs (the fields of
        `attribot.control.body.BodyGeometry`: camera_xyz, arm_xy, reach0, arm_range, lift_range, base_half,
        finger_open; metres, base frame), or None when the robot does not state it."""
        return None

    def travel(self) -> dict[str, tuple[float, float]]:
        """Each actuator target's travel, [low, high] in the request's unit: `lift` and `extension` (metres,
        from the body's lift_range and arm_range when it states a body), `pan` and `tilt` (radians; a
        head's default: any heading, and from straight down to straight up). The server clips targets
        into these and refuses those further out than ``requests.TRAVEL_TOLERANCE`."""
        out = dict(_ANY_TRAVEL)
        body = self.body()
        if body is not None:
            for name, field in (("lift", "lift_range"), ("extension", "arm_range")):
                low, high = body[field]
                out[name] = (float(low), float(high))
        return out

    def frame(self) -> CameraFrame:
        raise NotImplementedError

    def clock(self) -> float:
        return time.monotonic()

    def step(self, seconds: float) -> None:
        time.sleep(seconds)

    def drive(self, vx: float, vy: float, wz: float) -> None:
        raise NotImplementedError

    def set_head(self, pan: float, tilt: float) -> None:
        raise NotImplementedError

    def set_arm(self, lift: float, extension: float) -> None:
        raise NotImplementedError

    def grasp(self) -> bool:
        raise NotImplementedError

    def release(self) -> None:
        raise NotImplementedError

    def distance(self) -> float:
        raise NotImplementedError

    def tare_force(self) -> None:
        raise NotImplementedError

    def force(self) -> list[float]:
        raise NotImplementedError

    def pose(self) -> list[float]:
        raise NotImplementedError

    def sensors(self) -> list[str]:
        """The names of the optional sensors this robot reads with `read_sensor` (stated in its hello)."""
        return []

    def read_sensor(self, name: str) -> float:
        """One reading of the optional sensor `name`, in its unit (NaN: it read nothing)."""
        raise NotImplementedError

    def joints(self) -> dict[str, float]:
        raise NotImplementedError

    def stop(self) -> None:
        """Halt the base and hold the arm: called by the watchdog, on disconnect and on `stop`."""
        self.drive(0.0, 0.0, 0.0)

    def close(self) -> None:
        pass
