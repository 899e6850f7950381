"""Manipulating by perception: grasp and lift (checked by the gripper and the wrist's force sensor, within
the sensor's noise), put down where it was picked, put on a receptacle (checked by looking at it
afterwards), and push (checked by finding the object again where it went).

A small receptacle (a plate, a bowl) takes the object at its middle. The top of a large one (a table, a
counter, a shelf), whose middle may be out of reach or taken, is found in depth (`control.surface`): the
object goes to the free spot on it nearest the robot that the arm reaches from a free place to stand, is
lowered until the wrist feels the top carry it, and is then seen standing on the top."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from attribot.control.base import ControlError, Target
from attribot.control.body import BodyGeometry, CameraPose
from attribot.control.drive import Driver
from attribot.control.locate import Locator, view_of
from attribot.control.plant import Hold, Plant, Reach, moved
from attribot.control.reach import Reacher
from attribot.control.sighting import Box, nearest_to_centre
from attribot.control.spatial import ObjectEstimate, base_points, estimate_object, to_world
from attribot.control.surface import TopSurface, find_top
from attribot.frame import CameraInfo, Frame

__all__ = ["Manipulator"]


@dataclass
class Manipulator:
    """Picks, places and pushes (see the module docstring); `holding` is what the gripper holds."""

    plant: Plant
    driver: Driver
    locator: Locator
    reacher: Reacher
    holding: Hold | None = None
    load_spread: float = field(default=0.0, repr=False)  # the standard error of the last load reading

    def pick_up(self, target: Target, reach: Reach) -> None:
        """Grasp the object where `reach` brought the arm, lift it, and check that it is held."""
        t, world = self.plant.tuning, self.plant.world
        body = self.plant.body("pick_up")
        est = reach.estimate
        ext, z = reach.extension, float(np.clip(est.grip_z, *body.lift_range))
        headroom = self.headroom(est, body)
        world.release()  # open the fingers
        world.set_arm(max(z, self.plant.lift()), 0.0)
        self.plant.settle(t.arm_move_s)
        world.set_arm(z, 0.0)
        self.plant.settle(t.grip_lower_s)
        world.set_arm(z, ext)
        self.plant.settle(t.extend_s)
        load_before = self.load()
        if not world.grasp():
            self.retract(z)
            raise ControlError(
                f"grasp failed: the gripper closed on nothing where it saw {target.describe()} "
                f"({ext:.2f} m out, {z:.2f} m up)",
                "call robot.go_to_object(patch) again and retry; the object may be too big to grasp",
            )
        world.set_arm(z + headroom, ext)
        self.plant.settle(t.lift_load_s)
        self._check_lifted(target, z, load_before)
        self.holding = Hold(
            label=target.label or "object",
            find=target.find,
            pose=self.plant.pose(),
            lift=z,
            extension=ext,
            below=z - est.support_z,
            above=est.top_z - z,
            radius=est.radius,
        )

    def _check_lifted(self, target: Target, z: float, load_before: float | None) -> None:
        """After lifting: the fingers must not have met (it fell out), and the wrist must feel a load
        beyond the readings' noise (three standard errors of the difference), when the sensor is fine
        enough to feel a light object at all; a noisier one leaves it to the gripper."""
        t = self.plant.tuning
        before_spread = self.load_spread
        load = self.load()
        closed = float(self.plant.world.joint_states().get("gripper", 1.0)) < t.closed_gripper_m
        noise = t.load_sigmas * math.hypot(before_spread, self.load_spread)
        unloaded = False
        if load is not None and load_before is not None:
            unloaded = abs(load - load_before) < max(t.load_min_n, noise)
        if closed or (unloaded and noise < t.load_max_noise_n):
            self.plant.world.release()
            self.retract(z)
            felt = "the gripper closed on nothing" if closed else "the force sensor feels no load"
            raise ControlError(
                f"grasp failed: {felt} after lifting {target.describe()}",
                "call robot.go_to_object(patch) again and retry",
            )

    def check_held(self, target: Target, seen_first: Target) -> tuple[bool | None, str]:
        """Whether the object lifted is the target, by what the camera sees: a detection of its name that
        rose with the gripper (True); or detections of its name only elsewhere, nearer to where the image
        the program chose it from (`seen_first`) put it than the grasp was, so that another object was lifted
        (False). None when it cannot tell: no finder or depth, its name not seen at all, or seen only
        farther away (another object of its kind, while the detector misses the held one)."""
        hold = self.holding
        body = self.plant.body("pick_up")
        if hold is None or target.find is None or not self.plant.has("pose"):
            return None, "nothing to look for"
        js = self.plant.world.joint_states()
        lift = float(js.get("lift", hold.lift))
        grip = self.locator.grip_point(body, lift, float(js.get("arm", hold.extension)))
        grasped = self.locator.grip_point(body, hold.lift, hold.extension, hold.pose)
        self.locator.aim(grip, body, target, hold)
        camera = self.plant.world.camera_info()
        elsewhere: list[ObjectEstimate] = []

        def in_gripper(frame: Frame, box: Box) -> ObjectEstimate | None:
            if frame.depth is None:
                return None
            est = estimate_object(frame.depth, camera, self.plant.view(body), self.plant.pose(), box)
            if est is None:
                return None
            if float(np.hypot(*(est.xy() - grip[:2]))) <= hold.radius + 0.06 and est.top_z > lift:
                return est
            elsewhere.append(est)
            return None

        _, box = self.locator.look_again(target, camera, 0.5, in_gripper)
        if box is not None:
            return True, f"the camera sees the {hold.label} rise with the gripper"
        unseen = f"the camera does not see the {hold.label} in the gripper"
        first = self.locator.where_seen(seen_first, body)
        if first is None:
            return None, unseen
        if not elsewhere:  # look where the image showed it: still standing there, it was not lifted
            self.locator.aim(np.array(first.centre), body, target, hold)
            frame = self.plant.world.observe()
            for seen in target.find(frame):
                in_gripper(frame, seen)  # sorts it: in the gripper, or into `elsewhere`
        if not elsewhere:
            return None, unseen
        other = min(elsewhere, key=lambda e: float(np.linalg.norm(e.xy() - first.xy())))
        off_grasp = float(np.linalg.norm(grasped[:2] - first.xy()))
        off_other = float(np.linalg.norm(other.xy() - first.xy()))
        if off_other + max(0.03, hold.radius) >= off_grasp:  # as near: the same object, or as likely not
            return None, unseen
        return False, (
            f"the camera sees the {hold.label} {off_other * 100:.0f} cm from where the image showed it, and "
            f"not in the gripper, which closed {off_grasp * 100:.0f} cm from there"
        )

    def put_down(self) -> None:
        """Put what is held back where it was picked up."""
        hold = self.held("put_down")
        if moved(self.plant.pose(), hold.pose, 0.01, 0.02):
            self.carry_height(hold, hold.lift)
            self.driver.drive_to(hold.pose, None, "put_down")
        self.place(hold, hold.lift + 0.005)

    def put_on(self, target: Target) -> None:
        """Place what is held on top of the target object and check that it rests there."""
        hold = self.held("put_on")
        body = self.plant.body("put_on")
        top = self.top_seen(target, hold, body)
        if top is not None and top.area >= self.plant.tuning.large_top_m2:
            self.put_on_top(target, top, hold, body)
            return
        receptacle = self.locator.locate(target, "put_on")
        place_z = receptacle.top_z + hold.below + 0.01
        self.check_lift(place_z, receptacle.top_z, target, body)
        self.out_from_under(hold, place_z + 0.06, target, body)
        self.carry_height(hold, place_z + 0.06)
        # a receptacle takes the object anywhere near its middle: line up to a third of its radius
        tol = max(self.plant.tuning.arrive_tol, min(0.05, receptacle.radius / 3))
        reach = self.reacher.reach(receptacle, target, "put_on", holding=hold, tol=tol)
        self.plant.world.set_arm(place_z + 0.06, reach.extension)
        self.plant.settle(self.plant.tuning.extend_s)
        self.place(hold, place_z, extension=reach.extension)
        self.check_rests(hold, reach.estimate, target)

    def check_lift(self, place_z: float, top_z: float, target: Target, body: BodyGeometry) -> None:
        """Refuse a receptacle whose top is too high for the lift with the held object under the grip."""
        if place_z > body.lift_range[1]:
            raise ControlError(
                f"not reachable: the top of {target.describe()} is {top_z:.2f} m up, too high "
                "for the lift with the held object",
                "put the object on something lower",
            )

    # --- onto the top of a large receptacle -------------------------------------------------------
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
        self.check_lift(place_z, top.z, target, body)
        self.out_from_under(hold, place_z + 0.06, target, body)
        self.carry_height(hold, place_z + 0.06)
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
            self.carry_height(hold, place_z + 0.06)  # held up, clear of the top, to be put elsewhere
            raise ControlError(
                f"put_on failed: lowering the {hold.label} onto {target.describe()}, the wrist never felt "
                f"the top carry it (down to {place_z - hold.below - t.lower_below_m:.2f} m; the camera saw "
                f"the top at {top.z:.2f} m); it is still held",
                "put it down with robot.put_down(), or put it on another receptacle",
            )
        lift = self.plant.lift()
        self.let_go(lift, reach.extension)
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
        carried = self.force_z()
        if carried is None or abs(carried) < max(t.load_min_n, t.load_sigmas * self.load_spread * 2):
            world.set_arm(z, extension)
            self.plant.settle(t.place_lower_s)
            return None
        steps = int(round((0.02 + t.lower_below_m) / t.lower_step_m))
        for k in range(1, steps + 1):
            world.set_arm(z + 0.02 - k * t.lower_step_m, extension)
            self.plant.settle(t.lower_step_s)
            now = self.force_z()
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

    def push(self, target: Target) -> None:
        """Drive the base's front into an object on the floor and on by `push_m`; check that it moved."""
        body = self.plant.body("push")
        est = self.locator.locate(target, "push")
        if est.support_z > 0.08:
            raise ControlError(
                f"not reachable: {target.describe()} stands {est.support_z:.2f} m up, and this robot pushes "
                "with its base, which reaches only objects on the floor",
                "push objects that lie on the floor",
            )
        floor = self.locator.floor_map([target])
        floor.clear_disc(est.xy(), est.radius + 0.05)
        here = self.plant.pose()
        yaw = math.atan2(est.centre[1] - here[1], est.centre[0] - here[0])
        gap = body.base_half[0] + est.radius + 0.12
        start = (est.centre[0] - gap * math.cos(yaw), est.centre[1] - gap * math.sin(yaw), yaw)
        self.driver.drive_to(start, floor, "push", look_at=np.array(est.centre))
        before = self.locator.refind(est, target, "push")
        # drive into it: the base's front meets the object after 0.12 m, then pushes it on
        self.driver.straight(0.12 + self.plant.tuning.push_m)
        self.driver.straight(-(0.12 + self.plant.tuning.push_m))
        after = self.locator.refind(before, target, "push", search=0.6)
        shift = float(np.linalg.norm(after.xy() - before.xy()))
        if shift < 0.04:
            raise ControlError(
                f"push failed: {target.describe()} moved {shift * 100:.0f} cm",
                "the object may be too heavy or blocked; push something else",
            )

    def headroom(self, est: ObjectEstimate, body: BodyGeometry) -> float:
        """How far the object can be raised before it meets what is above it (a shelf board), by depth."""
        clear = self.plant.tuning.lift_clear
        frame = self.plant.world.observe()
        if frame.depth is None:
            return clear
        camera = frame.camera or self.plant.world.camera_info()
        pts = base_points(frame.depth, camera, self.plant.view(body), stride=2)
        pts = to_world(pts, self.plant.pose())
        over = pts[
            (np.hypot(pts[:, 0] - est.centre[0], pts[:, 1] - est.centre[1]) < est.radius + 0.03)
            & (pts[:, 2] > est.top_z + 0.04)
        ]
        if len(over) == 0:
            return clear
        return float(np.clip(float(over[:, 2].min()) - est.top_z - 0.02, 0.005, clear))

    def held(self, action: str) -> Hold:
        if self.holding is None:
            raise ControlError(f"{action}: the gripper holds nothing", "pick an object up first")
        return self.holding

    def carry_height(self, hold: Hold, z: float) -> None:
        """Pull the arm in with what is held, then raise it to `z` (at least where it is), to drive with it:
        in first, the way it came out, since a shelf's board may hang over where it was picked. Where a
        telescoping lift stops short (the object still under the board), it goes down again and the base
        backs off a little before the next try."""
        t = self.plant.tuning
        lift = self.plant.lift()
        self.plant.world.set_arm(lift, 0.0)
        self.plant.settle(t.arm_move_s)
        if z <= lift:
            return
        body = self.plant.geometry()
        for _ in range(3):
            self.plant.world.set_arm(z, 0.0)
            self.plant.settle(t.arm_move_s)
            stopped = self.plant.lift()
            # a heavy load sags a centimetre or two; a two-link arm reaches only what its linkage allows
            if stopped >= z - 0.03 or body is None or body.arm is not None:
                return
            self.plant.world.set_arm(lift, 0.0)
            self.plant.settle(t.arm_move_s)
            if not self.plant.has("base"):
                break
            self.driver.straight(-0.1)
        raise ControlError(
            f"not reachable: raising the {hold.label} to {z:.2f} m, the lift stopped at {stopped:.2f} m: "
            "something above holds it back",
            "put it down with robot.put_down(), or put it on something lower",
        )

    def out_from_under(self, hold: Hold, z: float, target: Target, body: BodyGeometry) -> None:
        """Before what is held is raised to lift `z`: while depth sees something hang over it with the arm
        pulled in (the board of a shelf it was picked from under), back the base off until it is out from
        under it (looking again after each step back: the object's far side is a guess from its front)."""
        lift = self.plant.lift()
        if z <= lift + 0.01 or not (self.plant.has("depth") and self.plant.has("base")):
            return
        grip_x, grip_y = body.reach_x(0.0), body.arm_xy[1]
        far = grip_x + hold.radius  # the held object's far side, forward of the base's centre
        for _ in range(3):
            self.locator.aim(self.locator.grip_point(body, lift + hold.above, 0.0), body, target, hold)
            frame = self.plant.world.observe()
            if frame.depth is None:
                return
            camera = frame.camera or self.plant.world.camera_info()
            pts = base_points(frame.depth, camera, self.plant.view(body), stride=2)
            # over the object's top nothing is the arm or the object itself
            over = pts[
                (np.abs(pts[:, 1] - grip_y) <= hold.radius + 0.03)
                & (pts[:, 0] >= body.base_half[0] + 0.02)
                & (pts[:, 0] <= far + 0.03)
                & (pts[:, 2] > lift + hold.above + 0.01)
                & (pts[:, 2] < z + hold.above + 0.03)
            ]
            if len(over) < 5:
                return
            self.driver.straight(-max(0.05, far + 0.05 - float(over[:, 0].min())))

    def place(self, hold: Hold, z: float, extension: float | None = None) -> None:
        """Lower what is held to `z`, let go, rise off it and pull the arm in."""
        t, world = self.plant.tuning, self.plant.world
        ext = hold.extension if extension is None else extension
        world.set_arm(max(z, self.plant.lift()), ext)
        self.plant.settle(t.arm_move_s)
        world.set_arm(z, ext)
        self.plant.settle(t.place_lower_s)
        self.let_go(z, ext)

    def let_go(self, z: float, extension: float) -> None:
        """Open the gripper on what is held at lift `z`, rise off it and pull the arm in."""
        t, world = self.plant.tuning, self.plant.world
        world.release()
        self.holding = None
        world.set_arm(z + t.lift_clear, extension)
        self.plant.settle(t.clear_s)
        self.retract(z + t.lift_clear)

    def retract(self, z: float) -> None:
        """Pull the arm in at `z`, then bring it to its resting pose."""
        t = self.plant.tuning
        self.plant.world.set_arm(z, 0.0)
        self.plant.settle(t.arm_move_s)
        self.plant.world.set_arm(*self.plant.body("pick_up").rest)
        self.plant.settle(t.arm_move_s)

    def check_rests(self, hold: Hold, receptacle: ObjectEstimate, target: Target) -> None:
        """Look at the receptacle: the placed object must stand on it."""
        body = self.plant.body("put_on")
        self.locator.aim(np.array(receptacle.centre), body, target)
        camera = self.plant.world.camera_info()
        frame = self.plant.world.observe()
        box = nearest_to_centre(hold.find(frame) if hold.find is not None else [], camera, 0.45)
        if box is None or frame.depth is None:
            if box is None and hold.find is not None:
                raise ControlError(
                    f"put_on failed: after letting go, the camera does not see the {hold.label} on "
                    f"{target.describe()}",
                    "it may have fallen; find it again in a new image",
                )
            return
        placed = estimate_object(frame.depth, camera, self.plant.view(body), self.plant.pose(), box)
        if placed is None:
            return
        off = float(np.linalg.norm(placed.xy() - receptacle.xy()))
        if off > receptacle.radius + 0.04 or placed.support_z < receptacle.top_z - 0.04:
            raise ControlError(
                f"put_on failed: the {hold.label} came to rest {off * 100:.0f} cm from the middle of "
                f"{target.describe()}, at {placed.support_z:.2f} m (its top is at {receptacle.top_z:.2f} m)",
                "try a larger or flatter receptacle",
            )

    def load(self) -> float | None:
        """The wrist's vertical load in newtons, averaged over a few readings; None without a force sensor."""
        force = self.force_z()
        return None if force is None else abs(force)

    def force_z(self) -> float | None:
        """The wrist's vertical force in newtons, signed, averaged over a few readings (`load_spread` its
        standard error); None without a force sensor."""
        t = self.plant.tuning
        if not self.plant.has("force"):
            return None
        readings = []
        for _ in range(t.load_readings):
            self.plant.world.step(t.load_step_s)
            readings.append(float(self.plant.world.read_force()[2]))
        self.load_spread = float(np.std(readings, ddof=1)) / math.sqrt(len(readings))
        return sum(readings) / len(readings)


def _cut_off(box: Box, camera: CameraInfo) -> bool:
    """Whether a box reaches an edge of the image (what it frames may go on beyond it)."""
    return box[0] <= 2 or box[1] <= 2 or box[2] >= camera.width - 2 or box[3] >= camera.height - 2
