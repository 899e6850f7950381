"""The ball-world fakes of tests/conftest.py are what they claim: projection, rangefinder and rotations
agree."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import BALLS, CAM, CAM_HEIGHT, Ball, BallWorld, _rot_head_to_world, _rot_world_to_head


def test_ball_world_projection_and_rangefinder_agree():
    w = BallWorld(BALLS)
    w.pan = w.tilt = 0.0
    # a ball straight ahead projects to the image centre, and the rangefinder reads its near surface
    w.balls = {"c": Ball("c", "ball", (2.0, 0.0, CAM_HEIGHT), 0.25, 1.0)}
    (det,) = w.boxes()
    assert ((det.box[0] + det.box[2]) / 2, (det.box[1] + det.box[3]) / 2) == pytest.approx((CAM.cx, CAM.cy))
    assert w.read_distance() == pytest.approx(1.75)


def test_rotations_are_inverse():
    v = np.array([0.3, -1.2, 0.7])
    assert _rot_world_to_head(0.4, -0.3, _rot_head_to_world(0.4, -0.3, v)) == pytest.approx(v)
