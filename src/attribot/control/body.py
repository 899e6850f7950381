"""What a perception-driven controller must know of the robot's body: where the camera sits, how far the
arm reaches, how big the base is. A real robot's driver states these from its data sheet; the simulator
from its model. Metres and radians, in the base frame (x forward, y left, z up, origin at the base's
centre on the floor).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["BodyGeometry"]


@dataclass(frozen=True)
class BodyGeometry:
    """camera_xyz: the optical centre, on the head's pan and tilt axes, in the base frame. arm_xy: where
    the arm's line leaves the mast (the arm extends along +x at lateral offset arm_xy[1]). reach0: from the
    arm's origin to the point between the fingertips at zero extension. arm_range / lift_range: the
    telescope's extension and the lift's height of the grip point. base_half: the footprint's half-lengths.
    finger_open: each finger's distance from the centre line when open."""

    camera_xyz: tuple[float, float, float]
    arm_xy: tuple[float, float]
    reach0: float
    arm_range: tuple[float, float]
    lift_range: tuple[float, float]
    base_half: tuple[float, float]
    finger_open: float = 0.07

    def reach_x(self, extension: float) -> float:
        """x in the base frame of the grip point at this arm extension."""
        return self.arm_xy[0] + self.reach0 + extension

    @property
    def radius(self) -> float:
        """The base's circumscribed radius: the clearance a turning base needs."""
        return math.hypot(*self.base_half)
