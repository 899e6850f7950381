"""Visual servoing: the robot turns its camera onto an object by what it sees, as the paper's robot did.

`ServoController.focus_on` first aims by geometry (the pointing controller: the box's ray from the
capture's intrinsics and head angles), then closes the loop on the camera: it finds the target once in a
fresh frame with the configured detector (`Target.find`) (or, with `preaim=False`, takes the box of the
unchanged view it was seen in, as the paper's robot did), tracks its box with KLT frame by frame, and
drives the head with a PID per axis on the box centre's angular error until the centre lies within
`tol_px` of the image centre. When the tracker loses the target it detects again, once, before giving up.
It steps the world one control period at a time (sim time in the simulator, wall time on a robot: no
sleeps) and uses only what a real robot has: frames (RGB), intrinsics, head joint angles and its base
pose; never the simulator's object poses, ids or segmentation. A robot without a camera head (the paper's
RoboMaster) centres left-right by turning its base with a PID on the same error, from the unchanged view.

The other actions act on what depth and odometry say, never on the simulator's state: an object is
located from the depth pixels in its box (or the rangefinder when there is no depth image); a floor map
is built from the depth images (anything above the floor blocks the base); the base drives a path planned
on that map with a PID per axis on the odometry pose, its head aimed at the object; at the goal the camera
finds the object again (detector once, then the servo loop), the object is located again, and the base
corrects its pose until the arm's line passes through the object. Grasps are checked by the gripper and
the force sensor, placements and pushes by looking at the object afterwards.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from attribot.control.base import CONTROLLERS, Capture, ControlError, Target, not_available
from attribot.control.body import BodyGeometry
from attribot.control.pid import PID
from attribot.control.pointing import PointingController
from attribot.control.spatial import (
    FloorMap,
    ObjectEstimate,
    base_points,
    estimate_object,
    head_towards,
    point_from_range,
    to_base,
    to_world,
)
from attribot.control.tracker import BoxTracker

__all__ = ["ServoController", "FocusReport"]


@dataclass(frozen=True)
class FocusReport:
    """How the last focus went: control steps, seconds of (sim or wall) time in all (the geometric pre-aim's
    settling included), final pixel error, re-detections."""

    steps: int
    seconds: float
    error_px: float
    redetections: int


@dataclass
class ServoController(PointingController):
    """Every Robot action by perception (see the module docstring).

    control_s: time per control step; tol_px: the centring tolerance; max_steps: the step budget of one
    focus; kp / ki: PID gains on the angular error (radians of head command per radian of error per step);
    max_step_rad: the largest head correction in one step; preaim: aim by geometry first and detect again
    (True), or track the target's box from the current view at once, which must not have changed since the
    capture (False: the paper's robot, and the only way without intrinsics one trusts). turn_kp / turn_ki /
    max_turn: the PID that turns the base (rad/s per radian of error) on a robot without a camera head,
    which is then centred left-right only and always from the unchanged view. drive_speed: the
    base's top speed, m/s; arrive_tol: how close (metres) the arm's line must pass to the object;
    align_tries: base corrections at the goal; stand_tries: places to stand tried when the camera loses the
    object at one; lift_clear: how high a picked object is raised (less under a shelf board); push_m: how
    far a push drives on after the base meets the object. max_misses: frames in a row a flaky detector may
    miss the object, when it is found by detection rather than tracked, while its box is carried along by
    the camera's own measured motion. max_tol_px: the most the centring tolerance widens to when the box is
    found by detection in every frame and the detections jitter (their spread sets it). back_off_m: how far
    the base backs off to look once more when the object is missed from where it stands at every turn.
    """

    name: str = "servo"
    control_s: float = 0.05
    tol_px: float = 1.5
    max_steps: int = 80
    kp: float = 0.8
    ki: float = 0.4
    max_step_rad: float = 0.15
    turn_kp: float = 3.0
    turn_ki: float = 0.5
    max_turn: float = 1.0
    preaim: bool = True
    drive_speed: float = 0.5
    arrive_tol: float = 0.012
    align_tries: int = 4
    stand_tries: int = 3
    lift_clear: float = 0.08
    push_m: float = 0.15
    max_misses: int = 3
    max_tol_px: float = 6.0
    back_off_m: float = 0.3
    load_readings: int = 8
    load_spread: float = field(default=0.0, repr=False)  # the standard error of the last load reading
    last: FocusReport | None = None
    tracked: tuple[float, float, float, float] | None = None  # the box being centred, while it is
    approached: _Reach | None = field(default=None, repr=False)  # where go_to_object brought the arm
    holding: _Hold | None = field(default=None, repr=False)

    def focus_on(self, target: Target) -> None:
        try:
            self._centre(target)
        finally:
            self.tracked = None

    def _centre(self, target: Target) -> None:
        camera = self.world.camera_info()
        self.waited_s, self.last = 0.0, None  # no report when the geometric aim is all there is
        caps = {str(c) for c in self.world.capabilities()}
        # without a pan/tilt head (the paper's RoboMaster) the base turns instead, centring the box
        # left-right only: its camera cannot tilt
        headless = "head" not in caps
        if headless and "base" not in caps:
            raise not_available("focus_on_patch", self._world_name, "it has neither a camera head nor a base")
        if self.preaim and not headless:
            super().focus_on(target)  # aim by geometry: the object is now near the image centre
            if target.find is None:
                return  # nothing to see it with again: keep the geometric aim
            frame = self.world.observe()
            box = _nearest_to_centre(target.find(frame), camera)
            if box is None:
                return  # the detector does not see it again: keep the geometric aim, as pointing would
        else:
            # the paper's way: the view has not changed since the capture, so its box is tracked as it is
            self._check_base(target.capture.base, caps)
            frame, box = self.world.observe(), target.box

        def see(frame: Any) -> Any:
            return None if target.find is None else _nearest_to_centre(target.find(frame), camera)

        def lost(why: str) -> ControlError:
            return ControlError(
                f"lost sight of {target.describe()} while centring it ({why})",
                "find the object again in a new image (image.find) and retry",
            )

        def carried(box: Any, turned: tuple[float, float]) -> Any:
            """The box moved by the camera's own rotation (pan, tilt; left and up positive): where a still
            object is now seen."""
            du, dv = camera.fx * math.tan(turned[0]), camera.fy * math.tan(turned[1])
            return (box[0] + du, box[1] + dv, box[2] + du, box[3] + dv)

        tracker = BoxTracker()
        state = tracker.start(frame.rgb, box)
        # a small or plain object may give too few features to track: the detector then finds it in every
        # frame instead (slower per step, as sure)
        tracking = not state.lost
        pids = [PID(self.kp, self.ki, out_min=-self.max_step_rad, out_max=self.max_step_rad) for _ in "pt"]
        turn = PID(self.turn_kp, self.turn_ki, out_min=-self.max_turn, out_max=self.max_turn)
        redetections, misses, steps, error, checked = 0, 0, 0, math.inf, False
        # found by detection, a box jitters from frame to frame: how far each detection lands from where
        # the last box, carried by the head's motion, says it must be; the centring tolerance widens to it
        innovations: list[float] = []
        tol = self.tol_px
        for step in range(1, self.max_steps + 1):
            steps = step
            if tracking and state.lost:
                if redetections or target.find is None:
                    raise lost(state.reason)
                redetections += 1
                seen = see(frame)
                tracking = False  # until the detector sees it again; then tracked anew
                if seen is None:
                    misses, box = 1, state.box
                else:
                    box = seen
                    state = tracker.start(frame.rgb, box)
                    tracking = not state.lost
            if tracking:
                box = state.box
            self.tracked = box
            u, v = (box[0] + box[2]) / 2, (box[1] + box[3]) / 2
            error = abs(u - camera.cx) if headless else math.hypot(u - camera.cx, v - camera.cy)
            if not tracking and len(innovations) >= 3:
                tol = min(max(self.tol_px, float(np.median(innovations[-6:]))), self.max_tol_px)
            if error <= tol:
                if not tracking or target.find is None or checked:
                    break
                # the tracked box may have drifted off the object (background features at its edges):
                # one detection confirms the centring, or the loop goes on with detections every frame
                checked = True
                seen = see(frame)
                if seen is None or _off_centre(seen, camera, headless) <= max(tol, self.tol_px):
                    break
                tracking, box = False, seen
                continue
            # angular errors: left of the centre means pan left (positive), above means tilt up (positive)
            pan_err = math.atan2(camera.cx - u, camera.fx)
            tilt_err = math.atan2(camera.cy - v, camera.fy)
            if headless:
                wz = turn.update(0.0, -pan_err, self.control_s)
                self.world.command_base(0.0, 0.0, wz)
            else:
                pan, tilt = _head(self.world)
                self.world.set_head(
                    pan + pids[0].update(0.0, -pan_err, self.control_s),
                    tilt + pids[1].update(0.0, -tilt_err, self.control_s),
                )
            self.world.step(self.control_s)
            frame = self.world.observe()
            if tracking:
                state = tracker.update(frame.rgb)
                continue
            if headless:  # a robot without a head may not report its pose: the commanded turn it is
                predicted = carried(box, (wz * self.control_s, 0.0))
            else:
                now = _head(self.world)
                predicted = carried(box, (now[0] - pan, now[1] - tilt))
            seen = _nearest_to(target.find(frame) if target.find else [], predicted)
            if seen is not None:
                innovations.append(_gap(seen, predicted))
                # half the detection, half the prediction: a jittery detector's noise is halved
                misses, box = 0, tuple((a + b) / 2 for a, b in zip(seen, predicted, strict=True))
                continue
            misses += 1
            if misses > self.max_misses:
                raise lost(f"too little texture to track, and the detector missed it {misses} times in a row")
            box = predicted
        else:
            if headless:
                self.world.command_base(0.0, 0.0, 0.0)
            raise ControlError(
                f"the camera did not centre {target.describe()} within {self.max_steps} control steps "
                f"({error:.1f} px off)",
                "the object may be moving or beyond the head's range: go_to_object first",
            )
        if headless:
            self.world.command_base(0.0, 0.0, 0.0)
        self.last = FocusReport(steps, self.waited_s + steps * self.control_s, error, redetections)

    # --- perception-driven actions ------------------------------------------------------------------
    def approach(self, target: Target) -> None:
        est = self._locate(target, "go_to_object")
        self.approached = None
        self.approached = self._go_reach(est, target, "go_to_object")

    def pick_up(self, target: Target) -> None:
        body = self._body("pick_up")
        if self.holding is not None:
            raise ControlError(f"the gripper already holds {self.holding.label}", "put it down first")
        reach = self.approached  # the Robot checks that go_to_object came to this same object
        if reach is None:
            self.approach(target)
            reach = self.approached
        assert reach is not None
        est = reach.estimate
        ext, z = reach.extension, float(np.clip(est.grip_z, *body.lift_range))
        headroom = self._headroom(est, body)
        self.world.release()  # open the fingers
        self.world.set_arm(max(z, self._lift()), 0.0)
        self._settle(0.8)
        self.world.set_arm(z, 0.0)
        self._settle(0.6)
        self.world.set_arm(z, ext)
        self._settle(1.0)
        load_before = self._load()
        if not self.world.grasp():
            self._retract(z)
            raise ControlError(
                f"grasp failed: the gripper closed on nothing where it saw {target.describe()} "
                f"({ext:.2f} m out, {z:.2f} m up)",
                "call robot.go_to_object(patch) again and retry; the object may be too big to grasp",
            )
        self.world.set_arm(z + headroom, ext)
        self._settle(1.5)
        before_spread = self.load_spread
        load = self._load()
        closed = float(self.world.joint_states().get("gripper", 1.0)) < 0.0003  # the fingers met: it fell out
        # no load: no change beyond the readings' noise (three standard errors of the difference), when the
        # sensor is fine enough to feel a light object at all; a noisier one leaves it to the gripper
        noise = 3.0 * math.hypot(before_spread, self.load_spread)
        unloaded = (
            load is not None and load_before is not None and abs(load - load_before) < max(0.004, noise)
        )
        if closed or (unloaded and noise < 0.05):
            self.world.release()
            self._retract(z)
            felt = "the gripper closed on nothing" if closed else "the force sensor feels no load"
            raise ControlError(
                f"grasp failed: {felt} after lifting {target.describe()}",
                "call robot.go_to_object(patch) again and retry",
            )
        self.holding = _Hold(
            label=target.label or "object",
            find=target.find,
            pose=self._pose(),
            lift=z,
            extension=ext,
            below=z - est.support_z,
            above=est.top_z - z,
            radius=est.radius,
        )
        self.approached = None

    def put_down(self) -> None:
        hold = self._held("put_down")
        if _moved(self._pose(), hold.pose, 0.01, 0.02):
            self._carry_height(hold, hold.lift)
            self._drive_to(hold.pose, None, "put_down")
        self._place(hold, hold.lift + 0.005)

    def put_on(self, target: Target) -> None:
        hold = self._held("put_on")
        body = self._body("put_on")
        receptacle = self._locate(target, "put_on")
        place_z = receptacle.top_z + hold.below + 0.01
        if place_z > body.lift_range[1]:
            raise ControlError(
                f"not reachable: the top of {target.describe()} is {receptacle.top_z:.2f} m up, too high "
                "for the lift with the held object",
                "put the object on something lower",
            )
        self._carry_height(hold, place_z + 0.06)
        # a receptacle takes the object anywhere near its middle: line up to a third of its radius
        tol = max(self.arrive_tol, min(0.05, receptacle.radius / 3))
        reach = self._go_reach(receptacle, target, "put_on", holding=hold, tol=tol)
        self.world.set_arm(place_z + 0.06, reach.extension)
        self._settle(1.0)
        self._place(hold, place_z, extension=reach.extension)
        self._check_rests(hold, reach.estimate, target)

    def push(self, target: Target) -> None:
        body = self._body("push")
        est = self._locate(target, "push")
        if est.support_z > 0.08:
            raise ControlError(
                f"not reachable: {target.describe()} stands {est.support_z:.2f} m up, and this robot pushes "
                "with its base, which reaches only objects on the floor",
                "push objects that lie on the floor",
            )
        floor = self._map([target])
        floor.clear_disc(est.xy(), est.radius + 0.05)
        here = self._pose()
        yaw = math.atan2(est.centre[1] - here[1], est.centre[0] - here[0])
        gap = body.base_half[0] + est.radius + 0.12
        start = (est.centre[0] - gap * math.cos(yaw), est.centre[1] - gap * math.sin(yaw), yaw)
        self._drive_to(start, floor, "push", look_at=np.array(est.centre))
        before = self._refind(est, target, "push")
        # drive into it: the base's front meets the object after 0.12 m, then pushes it on
        self._straight(0.12 + self.push_m, look_at=np.array(before.centre))
        self._straight(-(0.12 + self.push_m), look_at=None)
        after = self._refind(before, target, "push", search=0.6)
        moved = float(np.linalg.norm(after.xy() - before.xy()))
        if moved < 0.04:
            raise ControlError(
                f"push failed: {target.describe()} moved {moved * 100:.0f} cm",
                "the object may be too heavy or blocked; push something else",
            )

    def go_to_coords(self, target: Target) -> None:
        body = self._body("go_to_coords")
        goal = self._floor_point(target, body)
        floor = self._map([target])
        here = self._pose()
        yaw = math.atan2(goal[1] - here[1], goal[0] - here[0])
        towards = goal - np.array(here[:2])
        span = float(np.linalg.norm(towards))
        for back in np.arange(0.0, min(span, 1.5), 0.05):
            xy = goal - towards / max(span, 1e-9) * back
            if floor.footprint_free((xy[0], xy[1], yaw), body.base_half, 0.03):
                self._drive_to((float(xy[0]), float(xy[1]), yaw), floor, "go_to_coords")
                return
        raise ControlError(
            f"not reachable: the floor at ({goal[0]:.2f}, {goal[1]:.2f}) and the way to it are taken by "
            "something the camera sees",
            "choose a point on free floor",
        )

    # --- locating -------------------------------------------------------------------------------------
    def _body(self, action: str) -> BodyGeometry:
        body = getattr(self.world, "body", None)
        if body is None:
            raise not_available(action, self._world_name, "it does not state its body geometry")
        for need in ("base", "pose"):
            if need not in {str(c) for c in self.world.capabilities()}:
                raise not_available(action, self._world_name, f"it has no {need} capability")
        return body()

    def _pose(self) -> tuple[float, float, float]:
        p = self.world.base_pose()
        return float(p.x), float(p.y), float(p.yaw)

    def _has(self, capability: str) -> bool:
        return capability in {str(c) for c in self.world.capabilities()}

    def _locate(self, target: Target, action: str) -> ObjectEstimate:
        """Where the target is, from the depth of the image it was seen in; without one, by centring the
        camera on it and reading the rangefinder (which needs the view unchanged since that image)."""
        body = self._body(action)
        cap = target.capture
        if cap.depth is not None and cap.camera is not None and cap.head is not None and cap.base is not None:
            est = estimate_object(cap.depth, cap.camera, cap.head, cap.base, body, target.box)
            if est is not None:
                return est
        if cap.camera is None:
            raise not_available(action, self._world_name, "the image was taken without known intrinsics")
        if not self._has("distance"):
            raise not_available(action, self._world_name, "it has neither depth images nor a distance sensor")
        self.focus_on(target)
        return self._range_estimate(target.box, cap.camera, body)

    def _range_estimate(
        self, box: tuple[float, float, float, float], camera: Any, body: BodyGeometry
    ) -> ObjectEstimate:
        """The object at the image centre by the rangefinder, sized by its box at that range."""
        metres = float(self.world.read_distance())
        if not math.isfinite(metres):
            raise ControlError("the distance sensor sees nothing where the object is", "come closer first")
        head = _head(self.world)
        p = to_world(point_from_range(metres, camera, head, body, camera.cx, camera.cy), self._pose())
        w = (box[2] - box[0]) / camera.fx * metres
        h = (box[3] - box[1]) / camera.fy * metres
        return ObjectEstimate((float(p[0]), float(p[1]), float(p[2])), p[2] - h / 2, p[2] + h / 2, w / 2, 1)

    def _refind(
        self,
        est: ObjectEstimate,
        target: Target,
        action: str,
        search: float = 0.25,
        holding: _Hold | None = None,
    ) -> ObjectEstimate:
        """Look at where `est` should be, find the target there with the detector, centre it with the servo
        loop and locate it again from the new view."""
        body = self._body(action)
        self._aim(np.array(est.centre), body, target)
        camera = self.world.camera_info()
        ignore = None if holding is None else self._held_points(holding, body)
        reach = max(0.25, 3.0 * est.radius)

        def where(frame: Any, box: Any) -> ObjectEstimate | None:
            """The object in `box` located from depth, if it is about where `est` was (a box elsewhere,
            another object of the kind or a detector's mistake, is not it)."""
            if frame.depth is None:
                return est
            new = estimate_object(frame.depth, camera, _head(self.world), self._pose(), body, box, ignore)
            near = new is not None and float(np.linalg.norm(new.xy() - est.xy())) <= reach
            return new if near else None

        frame, box = self._look_again(target, camera, search, where)
        if box is None and self._has("base") and self.back_off_m > 0:
            # missed from here at every turn of the head (a viewpoint the detector fails from): step back
            # and look again from farther away, before giving it up
            self._straight(-self.back_off_m, None)
            self._aim(np.array(est.centre), body, target)
            frame, box = self._look_again(target, camera, search, where)
        if box is None:
            raise ControlError(
                f"target lost: the camera no longer sees {target.describe()} where it was "
                f"({est.centre[0]:.2f}, {est.centre[1]:.2f})",
                "find the object again in a new image and retry",
            )
        located = where(frame, box)
        seen = Target(box, self._capture(frame, camera), label=target.label, find=target.find)
        self.focus_on(seen)
        frame = self.world.observe()
        if frame.depth is None:
            box = _nearest_to_centre(target.find(frame) if target.find else [], camera, search) or box
            return self._range_estimate(box, camera, body) if self._has("distance") else est
        for box in _by_centre(target.find(frame) if target.find else [], camera, search):
            found = where(frame, box)
            if found is not None:
                return found
        # centred, the detector sees it no better (a viewpoint it misses the object from): where it was
        # found before centring
        return located if located is not None else est

    def _look_again(
        self, target: Target, camera: Any, search: float, accept: Callable[[Any, Any], Any] | None = None
    ) -> tuple[Any, Any]:
        """The frame and the target's box nearest the image centre (of those `accept` takes). A detector
        that misses the object in this view is given up to `max_misses` more views, the head turned a
        little each time, then a third of the view to either side (the same view would often be missed,
        or mistaken, the same way)."""
        pan, tilt = _head(self.world)

        def first(frame: Any, boxes: list[Any]) -> Any:
            return next((b for b in boxes if accept is None or accept(frame, b) is not None), None)

        for k in range(self.max_misses + 1 if target.find is not None else 1):
            if k:  # 0.02 rad to one side, then the other, then further
                self.world.set_head(pan + (1 if k % 2 else -1) * 0.02 * ((k + 1) // 2), tilt)
                self._settle(0.15)
            frame = self.world.observe()
            box = first(frame, _by_centre(target.find(frame) if target.find else [], camera, search))
            if box is not None:
                return frame, box
        if target.find is None:
            return frame, None
        # a detector that misses an object from one viewpoint may not from another: turn a third of the
        # view to each side, where the object sits elsewhere in the image, and look for it where it must be
        for turn in (camera.hfov / 3.0, -camera.hfov / 3.0):
            self.world.set_head(pan + turn, tilt)
            self._settle(0.4)
            frame = self.world.observe()
            shift = camera.fx * math.tan(turn)  # where the old line of sight now is, from the centre
            moved = _by_centre(
                [(b[0] - shift, b[1], b[2] - shift, b[3]) for b in target.find(frame)], camera, search
            )
            box = first(frame, [(b[0] + shift, b[1], b[2] + shift, b[3]) for b in moved])
            if box is not None:
                return frame, box
        self.world.set_head(pan, tilt)
        self._settle(0.3)
        return frame, None

    def _held_points(self, hold: _Hold, body: BodyGeometry) -> Any:
        """A mask of world points on the arm and on what it holds: a cylinder around the grip point and a
        capsule along the arm, from where the joints stand now."""
        js = self.world.joint_states()
        lift, ext = float(js.get("lift", hold.lift)), float(js.get("arm", hold.extension))
        pose = self._pose()
        grip = to_world(np.array([body.reach_x(ext), body.arm_xy[1], lift]), pose)
        tips = to_world(np.array([body.reach_x(ext) + 0.05, body.arm_xy[1], lift]), pose)
        root = to_world(np.array([body.arm_xy[0], body.arm_xy[1], lift]), pose)
        r = hold.radius + 0.04

        def held(points: np.ndarray) -> np.ndarray:
            flat = np.hypot(points[:, 0] - grip[0], points[:, 1] - grip[1]) <= r
            on = (
                flat & (points[:, 2] >= lift - hold.below - 0.03) & (points[:, 2] <= lift + hold.above + 0.03)
            )
            axis = tips - root
            t = np.clip((points - root) @ axis / max(float(axis @ axis), 1e-9), 0.0, 1.0)
            arm = np.linalg.norm(points - (root + t[:, None] * axis), axis=1) <= 0.1  # wrist and fingers
            return on | arm

        return held

    def _capture(self, frame: Any, camera: Any) -> Capture:
        return Capture(-1, camera, _head(self.world), self._pose(), depth=frame.depth)

    def _aim(self, point: np.ndarray, body: BodyGeometry, target: Target) -> None:
        pan, tilt = head_towards(point, self._pose(), body)
        self.world.set_head(pan, tilt)
        self._wait_still(target)

    def _floor_point(self, target: Target, body: BodyGeometry) -> np.ndarray:
        """The floor point under pixel `target.center` of its image: depth when the image has it, else the
        ray's crossing with the floor."""
        cap = target.capture
        if cap.camera is None or cap.head is None or cap.base is None:
            raise not_available("go_to_coords", self._world_name, "the image has no known intrinsics or pose")
        u, v = target.center
        if cap.depth is not None:
            r, c = min(int(v), cap.depth.shape[0] - 1), min(int(u), cap.depth.shape[1] - 1)
            p = base_points(cap.depth, cap.camera, cap.head, body, (c, r, c + 1, r + 1))
            if len(p):
                return to_world(p[0], cap.base)[:2]
        ray = point_from_range(1.0, cap.camera, cap.head, body, u, v) - np.asarray(body.camera_xyz)
        if ray[2] >= -1e-6:
            raise ControlError(
                f"go_to_coords: pixel ({u:.0f}, {v:.0f}) looks at or above the horizon, not at the floor",
                "pass a point on the floor, lower in the image",
            )
        t = body.camera_xyz[2] / -ray[2]
        return to_world(np.asarray(body.camera_xyz) + ray * t, cap.base)[:2]

    def _map(self, targets: list[Target], holding: _Hold | None = None) -> FloorMap:
        """A floor map from the current view and the depth images the targets were seen in."""
        body = self._body("go_to_object")
        here = self._pose()
        floor = FloorMap((here[0], here[1]))
        views = []
        frame = self.world.observe()
        if frame.depth is not None:
            views.append((frame.depth, frame.camera or self.world.camera_info(), _head(self.world), here))
        for t in targets:
            c = t.capture
            if c.depth is not None and c.camera is not None and c.head is not None and c.base is not None:
                views.append((c.depth, c.camera, c.head, c.base))
        for depth, camera, head, base in views:
            pts = base_points(depth, camera, head, body, stride=3)
            # not the robot itself, nor what its gripper holds
            pts = pts[np.hypot(pts[:, 0], pts[:, 1]) > body.radius + 0.05]
            floor.add(to_world(pts, base))
        if holding is not None:
            grip = to_world(np.array([body.reach_x(holding.extension), body.arm_xy[1], 0.0]), here)
            floor.clear_disc(grip[:2], 0.15)
        return floor

    # --- reaching -------------------------------------------------------------------------------------
    def _go_reach(
        self,
        est: ObjectEstimate,
        target: Target,
        action: str,
        holding: _Hold | None = None,
        tol: float | None = None,
    ) -> _Reach:
        """Drive to where the arm's line passes through the object and it is within the arm's range. The
        approach comes from the side the object was seen from; where the camera loses it at the goal (a
        shelf's side board in the way), the next place to stand is tried."""
        body = self._body(action)
        floor = self._map([target], holding)
        seen_from = target.capture.base or self._pose()
        lost: ControlError | None = None
        for tried, (pose, path) in enumerate(self._standing_poses(est, body, floor, seen_from)):
            if tried == self.stand_tries:
                break
            self._follow(path, pose, np.array(est.centre), action)
            try:
                return self._line_up(est, target, action, body, holding, tol)
            except ControlError as e:
                if not str(e).startswith("target lost"):
                    raise
                lost = e
        if lost is not None:
            raise lost
        raise ControlError(
            f"not reachable: no free place to stand within the arm's reach of {target.describe()} "
            f"(at {est.centre[0]:.2f}, {est.centre[1]:.2f}, {est.centre[2]:.2f} m)",
            "choose an object nearer a free edge of its furniture",
        )

    def _line_up(
        self,
        est: ObjectEstimate,
        target: Target,
        action: str,
        body: BodyGeometry,
        holding: _Hold | None,
        tol: float | None,
    ) -> _Reach:
        """Find the object again from here and correct the base until the arm's line passes within `tol`
        (default `arrive_tol`) of it."""
        tol = self.arrive_tol if tol is None else tol
        side = ext = math.nan
        for _ in range(self.align_tries):
            est = self._refind(est, target, action, holding=holding)
            local = to_base(np.array(est.centre), self._pose())
            ext = float(local[0] - body.reach_x(0.0))
            side = float(local[1] - body.arm_xy[1])
            lo, hi = body.arm_range
            # a centimetre beyond the telescope's ends still closes the fingers on the object
            if abs(side) <= tol and lo - 0.015 <= ext <= hi + 0.015:
                return _Reach(target.label, est, float(np.clip(ext, lo, hi)))
            fix = ext - float(np.clip(ext, lo + 0.03, hi - 0.03))
            x, y, yaw = self._pose()
            c, s = math.cos(yaw), math.sin(yaw)
            self._drive_to((x + c * fix - s * side, y + s * fix + c * side, yaw), None, action, est.centre)
        raise ControlError(
            f"not reachable: the robot could not line its arm up with {target.describe()} "
            f"(after {self.align_tries} corrections, {abs(side) * 100:.1f} cm aside, extension {ext:.2f} m)",
            "the object may lie beyond the arm's reach from any free place; choose another",
        )

    def _standing_poses(
        self,
        est: ObjectEstimate,
        body: BodyGeometry,
        floor: FloorMap,
        seen_from: tuple[float, float, float],
    ) -> Iterator[tuple[tuple[float, float, float], list[np.ndarray]]]:
        """Base poses facing the object with the grip point on it at the shortest free extension, and paths
        to them: first along the line it was seen along (that side has a view of it), then turned more and
        more from it."""
        here = self._pose()
        centre = est.xy()
        bearing = math.atan2(centre[1] - seen_from[1], centre[0] - seen_from[0])
        for turn in (0.0, 0.35, -0.35, 0.7, -0.7, 1.05, -1.05, 1.4, -1.4, 1.75, -1.75, 2.1, -2.1, math.pi):
            yaw = bearing + turn
            c, s = math.cos(yaw), math.sin(yaw)
            # a few centimetres of extension to spare either way, for the corrections at the goal
            for ext in np.arange(body.arm_range[0] + 0.05, body.arm_range[1] - 0.03, 0.02):
                lx, ly = body.reach_x(float(ext)), body.arm_xy[1]
                pose = (centre[0] - (c * lx - s * ly), centre[1] - (s * lx + c * ly), yaw)
                if floor.footprint_free(pose, body.base_half, 0.04):
                    path = floor.path(np.array(here[:2]), np.array(pose[:2]), body.radius + 0.02)
                    if path is not None:
                        yield pose, path
                    break

    def _headroom(self, est: ObjectEstimate, body: BodyGeometry) -> float:
        """How far the object can be raised before it meets what is above it (a shelf board), by depth."""
        frame = self.world.observe()
        if frame.depth is None:
            return self.lift_clear
        camera = frame.camera or self.world.camera_info()
        pts = to_world(base_points(frame.depth, camera, _head(self.world), body, stride=2), self._pose())
        over = pts[
            (np.hypot(pts[:, 0] - est.centre[0], pts[:, 1] - est.centre[1]) < est.radius + 0.03)
            & (pts[:, 2] > est.top_z + 0.04)
        ]
        if len(over) == 0:
            return self.lift_clear
        return float(np.clip(float(over[:, 2].min()) - est.top_z - 0.02, 0.005, self.lift_clear))

    # --- holding and placing --------------------------------------------------------------------------
    def _held(self, action: str) -> _Hold:
        if self.holding is None:
            raise ControlError(f"{action}: the gripper holds nothing", "pick an object up first")
        return self.holding

    def _lift(self) -> float:
        return float(self.world.joint_states().get("lift", 0.2))

    def _carry_height(self, hold: _Hold, z: float) -> None:
        """Raise what is held to `z` (at least where it is) and pull the arm in, to drive with it."""
        z = max(z, self._lift())
        self.world.set_arm(z, hold.extension)
        self._settle(0.8)
        self.world.set_arm(z, 0.0)
        self._settle(0.8)

    def _place(self, hold: _Hold, z: float, extension: float | None = None) -> None:
        ext = hold.extension if extension is None else extension
        self.world.set_arm(max(z, self._lift()), ext)
        self._settle(0.8)
        self.world.set_arm(z, ext)
        self._settle(1.2)
        self.world.release()
        self.holding = None
        self.world.set_arm(z + self.lift_clear, ext)
        self._settle(0.6)
        self._retract(z + self.lift_clear)

    def _retract(self, z: float) -> None:
        self.world.set_arm(z, 0.0)
        self._settle(0.8)
        self.world.set_arm(0.2, 0.0)
        self._settle(0.8)

    def _check_rests(self, hold: _Hold, receptacle: ObjectEstimate, target: Target) -> None:
        """Look at the receptacle: the placed object must stand on it."""
        body = self._body("put_on")
        self._aim(np.array(receptacle.centre), body, target)
        camera = self.world.camera_info()
        frame = self.world.observe()
        boxes = hold.find(frame) if hold.find is not None else []
        box = _nearest_to_centre(boxes, camera, 0.45)
        if box is None or frame.depth is None:
            if box is None and hold.find is not None:
                raise ControlError(
                    f"put_on failed: after letting go, the camera does not see the {hold.label} on "
                    f"{target.describe()}",
                    "it may have fallen; find it again in a new image",
                )
            return
        placed = estimate_object(frame.depth, camera, _head(self.world), self._pose(), body, box)
        if placed is None:
            return
        off = float(np.linalg.norm(placed.xy() - receptacle.xy()))
        if off > receptacle.radius + 0.04 or placed.support_z < receptacle.top_z - 0.04:
            raise ControlError(
                f"put_on failed: the {hold.label} came to rest {off * 100:.0f} cm from the middle of "
                f"{target.describe()}, at {placed.support_z:.2f} m (its top is at {receptacle.top_z:.2f} m)",
                "try a larger or flatter receptacle",
            )

    def _load(self) -> float | None:
        """The wrist's vertical load in newtons, averaged over a few readings; None without a force sensor."""
        if not self._has("force"):
            return None
        readings = []
        for _ in range(self.load_readings):
            self.world.step(0.02)
            readings.append(float(self.world.read_force()[2]))
        self.load_spread = float(np.std(readings, ddof=1)) / math.sqrt(len(readings))
        return abs(sum(readings) / len(readings))

    # --- driving --------------------------------------------------------------------------------------
    def _settle(self, seconds: float) -> None:
        self.world.step(seconds)

    def _drive_to(
        self,
        pose: tuple[float, float, float],
        floor: FloorMap | None,
        action: str,
        look_at: Any = None,
    ) -> None:
        """Drive to `pose`: along a path on `floor` when given, else straight."""
        path: list[np.ndarray] | None = [np.array(pose[:2])]
        if floor is not None:
            body = self._body(action)
            path = floor.path(np.array(self._pose()[:2]), np.array(pose[:2]), body.radius + 0.02)
            if path is None:
                raise ControlError(
                    f"not reachable: no free way to ({pose[0]:.2f}, {pose[1]:.2f}) on the floor the camera "
                    "sees",
                    "choose a place the robot can drive to",
                )
        self._follow(path or [], pose, None if look_at is None else np.asarray(look_at, float), action)

    def _follow(
        self, path: list[np.ndarray], pose: tuple[float, float, float], look_at: Any, action: str
    ) -> None:
        """Follow waypoints with a PID per axis on the odometry pose, ending at `pose` (its yaw on the last
        leg), the head kept on `look_at`; fail when the base stalls or the step budget runs out."""
        body = self._body(action)
        dt = self.control_s
        pids = [PID(2.0, 0.3, out_min=-self.drive_speed, out_max=self.drive_speed) for _ in "xy"]
        yaw_pid = PID(2.5, 0.2, out_min=-1.5, out_max=1.5)
        legs = list(path) or [np.array(pose[:2])]
        budget = int(60.0 / dt)
        stall_at, stall_from = 0, self._pose()
        for i, wp in enumerate(legs):
            last = i == len(legs) - 1
            for p in [*pids, yaw_pid]:
                p.reset()
            while True:
                x, y, yaw = self._pose()
                ex, ey = float(wp[0] - x), float(wp[1] - y)
                dist = math.hypot(ex, ey)
                want = pose[2] if (last or dist < 0.05) else math.atan2(ey, ex)
                eyaw = math.remainder(want - yaw, math.tau)
                if dist < (self.arrive_tol * 0.5 if last else 0.08) and (not last or abs(eyaw) < 0.01):
                    break
                c, s = math.cos(yaw), math.sin(yaw)
                fx, fy = c * ex + s * ey, -s * ex + c * ey  # the error in the robot's frame
                self.world.command_base(
                    pids[0].update(fx, 0.0, dt), pids[1].update(fy, 0.0, dt), yaw_pid.update(eyaw, 0.0, dt)
                )
                if look_at is not None:
                    self.world.set_head(*head_towards(look_at, (x, y, yaw), body))
                self.world.step(dt)
                budget -= 1
                stall_at += 1
                if stall_at * dt >= 1.5:
                    now = self._pose()
                    if not _moved(now, stall_from, 0.01, 0.02) and dist > 0.05:
                        self._stop()
                        raise ControlError(
                            f"blocked: the base stopped at ({now[0]:.2f}, {now[1]:.2f}) on its way to "
                            f"({pose[0]:.2f}, {pose[1]:.2f})",
                            "something the camera did not see is in the way; choose another target",
                        )
                    stall_at, stall_from = 0, now
                if budget <= 0:
                    self._stop()
                    raise ControlError(
                        f"did not converge: the base did not reach ({pose[0]:.2f}, {pose[1]:.2f}) within "
                        "60 s",
                        "something blocks the way; choose another target",
                    )
        self._stop()

    def _straight(self, metres: float, look_at: Any) -> None:
        """Drive straight forward (or back) by `metres` on odometry, whatever is in the way."""
        x, y, yaw = self._pose()
        goal = (x + metres * math.cos(yaw), y + metres * math.sin(yaw), yaw)
        speed, dt = 0.2 * math.copysign(1.0, metres), self.control_s
        for _ in range(int(abs(metres) / 0.2 / dt * 2) + 20):
            now = self._pose()
            left = (goal[0] - now[0]) * math.cos(yaw) + (goal[1] - now[1]) * math.sin(yaw)
            if left * speed <= 0.005:
                break
            self.world.command_base(speed, 0.0, 0.0)
            self.world.step(dt)
        self._stop()

    def _stop(self) -> None:
        self.world.command_base(0.0, 0.0, 0.0)
        self.world.step(0.3)


def _head(world: Any) -> tuple[float, float]:
    js = world.joint_states()
    return float(js["head_pan"]), float(js["head_tilt"])


def _off_centre(box: tuple[float, float, float, float], camera: Any, across_only: bool = False) -> float:
    """Pixels from the box's centre to the image centre (left-right only with `across_only`)."""
    dx = (box[0] + box[2]) / 2 - camera.cx
    return abs(dx) if across_only else math.hypot(dx, (box[1] + box[3]) / 2 - camera.cy)


def _gap(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> float:
    """Distance between two boxes' centres, pixels."""
    return math.hypot((a[0] + a[2] - b[0] - b[2]) / 2, (a[1] + a[3] - b[1] - b[3]) / 2)


def _nearest_to(
    boxes: list[tuple[float, float, float, float]], predicted: tuple[float, float, float, float]
) -> Any:
    """The box nearest the predicted one, within the predicted box's own size (farther is another thing:
    a false positive, another object of the kind); None if none."""
    reach = max(predicted[2] - predicted[0], predicted[3] - predicted[1], 8.0)
    near = [b for b in boxes if _gap(b, predicted) <= reach]
    return min(near, key=lambda b: _gap(b, predicted)) if near else None


def _by_centre(
    boxes: list[tuple[float, float, float, float]], camera: Any, within: float = 0.25
) -> list[Any]:
    """The boxes within `within` of the image's smaller side from its centre, nearest first."""
    radius = min(camera.width, camera.height) * within
    return sorted(
        (b for b in boxes if _off_centre(b, camera) <= radius), key=lambda b: _off_centre(b, camera)
    )


def _nearest_to_centre(
    boxes: list[tuple[float, float, float, float]], camera: Any, within: float = 0.25
) -> Any:
    """The box whose centre is nearest the image centre, within `within` of the image's smaller side;
    None if none."""
    near = _by_centre(boxes, camera, within)
    return near[0] if near else None


@dataclass(frozen=True)
class _Reach:
    """Where go_to_object left the robot: the object located from there, and the arm extension to it."""

    label: str
    estimate: ObjectEstimate
    extension: float


@dataclass(frozen=True)
class _Hold:
    """What pick_up holds: its name and finder, the base pose, lift and extension it was picked at, and how
    far the object reaches below and above the grip point, and its radius."""

    label: str
    find: Any
    pose: tuple[float, float, float]
    lift: float
    extension: float
    below: float
    above: float
    radius: float


def _moved(
    a: tuple[float, float, float], b: tuple[float, float, float], metres: float, radians: float
) -> bool:
    """True when pose `a` lies more than `metres` or `radians` from pose `b`."""
    turned = abs(math.remainder(a[2] - b[2], math.tau))
    return math.hypot(a[0] - b[0], a[1] - b[1]) > metres or turned > radians


@CONTROLLERS.register("servo")
def _servo(world: Any) -> ServoController:
    return ServoController(world)
