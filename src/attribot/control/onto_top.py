"""Putting what is held on the top of a large receptacle (a table, a counter, a shelf), whose middle may be
out of reach or taken: the top is found in depth (`control.surface`), the object goes to the free spot on it
nearest the robot that the arm reaches from a free place to stand, is lowered until the wrist feels the top
carry it, and is then seen standing on the top."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from attribot.control.base import ControlError, Failure, Target
from attribot.control.body import BodyGeometry, CameraPose
from attribot.control.drive import Driver
from attribot.control.locate import Locator, view_of
from attribot.control.plant import Hold, Plant
from attribot.control.reach import Reacher
from attribot.control.sighting import Box, nearest_to_centre
from attribot.control.spatial import ObjectEstimate, base_points, estimate_object, to_world
from attribot.control.surface import TopSurface, find_top
from attribot.frame import CameraInfo

if TYPE_CHECKING:
    from attribot.control.manipulate import Manipulator

__all__ = ["TopPlacer"]


@dataclass
class TopPlacer:
    """The steps of putting on a large top, over the hand that holds the object (its lift, its letting go
    and its force readings are the hand's)."""

    hand: Manipulator

    @property
    def plant(self) -> Plant:
        return self.hand.plant

    @property
    def driver(self) -> Driver:
        return self.hand.driver

    @property
    def locator(self) -> Locator:
        return self.hand.locator

    @property
    def reacher(self) -> Reacher:
        return self.hand.reacher

    def top_seen(self, target: Target, hold: Hold, body: BodyGeometry) -> TopSurface | None:
        """The receptacle's top as the depth of the image it was seen in shows it, or, where that image cut
        it off at an edge (the board of a shelf above the view, a table's near half below it), as a fresh
        look centred on it shows it; None without depth (or without a known camera pose), or when its box
        holds no large horizontal surface."""
        cap = target.capture
        view = view_of(cap, body)
        if cap.depth is None or cap.camera is None or view is None or cap.base is None:
            return None
        top = self.top_in(cap.depth, cap.camera, view, cap.base, target.box, hold, body)
        if not _cut_off(target.box, cap.camera) or target.find is None:
            return top
        est = self.locator.where_seen(target, body)
        if est is None:
            return top
        self.locator.aim(np.array(est.centre), body, target, hold)
        frame = self.plant.world.observe()
        camera = frame.camera or self.plant.world.camera_info()
        box = nearest_to_centre(target.find(frame), camera, 0.45)
        if box is None or frame.depth is None:
            return top
        again = self.top_in(frame.depth, camera, self.plant.view(body), self.plant.pose(), box, hold, body)
        return again if again is not None else top  # centred on it, the camera sees more of it

    def top_in(
        self,
        depth: np.ndarray,
        camera: CameraInfo,
        view: CameraPose,
        base: tuple[float, float, float],
        box: Box,
        hold: Hold,
        body: BodyGeometry,
    ) -> TopSurface | None:
        """The top in a box of a depth image, the arm and what it holds left out."""
        pts = to_world(base_points(depth, camera, view, box), base)
        pts = pts[~self.locator.held_points(hold, body)(pts)]
        return find_top(pts, above=self.plant.tuning.top_clear_m)

    def put_on_top(self, target: Target, top: TopSurface, hold: Hold, body: BodyGeometry) -> None:
        """Put what is held on a free spot of the top nearest the robot: drive where the arm reaches it,
        line the arm up with it as seen from there, lower the object until the top carries it, let go,
        and check that it stands there."""
        t = self.plant.tuning
        place_z = top.z + hold.below + 0.005
        self.hand.check_lift(place_z, top.z, target, body)
        self.hand.out_from_under(hold, place_z + 0.06, target, body)
        self.hand.carry_height(hold, place_z + 0.06)
        spot, pose, path = self.choose_spot(target, top, hold, body)
        self.driver.follow(path, pose, np.array(spot.centre), "put_on")
        seen = [top]

        def relocate(est: ObjectEstimate) -> ObjectEstimate:
            near, local = self.spot_near(est, seen[-1], hold, body, target)
            seen.append(local)
            return near

        reach = self.reacher.line_up(spot, target, "put_on", body, hold, t.place_tol, relocate=relocate)
        self.plant.world.set_arm(place_z + 0.06, reach.extension)
        self.plant.settle(t.extend_s)
        rested = self.lower_onto(place_z, reach.extension)
        if rested is False:
            self.hand.carry_height(hold, place_z + 0.06)  # held up, clear of the top, to be put elsewhere
            raise ControlError(
                f"put_on failed: lowering the {hold.label} onto {target.describe()}, the wrist never felt "
                f"the top carry it (down to {place_z - hold.below - t.lower_below_m:.2f} m; the camera saw "
                f"the top at {top.z:.2f} m); it is still held",
                "put it down with robot.put_down(), or put it on another receptacle",
            )
        lift = self.plant.lift()
        self.hand.let_go(lift, reach.extension)
        self.check_on_top(hold, reach.estimate, seen, target)

    def choose_spot(
        self, target: Target, top: TopSurface, hold: Hold, body: BodyGeometry
    ) -> tuple[ObjectEstimate, tuple[float, float, float], list[np.ndarray]]:
        """The free spot on the top nearest the robot from which a free place to stand is within the arm's
        reach, that place and the path to it."""
        t = self.plant.tuning
        spots = self.free_spots(top, hold)
        name = f"the top of {target.describe()}"
        if len(spots) == 0:
            raise ControlError(
                f"put_on failed: the camera sees no free spot on {name} (at {top.z:.2f} m) for the "
                f"{hold.label}: what stands there covers it, or it is hidden from here",
                "clear a spot on it, or put the object on another receptacle",
            )
        here = self.plant.pose()
        floor = self.locator.floor_map([target], hold)
        order = np.argsort(np.linalg.norm(spots - np.array(here[:2]), axis=1))
        for k in order[: t.spot_tries]:
            spot = self.spot_estimate(spots[k], top, hold)
            for pose, path in self.reacher.standing_poses(spot, body, floor, here):
                return spot, pose, path
        raise ControlError(
            f"not reachable: no free place to stand within the arm's reach of the free spots on {name} "
            f"nearest the robot ({min(len(spots), t.spot_tries)} tried)",
            "clear the way to it, or put the object on another receptacle",
            reason=Failure.NOT_REACHABLE,
        )

    def free_spots(self, top: TopSurface, hold: Hold) -> np.ndarray:
        """The top's free spots for what is held: with the clearance kept round it, or, where the top has
        no room for that, with only a cell's worth round what stands there."""
        spots = top.free_spots(hold.radius + self.plant.tuning.place_clear_m)
        return spots if len(spots) else top.free_spots(hold.radius)

    @staticmethod
    def spot_estimate(xy: np.ndarray, top: TopSurface, hold: Hold) -> ObjectEstimate:
        """A spot on the top, as the object put there would stand: its grip point over it."""
        grip_z = top.z + hold.below
        return ObjectEstimate(
            (float(xy[0]), float(xy[1]), grip_z), top.z, grip_z + hold.above, hold.radius, 1
        )

    def spot_near(
        self, spot: ObjectEstimate, top: TopSurface, hold: Hold, body: BodyGeometry, target: Target
    ) -> tuple[ObjectEstimate, TopSurface]:
        """The spot again, from a fresh look at it (the arm and what it holds left out of the depth): kept
        while nothing is seen standing there, else the free spot nearest it; and the top seen from here."""
        self.locator.aim(np.array([spot.centre[0], spot.centre[1], top.z]), body, target, hold)
        frame = self.plant.world.observe()
        local = None
        if frame.depth is not None:
            camera = frame.camera or self.plant.world.camera_info()
            pts = to_world(base_points(frame.depth, camera, self.plant.view(body)), self.plant.pose())
            pts = pts[~self.locator.held_points(hold, body)(pts)]
            pts = pts[np.hypot(pts[:, 0] - spot.centre[0], pts[:, 1] - spot.centre[1]) < 0.6]
            # what stands on the top has its foot there, below the held object carried over it
            local = find_top(pts, near=(spot.xy(), top.z), above=self.plant.tuning.top_clear_m, up_to=0.05)
        if local is None:
            return spot, top  # no better look from here: keep the spot as seen before
        if not local.blocked_near(spot.xy(), hold.radius):
            # still free where the camera sees it; what the held object hides from here was free before
            return self.spot_estimate(spot.xy(), local, hold), local
        spots = self.free_spots(local, hold)
        if len(spots) == 0:
            raise ControlError(
                f"put_on failed: seen from near, the top of {target.describe()} has no free spot for the "
                f"{hold.label} around ({spot.centre[0]:.2f}, {spot.centre[1]:.2f})",
                "clear a spot on it, or put the object on another receptacle",
            )
        best = spots[int(np.argmin(np.linalg.norm(spots - spot.xy(), axis=1)))]
        return self.spot_estimate(best, local, hold), local

    def lower_onto(self, z: float, extension: float) -> bool | None:
        """Lower what is held until the top carries it, the grip coming down to `z` where depth says the
        object meets the top: step by step while the wrist's load is watched, from a little above `z` to
        `lower_below_m` under it. True when the load fell (it rests), False when it never did; None without
        a force sensor fine enough to tell (then lowered to `z`)."""
        t, world = self.plant.tuning, self.plant.world
        world.set_arm(z + 0.02, extension)
        self.plant.settle(t.arm_move_s)
        carried = self.hand.force_z()
        if carried is None or abs(carried) < max(t.load_min_n, t.load_sigmas * self.hand.load_spread * 2):
            world.set_arm(z, extension)
            self.plant.settle(t.place_lower_s)
            return None
        steps = int(round((0.02 + t.lower_below_m) / t.lower_step_m))
        for k in range(1, steps + 1):
            world.set_arm(z + 0.02 - k * t.lower_step_m, extension)
            self.plant.settle(t.lower_step_s)
            now = self.hand.force_z()
            assert now is not None
            # carried, the wrist feels the object's weight; resting, the top takes it (pressed, the sign
            # turns): half of it gone is the top's doing, far beyond the readings' noise
            if now * math.copysign(1.0, carried) < abs(carried) / 2:
                return True
        return False

    def check_on_top(self, hold: Hold, spot: ObjectEstimate, tops: list[TopSurface], target: Target) -> None:
        """Look where the object was let go: it must stand on the top, inside its edges as any of the looks
        at it (`tops`) saw them: depth points standing on the top in the detector's box of it, or (where the
        detector does not see it) where it was let go."""
        body = self.plant.body("put_on")
        top = tops[-1]
        self.locator.aim(np.array([spot.centre[0], spot.centre[1], top.z]), body, target)
        camera = self.plant.world.camera_info()
        frame = self.plant.world.observe()
        if frame.depth is None:
            return
        view, pose = self.plant.view(body), self.plant.pose()
        box = nearest_to_centre(hold.find(frame) if hold.find is not None else [], camera, 0.45)
        pts = to_world(base_points(frame.depth, camera, view, box), pose)
        if box is None:
            pts = pts[np.hypot(pts[:, 0] - spot.centre[0], pts[:, 1] - spot.centre[1]) <= hold.radius + 0.01]
        height = hold.below + hold.above
        up = pts[(pts[:, 2] > top.z + self.plant.tuning.top_clear_m) & (pts[:, 2] < top.z + height + 0.05)]
        on = np.zeros(len(up), bool)
        for seen in tops:
            on |= seen.on_top(up[:, :2], margin=seen.cell)
        if int(on.sum()) >= 10:
            return
        name = f"the top of {target.describe()}"
        placed = None if box is None else estimate_object(frame.depth, camera, view, pose, box)
        if placed is None:
            raise ControlError(
                f"put_on failed: after letting go, the camera sees nothing standing on {name} where the "
                f"{hold.label} was put",
                "it may have fallen; find it again in a new image",
            )
        flat = height < 0.03 and abs(placed.support_z - top.z) <= 0.02
        if flat and any(bool(seen.on_top(placed.xy(), margin=seen.cell)[0]) for seen in tops):
            return  # too flat to stand out of the top in depth (a CD): seen by the detector lying on it
        off = float(np.linalg.norm(placed.xy() - spot.xy()))
        raise ControlError(
            f"put_on failed: the {hold.label} came to rest {off * 100:.0f} cm from where it was let go, at "
            f"{placed.support_z:.2f} m, off {name} (at {top.z:.2f} m)",
            "find it again in a new image",
        )


def _cut_off(box: Box, camera: CameraInfo) -> bool:
    """Whether a box reaches an edge of the image (what it frames may go on beyond it)."""
    return box[0] <= 2 or box[1] <= 2 or box[2] >= camera.width - 2 or box[3] >= camera.height - 2
