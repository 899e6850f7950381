"""Reaching: drive to where the arm's line passes through an object within the arm's range, coming from
the side it was seen from, and correct the base at the goal until the line passes close enough.

Without depth, with the rangefinder on the gripper (the RoboMaster EP), the gripper cannot measure an
object it already surrounds: the base lines up a little short of the grasp (the beam still sees the
object's front), then drives the rest of the way straight, on odometry, as the paper's robot did."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from attribot.control.base import ControlError, Failure, Target
from attribot.control.body import BodyGeometry
from attribot.control.drive import Driver
from attribot.control.locate import Locator
from attribot.control.plant import Hold, Plant, Reach
from attribot.control.spatial import FloorMap, ObjectEstimate, to_base

__all__ = ["Reacher"]

# the turns from the line the object was seen along at which a place to stand is sought, in this order
_STANDING_TURNS = (0.0, 0.35, -0.35, 0.7, -0.7, 1.05, -1.05, 1.4, -1.4, 1.75, -1.75, 2.1, -2.1, math.pi)


WIDE_TOL_SHARE = 0.25
"""The arm's line may pass this share of a wide object's radius from its middle (a backpack's 13 cm: 3 cm).
Depth places a wide object's middle from the side it sees, which shifts by a centimetre or two with each
correction of the base: lined up to `arrive_tol`, the corrections chase it, while the fingers close on the
object anywhere near its middle."""


@dataclass
class Reacher:
    """Brings the arm to objects (see the module docstring)."""

    plant: Plant
    driver: Driver
    locator: Locator

    def reach(
        self,
        est: ObjectEstimate,
        target: Target,
        action: str,
        holding: Hold | None = None,
        tol: float | None = None,
    ) -> Reach:
        """Drive to where the arm's line passes through the object and it is within the arm's range. The
        approach comes from the side the object was seen from; where the camera loses it at the goal (a
        shelf's side board in the way), the next place to stand is tried."""
        body = self.plant.body(action)
        floor = self.locator.floor_map([target], holding)
        seen_from = target.capture.base or self.plant.pose()
        lost: ControlError | None = None
        # without depth the floor map does not see the object: the base must stop short of its front
        blind = target.capture.depth is None
        short = est.radius + 0.05 if blind and body.arm is not None else 0.0
        poses = self.standing_poses(est, body, floor, seen_from, blind, short)
        for tried, (pose, path) in enumerate(poses):
            if tried == self.plant.tuning.stand_tries:
                break
            self.driver.follow(path, pose, np.array(est.centre), action)
            try:
                return self.line_up(est, target, action, body, holding, tol, short)
            except ControlError as e:
                if e.reason is not Failure.TARGET_LOST:
                    raise
                lost = e
        if lost is not None:
            raise lost
        raise ControlError(
            f"not reachable: no free place to stand within the arm's reach of {target.describe()} "
            f"(at {est.centre[0]:.2f}, {est.centre[1]:.2f}, {est.centre[2]:.2f} m)",
            "choose an object nearer a free edge of its furniture",
            reason=Failure.NOT_REACHABLE,
        )

    def line_up(
        self,
        est: ObjectEstimate,
        target: Target,
        action: str,
        body: BodyGeometry,
        holding: Hold | None,
        tol: float | None,
        short: float = 0.0,
        relocate: Callable[[ObjectEstimate], ObjectEstimate] | None = None,
    ) -> Reach:
        """Find the object again from here (by the detector; or by `relocate`, which sees where `est` is
        now) and correct the base until the arm's line passes within `tol` of it, `short` metres short of
        the grasp; then drive those straight. `tol` by default: `arrive_tol`, or, for a wide object, a share
        of its radius (`WIDE_TOL_SHARE`)."""
        tuning = self.plant.tuning
        side = ext = math.nan
        for _ in range(tuning.align_tries):
            if relocate is not None:
                est = relocate(est)
            else:
                est = self.locator.refind(est, target, action, holding=holding)
            local = to_base(np.array(est.centre), self.plant.pose())
            ext = float(local[0] - body.reach_x(0.0) - short)
            side = float(local[1] - body.arm_xy[1])
            lo, hi = body.arm_range
            within = max(tuning.arrive_tol, WIDE_TOL_SHARE * est.radius) if tol is None else tol
            # a centimetre beyond the telescope's ends still closes the fingers on the object
            if abs(side) <= within and lo - 0.015 <= ext <= hi + 0.015:
                if short:
                    self.driver.straight(short)
                return Reach(target.label, est, float(np.clip(ext, lo, hi)))
            fix = ext - float(np.clip(ext, lo + 0.03, hi - 0.03))
            x, y, yaw = self.plant.pose()
            c, s = math.cos(yaw), math.sin(yaw)
            corrected = (x + c * fix - s * side, y + s * fix + c * side, yaw)
            self.driver.drive_to(corrected, None, action, est.centre)
        raise ControlError(
            f"not reachable: the robot could not line its arm up with {target.describe()} (after "
            f"{tuning.align_tries} corrections, {abs(side) * 100:.1f} cm aside, extension {ext:.2f} m)",
            "the object may lie beyond the arm's reach from any free place; choose another",
            reason=Failure.NOT_REACHABLE,
        )

    def standing_poses(
        self,
        est: ObjectEstimate,
        body: BodyGeometry,
        floor: FloorMap,
        seen_from: tuple[float, float, float],
        blind: bool = False,
        short: float = 0.0,
    ) -> Iterator[tuple[tuple[float, float, float], list[np.ndarray]]]:
        """Base poses facing the object with the grip point on it at the shortest free extension (`short`
        metres short of it), and paths to them: first along the line it was seen along (that side has a
        view of it), then turned more and more from it. `blind`: the map does not show the object, so the
        base's front must stay short of it."""
        here = self.plant.pose()
        centre = est.xy()
        bearing = math.atan2(centre[1] - seen_from[1], centre[0] - seen_from[0])
        for turn in _STANDING_TURNS:
            yaw = bearing + turn
            c, s = math.cos(yaw), math.sin(yaw)
            # a few centimetres of extension to spare either way, for the corrections at the goal
            lo, hi = body.arm_range
            spare = min(0.05, (hi - lo) / 3), min(0.03, (hi - lo) / 3)
            exts = np.arange(lo + spare[0], hi - spare[1], 0.02)
            # blind, the base may need the whole reach to stay short of a wide object
            for ext in np.append(exts, hi) if blind else exts:
                lx, ly = body.reach_x(float(ext)), body.arm_xy[1]
                if blind and lx - est.radius < body.base_half[0] + 0.01:
                    continue
                lx += short
                pose = (centre[0] - (c * lx - s * ly), centre[1] - (s * lx + c * ly), yaw)
                if floor.footprint_free(pose, body.base_half, 0.04):
                    path = floor.path(np.array(here[:2]), np.array(pose[:2]), body.radius + 0.02)
                    if path is not None:
                        yield pose, path
                    break
