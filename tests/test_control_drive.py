"""The driver on its own: a base that meets something at its goal (odometry drift puts the goal a little
inside the furniture) has arrived as near as it can; one stopped short of it is blocked."""

from __future__ import annotations

import math

import pytest

from attribot.control.base import ControlError
from attribot.control.body import BodyGeometry
from attribot.control.drive import Driver
from attribot.control.plant import Plant
from attribot.control.tuning import ServoTuning
from attribot.embodiments.base import Pose2D

BODY = BodyGeometry(
    camera_xyz=(0.0, 0.0, 1.2),
    arm_xy=(0.0, 0.0),
    reach0=0.4,
    arm_range=(0.0, 0.5),
    lift_range=(0.0, 1.0),
    base_half=(0.2, 0.15),
)


class WalledBase:
    """A base that follows velocity commands exactly, except that a wall at x = `wall` stops it."""

    name = "walled"

    def __init__(self, wall: float) -> None:
        self.wall, self.x, self.y, self.yaw = wall, 0.0, 0.0, 0.0
        self.cmd = (0.0, 0.0, 0.0)

    def capabilities(self) -> set[str]:
        return {"base", "pose"}

    def body(self) -> BodyGeometry:
        return BODY

    def base_pose(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)

    def command_base(self, vx: float, vy: float, wz: float) -> None:
        self.cmd = (vx, vy, wz)

    def set_head(self, pan: float, tilt: float) -> None:
        pass

    def step(self, seconds: float) -> None:
        vx, vy, wz = self.cmd
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        self.x = min(self.x + (c * vx - s * vy) * seconds, self.wall)
        self.y += (s * vx + c * vy) * seconds
        self.yaw += wz * seconds


def drive(wall: float, goal: float) -> WalledBase:
    world = WalledBase(wall)
    Driver(Plant(world, ServoTuning(), "walled")).follow([], (goal, 0.0, 0.0), None, "go_to_object")  # type: ignore[arg-type]
    return world


def test_a_free_base_reaches_its_goal():
    assert drive(wall=10.0, goal=1.0).x == pytest.approx(1.0, abs=0.01)


def test_a_base_stalled_just_short_of_its_goal_has_arrived():
    world = drive(wall=0.985, goal=1.0)  # 1.5 cm short: what odometry drift does at a counter
    assert world.x == pytest.approx(0.985)


def test_a_base_stalled_well_short_of_its_goal_is_blocked():
    with pytest.raises(ControlError, match="blocked"):
        drive(wall=0.8, goal=1.0)
