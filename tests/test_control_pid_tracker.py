"""The PID and the KLT box tracker of `attribot.control`: behaviour on plants and images with known truth."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from attribot.control.pid import PID
from attribot.control.tracker import BoxTracker
from attribot.errors import InputError

# ---- PID -------------------------------------------------------------------------------------------------


def _run_first_order(
    pid: PID, setpoint: float, steps: int, dt: float, tau: float = 0.3, gain: float = 1.0
) -> list[float]:
    """A first-order plant x' = (gain * u - x) / tau driven by the PID; the trajectory of x."""
    x, xs = 0.0, []
    for _ in range(steps):
        u = pid.update(setpoint, x, dt)
        x += dt * (gain * u - x) / tau
        xs.append(x)
    return xs


def test_pid_drives_a_first_order_plant_to_its_setpoint():
    xs = _run_first_order(PID(kp=2.0, ki=3.0, kd=0.05, out_min=-5, out_max=5), 1.0, 1500, 0.01)
    assert xs[-1] == pytest.approx(1.0, abs=1e-3)  # the integral removes the steady-state error
    p_only = _run_first_order(PID(kp=2.0), 1.0, 400, 0.01)
    assert p_only[-1] == pytest.approx(2 / 3, abs=1e-3)  # kp alone leaves kp/(1+kp)


def test_pid_output_is_clamped_and_the_integral_does_not_wind_up():
    pid = PID(kp=1.0, ki=5.0, out_min=-1.0, out_max=1.0)
    for _ in range(1000):  # a long saturated approach: the plant cannot follow
        assert -1.0 <= pid.update(100.0, 0.0, 0.01) <= 1.0
    assert pid.integral <= 1.0  # never more than the output can use
    windup_free = PID(kp=2.0, ki=4.0, out_min=-0.5, out_max=0.5)
    xs = _run_first_order(windup_free, 1.0, 3000, 0.01, tau=1.0, gain=3.0)
    overshoot = max(xs) - 1.0
    assert overshoot < 0.02 and xs[-1] == pytest.approx(1.0, abs=1e-3)


def test_pid_derivative_acts_on_the_measurement_so_a_new_setpoint_does_not_kick():
    pid = PID(kp=1.0, kd=10.0)
    pid.update(0.0, 0.5, 0.01)
    pid.update(0.0, 0.5, 0.01)
    out = pid.update(5.0, 0.5, 0.01)  # setpoint jumps, measurement still
    assert out == pytest.approx(4.5)  # kp * error only, no spike from kd
    moving = pid.update(5.0, 0.6, 0.01)  # the measurement moves: the derivative brakes
    assert moving < 4.4


def test_pid_integrates_with_the_real_dt_of_each_step():
    a, b = PID(kp=0.0, ki=1.0), PID(kp=0.0, ki=1.0)
    a.update(1.0, 0.0, 0.1)
    a.update(1.0, 0.0, 0.1)
    b.update(1.0, 0.0, 0.2)  # one late step carries as much as two on time
    assert a.integral == pytest.approx(b.integral) == pytest.approx(0.2)


@pytest.mark.parametrize("dt", [0.0, -0.1, float("nan"), float("inf")])
def test_pid_refuses_a_step_that_is_not_a_positive_time(dt):
    with pytest.raises(InputError, match="dt"):
        PID(kp=1.0).update(1.0, 0.0, dt)


@pytest.mark.parametrize("kwargs", [{"kp": -1.0}, {"kp": 1.0, "out_min": 1.0, "out_max": 1.0}])
def test_pid_refuses_bad_gains_and_limits(kwargs):
    with pytest.raises(InputError):
        PID(**kwargs)


# ---- KLT box tracker -------------------------------------------------------------------------------------

H, W = 240, 320


def _texture(seed: int = 0) -> np.ndarray:
    """A grey background with a textured square patch: what a camera sees of an object on a plain wall."""
    rng = np.random.default_rng(seed)
    img = np.full((H, W), 110, np.uint8)
    patch = cv2.GaussianBlur(rng.integers(0, 256, (80, 80), dtype=np.uint8), (5, 5), 1.2)
    img[80:160, 120:200] = patch
    return img


def _warp(img: np.ndarray, dx: float, dy: float, scale: float = 1.0, centre=(160.0, 120.0)) -> np.ndarray:
    m = cv2.getRotationMatrix2D(centre, 0.0, scale)
    m[:, 2] += (dx, dy)
    return cv2.warpAffine(img, m, (W, H), flags=cv2.INTER_LINEAR, borderValue=110)


def test_tracker_follows_a_translating_object_to_within_a_pixel():
    base = _texture()
    tracker = BoxTracker()
    start = tracker.start(base, (120, 80, 200, 160))
    assert not start.lost and start.features >= 15
    for k in range(1, 21):
        r = tracker.update(_warp(base, 2.0 * k, -1.0 * k))
        assert not r.lost
    assert r.box == pytest.approx((160, 60, 240, 140), abs=1.0)


def test_tracker_scales_the_box_as_the_object_grows():
    base = _texture(1)
    tracker = BoxTracker()
    tracker.start(base, (120, 80, 200, 160))
    for k in range(1, 9):  # the robot drives closer: the image grows 4% a frame about the centre
        r = tracker.update(_warp(base, 0, 0, 1.04**k))
        assert not r.lost
    width = r.box[2] - r.box[0]
    assert width == pytest.approx(80 * 1.04**8, rel=0.03)
    assert ((r.box[0] + r.box[2]) / 2, (r.box[1] + r.box[3]) / 2) == pytest.approx((160, 120), abs=1.0)


def test_tracker_says_lost_when_the_object_vanishes_and_keeps_the_last_box():
    base = _texture(2)
    tracker = BoxTracker()
    tracker.start(base, (120, 80, 200, 160))
    r = tracker.update(_warp(base, 3, 0))
    assert not r.lost
    gone = tracker.update(np.full((H, W), 110, np.uint8))
    assert gone.lost and gone.reason and gone.box == r.box


def test_tracker_reseeds_inside_the_box_when_too_few_features_survive():
    base = _texture(3)
    tracker = BoxTracker(max_features=40, min_features=38, lost_features=4)
    tracker.start(base, (120, 80, 200, 160))
    occluded = _warp(base, 2, 0)
    occluded[80:160, 122:150] = 110  # a third of the object hidden: its features fail the check
    r = tracker.update(occluded)
    assert not r.lost and r.reseeded


def test_tracker_on_a_box_without_texture_is_lost_at_once():
    flat = np.full((H, W, 3), 90, np.uint8)
    assert BoxTracker().start(flat, (10, 10, 60, 60)).lost


def test_a_sliver_of_a_box_is_lost_at_once_not_an_error():
    # a far object's box, or one a detector's jitter squeezed to a pixel: nothing to track, so the servo
    # falls back on detecting it in every frame
    tracker = BoxTracker()
    result = tracker.start(_texture(), (120.0, 80.0, 170.0, 81.0))
    assert result.lost and "too thin" in result.reason
    assert tracker.update(_texture()).lost


def test_tracker_refuses_bad_input():
    tracker = BoxTracker()
    with pytest.raises(InputError, match="no target"):
        tracker.update(_texture())
    with pytest.raises(InputError, match="outside the image"):
        tracker.start(_texture(), (400, 300, 500, 400))
    tracker.start(_texture(), (120, 80, 200, 160))
    with pytest.raises(InputError, match="frame size changed"):
        tracker.update(np.zeros((10, 10), np.uint8))
    with pytest.raises(InputError, match="out of order"):
        BoxTracker(min_features=5, lost_features=10)
