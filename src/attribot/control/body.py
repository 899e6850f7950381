"""What a perception-driven controller must know of the robot's body: where the camera is and where it
looks (a function of the joints), how far the arm reaches, how big the base is. A real robot's driver states
these from its data sheet; the simulator from its model. Metres and radians, in the base frame (x forward,
y left, z up, origin at the base's centre on the floor).

Two kinds of body: a camera on a pan-tilt head at a fixed point (`camera_xyz`) with a telescoping arm on a
lift (the default simulated robot), and a camera riding on a two-link arm (`arm`: the RoboMaster EP), whose
pose follows from the arm's two joints. Both take the same arm commands: the grip point's height (`lift`)
and its reach forward (`extension`, from `reach_x(0)`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from functools import cached_property
from typing import Any

import numpy as np

__all__ = ["BodyGeometry", "CameraPose", "TwoLinkArm"]


@dataclass(frozen=True)
class CameraPose:
    """A camera (or a rangefinder's beam) in the base frame: its optical centre `xyz`, and its axis turned
    `pan` about the base's up axis (left positive) and `tilt` above the horizontal (up positive); no
    roll."""

    xyz: tuple[float, float, float]
    pan: float
    tilt: float

    @property
    def angles(self) -> tuple[float, float]:
        return self.pan, self.tilt


@dataclass(frozen=True)
class TwoLinkArm:
    """A two-link arm in the base's x-z plane (at lateral offset `y`) whose end bracket stays level (a
    parallel linkage, as on the RoboMaster EP), carrying the camera on its forearm and the rangefinder on the
    bracket. Joint angles are each link's elevation above the base's forward axis (up positive): `upper`
    for the upper arm, `fore` for the forearm.

    shoulder: the shoulder axis (x, z). links: upper arm and forearm lengths. upper_range, fore_range: the
    links' elevation limits; bend_range: limits of upper - fore. grip: the grip point (between the
    fingertips) from the forearm's tip, (forward, up). camera: the optical centre from the elbow, along the
    forearm and square to it (up); camera_pitch: its optical axis above the forearm's direction.
    rangefinder: the rangefinder from the grip point (forward, up); its beam points along the base's
    forward axis (the bracket is level)."""

    shoulder: tuple[float, float]
    links: tuple[float, float]
    upper_range: tuple[float, float]
    fore_range: tuple[float, float]
    bend_range: tuple[float, float]
    grip: tuple[float, float]
    camera: tuple[float, float]
    camera_pitch: float
    rangefinder: tuple[float, float]
    y: float = 0.0

    def feasible(self, upper: float, fore: float, slack: float = 1e-9) -> bool:
        """Whether the joint angles lie within the arm's limits."""
        return all(
            lo - slack <= v <= hi + slack
            for v, (lo, hi) in (
                (upper, self.upper_range),
                (fore, self.fore_range),
                (upper - fore, self.bend_range),
            )
        )

    def elbow(self, upper: float) -> tuple[float, float]:
        """The elbow axis (x, z)."""
        return (
            self.shoulder[0] + self.links[0] * math.cos(upper),
            self.shoulder[1] + self.links[0] * math.sin(upper),
        )

    def grip_point(self, upper: float, fore: float) -> tuple[float, float]:
        """The grip point (x, z) at these joint angles."""
        ex, ez = self.elbow(upper)
        return (
            ex + self.links[1] * math.cos(fore) + self.grip[0],
            ez + self.links[1] * math.sin(fore) + self.grip[1],
        )

    def solve(self, x: float, z: float) -> tuple[float, float] | None:
        """The joint angles (upper, fore) that put the grip point at (x, z), elbow up; None when out of reach
        or beyond the limits."""
        wx, wz = x - self.grip[0] - self.shoulder[0], z - self.grip[1] - self.shoulder[1]
        a, b = self.links
        r2 = wx * wx + wz * wz
        c = (r2 - a * a - b * b) / (2 * a * b)
        if not -1.0 <= c <= 1.0:
            return None
        bend = math.acos(c)  # upper - fore, the elbow bending up
        upper = math.atan2(wz, wx) + math.atan2(b * math.sin(bend), a + b * math.cos(bend))
        fore = upper - bend
        return (upper, fore) if self.feasible(upper, fore) else None

    @cached_property
    def _grid(self) -> tuple[np.ndarray, np.ndarray]:
        """Feasible joint angles on a fine grid, and their grip points: for the nearest reachable pose."""
        u, f = np.meshgrid(np.linspace(*self.upper_range, 241), np.linspace(*self.fore_range, 241))
        ok = (u - f >= self.bend_range[0]) & (u - f <= self.bend_range[1])
        u, f = u[ok], f[ok]
        ex = self.shoulder[0] + self.links[0] * np.cos(u) + self.links[1] * np.cos(f) + self.grip[0]
        ez = self.shoulder[1] + self.links[0] * np.sin(u) + self.links[1] * np.sin(f) + self.grip[1]
        return np.stack([u, f], axis=1), np.stack([ex, ez], axis=1)

    def nearest(self, x: float, z: float) -> tuple[float, float]:
        """The joint angles that put the grip point at (x, z), or as near it as the arm reaches."""
        exact = self.solve(x, z)
        if exact is not None:
            return exact
        angles, points = self._grid
        i = int(np.argmin(np.hypot(points[:, 0] - x, points[:, 1] - z)))
        return float(angles[i, 0]), float(angles[i, 1])

    def camera_pose(self, upper: float, fore: float) -> CameraPose:
        """Where the camera on the forearm is and looks at these joint angles."""
        ex, ez = self.elbow(upper)
        along, up = self.camera
        c, s = math.cos(fore), math.sin(fore)
        return CameraPose(
            (ex + along * c - up * s, self.y, ez + along * s + up * c), 0.0, fore + self.camera_pitch
        )

    def range_pose(self, upper: float, fore: float) -> CameraPose:
        """Where the rangefinder on the bracket is; its beam is level, along the base's forward axis."""
        gx, gz = self.grip_point(upper, fore)
        return CameraPose((gx + self.rangefinder[0], self.y, gz + self.rangefinder[1]), 0.0, 0.0)


