"""Manipulating by perception: grasp and lift (checked by the gripper and the wrist's force sensor, within
the sensor's noise), put down where it was picked, put on a receptacle (checked by looking at it
afterwards), and push (checked by finding the object again where it went).

A small receptacle (a plate, a bowl) takes the object at its middle; the top of a large one (a table, a
counter, a shelf) takes it on a free spot (`control.onto_top`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from attribot.control.base import ControlError, Failure, Target
from attribot.control.body import BodyGeometry
from attribot.control.drive import Driver
from attribot.control.locate import Locator
from attribot.control.onto_top import TopPlacer
from attribot.control.plant import Hold, Plant, Reach, moved
from attribot.control.reach import Reacher
from attribot.control.sighting import Box, nearest_to_centre
from attribot.control.spatial import ObjectEstimate, base_points, estimate_object, to_world
from attribot.frame import Frame

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
                reason=Failure.GRASP_FAILED,
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
                reason=Failure.GRASP_FAILED,
            )

    def check_held(self, target: Target, seen_first: Target) -> tuple[bool | None, str]:
        """Whether the object lifted is the target, by what the camera sees: its name rising with the gripper
        (True); or seen only elsewhere, nearer than the grasp to where the program's image (`seen_first`) put
        it, so that another object was lifted (False). None when it cannot tell: no finder or depth, the name
        not seen, or seen only farther away (another of its kind, the held one missed). True without a look
        where the gripper closed within `slack` of where that image put it: no sighting can be nearer."""
        hold = self.holding
        body = self.plant.body("pick_up")
        if hold is None or target.find is None or not self.plant.has("pose"):
            return None, "nothing to look for"
        js = self.plant.world.joint_states()
        lift = float(js.get("lift", hold.lift))
        grip = self.locator.grip_point(body, lift, float(js.get("arm", hold.extension)))
        grasped = self.locator.grip_point(body, hold.lift, hold.extension, hold.pose)
        first = self.locator.where_seen(seen_first, body)
        off_grasp = None if first is None else float(np.linalg.norm(grasped[:2] - first.xy()))
        slack = max(0.03, hold.radius)  # a sighting of the name must be this much nearer to say "another"
        if off_grasp is not None and off_grasp <= slack:
            said = f"the gripper closed {off_grasp * 100:.0f} cm from where the image showed the {hold.label}"
            return True, said
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

        # the object is where the gripper is: the head nudged around it, not turned aside (and once only
        # for a target depth placed, which the detector never saw surely)
        nudges = 0 if target.by_depth else None
        _, box = self.locator.look_again(target, camera, 0.5, in_gripper, aside=False, nudges=nudges)
        if box is not None:
            return True, f"the camera sees the {hold.label} rise with the gripper"
        unseen = f"the camera does not see the {hold.label} in the gripper"
        if first is None or off_grasp is None:
            return None, unseen
        if not elsewhere:  # look where the image showed it: still standing there, it was not lifted
            self.locator.aim(np.array(first.centre), body, target, hold)
            frame = self.plant.world.observe()
            for seen in target.find(frame):
                in_gripper(frame, seen)  # sorts it: in the gripper, or into `elsewhere`
        if not elsewhere:
            return None, unseen
        other = min(elsewhere, key=lambda e: float(np.linalg.norm(e.xy() - first.xy())))
        off_other = float(np.linalg.norm(other.xy() - first.xy()))
        if off_other + slack >= off_grasp:  # as near: the same object, or as likely not
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
        onto = TopPlacer(self)
        top = onto.top_seen(target, hold, body)
        if top is not None and top.area >= self.plant.tuning.large_top_m2:
            onto.put_on_top(target, top, hold, body)
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
                reason=Failure.NOT_REACHABLE,
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
                reason=Failure.NOT_REACHABLE,
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
            reason=Failure.NOT_REACHABLE,
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
