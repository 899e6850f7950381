"""The focusing state machine on its own, with a fake world (tests/conftest.py's BallWorld: spheres seen by
a pinhole camera on a pan/tilt head with first-order dynamics, frames without texture) and scripted
trackers: its phases, its transitions and its failures. The servo's tests run it in MuJoCo."""

from __future__ import annotations

import pytest

from attribot.control.base import Capture, ControlError, Target
from attribot.control.focus import FocusLoop, Phase
from attribot.control.plant import Plant
from attribot.control.tracker import TrackResult
from attribot.control.tuning import ServoTuning
from attribot.frame import Frame
from conftest import BALLS, CAM, BallWorld


def _ball_box(world: BallWorld, ball: str = "b1") -> tuple[float, float, float, float]:
    """Where the world projects the ball now (the truth, from the world's own geometry)."""
    return next(d.box for d in world.boxes() if d.object_id == ball)


def _finder(ball: str = "b1"):
    def find(frame: Frame) -> list[tuple[float, float, float, float]]:
        return [d.box for d in frame.__dict__["_detections"] if d.object_id == ball]

    return find


def _loop(world: BallWorld, find=None, tracker=None, **tuning) -> FocusLoop:
    find = find or _finder()
    frame = world.observe()
    target = Target(_ball_box(world), Capture(0, CAM, (0.0, 0.0)), label="ball", find=find)
    plant = Plant(world, ServoTuning(**tuning), world.name)
    return FocusLoop(plant, target, CAM, frame, target.box, tracker=tracker)


def _off_centre(box: tuple[float, float, float, float]) -> float:
    return abs((box[0] + box[2]) / 2 - CAM.cx) + abs((box[1] + box[3]) / 2 - CAM.cy)


def _run_collecting_phases(loop: FocusLoop) -> list[Phase]:
    phases = [loop.phase]
    while loop.phase is not Phase.CENTRED:
        assert loop.steps < loop.tuning.max_steps
        loop.step()
        if loop.phase is not phases[-1]:
            phases.append(loop.phase)
    return phases


class _ScriptedTracker:
    """A tracker that starts on any box and then reports what `update` is told to (lost, or a fixed box)."""

    def __init__(self, update_box=None, lost: bool = False) -> None:
        self.update_box, self.lost, self.starts = update_box, lost, 0

    def start(self, image, box) -> TrackResult:
        self.starts += 1
        self.box = box
        return TrackResult(box, False, 20, True, "")

    def update(self, image) -> TrackResult:
        box = self.update_box or self.box
        return TrackResult(box, self.lost, 0 if self.lost else 20, False, "occluded" if self.lost else "")


def test_a_textureless_box_is_centred_by_detection_in_every_frame():
    world = BallWorld(BALLS)
    loop = _loop(world)
    assert loop.phase is Phase.DETECTING  # the fake's frames are black: nothing to track
    assert _off_centre(_ball_box(world)) > 50
    loop.run()
    assert loop.phase is Phase.CENTRED and loop.error <= loop.tol and loop.steps > 3
    assert _off_centre(_ball_box(world)) <= 3.0  # by the world's geometry, not the loop's own box
    # each frame's detection was compared with where the head's motion carried the box
    assert loop.redetections == 0 and loop.innovations


def test_a_track_that_drifted_onto_the_centre_is_caught_by_the_confirming_detection():
    world = BallWorld(BALLS)
    centred = (CAM.cx - 5, CAM.cy - 5, CAM.cx + 5, CAM.cy + 5)  # the track claims the ball is centred
    loop = _loop(world, tracker=_ScriptedTracker(update_box=centred))
    assert loop.phase is Phase.TRACKING
    assert _run_collecting_phases(loop) == [Phase.TRACKING, Phase.DETECTING, Phase.CENTRED]
    assert loop.confirmed and _off_centre(_ball_box(world)) <= 3.0


def test_a_lost_track_is_detected_again_once_and_tracked_anew():
    world = BallWorld(BALLS)
    tracker = _ScriptedTracker(lost=True)
    loop = _loop(world, tracker=tracker)
    loop.step()  # moves once; the tracker loses the box in the new frame
    tracker.lost = False
    loop.step()
    assert loop.redetections == 1 and tracker.starts == 2 and loop.phase is Phase.TRACKING


def test_a_track_lost_a_second_time_fails_clearly():
    loop = _loop(BallWorld(BALLS), tracker=_ScriptedTracker(lost=True))
    with pytest.raises(ControlError, match=r"lost sight of ball while centring it \(occluded\)"):
        loop.run()
    assert loop.redetections == 1


def test_a_detector_that_stops_seeing_the_object_fails_after_max_misses():
    seen = []

    def once(frame: Frame):
        seen.append(frame)
        return _finder()(frame) if len(seen) == 1 else []

    loop = _loop(BallWorld(BALLS), find=once, max_misses=2)
    with pytest.raises(ControlError, match="detector missed it 3 times in a row"):
        loop.run()
    assert loop.misses == 3 and loop.phase is Phase.DETECTING


def test_the_step_budget_ends_a_focus_that_does_not_converge():
    world = BallWorld(BALLS)
    loop = _loop(world, max_steps=2)
    with pytest.raises(ControlError, match="did not centre ball within 2 control steps"):
        loop.run()
    assert loop.steps == 2 and loop.phase is Phase.DETECTING


def test_reacquire_takes_the_id_where_known_else_the_box_nearest_the_centre():
    """A target seen again in a new frame: the box of its world id where the detector gives ids, else the
    box of its name nearest the image centre, within a quarter of the image; none there, none at all."""
    from attribot.control.sighting import reacquire

    world = BallWorld(BALLS)
    boxes = {d.object_id: d.box for d in world.boxes()}

    def sightings(frame: Frame):
        return [(d.box, d.object_id) for d in world.boxes()]

    off_centre = max(boxes, key=lambda i: abs((boxes[i][0] + boxes[i][2]) / 2 - CAM.cx))
    by_id = reacquire(world, sightings, "ball", off_centre, index=3)
    assert by_id is not None and by_id.box == boxes[off_centre] and by_id.capture.index == 3
    assert by_id.capture.head == (world.pan, world.tilt) and by_id.object_id == off_centre
    central = reacquire(world, sightings, "ball", off_centre, index=4, by_id=False)
    nearest = min(
        boxes.values(), key=lambda b: abs((b[0] + b[2]) / 2 - CAM.cx) + abs((b[1] + b[3]) / 2 - CAM.cy)
    )
    assert central is not None and central.box == nearest and central.object_id == off_centre
    assert reacquire(world, lambda frame: [], "ball", None, index=5) is None
