"""Centring the camera on a target by what it sees, as a small state machine (`FocusLoop`).

Phases: TRACKING (KLT carries the box from frame to frame), DETECTING (the detector finds the box in every
frame, carried between frames by the camera's own measured motion), CENTRED (done). Transitions:

- start: TRACKING, or DETECTING when the box has too few features to track (a small or plain object);
- TRACKING -> DETECTING when the tracker loses the box (the detector looks once; it is tracked anew when
  seen, TRACKING again) or when the confirming detection at the centre disagrees with a drifted track;
- TRACKING or DETECTING -> CENTRED when the box centre lies within the tolerance (a tracked box confirmed
  by one detection first);
- a `ControlError` when the target is lost a second time, when the detector misses it more than
  `max_misses` frames in a row, or when the step budget runs out.

Each control step moves the head (or, on a robot without a camera head, turns the base) by a PID per axis
on the box centre's angular error, steps the world one control period and observes a new frame. The loop
uses frames, intrinsics and head angles only, through the `ServoWorld` protocol.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from attribot.control.base import ControlError, Controller, Target
from attribot.control.pid import PID
from attribot.control.plant import Plant
from attribot.control.sighting import Box, carried, gap, nearest_to, nearest_to_centre, off_centre
from attribot.control.tracker import BoxTracker
from attribot.frame import CameraInfo, Frame

__all__ = ["FocusLoop", "FocusReport", "Phase", "correct_aim"]


class Phase(StrEnum):
    TRACKING = "tracking"
    DETECTING = "detecting"
    CENTRED = "centred"


@dataclass(frozen=True)
class FocusReport:
    """How the last focus went: control steps, seconds of (sim or wall) time in all (the geometric pre-aim's
    settling included), final pixel error, re-detections."""

    steps: int
    seconds: float
    error_px: float
    redetections: int


class FocusLoop:
    """One centring of one target from `frame`, where it is seen at `box` (see the module docstring).

    headless: centre left-right by turning the base (no camera head). tracker: the KLT tracker (a fresh
    `BoxTracker` by default). show: told the box being centred at each step (the episode recorder draws
    it)."""

    def __init__(
        self,
        plant: Plant,
        target: Target,
        camera: CameraInfo,
        frame: Frame,
        box: Box,
        *,
        headless: bool = False,
        tracker: BoxTracker | None = None,
        show: Callable[[Box], None] | None = None,
    ) -> None:
        t = self.tuning = plant.tuning
        self.plant, self.target, self.camera, self.headless = plant, target, camera, headless
        self.frame, self.box = frame, box
        self.tracker = tracker if tracker is not None else BoxTracker()
        self.track = self.tracker.start(frame.rgb, box)
        # a small or plain object may give too few features to track: the detector then finds it in every
        # frame instead (slower per step, as sure)
        self.phase = Phase.DETECTING if self.track.lost else Phase.TRACKING
        self.pids = [PID(t.kp, t.ki, out_min=-t.max_step_rad, out_max=t.max_step_rad) for _ in "pt"]
        self.turn = PID(t.turn_kp, t.turn_ki, out_min=-t.max_turn, out_max=t.max_turn)
        self.steps = self.redetections = self.misses = 0
        self.error = math.inf
        self.confirmed = False  # the one detection that confirms a tracked centring was made
        # found by detection, a box jitters from frame to frame: how far each detection lands from where
        # the last box, carried by the head's motion, says it must be; the centring tolerance widens to it
        self.innovations: list[float] = []
        self.tol = t.tol_px
        self.show = show

    def run(self) -> None:
        """Step until CENTRED; a `ControlError` when the target is lost or the step budget runs out. A
        headless robot's base is stopped when it is centred or out of steps."""
        while self.phase is not Phase.CENTRED:
            if self.steps == self.tuning.max_steps:
                if self.headless:
                    self.plant.world.command_base(0.0, 0.0, 0.0)
                raise ControlError(
                    f"the camera did not centre {self.target.describe()} within {self.tuning.max_steps} "
                    f"control steps ({self.error:.1f} px off)",
                    "the object may be moving or beyond the head's range: go_to_object first",
                )
            self.step()
        if self.headless:
            self.plant.world.command_base(0.0, 0.0, 0.0)

    def step(self) -> None:
        """One control step: where the box is now; CENTRED when it is within the tolerance, else one move of
        the camera and the box followed into the new frame."""
        self.steps += 1
        if self.phase is Phase.TRACKING and self.track.lost:
            self._redetect()
        if self.phase is Phase.TRACKING:
            self.box = self.track.box
        if self.show is not None:
            self.show(self.box)
        u, v = (self.box[0] + self.box[2]) / 2, (self.box[1] + self.box[3]) / 2
        cam = self.camera
        self.error = abs(u - cam.cx) if self.headless else math.hypot(u - cam.cx, v - cam.cy)
        if self.phase is Phase.DETECTING and len(self.innovations) >= 3:
            spread = float(np.median(self.innovations[-6:]))
            self.tol = min(max(self.tuning.tol_px, spread), self.tuning.max_tol_px)
        if self.error <= self.tol:
            self._arrive()
            return
        turned = self._move(u, v)
        self.plant.world.step(self.tuning.control_s)
        self.frame = self.plant.world.observe()
        if self.phase is Phase.TRACKING:
            self.track = self.tracker.update(self.frame.rgb)
        else:
            self._detect_carried(turned())

    def _see(self) -> Box | None:
        find = self.target.find
        return None if find is None else nearest_to_centre(find(self.frame), self.camera)

    def _lost(self, why: str) -> ControlError:
        return ControlError(
            f"lost sight of {self.target.describe()} while centring it ({why})",
            "find the object again in a new image (image.find) and retry",
        )

    def _redetect(self) -> None:
        """The tracker lost the box: the detector looks once (a second loss is an error)."""
        if self.redetections or self.target.find is None:
            raise self._lost(self.track.reason)
        self.redetections += 1
        seen = self._see()
        self.phase = Phase.DETECTING  # until the detector sees it again; then tracked anew
        if seen is None:
            self.misses, self.box = 1, self.track.box
            return
        self.box = seen
        self.track = self.tracker.start(self.frame.rgb, seen)
        if not self.track.lost:
            self.phase = Phase.TRACKING

    def _arrive(self) -> None:
        """Within the tolerance: CENTRED, unless the one confirming detection of a tracked box finds the
        object elsewhere (the track drifted off it onto background features), when the box is found by
        detection from then on."""
        if self.phase is Phase.DETECTING or self.target.find is None or self.confirmed:
            self.phase = Phase.CENTRED
            return
        self.confirmed = True
        seen = self._see()
        if seen is None or off_centre(seen, self.camera, self.headless) <= max(self.tol, self.tuning.tol_px):
            self.phase = Phase.CENTRED
            return
        self.phase, self.box = Phase.DETECTING, seen

    def _move(self, u: float, v: float) -> Callable[[], tuple[float, float]]:
        """Command one PID step of the head (or the base) towards pixel (u, v); returns how far the camera
        has turned since (pan, tilt), to be asked once the world has stepped."""
        cam, dt = self.camera, self.tuning.control_s
        # angular errors: left of the centre means pan left (positive), above means tilt up (positive)
        pan_err = math.atan2(cam.cx - u, cam.fx)
        tilt_err = math.atan2(cam.cy - v, cam.fy)
        if self.headless:
            wz = self.turn.update(0.0, -pan_err, dt)
            self.plant.world.command_base(0.0, 0.0, wz)
            # a robot without a head may not report its pose: the commanded turn it is
            return lambda: (wz * dt, 0.0)
        pan, tilt = self.plant.head()
        self.plant.world.set_head(
            pan + self.pids[0].update(0.0, -pan_err, dt), tilt + self.pids[1].update(0.0, -tilt_err, dt)
        )

        def turned() -> tuple[float, float]:
            now = self.plant.head()
            return now[0] - pan, now[1] - tilt

        return turned

    def _detect_carried(self, turned: tuple[float, float]) -> None:
        """DETECTING: the detection nearest where the camera's motion carried the box, averaged with that
        prediction; a miss keeps the prediction, up to `max_misses` in a row."""
        predicted = carried(self.box, self.camera, turned)
        find = self.target.find
        seen = nearest_to(find(self.frame) if find else [], predicted)
        if seen is not None:
            self.innovations.append(gap(seen, predicted))
            # half the detection, half the prediction: a jittery detector's noise is halved
            self.misses = 0
            self.box = (
                (seen[0] + predicted[0]) / 2,
                (seen[1] + predicted[1]) / 2,
                (seen[2] + predicted[2]) / 2,
                (seen[3] + predicted[3]) / 2,
            )
            return
        self.misses += 1
        if self.misses > self.tuning.max_misses:
            raise self._lost(
                f"too little texture to track, and the detector missed it {self.misses} times in a row"
            )
        self.box = predicted


def correct_aim(
    controller: Controller,
    find_again: Callable[[], Target | None],
    corrections: int,
    tol_px: float,
    *,
    headless: bool,
) -> None:
    """After the camera was pointed at an object by geometry: find it again in fresh images
    (`find_again`) and point again until it sits at the image centre within `tol_px`, at most
    `corrections` times. This absorbs what the controller's geometry ignores (the camera's offset from the
    head axes, head tracking error). Without a camera head (`headless`) only the base turns the camera:
    left-right is all it can centre. Stops where the object is not found again or has no intrinsics to
    check against: the geometric aim stands."""
    for _ in range(corrections):
        seen = find_again()
        if seen is None or seen.capture.camera is None:
            return
        cam = seen.capture.camera
        u, v = seen.center
        off = abs(u - cam.cx) if headless else math.hypot(u - cam.cx, v - cam.cy)
        if off <= tol_px:
            return
        controller.focus_on(seen)
