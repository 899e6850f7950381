"""Locating objects by perception: from the depth of the image a target was seen in, by the rangefinder
after centring on it (along the optical axis, or, on a camera riding on an arm, by the beam at the gripper:
`attribot.control.ranging`), or by looking where it should be and finding it again with the detector
(turning the camera a little, then a third of the view aside, then backing off, when the detector misses
it; then depth, where something of its height still stands where it was). A camera without a pan-tilt
head is turned by turning the base, and raised or lowered with the arm that carries it. Also the floor map
built from depth images and the floor point under a pixel."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from attribot.boxes import at_edge
from attribot.control.base import Capture, ControlError, Failure, Target, not_available
from attribot.control.body import BodyGeometry, CameraPose
from attribot.control.candidates import LOW_RISE_M
from attribot.control.drive import Driver
from attribot.control.plant import Hold, Plant
from attribot.control.ranging import beam_estimate, beam_lift
from attribot.control.sighting import Box, by_centre, nearest_to_centre
from attribot.control.spatial import (
    FloorMap,
    ObjectEstimate,
    base_points,
    estimate_object,
    head_towards,
    point_from_range,
    projected_box,
    to_base,
    to_world,
)
from attribot.frame import CameraInfo, Frame

__all__ = ["Locator", "beneath", "view_of"]

Accept = Callable[[Frame, Box], ObjectEstimate | None]

SETTLED_M = 0.03
"""Depth sees the object it came to where it was when its place now is this near the one it came to
(metres, across the floor); farther, the detector says which of what stands there it is (under realistic
noise the first image may put an object 20 cm off, and depth finds something else of its height there)."""
STILL_THERE_HEIGHT = 0.3
"""An object the detector no longer sees is still where it was when depth sees something there whose top is
within this share of its height (at least 5 cm) of its top before."""
BENEATH_DROP_M = 0.1
"""A box located as something that stands this much lower than the object did (metres, more than a board
is thick) and spreads far wider (`BENEATH_SPREAD`) is the furniture under the object, not it."""
BENEATH_SPREAD = (2.0, 0.05)
"""Far wider: a radius over this factor times the object's, plus this margin (metres)."""


def beneath(new: ObjectEstimate, old: ObjectEstimate) -> bool:
    """Whether `new` is the furniture under the object `old` located rather than the object: seen nearer,
    a detector may box a whole table under a flat book, and the box's middle is still the book's. It stands
    lower than the object by more than a board's thickness and spreads far wider (`BENEATH_DROP_M`,
    `BENEATH_SPREAD`). Where the object was first placed too high (its foot hidden behind an edge), the
    nearer view lowers its support but not its width."""
    factor, margin = BENEATH_SPREAD
    return new.support_z < old.support_z - BENEATH_DROP_M and new.radius > factor * old.radius + margin


