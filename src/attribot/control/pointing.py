"""Geometric pointing: turn a pan/tilt camera head so that the image centre falls on a box.

The ray through the box centre is computed from the pinhole intrinsics of the capture, rotated by the
head angles at capture into the base frame, and the head is commanded to the pan/tilt that aligns the
optical axis with it; then the world is stepped until the head settles. The rangefinder, which looks
along the optical axis, then reads what lies at the box centre. This is open loop: it assumes the optical
centre sits on the pan/tilt axes (the parallax of a few centimetres is ignored) and that the base has not
moved since the capture (it refuses when it has).

Head convention (as `Embodiment.set_head`): pan about the base's up axis, left positive; tilt about the
panned left axis, up positive; at (0, 0) the optical axis points along the base's forward axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from attribot.control.base import (
    CONTROLLERS,
    ControlError,
    Target,
    UnsupportedController,
    angle_close,
    not_available,
)
from attribot.frame import CameraInfo

__all__ = ["PointingController", "pan_tilt_towards", "pixel_ray"]


def pixel_ray(camera: CameraInfo, u: float, v: float) -> tuple[float, float, float]:
    """Unit ray through pixel `(u, v)` (y down) as `(forward, left, up)` in the camera's head frame.

    >>> cam = CameraInfo(width=640, height=480, fx=500.0, fy=500.0, cx=320.0, cy=240.0)
    >>> pixel_ray(cam, 320.0, 240.0)
    (1.0, 0.0, 0.0)
    """
    f, left, up = 1.0, -(u - camera.cx) / camera.fx, -(v - camera.cy) / camera.fy
    n = math.sqrt(f * f + left * left + up * up)
    return f / n, (left / n) + 0.0, (up / n) + 0.0


def pan_tilt_towards(
    camera: CameraInfo, head: tuple[float, float], u: float, v: float
) -> tuple[float, float]:
    """Head `(pan, tilt)` radians that put pixel `(u, v)` of an image taken at `head` on the optical axis.

    >>> cam = CameraInfo(width=640, height=480, fx=320.0, fy=320.0, cx=320.0, cy=240.0)
    >>> pan, tilt = pan_tilt_towards(cam, (0.0, 0.0), 0.0, 240.0)   # left edge: 45 degrees to the left
    >>> round(math.degrees(pan), 6), round(math.degrees(tilt), 6)
    (45.0, 0.0)
    """
    pan0, tilt0 = head
    f, left, up = pixel_ray(camera, u, v)
    # tilt (pitch up) about the head's left axis, then pan (yaw left) about the base's up axis
    f1 = f * math.cos(tilt0) - up * math.sin(tilt0)
    u1 = f * math.sin(tilt0) + up * math.cos(tilt0)
    f2 = f1 * math.cos(pan0) - left * math.sin(pan0)
    l2 = f1 * math.sin(pan0) + left * math.cos(pan0)
    return math.atan2(l2, f2), math.atan2(u1, math.hypot(f2, l2))


@dataclass
class PointingController(UnsupportedController):
    """Focuses the camera by geometry (see the module docstring); every other action is unsupported.

    step_s: simulated (or waited) seconds per settling step; timeout_s: give up after this long;
    tol_rad: how close the head must come to the commanded angles; base_tol: metres / radians of base
    motion since the capture beyond which the box no longer says where to look.
    """

    name: str = "pointing"
    step_s: float = 0.05
    timeout_s: float = 6.0
    tol_rad: float = 3e-3
    base_tol: float = 0.01

    def focus_on(self, target: Target) -> None:
        cap = target.capture
        if cap.camera is None or cap.head is None:
            raise not_available(
                "focus_on_patch",
                self._world_name,
                "the image was taken without known intrinsics or head angles",
            )
        caps = {str(c) for c in self.world.capabilities()}
        if "head" not in caps:
            raise not_available("focus_on_patch", self._world_name, "it has no pan/tilt camera head")
        self._check_base(cap.base, caps)
        pan, tilt = pan_tilt_towards(cap.camera, cap.head, *target.center)
        self.world.set_head(pan, tilt)
        self._settle(pan, tilt, target)

    def _check_base(self, base: tuple[float, float, float] | None, caps: set[str]) -> None:
        if base is None or "pose" not in caps:
            return
        now = self.world.base_pose()
        moved = math.hypot(now.x - base[0], now.y - base[1])
        if moved > self.base_tol or not angle_close(now.yaw, base[2], self.base_tol):
            raise ControlError(
                f"the robot has moved {moved:.2f} m since this image was taken, so its boxes no longer say "
                "where to look",
                "measure distances (focus_on_patch, measure_distance) before go_to_object or go_to_coords",
            )

    def _settle(self, pan: float, tilt: float, target: Target) -> None:
        last: tuple[float, float] | None = None
        elapsed = 0.0
        while elapsed < self.timeout_s:
            self.world.step(self.step_s)
            elapsed += self.step_s
            now = _head(self.world)
            if angle_close(now[0], pan, self.tol_rad) and angle_close(now[1], tilt, self.tol_rad):
                return
            if (
                elapsed >= 0.5
                and last is not None
                and all(angle_close(a, b, 1e-5) for a, b in zip(now, last, strict=True))
            ):
                raise ControlError(
                    f"the camera head stopped at pan {math.degrees(now[0]):.1f}, tilt "
                    f"{math.degrees(now[1]):.1f} degrees short of {target.describe()} (pan "
                    f"{math.degrees(pan):.1f}, tilt {math.degrees(tilt):.1f}): "
                    "it lies beyond the head's range",
                    "go_to_object first so that the object is in front of the robot",
                )
            last = now
        raise ControlError(
            f"the camera head did not settle on {target.describe()} within {self.timeout_s:.1f} s",
            "check the world's head controller; this is a fault of the world, not of the program",
        )


def _head(world: Any) -> tuple[float, float]:
    js = world.joint_states()
    return float(js["head_pan"]), float(js["head_tilt"])


@CONTROLLERS.register("default")
def _default(world: Any) -> PointingController:
    return PointingController(world)
