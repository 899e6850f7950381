"""The robot as the servo's collaborators share it: the world behind `ServoWorld`, the tuning, and the
readings every one of them takes (pose, head angles, capabilities, body), plus the two records that pass
between them (where the arm reached, what the gripper holds)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from attribot.control.base import not_available
from attribot.control.body import BodyGeometry, CameraPose
from attribot.control.spatial import ObjectEstimate
from attribot.control.tuning import ServoTuning
from attribot.control.world import ServoWorld, head_angles
from attribot.errors import UnsupportedAction

__all__ = ["Plant", "Reach", "Hold", "moved"]


@dataclass
class Plant:
    """The world, its name for messages, and the servo's tuning, with the readings shared by the servo's
    collaborators."""

    world: ServoWorld
    tuning: ServoTuning
    world_name: str

    def has(self, capability: str) -> bool:
        return capability in {str(c) for c in self.world.capabilities()}

    def pose(self) -> tuple[float, float, float]:
        """The base's `(x, y, yaw)` by odometry."""
        p = self.world.base_pose()
        return float(p.x), float(p.y), float(p.yaw)

    def head(self) -> tuple[float, float]:
        """The head's `(pan, tilt)`, radians."""
        return head_angles(self.world)

    def lift(self) -> float:
        """The lift's height now, metres."""
        return float(self.world.joint_states().get("lift", 0.2))

    @property
    def headless(self) -> bool:
        """The camera has no pan-tilt head of its own: the base turns it left and right."""
        return not self.has("head")

    def view(self, body: BodyGeometry) -> CameraPose:
        """Where the camera is and looks now, in the base frame."""
        return body.camera_pose(self.world.joint_states())

    def arm(self) -> tuple[float, float] | None:
        """The arm's `(lift, extension)` now, or None where the world does not report it."""
        js = self.world.joint_states()
        if "lift" not in js or "arm" not in js:
            return None
        return float(js["lift"]), float(js["arm"])

    def body(self, action: str) -> BodyGeometry:
        """The robot's body geometry, or `UnsupportedAction` for `action` when it does not state it or has
        no base or pose to act with."""
        body = getattr(self.world, "body", None)
        if body is None:
            raise not_available(action, self.world_name, "it does not state its body geometry")
        for need in ("base", "pose"):
            if not self.has(need):
                raise not_available(action, self.world_name, f"it has no {need} capability")
        return body()

    def geometry(self) -> BodyGeometry | None:
        """The robot's body geometry, or None where it does not state it."""
        body = getattr(self.world, "body", None)
        if body is None:
            return None
        try:
            return body()
        except UnsupportedAction:
            return None

    def settle(self, seconds: float) -> None:
        """Let a commanded motion complete."""
        self.world.step(seconds)


@dataclass(frozen=True)
class Reach:
    """Where go_to_object left the robot: the object located from there, and the arm extension to it."""

    label: str
    estimate: ObjectEstimate
    extension: float


@dataclass(frozen=True)
class Hold:
    """What pick_up holds: its name and finder, the base pose, lift and extension it was picked at, and how
    far the object reaches below and above the grip point, and its radius."""

    label: str
    find: Callable[[Any], list[tuple[float, float, float, float]]] | None
    pose: tuple[float, float, float]
    lift: float
    extension: float
    below: float
    above: float
    radius: float


def moved(
    a: tuple[float, float, float], b: tuple[float, float, float], metres: float, radians: float
) -> bool:
    """True when pose `a` lies more than `metres` or `radians` from pose `b`."""
    turned = abs(math.remainder(a[2] - b[2], math.tau))
    return math.hypot(a[0] - b[0], a[1] - b[1]) > metres or turned > radians