@dataclass
class Locator:
    """Finds where targets are (see the module docstring). focus: centres the camera on a target (the
    controller's focus_on); wait_still: steps the world until the head stops after a command; sighting:
    the box the last focus centred and the camera's pose it was seen from (None when there is none)."""

    plant: Plant
    driver: Driver
    focus: Callable[[Target], None]
    wait_still: Callable[[Target], Any]
    sighting: Callable[[], tuple[Box, CameraPose] | None] = lambda: None

    def locate(self, target: Target, action: str) -> ObjectEstimate:
        """Where the target is, from the depth of the image it was seen in; without one, by centring the
        camera on it and reading the rangefinder (which needs the view unchanged since that image)."""
        body = self.plant.body(action)
        cap = target.capture
        est = self.where_seen(target, body)
        if est is not None:
            return est
        if cap.camera is None:
            raise not_available(action, self.plant.world_name, "the image was taken without known intrinsics")
        if not self.plant.has("distance"):
            raise not_available(
                action, self.plant.world_name, "it has neither depth images nor a distance sensor"
            )
        self.focus(target)
        return self.range_estimate(target.box, cap.camera, body)

    def where_seen(self, target: Target, body: BodyGeometry) -> ObjectEstimate | None:
        """Where the target was when its image was taken, from that image's depth; None without depth (or
        without a known camera pose), or when its box holds no valid depth."""
        cap = target.capture
        view = view_of(cap, body)
        if cap.depth is None or cap.camera is None or view is None or cap.base is None:
            return None
        return estimate_object(cap.depth, cap.camera, view, cap.base, target.box)

    def range_estimate(self, box: Box, camera: CameraInfo, body: BodyGeometry) -> ObjectEstimate:
        """The object at the image centre by the rangefinder, sized by its box at that range (with a
        camera on an arm: by the beam at the gripper, `beam_range`)."""
        metres = self.read_range()
        if body.arm is not None:
            return self.beam_range(metres, camera, body)
        view = self.plant.view(body)
        p = to_world(point_from_range(metres, camera, view, camera.cx, camera.cy), self.plant.pose())
        w, h = camera.metres_across(box, metres)
        return ObjectEstimate((float(p[0]), float(p[1]), float(p[2])), p[2] - h / 2, p[2] + h / 2, w / 2, 1)

    def read_range(self) -> float:
        """The rangefinder's reading: the median of a few, a dropout (nothing in range) left out."""
        t, world = self.plant.tuning, self.plant.world
        readings = []
        for k in range(t.range_readings):
            if k:
                world.step(t.range_step_s)
            r = float(world.read_distance())
            if math.isfinite(r):
                readings.append(r)
        if not readings:
            raise ControlError("the distance sensor sees nothing where the object is", "come closer first")
        return float(np.median(readings))

    def beam_range(self, metres: float, camera: CameraInfo, body: BodyGeometry) -> ObjectEstimate:
        """The object the last focus centred, its front `metres` ahead of the beam at the gripper, its
        height and width from its box in the view it was centred in."""
        sighted = self.sighting()
        beam = body.range_pose(self.plant.world.joint_states())
        est = None
        if sighted is not None:
            est = beam_estimate(metres, beam, sighted[0], camera, sighted[1], self.plant.pose())
        if est is None:
            raise ControlError(
                "the camera's last view of the object does not reach where the distance sensor finds it",
                "focus on the object (image.find it again) and retry",
            )
        return est

    def aim_beam(self, camera: CameraInfo, body: BodyGeometry) -> None:
        """With the rangefinder on an arm's gripper: raise or lower the arm so that the level beam meets the
        middle of the object the last focus centred (supposing it stands on the floor)."""
        sighted = self.sighting()
        if body.arm is None or sighted is None or not self.plant.has("distance"):
            return
        lift = beam_lift(sighted[0], camera, sighted[1], body)
        arm = self.plant.arm()
        if lift is None or arm is None:
            return
        self.plant.world.set_arm(lift, arm[1])
        self.plant.settle(self.plant.tuning.arm_move_s)

    def near(
        self, est: ObjectEstimate, camera: CameraInfo, body: BodyGeometry, holding: Hold | None
    ) -> Accept:
        """Whether a box of a frame is the object of `est`: it is located from depth about where `est` was
        (a box elsewhere, another object of the kind or a detector's mistake, is not it); without depth,
        every box is."""
        ignore = None if holding is None else self.held_points(holding, body)
        reach = max(0.25, 3.0 * est.radius)

        def where(frame: Frame, box: Box) -> ObjectEstimate | None:
            depth = frame.scene_depth  # the arm in front of the object is not part of it
            if depth is None:
                return est
            pose = self.plant.pose()
            new = estimate_object(depth, camera, self.plant.view(body), pose, box, ignore)
            if new is None or float(np.linalg.norm(new.xy() - est.xy())) > reach:
                return None
            return None if beneath(new, est) else new

        return where

    def refind(
        self,
        est: ObjectEstimate,
        target: Target,
        action: str,
        search: float = 0.25,
        holding: Hold | None = None,
    ) -> ObjectEstimate:
        """The target seen again from here: where depth still sees something of its height just where `est`
        put it (`still_there`, within `SETTLED_M`); else found there by the detector (the head nudged and
        turned aside where it misses), located by depth in its box, and, where the box is cut by the image's
        edge, centred by the servo loop and located again. Depth first: come to an object it found, the
        robot need not detect it again (one or two network passes) to see it stand where it was; where depth
        sees something elsewhere (the first image's depth was off, the object moved), the detector says
        which it is."""
        body = self.plant.body(action)
        self.aim(np.array(est.centre), body, target, holding)
        camera = self.plant.world.camera_info()
        where = self.near(est, camera, body, holding)
        # what lies flat (a fork rises a centimetre over the table) depth cannot tell from what it lies on
        if not target.by_depth and est.top_z - est.support_z >= LOW_RISE_M:
            seen = self.still_there(est, camera, body, where)
            if seen is not None and float(np.linalg.norm(seen.xy() - est.xy())) <= SETTLED_M:
                return seen
        # a target depth placed (the detector never saw it surely) is looked at once from here, where it is
        # nearer and larger: turning the camera for a detection the detector never gave costs passes in vain
        persist = not target.by_depth
        frame, box = self.look_again(
            target, camera, search, where, aside=persist, nudges=None if persist else 0
        )
        if box is None:
            # missed from every view here (a backpack close up, seen from above), or a target depth placed:
            # what depth sees of its height where it was is it (odometry that drifted on the way puts the
            # old place a few centimetres off). Asked before backing off, which would leave the base away
            # from where it reaches
            seen = self.still_there(est, camera, body, where)
            if seen is not None or target.by_depth:
                return seen or est
        if box is None and self.plant.has("base") and self.plant.tuning.back_off_m > 0:
            # a viewpoint the detector fails from: look again from farther away (once)
            self.driver.straight(-self.plant.tuning.back_off_m)
            self.aim(np.array(est.centre), body, target, holding)
            frame, box = self.look_again(target, camera, search, where)
            seen = None if box is not None else self.still_there(est, camera, body, where)
            if seen is not None:
                return seen
        if box is None:
            raise ControlError(
                f"target lost: the camera no longer sees {target.describe()} where it was "
                f"({est.centre[0]:.2f}, {est.centre[1]:.2f})",
                "find the object again in a new image and retry",
                reason=Failure.TARGET_LOST,
            )
        return self.located(frame, box, est, target, camera, body, search, where)

    def located(
        self,
        frame: Frame,
        box: Box,
        est: ObjectEstimate,
        target: Target,
        camera: CameraInfo,
        body: BodyGeometry,
        search: float,
        where: Accept,
    ) -> ObjectEstimate:
        """Where the target the detector found at `box` of `frame` is: placed by depth in the box; where the
        box is cut by the image's edge (or depth cannot place it), centred by the servo loop first."""
        located = where(frame, box)
        if located is not None and frame.depth is not None and not at_edge(box, frame.width, frame.height):
            # seen whole by the camera aimed at it, and placed by depth: centring it would turn the head a
            # few pixels' worth and detect it again, for the same place
            return located
        self.focus(Target(box, self.capture(frame, camera, body), label=target.label, find=target.find))
        frame = self.plant.world.observe()
        found = target.find(frame) if target.find else []
        if frame.depth is None:
            box = nearest_to_centre(found, camera, search) or box
            return self.range_estimate(box, camera, body) if self.plant.has("distance") else est
        for box in by_centre(found, camera, search):
            again = where(frame, box)
            if again is not None:
                return again
        # centred, the detector sees it no better (a viewpoint it misses the object from): where it was
        # found before centring
        return located if located is not None else est

    def still_there(
        self, est: ObjectEstimate, camera: CameraInfo, body: BodyGeometry, where: Accept
    ) -> ObjectEstimate | None:
        """The object of `est` as depth sees it now where `est` puts it (its box in the view projected from
        its place and size), if something stands there about as high as it (`STILL_THERE_HEIGHT`); None
        without depth, or where nothing of its height is there (it was moved, or it is hidden)."""
        frame = self.plant.world.observe()
        if frame.depth is None:
            return None
        (x, y, _), r = est.centre, est.radius
        corners = np.array(
            [(x + dx, y + dy, z) for dx in (-r, r) for dy in (-r, r) for z in (est.support_z, est.top_z)]
        )
        box = projected_box(to_base(corners, self.plant.pose()), camera, self.plant.view(body))
        now = None if box is None else where(frame, box)
        if now is None:
            return None
        height = est.top_z - est.support_z
        return now if abs(now.top_z - est.top_z) <= STILL_THERE_HEIGHT * max(height, 0.05) else None

    def look_again(
        self,
        target: Target,
        camera: CameraInfo,
        search: float,
        accept: Accept | None = None,
        aside: bool = True,
        nudges: int | None = None,
    ) -> tuple[Frame, Box | None]:
        """The frame and the target's box nearest the image centre (of those `accept` takes). A detector
        that misses the object in this view is given up to `nudges` (default `max_misses`) more views, the
        head turned a little each time, then (with `aside`) a third of the view to either side (the same
        view would often be missed, or mistaken, the same way)."""
        t, world = self.plant.tuning, self.plant.world
        home = self.plant.pose() if self.plant.headless else self.plant.head()
        nudges = t.max_misses if nudges is None else nudges

        def first(frame: Frame, boxes: list[Box]) -> Box | None:
            return next((b for b in boxes if accept is None or accept(frame, b) is not None), None)

        for k in range(nudges + 1 if target.find is not None else 1):
            if k:  # a nudge to one side, then the other, then further
                self.turn(home, (1 if k % 2 else -1) * t.nudge_rad * ((k + 1) // 2), t.nudge_settle_s)
            frame = world.observe()
            box = first(frame, by_centre(target.find(frame) if target.find else [], camera, search))
            if box is not None:
                return frame, box
        if target.find is None or not aside:
            if target.find is not None and nudges:  # the head back where it looked from
                self.turn(home, 0.0, t.look_back_settle_s)
            return frame, None
        # a detector that misses an object from one viewpoint may not from another: turn a third of the
        # view to each side, where the object sits elsewhere in the image, and look for it where it must be
        for turn in (camera.hfov / 3.0, -camera.hfov / 3.0):
            self.turn(home, turn, t.side_look_settle_s)
            frame = world.observe()
            shift = camera.fx * math.tan(turn)  # where the old line of sight now is, from the centre
            moved = by_centre(
                [(b[0] - shift, b[1], b[2] - shift, b[3]) for b in target.find(frame)], camera, search
            )
            box = first(frame, [(b[0] + shift, b[1], b[2] + shift, b[3]) for b in moved])
            if box is not None:
                return frame, box
        self.turn(home, 0.0, t.look_back_settle_s)
        return frame, None

    def turn(self, home: tuple[float, ...], offset: float, settle_s: float) -> None:
        """Turn the camera `offset` radians left of where it looked from `home`: the head's (pan, tilt), or,
        without a head, the base's pose (the base turns on the spot)."""
        if self.plant.headless:
            x, y, yaw = home
            self.driver.drive_to((x, y, yaw + offset), None, "focus_on_patch")
            return
        pan, tilt = home
        self.plant.world.set_head(pan + offset, tilt)
        self.plant.settle(settle_s)

    def held_points(self, hold: Hold, body: BodyGeometry) -> Callable[[np.ndarray], np.ndarray]:
        """A mask of world points on the arm and on what it holds: a cylinder around the grip point and a
        capsule along the arm, from where the joints stand now."""
        js = self.plant.world.joint_states()
        lift, ext = float(js.get("lift", hold.lift)), float(js.get("arm", hold.extension))
        pose = self.plant.pose()
        grip = self.grip_point(body, lift, ext)
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

    def grip_point(
        self,
        body: BodyGeometry,
        lift: float,
        extension: float,
        pose: tuple[float, float, float] | None = None,
    ) -> np.ndarray:
        """The world point between the fingertips with the arm at `lift` and `extension`, the base at
        `pose` (where it stands now by default)."""
        at = self.plant.pose() if pose is None else pose
        return to_world(np.array([body.reach_x(extension), body.arm_xy[1], lift]), at)

    def capture(self, frame: Frame, camera: CameraInfo, body: BodyGeometry) -> Capture:
        """What is known of `frame`, taken just now."""
        head = None if self.plant.headless else self.plant.head()
        return Capture(
            -1,
            camera,
            head,
            self.plant.pose(),
            depth=frame.scene_depth,
            view=self.plant.view(body),
            arm=self.plant.arm(),
        )

    def aim(self, point: np.ndarray, body: BodyGeometry, target: Target, holding: Hold | None = None) -> None:
        """Turn the camera onto a world point and wait until it stops: the head; without a head, the base
        on the spot, and the arm that carries the camera up or down (unless it holds something)."""
        if not self.plant.headless:
            pan, tilt = head_towards(point, self.plant.pose(), body)
            self.plant.world.set_head(pan, tilt)
            self.wait_still(target)
            return
        x, y, _ = self.plant.pose()
        self.driver.drive_to((x, y, math.atan2(point[1] - y, point[0] - x)), None, "focus_on_patch")
        if body.arm is not None and holding is None:
            local = to_base(np.asarray(point, float), self.plant.pose())
            self.plant.world.set_arm(*body.look_pose((float(local[0]), float(local[1]), float(local[2]))))
            self.plant.settle(self.plant.tuning.arm_move_s)

    def floor_point(self, target: Target, body: BodyGeometry) -> np.ndarray:
        """The floor point under pixel `target.center` of its image: depth when the image has it, else the
        ray's crossing with the floor."""
        cap = target.capture
        view = view_of(cap, body)
        if cap.camera is None or view is None or cap.base is None:
            raise not_available(
                "go_to_coords", self.plant.world_name, "the image has no known intrinsics or pose"
            )
        u, v = target.center
        if cap.depth is not None:
            r, c = min(int(v), cap.depth.shape[0] - 1), min(int(u), cap.depth.shape[1] - 1)
            p = base_points(cap.depth, cap.camera, view, (c, r, c + 1, r + 1))
            if len(p):
                return to_world(p[0], cap.base)[:2]
        ray = point_from_range(1.0, cap.camera, view, u, v) - np.asarray(view.xyz)
        if ray[2] >= -1e-6:
            raise ControlError(
                f"go_to_coords: pixel ({u:.0f}, {v:.0f}) looks at or above the horizon, not at the floor",
                "pass a point on the floor, lower in the image",
            )
        t = view.xyz[2] / -ray[2]
        return to_world(np.asarray(view.xyz) + ray * t, cap.base)[:2]

    def floor_map(self, targets: list[Target], holding: Hold | None = None) -> FloorMap:
        """A floor map from the current view and the depth images the targets were seen in."""
        body = self.plant.body("go_to_object")
        here = self.plant.pose()
        floor = FloorMap((here[0], here[1]))
        views = []
        frame = self.plant.world.observe()
        if frame.depth is not None:
            camera = frame.camera or self.plant.world.camera_info()
            views.append((frame.depth, camera, self.plant.view(body), here))
        for t in targets:
            c = t.capture
            view = view_of(c, body)
            if c.depth is not None and c.camera is not None and view is not None and c.base is not None:
                views.append((c.depth, c.camera, view, c.base))
        for depth, camera, view, base in views:
            pts = base_points(depth, camera, view, stride=3)
            # not the robot itself, nor what its gripper holds
            pts = pts[np.hypot(pts[:, 0], pts[:, 1]) > body.radius + 0.05]
            floor.add(to_world(pts, base))
        if holding is not None:
            grip = to_world(np.array([body.reach_x(holding.extension), body.arm_xy[1], 0.0]), here)
            floor.clear_disc(grip[:2], 0.15)
        return floor


def view_of(capture: Capture, body: BodyGeometry) -> CameraPose | None:
    """Where the camera was when `capture` was taken: as recorded, or from its head angles on a head."""
    if capture.view is not None:
        return capture.view
    if capture.head is not None and body.arm is None:
        return body.head_view(capture.head)
    return None
