"""The mast robot's dimensions and joints, apart from the code that builds it (`attribot.sim.robot`), so that
planning a scene and checking a scene config need no MuJoCo."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["RobotGeometry", "GEOMETRY", "JOINTS"]


@dataclass(frozen=True)
class RobotGeometry:
    """Dimensions that scene layout and scripted manipulation need (metres, radians)."""

    base_half: tuple[float, float] = (0.19, 0.16)  # footprint half-lengths, x and y
    base_top: float = 0.16
    mast_xy: tuple[float, float] = (-0.10, -0.08)  # mast position in the base frame
    head_height: float = 1.32  # pan/tilt axes and optical centre above the floor
    lift_range: tuple[float, float] = (0.03, 1.12)  # carriage height
    arm_range: tuple[float, float] = (0.0, 0.55)  # telescoping extension
    arm_reach0: float = 0.42  # from the mast to the wrist at zero extension
    grip_offset: float = 0.085  # from the wrist to the point between the fingertips
    finger_range: tuple[float, float] = (0.0, 0.07)  # opening of each finger from the centre line
    fovy_deg: float = 58.0
    pan_range: tuple[float, float] = (-2.6, 2.6)
    tilt_range: tuple[float, float] = (-1.3, 0.6)
    range_max: float = 8.0

    def reach_x(self, extension: float) -> float:
        """x in the base frame of the grip point at this arm extension."""
        return self.mast_xy[0] + self.arm_reach0 + extension + self.grip_offset


GEOMETRY = RobotGeometry()

JOINTS = ("base_x", "base_y", "base_yaw", "head_pan", "head_tilt", "lift", "arm", "finger_l", "finger_r")
