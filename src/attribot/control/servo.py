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
RoboMaster) centres left-right by turning its base with a PID on the same error, from the view the image
was taken in (it drives back there, and puts back the arm its camera rides on, when it has moved since);
with its rangefinder on the gripper it then raises or lowers the arm so that the beam meets the object.

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
from dataclasses import dataclass, field

import numpy as np

from attribot.control.base import CONTROLLERS, ControlError, Failure, Target, not_available
from attribot.control.body import CameraPose
from attribot.control.drive import Driver
from attribot.control.focus import FocusLoop, FocusReport
from attribot.control.locate import Locator
from attribot.control.manipulate import Manipulator
from attribot.control.plant import Hold, Plant, Reach, moved
from attribot.control.pointing import PointingController
from attribot.control.reach import Reacher
from attribot.control.sighting import Box, nearest_to, nearest_to_centre
from attribot.control.tuning import ServoTuning
from attribot.control.world import ServoWorld
from attribot.frame import CameraInfo, Frame

__all__ = ["ServoController", "FocusReport"]

NEAR_CAPTURE_M = 0.05
"""A robot within this many metres (and radians) of where an image was taken stands there, give or take what
its drives back leave: a look nearer from there comes back to exactly where the image was taken."""


@dataclass
class ServoController(PointingController):
    """Every Robot action by perception (see the module docstring), through its collaborators: a
    `FocusLoop` per centring, a `Locator`, a `Reacher`, a `Manipulator` and a `Driver`, all sharing one
    `Plant` (the world typed as `ServoWorld`) and one `ServoTuning`.

    tuning: every gain, tolerance and timing. preaim: aim by geometry first and detect again (True), or
    track the target's box from the current view at once, which must not have changed since the capture
    (False: the paper's robot, and the only way without intrinsics one trusts). A robot without a camera
    head is centred left-right only, by turning its base, and always from the unchanged view.
    last: how the last focus went; tracked: the box being centred, while it is; sighted: the box the last
    focus centred and where the camera was then; approached: where go_to_object brought the arm, for
    pick_up.
    """

    name: str = "servo"
    tuning: ServoTuning = field(default_factory=ServoTuning)
    preaim: bool = True
    last: FocusReport | None = None
    tracked: Box | None = None
    sighted: tuple[Box, CameraPose] | None = None
    approached: Reach | None = field(default=None, repr=False)
    driven: list[tuple[tuple[float, float, float], list[np.ndarray]]] = field(
        default_factory=list, repr=False
    )
    """Where `look_nearer` drove from and along which path, for `return_to`."""
    nearer_from: tuple[tuple[float, float, float], tuple[float, float] | None] | None = field(
        default=None, repr=False
    )
    """The base pose and head angles before the first `look_nearer` since the last `return_to`."""
    plant: Plant = field(init=False, repr=False)
    driver: Driver = field(init=False, repr=False)
    locator: Locator = field(init=False, repr=False)
    reacher: Reacher = field(init=False, repr=False)
    manipulator: Manipulator = field(init=False, repr=False)

    def __post_init__(self) -> None:
        super().__post_init__()
        world: ServoWorld = self.world
        self.plant = Plant(world, self.tuning, self._world_name)
        self.driver = Driver(self.plant)
        self.locator = Locator(self.plant, self.driver, self.focus_on, self._wait_still, lambda: self.sighted)
        self.reacher = Reacher(self.plant, self.driver, self.locator)
        self.manipulator = Manipulator(self.plant, self.driver, self.locator, self.reacher)

    @property
    def holding(self) -> Hold | None:
        """What the gripper holds, or None."""
        return self.manipulator.holding

    def focus_on(self, target: Target) -> None:
        self.sighted = None
        try:
            self._centre(target)
        finally:
            self.tracked = None
        body = self.plant.geometry()
        if body is not None and body.arm is not None:
            # the beam runs between the fingers: a gripper left closed (a grasp that closed on nothing)
            # would be all it sees
            gripper = self.plant.world.joint_states().get("gripper")
            if self.holding is None and gripper is not None and gripper < body.finger_open / 2:
                self.plant.world.release()
            self.locator.aim_beam(self.plant.world.camera_info(), body)

    def _centre(self, target: Target) -> None:
        world = self.plant.world
        camera = world.camera_info()
        self.waited_s, self.last = 0.0, None  # no report when the geometric aim is all there is
        caps = {str(c) for c in world.capabilities()}
        # without a pan/tilt head (the paper's RoboMaster) the base turns instead, centring the box
        # left-right only: its camera cannot tilt
        headless = "head" not in caps
        if headless and "base" not in caps:
            raise not_available("focus_on_patch", self._world_name, "it has neither a camera head nor a base")
        start = self._first_view(target, camera, caps, headless)
        if start is None:
            return
        loop = FocusLoop(self.plant, target, camera, *start, headless=headless, show=self._show)
        loop.run()
        body = self.plant.geometry()
        self.sighted = None if body is None else (loop.box, self.plant.view(body))
        seconds = self.waited_s + loop.steps * self.tuning.control_s
        self.last = FocusReport(loop.steps, seconds, loop.error, loop.redetections)

    def _first_view(
        self, target: Target, camera: CameraInfo, caps: set[str], headless: bool
    ) -> tuple[Frame, Box] | None:
        """The frame the closed loop starts from and the target's box in it; None when the geometric aim
        is all there is (no finder, or the detector does not see the target again, as pointing would)."""
        world = self.plant.world
        if self.preaim and not headless:
            PointingController.focus_on(self, target)  # the object is now near the image centre
            if target.find is None:
                return None
            frame = world.observe()
            box = nearest_to_centre(target.find(frame), camera)
            return None if box is None else (frame, box)
        # the paper's way: the view has not changed since the capture, so its box is tracked as it is
        went_back = self._back_to_capture(target, caps)
        frame = world.observe()
        if went_back and target.find is not None:  # back by odometry: where it is seen again
            return frame, nearest_to(target.find(frame), target.box) or target.box
        return frame, target.box

    def _back_to_capture(self, target: Target, caps: set[str]) -> bool:
        """Put the camera back where the target's image was taken: the base by odometry, and the arm it
        rides on; whether the base moved. A robot that does not state its body refuses when it has moved."""
        cap, body = target.capture, self.plant.geometry()
        if body is None or cap.base is None or not {"base", "pose"} <= caps:
            self._check_base(cap.base, caps)
            return False
        went = moved(self.plant.pose(), cap.base, self.base_tol, self.base_tol)
        if went:
            self.driver.drive_to(cap.base, None, "focus_on_patch")
        arm = self.plant.arm()
        if (
            self.holding is None
            and cap.arm is not None
            and arm is not None
            and max(abs(a - b) for a, b in zip(arm, cap.arm, strict=True)) > 0.005
        ):
            self.plant.world.set_arm(*cap.arm)
            self.plant.settle(self.tuning.arm_move_s)
        return went

    def _show(self, box: Box) -> None:
        self.tracked = box

    # --- perception-driven actions ------------------------------------------------------------------
    def approach(self, target: Target) -> None:
        est = self.locator.locate(target, "go_to_object")
        self.approached = None
        self.approached = self.reacher.reach(est, target, "go_to_object")

    def pick_up(self, target: Target) -> None:
        self.plant.body("pick_up")
        if self.holding is not None:
            raise ControlError(f"the gripper already holds {self.holding.label}", "put it down first")
        reach = self.approached  # the Robot checks that go_to_object came to this same object
        if reach is None:
            self.approach(target)
            reach = self.approached
        assert reach is not None
        self.manipulator.pick_up(target, reach)
        self.approached = None

    def check_held(self, target: Target, seen_first: Target) -> tuple[bool | None, str]:
        """Whether what was just lifted is the target, by looking at it (`Manipulator.check_held`)."""
        return self.manipulator.check_held(target, seen_first)

    def put_down(self) -> None:
        self.manipulator.put_down()

    def put_on(self, target: Target) -> None:
        self.manipulator.put_on(target)

    def push(self, target: Target) -> None:
        self.manipulator.push(target)

    def look_nearer(self, target: Target, distance: float) -> bool:
        """Drive to a free place about `distance` from the object in the target's box (located from the depth
        of the image it was seen in), facing it, on a free path (from the side it was seen from, else turned
        from it), and aim the camera at it: a small object seen from afar grows in the frame. Only where it
        is farther than `distance`; False where it did not drive (already near, or no free place found: it
        then only aims the camera). `return_to` drives back the way it came."""
        body = self.plant.body("look_harder")
        if self.nearer_from is None:
            here, cap = self.plant.pose(), target.capture
            head = self.plant.head() if self.plant.has("head") else None
            # standing about where the image was taken (a look nearer before came back a few millimetres
            # off), back to exactly there: coming back to where each look started adds their errors up
            if cap.base is not None and not moved(here, cap.base, NEAR_CAPTURE_M, NEAR_CAPTURE_M):
                here, head = cap.base, cap.head or head
            self.nearer_from = (here, head)
        est = self.locator.locate(target, "look_harder")
        here = self.plant.pose()
        centre = est.xy()
        if float(np.linalg.norm(centre - np.array(here[:2]))) > distance:
            floor = self.locator.floor_map([target])
            bearing = math.atan2(centre[1] - here[1], centre[0] - here[0])
            for turn in (0.0, 0.5, -0.5, 1.0, -1.0, 1.5, -1.5):  # the side it was seen from first
                yaw = bearing + turn
                for metres in (distance * 0.7, distance, distance * 1.3):
                    xy = centre - metres * np.array([math.cos(yaw), math.sin(yaw)])
                    pose = (float(xy[0]), float(xy[1]), yaw)
                    if not floor.footprint_free(pose, body.base_half, 0.04):
                        continue
                    path = floor.path(np.array(here[:2]), xy, body.radius + 0.02)
                    if path is not None:
                        self.driven.append((here, [np.array(here[:2]), *path]))
                        self.driver.follow(path, pose, np.array(est.centre), "look_harder")
                        self.locator.aim(np.array(est.centre), body, target)
                        return True
        self.locator.aim(np.array(est.centre), body, target)
        return False

    def return_to(self) -> None:
        """Drive back (odometry) the way `look_nearer` came, which was free then, to the pose and head angles
        it started from: where the robot looked from before it went to look nearer. The last centimetres
        straight, so that boxes of the image taken there still say where to look."""
        if self.nearer_from is None:
            return
        (pose, head), self.nearer_from = self.nearer_from, None
        legs = self.driven[::-1]
        self.driven.clear()
        for start, path in legs:
            back = path[::-1]
            # from the waypoint nearest where it stands (a drive that stopped short stopped on the way)
            here = np.array(self.plant.pose()[:2])
            nearest = int(np.argmin([float(np.linalg.norm(w - here)) for w in back]))
            rest = back[nearest + 1 :] or [np.array(start[:2])]
            # facing the way it drives, to turn round only where it stood: turned to the pose it left from
            # as the last leg starts, it swept the furniture it had passed with its back (a base is no disc)
            towards = rest[-1] - (rest[-2] if len(rest) > 1 else here)
            yaw = math.atan2(towards[1], towards[0]) if float(np.linalg.norm(towards)) > 0.05 else start[2]
            self.driver.follow(rest, (start[0], start[1], yaw), None, "look_harder")
        for _ in range(3):
            if not moved(self.plant.pose(), pose, 0.004, 0.004):
                break
            self.driver.drive_to(pose, None, "look_harder")
        if head is not None and self.plant.has("head"):
            self.plant.world.set_head(*head)
            self.plant.settle(self.tuning.look_back_settle_s)

    def go_to_coords(self, target: Target) -> None:
        body = self.plant.body("go_to_coords")
        goal = self.locator.floor_point(target, body)
        floor = self.locator.floor_map([target])
        here = self.plant.pose()
        yaw = math.atan2(goal[1] - here[1], goal[0] - here[0])
        towards = goal - np.array(here[:2])
        span = float(np.linalg.norm(towards))
        for back in np.arange(0.0, min(span, 1.5), 0.05):
            xy = goal - towards / max(span, 1e-9) * back
            if floor.footprint_free((xy[0], xy[1], yaw), body.base_half, 0.03):
                self.driver.drive_to((float(xy[0]), float(xy[1]), yaw), floor, "go_to_coords")
                return
        raise ControlError(
            f"not reachable: the floor at ({goal[0]:.2f}, {goal[1]:.2f}) and the way to it are taken by "
            "something the camera sees",
            "choose a point on free floor",
            reason=Failure.NOT_REACHABLE,
        )


@CONTROLLERS.register("servo")
def _servo(world: ServoWorld) -> ServoController:
    return ServoController(world)
