"""Visual servoing: the robot turns its camera onto an object by what it sees, as the paper's robot did.

`ServoController.focus_on` first aims by geometry (the pointing controller: the box's ray from the
capture's intrinsics and head angles), then closes the loop on the camera: it finds the target once in a
fresh frame with the configured detector (`Target.find`) (or, with `preaim=False`, takes the box of the
unchanged view it was seen in, as the paper's robot did), tracks its box with KLT frame by frame, and
drives the head with a PID per axis on the box centre's angular error until the centre lies within
`tol_px` of the image centre. When the tracker loses the target it detects again, once, before giving up.
It steps the world one control period at a time (sim time in the simulator, wall time on a robot: no
sleeps) and uses only what a real robot has: frames (RGB), intrinsics, head joint angles and its base
pose; never the simulator's object poses, ids or segmentation.

Driving to an object and manipulating it through perception are not built yet: those actions are refused
with `UnsupportedAction` ("not available"), so that a program and the planner's retry know it; the
privileged simulator controller (`--controller privileged`) does them by reading the simulator's state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from attribot.control.base import CONTROLLERS, ControlError, Target
from attribot.control.pid import PID
from attribot.control.pointing import PointingController
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
    """Focus by visual servoing (see the module docstring); the other actions are not available yet.

    control_s: time per control step; tol_px: the centring tolerance; max_steps: the step budget of one
    focus; kp / ki: PID gains on the angular error (radians of head command per radian of error per step);
    max_step_rad: the largest head correction in one step; preaim: aim by geometry first and detect again
    (True), or track the target's box from the current view at once, which must not have changed since the
    capture (False: the paper's robot, and the only way without intrinsics one trusts).
    """

    name: str = "servo"
    control_s: float = 0.05
    tol_px: float = 1.5
    max_steps: int = 80
    kp: float = 0.8
    ki: float = 0.4
    max_step_rad: float = 0.15
    preaim: bool = True
    last: FocusReport | None = None
    tracked: tuple[float, float, float, float] | None = None  # the box being centred, while it is

    def focus_on(self, target: Target) -> None:
        try:
            self._centre(target)
        finally:
            self.tracked = None

    def _centre(self, target: Target) -> None:
        camera = self.world.camera_info()
        self.waited_s, self.last = 0.0, None  # no report when the geometric aim is all there is
        if self.preaim:
            super().focus_on(target)  # aim by geometry: the object is now near the image centre
            if target.find is None:
                return  # nothing to see it with again: keep the geometric aim
            frame = self.world.observe()
            box = _nearest_to_centre(target.find(frame), camera)
            if box is None:
                return  # the detector does not see it again: keep the geometric aim, as pointing would
        else:
            # the paper's way: the view has not changed since the capture, so its box is tracked as it is
            self._check_base(target.capture.base, {str(c) for c in self.world.capabilities()})
            frame, box = self.world.observe(), target.box

        def see(frame: Any) -> Any:
            return None if target.find is None else _nearest_to_centre(target.find(frame), camera)

        def lost(why: str) -> ControlError:
            return ControlError(
                f"lost sight of {target.describe()} while centring it ({why})",
                "find the object again in a new image (image.find) and retry",
            )

        tracker = BoxTracker()
        state = tracker.start(frame.rgb, box)
        # a small or plain object may give too few features to track: the detector then finds it in every
        # frame instead (slower per step, as sure)
        tracking = not state.lost
        pids = [PID(self.kp, self.ki, out_min=-self.max_step_rad, out_max=self.max_step_rad) for _ in "pt"]
        redetections, steps, error, checked = 0, 0, math.inf, False
        for step in range(1, self.max_steps + 1):
            steps = step
            if tracking and state.lost:
                if redetections or target.find is None:
                    raise lost(state.reason)
                redetections += 1
                frame = self.world.observe()
                box = see(frame)
                if box is None:
                    raise lost("the detector does not see it again")
                state = tracker.start(frame.rgb, box)
                tracking = not state.lost
            if tracking:
                box = state.box
            self.tracked = box
            u, v = (box[0] + box[2]) / 2, (box[1] + box[3]) / 2
            error = math.hypot(u - camera.cx, v - camera.cy)
            if error <= self.tol_px:
                if not tracking or target.find is None or checked:
                    break
                # the tracked box may have drifted off the object (background features at its edges):
                # one detection confirms the centring, or the loop goes on with detections every frame
                checked = True
                seen = see(frame)
                if seen is None or _off_centre(seen, camera) <= self.tol_px:
                    break
                tracking, box = False, seen
                continue
            # angular errors: left of the centre means pan left (positive), above means tilt up (positive)
            pan_err = math.atan2(camera.cx - u, camera.fx)
            tilt_err = math.atan2(camera.cy - v, camera.fy)
            pan, tilt = _head(self.world)
            self.world.set_head(
                pan + pids[0].update(0.0, -pan_err, self.control_s),
                tilt + pids[1].update(0.0, -tilt_err, self.control_s),
            )
            self.world.step(self.control_s)
            frame = self.world.observe()
            if tracking:
                state = tracker.update(frame.rgb)
            else:
                box = see(frame)
                if box is None:
                    raise lost("too little texture to track, and the detector does not see it")
        else:
            raise ControlError(
                f"the camera did not centre {target.describe()} within {self.max_steps} control steps "
                f"({error:.1f} px off)",
                "the object may be moving or beyond the head's range: go_to_object first",
            )
        self.last = FocusReport(steps, self.waited_s + steps * self.control_s, error, redetections)


def _head(world: Any) -> tuple[float, float]:
    js = world.joint_states()
    return float(js["head_pan"]), float(js["head_tilt"])


def _off_centre(box: tuple[float, float, float, float], camera: Any) -> float:
    return math.hypot((box[0] + box[2]) / 2 - camera.cx, (box[1] + box[3]) / 2 - camera.cy)


def _nearest_to_centre(boxes: list[tuple[float, float, float, float]], camera: Any) -> Any:
    """The box whose centre is nearest the image centre, within a quarter of the image; None if none."""
    radius = min(camera.width, camera.height) / 4.0
    near = [b for b in boxes if _off_centre(b, camera) <= radius]
    return min(near, key=lambda b: _off_centre(b, camera)) if near else None


@CONTROLLERS.register("servo")
def _servo(world: Any) -> ServoController:
    return ServoController(world)
