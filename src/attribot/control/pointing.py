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
from attribot.control.world import head_angles
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

    step_s: simulated (or waited) seconds per settling step; min_wait_s / still_rad: the head is at rest
    when it moved less than still_rad in one step after at least min_wait_s; timeout_s: give up after
    this long; tol_rad: how close the head must come to the wanted angles; corrections: re-commands
    that remove steady-state error; range_gap_rad: a head that stops further off than this has hit its
    limit; base_tol: metres / radians of base motion since the capture beyond which the box no longer
    says where to look.
    """

    name: str = "pointing"
    step_s: float = 0.05
    min_wait_s: float = 0.15
    still_rad: float = 2e-4
    timeout_s: float = 6.0
    tol_rad: float = 1e-3
    corrections: int = 3
    range_gap_rad: float = 0.05
    base_tol: float = 0.01
    waited_s: float = 0.0  # time stepped while the head settled, since it was last zeroed

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
        want = pan_tilt_towards(cap.camera, cap.head, *target.center)
        # command, wait until the head stops, and add what is still missing to the command: a position
        # servo carrying the head's weight settles a few milliradians short (steady-state sag)
        command = want
        for _ in range(self.corrections + 1):
            self.world.set_head(*command)
            now = self._wait_still(target)
            gap = (math.remainder(want[0] - now[0], math.tau), math.remainder(want[1] - now[1], math.tau))
            if abs(gap[0]) <= self.tol_rad and abs(gap[1]) <= self.tol_rad:
                return
            if max(abs(gap[0]), abs(gap[1])) > self.range_gap_rad:
                raise ControlError(
                    f"the camera head stopped at pan {math.degrees(now[0]):.1f}, tilt "
                    f"{math.degrees(now[1]):.1f} degrees short of {target.describe()} (pan "
                    f"{math.degrees(want[0]):.1f}, tilt {math.degrees(want[1]):.1f}): "
                    "it lies beyond the head's range",
                    "go_to_object first so that the object is in front of the robot",
                )
            command = (command[0] + gap[0], command[1] + gap[1])
        # within range_gap_rad but not within tol_rad after the corrections: close enough to aim the
        # rangefinder at an object, and the Robot's visual check corrects what is left

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

    def _wait_still(self, target: Target) -> tuple[float, float]:
        """Step the world until the head stops moving; its angles then."""
        last = head_angles(self.world)
        elapsed = 0.0
        while elapsed < self.timeout_s:
            self.world.step(self.step_s)
            elapsed += self.step_s
            self.waited_s += self.step_s
            now = head_angles(self.world)
            still = all(angle_close(a, b, self.still_rad) for a, b in zip(now, last, strict=True))
            if still and elapsed >= self.min_wait_s:
                return now
            last = now
        raise ControlError(
            f"the camera head did not come to rest while turning to {target.describe()} within "
            f"{self.timeout_s:.1f} s",
            "check the world's head controller; this is a fault of the world, not of the program",
        )


@CONTROLLERS.register("default")
def _default(world: Any) -> PointingController:
    return PointingController(world)
