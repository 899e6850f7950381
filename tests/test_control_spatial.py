"""Locating objects and planning paths from depth alone: back-projection, object estimates from a ray-cast
depth image whose scene is known exactly, the floor map and its paths."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from attribot.control.base import Capture, ControlError, Failure, Target
from attribot.control.body import BodyGeometry
from attribot.control.reach import Reacher
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
from attribot.control.tuning import ServoTuning
from attribot.frame import CameraInfo, Frame

BODY = BodyGeometry(
    camera_xyz=(-0.1, -0.08, 1.3),
    arm_xy=(-0.1, -0.08),
    reach0=0.5,
    arm_range=(0.0, 0.55),
    lift_range=(0.03, 1.1),
    base_half=(0.19, 0.16),
)
CAMERA = CameraInfo(width=160, height=120, fx=110.0, fy=110.0, cx=80.0, cy=60.0)

Box3 = tuple[tuple[float, float, float], tuple[float, float, float]]


def _ray_cast(head: tuple[float, float], base: tuple[float, float, float], boxes: list[Box3]) -> np.ndarray:
    """Depth along the optical axis of a floor (z=0) and axis-aligned boxes (world frame), by exact ray
    intersection: the scene is known, so the estimates can be checked to the millimetre."""
    v, u = np.mgrid[0 : CAMERA.height, 0 : CAMERA.width] + 0.5
    d = np.ones_like(u)
    rays = base_points(d.astype(np.float32), CAMERA, BODY.head_view(head)) - np.asarray(BODY.camera_xyz)
    origin = to_world(np.asarray(BODY.camera_xyz), base)
    dirs = to_world(rays, (0.0, 0.0, base[2]))  # rotate only
    best = np.full(len(dirs), np.inf)
    down = dirs[:, 2] < 0
    best[down] = -origin[2] / dirs[down, 2]
    for lo, hi in boxes:
        with np.errstate(divide="ignore", invalid="ignore"):
            t0 = (np.asarray(lo) - origin) / dirs
            t1 = (np.asarray(hi) - origin) / dirs
        near = np.nanmax(np.minimum(t0, t1), axis=1)
        far = np.nanmin(np.maximum(t0, t1), axis=1)
        hit = (near <= far) & (near > 0)
        best[hit] = np.minimum(best[hit], near[hit])
    # t runs along a ray whose forward (optical axis) component is 1: t is the depth
    return best.reshape(u.shape).astype(np.float32)


def _project(point: np.ndarray, head: tuple[float, float], base: tuple[float, float, float]) -> tuple:
    p = to_base(point, base) - np.asarray(BODY.camera_xyz)
    pan, tilt = head
    # undo pan, then tilt
    f = p[0] * math.cos(pan) + p[1] * math.sin(pan)
    left = -p[0] * math.sin(pan) + p[1] * math.cos(pan)
    fwd = f * math.cos(tilt) + p[2] * math.sin(tilt)
    up = -f * math.sin(tilt) + p[2] * math.cos(tilt)
    return CAMERA.cx - left / fwd * CAMERA.fx, CAMERA.cy - up / fwd * CAMERA.fy


def test_world_and_base_frames_are_inverse():
    pts = np.array([[1.0, 2.0, 0.3], [-0.5, 0.25, 1.0]])
    pose = (0.7, -1.2, 2.1)
    assert np.allclose(to_base(to_world(pts, pose), pose), pts)
    assert np.allclose(to_world(np.array([1.0, 0.0, 0.5]), (1.0, 1.0, math.pi / 2)), [1.0, 2.0, 0.5])


def test_a_range_along_the_aimed_axis_lands_on_the_point():
    pose = (0.3, -0.4, 0.6)
    target = np.array([1.8, 0.9, 0.5])
    head = head_towards(target, pose, BODY)
    rng = float(np.linalg.norm(to_base(target, pose) - np.asarray(BODY.camera_xyz)))
    p = to_world(point_from_range(rng, CAMERA, BODY.head_view(head), CAMERA.cx, CAMERA.cy), pose)
    assert np.allclose(p, target, atol=1e-9)


@pytest.mark.parametrize("head", [(0.0, -0.5), (0.35, -0.7), (-0.3, -0.4)])
def test_an_object_on_a_table_is_located_from_its_depth_pixels(head):
    base = (0.1, 0.2, 0.15)
    table = ((1.0, -0.6, 0.0), (1.8, 0.8, 0.45))
    obj = ((1.25, 0.05, 0.45), (1.33, 0.13, 0.57))  # 8 x 8 x 12 cm on the table
    centre = np.array([1.29, 0.09, 0.51])
    # look at it, as the controller would before locating
    head = head_towards(centre, base, BODY)
    depth = _ray_cast(head, base, [table, obj])
    corners = np.array([[x, y, z] for x in (1.25, 1.33) for y in (0.05, 0.13) for z in (0.45, 0.57)])
    uv = np.array([_project(c, head, base) for c in corners])
    box = (uv[:, 0].min() - 2, uv[:, 1].min() - 2, uv[:, 0].max() + 2, uv[:, 1].max() + 2)
    est = estimate_object(depth, CAMERA, BODY.head_view(head), base, box)
    assert est is not None
    assert est.support_z == pytest.approx(0.45, abs=0.01)
    assert est.top_z == pytest.approx(0.57, abs=0.015)
    assert np.linalg.norm(np.array(est.centre[:2]) - centre[:2]) < 0.025
    assert est.radius == pytest.approx(0.04, abs=0.025)


def test_a_board_above_a_gap_is_not_part_of_the_object_under_it():
    base = (0.0, 0.0, 0.0)
    shelf_low = ((1.0, -0.5, 0.0), (1.5, 0.5, 0.42))
    board = ((1.0, -0.5, 0.86), (1.5, 0.5, 0.9))
    box = ((1.1, -0.15, 0.42), (1.3, 0.05, 0.6))
    head = head_towards(np.array([1.2, -0.05, 0.51]), base, BODY)
    depth = _ray_cast(head, base, [shelf_low, board, box])
    # a loose box that takes in the board's front edge above it
    corners = [(1.1, -0.15, 0.42), (1.1, 0.05, 0.42), (1.1, -0.15, 0.9), (1.3, 0.05, 0.6)]
    uv = np.array([_project(np.array(c), head, base) for c in corners])
    pixels = (uv[:, 0].min(), max(uv[:, 1].min(), 0.0), uv[:, 0].max(), uv[:, 1].max())
    est = estimate_object(depth, CAMERA, BODY.head_view(head), base, pixels)
    assert est is not None and est.top_z == pytest.approx(0.6, abs=0.015)


def test_the_grip_of_a_thin_bent_thing_lands_on_it_not_in_the_empty_middle():
    base = (0.0, 0.0, 0.0)
    table = ((1.0, -0.6, 0.0), (1.8, 0.6, 0.45))
    # an L of two thin bars: the middle of its extent is empty table
    bars = [((1.2, 0.0, 0.45), (1.45, 0.02, 0.47)), ((1.2, 0.0, 0.45), (1.22, 0.25, 0.47))]
    head = head_towards(np.array([1.3, 0.1, 0.46]), base, BODY)
    depth = _ray_cast(head, base, [table, *bars])
    uv = np.array([_project(np.array(c), head, base) for c in [(1.2, 0.0, 0.45), (1.45, 0.25, 0.47)]])
    box = (uv[:, 0].min() - 1, uv[:, 1].min() - 1, uv[:, 0].max() + 1, uv[:, 1].max() + 1)
    est = estimate_object(depth, CAMERA, BODY.head_view(head), base, box)
    assert est is not None
    x, y = est.centre[:2]
    on_a_bar = (1.2 <= x <= 1.45 and -0.01 <= y <= 0.03) or (1.19 <= x <= 1.23 and 0.0 <= y <= 0.25)
    assert on_a_bar, est.centre


def test_an_open_laptop_is_gripped_by_its_base_not_the_middle_of_its_screen():
    base = (0.0, 0.0, 0.0)
    table = ((1.0, -0.6, 0.0), (1.8, 0.6, 0.75))
    keyboard = ((1.2, -0.17, 0.75), (1.44, 0.17, 0.77))
    screen = ((1.44, -0.17, 0.75), (1.46, 0.17, 0.98))
    head = head_towards(np.array([1.32, 0.0, 0.8]), base, BODY)
    depth = _ray_cast(head, base, [table, keyboard, screen])
    corners = [(1.2, -0.17, 0.75), (1.46, 0.17, 0.98), (1.2, 0.17, 0.75), (1.46, -0.17, 0.98)]
    uv = np.array([_project(np.array(c), head, base) for c in corners])
    box = (uv[:, 0].min() - 1, uv[:, 1].min() - 1, uv[:, 0].max() + 1, uv[:, 1].max() + 1)
    est = estimate_object(depth, CAMERA, BODY.head_view(head), base, box)
    assert est is not None and est.top_z == pytest.approx(0.98, abs=0.015)
    assert est.grip_z == pytest.approx(0.76, abs=0.015)


def test_a_thin_object_in_front_of_a_wall_is_not_taken_for_the_wall():
    base = (0.0, 0.0, 0.0)
    wall = ((3.0, -3.0, 0.0), (3.1, 3.0, 2.5))
    pole = ((1.5, -0.09, 0.0), (1.52, -0.07, 1.4))
    head = head_towards(np.array([1.51, -0.08, 0.7]), base, BODY)
    depth = _ray_cast(head, base, [wall, pole])
    top, bottom = (_project(np.array([1.51, -0.08, z]), head, base)[1] for z in (1.4, 0.0))
    box = (CAMERA.cx - 6, max(top - 2, 0.0), CAMERA.cx + 6, min(bottom + 2, CAMERA.height))  # a loose box
    est = estimate_object(depth, CAMERA, BODY.head_view(head), base, box)
    assert est is not None and abs(est.centre[0] - 1.51) < 0.05


def test_ignored_points_are_left_out_of_the_estimate():
    base = (0.0, 0.0, 0.0)
    table = ((1.0, -0.5, 0.0), (1.6, 0.5, 0.45))
    plate = ((1.2, -0.15, 0.45), (1.4, 0.05, 0.47))
    held = ((1.2, -0.12, 0.5), (1.28, -0.04, 0.58))  # hangs just over the plate, in the camera's way
    head = head_towards(np.array([1.3, -0.05, 0.46]), base, BODY)
    depth = _ray_cast(head, base, [table, plate, held])
    uv = np.array([_project(np.array(c), head, base) for c in [(1.2, -0.15, 0.45), (1.4, 0.05, 0.47)]])
    box = (uv[:, 0].min() - 15, uv[:, 1].min() - 15, uv[:, 0].max() + 15, uv[:, 1].max() + 15)
    fooled = estimate_object(depth, CAMERA, BODY.head_view(head), base, box)
    assert fooled is not None and fooled.top_z > 0.55  # what the held object does to it

    def is_held(points: np.ndarray) -> np.ndarray:
        return points[:, 2] > 0.49

    est = estimate_object(depth, CAMERA, BODY.head_view(head), base, box, ignore=is_held)
    assert est is not None and est.top_z == pytest.approx(0.47, abs=0.01)


def test_the_floor_map_plans_around_what_depth_saw():
    floor = FloorMap((0.0, 0.0), half=3.0)
    # a wall of points from y=-1 to y=1 at x=1, 0.5 m high
    ys = np.linspace(-1.0, 1.0, 200)
    floor.add(np.column_stack([np.full_like(ys, 1.0), ys, np.full_like(ys, 0.5)]))
    floor.add(np.array([[2.0, 2.0, 0.01]]))  # on the floor: not an obstacle
    assert not floor.occupied[floor.index(np.array([2.0, 2.0]))]
    path = floor.path(np.array([0.0, 0.0]), np.array([2.0, 0.0]), radius=0.3)
    assert path is not None and np.allclose(path[-1], [2.0, 0.0])
    # every leg keeps the base's radius from the wall (less a cell of grid rounding)
    wall = np.column_stack([np.full_like(ys, 1.0), ys])
    pts = [np.array([0.0, 0.0]), *path]
    for a, b in zip(pts, pts[1:], strict=False):
        for t in np.linspace(0, 1, 50):
            assert np.min(np.linalg.norm(wall - (a + (b - a) * t), axis=1)) > 0.3 - 0.05
    assert not floor.footprint_free((1.0, 0.0, 0.0), BODY.base_half, 0.03)
    assert floor.footprint_free((0.0, 0.0, 0.0), BODY.base_half, 0.03)
    floor.clear_disc(np.array([1.0, 0.0]), 0.2)
    assert not floor.occupied[floor.index(np.array([1.0, 0.0]))]


def test_no_path_through_a_closed_room():
    floor = FloorMap((0.0, 0.0), half=2.0)
    t = np.linspace(0, math.tau, 2000)
    floor.add(np.column_stack([np.cos(t), np.sin(t), np.full_like(t, 0.5)]))  # a ring around the robot
    assert floor.path(np.array([0.0, 0.0]), np.array([1.6, 0.0]), radius=0.25) is None


def test_a_box_spans_its_pixels_times_the_distance_over_the_focal_length():
    """One way to size a box in metres, as `ImagePatch.size_at`, the rangefinder's estimate and depth's
    checks all do: 55 x 22 pixels at 2 m through a 110-pixel focal length are 1.0 x 0.4 m."""
    width, height = CAMERA.metres_across((10.0, 20.0, 65.0, 42.0), 2.0)
    assert width == pytest.approx(1.0) and height == pytest.approx(0.4)
    assert CAMERA.metres_across((10.0, 20.0, 65.0, 42.0), 0.0) == (0.0, 0.0)


def test_the_arm_in_front_of_an_object_is_not_placed_as_part_of_it():
    """The frame's `scene_depth` leaves the robot's own body out: a gripper held before a backpack (the
    servo's last look at the goal) no longer pulls its estimate to the gripper, while the raw depth does."""
    base = (0.0, 0.0, 0.0)
    bag = ((0.9, -0.15, 0.0), (1.15, 0.15, 0.45))
    arm = ((0.8, -0.3, 0.1), (0.84, 0.0, 0.35))  # the telescope and fingers, reaching in from the side
    head = head_towards(np.array([1.02, 0.0, 0.22]), base, BODY)
    scene = _ray_cast(head, base, [bag])
    seen = _ray_cast(head, base, [bag, arm])
    own = seen < scene - 1e-4  # where the arm is what the camera sees
    assert own.any()
    frame = Frame(rgb=np.zeros((CAMERA.height, CAMERA.width, 3), np.uint8), depth=seen, own_body=own)
    corners = np.array([[x, y, z] for x in (0.9, 1.15) for y in (-0.15, 0.15) for z in (0.0, 0.45)])
    uv = np.array([_project(c, head, base) for c in corners])
    box = (uv[:, 0].min(), uv[:, 1].min(), uv[:, 0].max(), uv[:, 1].max())
    truth = estimate_object(scene, CAMERA, BODY.head_view(head), base, box)
    left_out = estimate_object(frame.scene_depth, CAMERA, BODY.head_view(head), base, box)
    raw = estimate_object(frame.depth, CAMERA, BODY.head_view(head), base, box)
    assert truth is not None and left_out is not None and raw is not None
    assert np.linalg.norm(left_out.xy() - truth.xy()) < 0.02
    assert np.linalg.norm(raw.xy() - truth.xy()) > 0.05  # the arm taken for part of the bag
    # without a body in view, or without depth, it is the depth as it is
    assert Frame(rgb=frame.rgb, depth=seen).scene_depth is seen and Frame(rgb=frame.rgb).scene_depth is None


class _ChasedBase:
    """A base that drives where it is told, and a depth estimate that follows it: each correction shows
    another side of the object, whose middle then seems to move 80% of the way along with the base."""

    def __init__(self, radius: float) -> None:
        self.pose = (0.0, 0.0, 0.0)
        self.radius = radius
        self.tuning = ServoTuning()
        self.drives = 0

    def refind(self, est: ObjectEstimate, *args: object, **kwargs: object) -> ObjectEstimate:
        x, y, _ = self.pose
        centre = (BODY.reach_x(0.2) + 0.8 * x, BODY.arm_xy[1] + 0.03 + 0.8 * y, 0.2)
        return ObjectEstimate(centre, 0.0, 0.4, self.radius, 500)

    def drive_to(self, pose: tuple[float, float, float], *args: object) -> None:
        self.pose, self.drives = pose, self.drives + 1


@pytest.mark.parametrize("radius", [0.03, 0.13])
def test_the_arm_lines_up_with_a_wide_object_within_a_share_of_its_width(radius):
    chased = _ChasedBase(radius)
    plant = SimpleNamespace(tuning=chased.tuning, pose=lambda: chased.pose)
    reacher = Reacher(plant, SimpleNamespace(drive_to=chased.drive_to), SimpleNamespace(refind=chased.refind))
    first = chased.refind(None)
    target = Target((0.0, 0.0, 1.0, 1.0), Capture(0), label="backpack")
    if radius < 0.05:  # a mug's middle must be met to the centimetre: the chase runs out of corrections
        with pytest.raises(ControlError, match="could not line its arm up") as err:
            reacher.line_up(first, target, "go_to_object", BODY, None, None)
        assert err.value.reason is Failure.NOT_REACHABLE
        return
    reach = reacher.line_up(first, target, "go_to_object", BODY, None, None)
    assert chased.drives == 0 and reach.estimate.radius == radius