@dataclass(frozen=True)
class BodyGeometry:
    """camera_xyz: the optical centre, on the head's pan and tilt axes, in the base frame (with an `arm`
    carrying the camera: where it is when the arm rests). arm_xy: where the arm's line starts (the arm
    reaches along +x at lateral offset arm_xy[1]). reach0: from there to the point between the fingertips
    at zero extension. arm_range / lift_range: the extension and the grip point's height the controller
    commands (with an `arm`, a box inside its reach). base_half: the footprint's half-lengths. finger_open:
    each finger's distance from the centre line when open. arm: the two-link arm that carries the camera
    (None: a pan-tilt head). rest: the arm's (lift, extension) while it waits."""

    camera_xyz: tuple[float, float, float]
    arm_xy: tuple[float, float]
    reach0: float
    arm_range: tuple[float, float]
    lift_range: tuple[float, float]
    base_half: tuple[float, float]
    finger_open: float = 0.07
    arm: TwoLinkArm | None = None
    rest: tuple[float, float] = (0.2, 0.0)

    def reach_x(self, extension: float) -> float:
        """x in the base frame of the grip point at this arm extension."""
        return self.arm_xy[0] + self.reach0 + extension

    @property
    def radius(self) -> float:
        """The base's circumscribed radius: the clearance a turning base needs."""
        return math.hypot(*self.base_half)

    def head_view(self, head: tuple[float, float]) -> CameraPose:
        """The camera on the pan-tilt head at these head angles."""
        return CameraPose(self.camera_xyz, head[0], head[1])

    def arm_angles(self, joints: Mapping[str, float]) -> tuple[float, float]:
        """The arm's (upper, fore) elevations: from its joints when they are reported, else from the grip
        point's lift and extension (a robot that reports only where its gripper is)."""
        assert self.arm is not None
        if "upper_arm" in joints and "forearm" in joints:
            return float(joints["upper_arm"]), float(joints["forearm"])
        return self.arm.nearest(self.reach_x(float(joints["arm"])), float(joints["lift"]))

    def camera_pose(self, joints: Mapping[str, float]) -> CameraPose:
        """Where the camera is and looks, from the joint states (head_pan and head_tilt for a head;
        upper_arm and forearm, or lift and arm, for a camera on the arm)."""
        if self.arm is None:
            return self.head_view((float(joints["head_pan"]), float(joints["head_tilt"])))
        return self.arm.camera_pose(*self.arm_angles(joints))

    def range_pose(self, joints: Mapping[str, float]) -> CameraPose:
        """Where the rangefinder is and points: along the camera's optical axis on a head; on the bracket
        of an arm."""
        if self.arm is None:
            return self.camera_pose(joints)
        return self.arm.range_pose(*self.arm_angles(joints))

    def look_pose(self, point: tuple[float, float, float]) -> tuple[float, float]:
        """The arm's (lift, extension) whose camera looks most nearly at the base-frame `point` up and down
        (a camera on an arm tilts only with it): the rest pose while it looks within 20 degrees of it."""
        assert self.arm is not None
        arm = self.arm

        def miss(pose: tuple[float, float]) -> float:
            view = arm.camera_pose(*arm.nearest(self.reach_x(pose[1]), pose[0]))
            dx, dy, dz = (point[i] - view.xyz[i] for i in range(3))
            return abs(math.atan2(dz, math.hypot(dx, dy)) - view.tilt)

        if miss(self.rest) <= math.radians(20):
            return self.rest
        poses = [
            (float(lift), float(ext))
            for lift in np.linspace(*self.lift_range, 12)
            for ext in np.linspace(*self.arm_range, 4)
        ]
        return min(poses, key=miss)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> BodyGeometry:
        """A body from its fields as JSON gives them (lists for tuples, `arm` a mapping or null): what a
        driver states in the bridge's hello. A missing or unknown field, or a value of the wrong kind, is a
        `TypeError` or `ValueError` naming it."""

        def value(v: Any) -> Any:
            return tuple(float(x) for x in v) if isinstance(v, (list, tuple)) else float(v)

        values: dict[str, Any] = {}
        for name, v in data.items():
            if name == "arm":
                if v is not None:
                    known = {f.name for f in fields(TwoLinkArm)}
                    unknown = sorted(set(v) - known)
                    if unknown:
                        raise TypeError(f"the arm has no field(s) {', '.join(unknown)}")
                    v = TwoLinkArm(**{k: value(x) for k, x in v.items()})
                values[name] = v
            else:
                values[name] = value(v)
        return cls(**values)
