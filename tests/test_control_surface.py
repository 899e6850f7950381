"""The top of a large receptacle from depth points (`attribot.control.surface`), on point clouds built here
from known geometry: a table with a mug on it, what the mug hides, a shelf's two boards, a book lying flat,
a wall, two tables at different heights. The truth is the geometry the points were made from."""

from __future__ import annotations

import numpy as np
import pytest

from attribot.control.surface import find_top

STEP = 0.01  # metres between the depth samples of a surface


def _slab(x: tuple[float, float], y: tuple[float, float], z: float) -> np.ndarray:
    """Points of a horizontal rectangle at height z."""
    xs, ys = np.meshgrid(np.arange(x[0], x[1], STEP), np.arange(y[0], y[1], STEP), indexing="ij")
    return np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, z)])


def _wall(x: float, y: tuple[float, float], z: tuple[float, float]) -> np.ndarray:
    """Points of a vertical rectangle at x."""
    ys, zs = np.meshgrid(np.arange(y[0], y[1], STEP), np.arange(z[0], z[1], STEP), indexing="ij")
    return np.column_stack([np.full(ys.size, x), ys.ravel(), zs.ravel()])


def _cylinder(xy: tuple[float, float], r: float, z: tuple[float, float]) -> np.ndarray:
    """Points of an upright cylinder's side and top."""
    a, zs = np.meshgrid(np.linspace(0, 2 * np.pi, 40), np.arange(z[0], z[1], STEP), indexing="ij")
    side = np.column_stack([xy[0] + r * np.cos(a.ravel()), xy[1] + r * np.sin(a.ravel()), zs.ravel()])
    top = _slab((xy[0] - r, xy[0] + r), (xy[1] - r, xy[1] + r), z[1])
    top = top[np.hypot(top[:, 0] - xy[0], top[:, 1] - xy[1]) <= r]
    return np.vstack([side, top])


def _table_with_a_mug(hidden: bool = True) -> tuple[np.ndarray, tuple[float, float], float]:
    """A table top 0.7 x 0.9 m at 0.75 m seen from the -x side, its front face, a mug of radius 4 cm at
    (0.35, 0.45), and (with `hidden`) no depth on the top behind the mug, as a camera there sees it."""
    top = _slab((0.0, 0.7), (0.0, 0.9), 0.75)
    mug = (0.35, 0.45)
    if hidden:
        behind = (top[:, 0] > mug[0]) & (np.abs(top[:, 1] - mug[1]) < 0.05)
        top = top[~behind]
    front = _wall(0.0, (0.0, 0.9), (0.05, 0.75))
    return np.vstack([top, front, _cylinder(mug, 0.04, (0.75, 0.85))]), mug, 0.04


def test_the_top_is_found_at_its_height_with_what_stands_on_it_blocked():
    points, mug, r = _table_with_a_mug()
    top = find_top(points)
    assert top is not None
    assert top.z == pytest.approx(0.75, abs=0.002)
    assert top.area == pytest.approx(0.7 * 0.9, rel=0.15)
    assert top.blocked_near(np.array(mug), r)
    assert not top.blocked_near(np.array([0.1, 0.1]), 0.05)


@pytest.mark.parametrize("radius", [0.04, 0.1])
def test_free_spots_keep_off_what_stands_there_what_it_hides_and_the_edges(radius):
    points, mug, r = _table_with_a_mug()
    top = find_top(points)
    assert top is not None
    spots = top.free_spots(radius)
    assert len(spots) > 20
    # a disc of the radius at each spot lies on the table, clear of the mug
    assert np.all(spots[:, 0] - radius >= -0.005) and np.all(spots[:, 0] + radius <= 0.705)
    assert np.all(spots[:, 1] - radius >= -0.005) and np.all(spots[:, 1] + radius <= 0.905)
    assert np.all(np.hypot(spots[:, 0] - mug[0], spots[:, 1] - mug[1]) >= r + radius)
    # nor on the part of the top the mug hides from the camera (it may hold something unseen)
    shadow = (spots[:, 0] > mug[0]) & (np.abs(spots[:, 1] - mug[1]) < 0.05)
    assert not shadow.any()


def test_a_top_taken_by_what_stands_there_has_no_free_spot():
    top_points = _slab((0.0, 0.3), (0.0, 0.3), 0.75)
    cups = [_cylinder((x, y), 0.04, (0.75, 0.85)) for x in (0.075, 0.225) for y in (0.075, 0.225)]
    top = find_top(np.vstack([top_points, *cups]))
    assert top is not None and top.z == pytest.approx(0.75, abs=0.002)
    assert len(top.free_spots(0.07)) == 0
    empty = find_top(top_points)
    assert empty is not None and len(empty.free_spots(0.07)) > 0  # without them it takes the object


def test_a_shelf_top_is_its_highest_large_board_not_a_book_on_it():
    low = _slab((0.0, 0.45), (0.0, 1.2), 0.42)
    high = _slab((0.0, 0.45), (0.0, 1.2), 0.9)
    book = _slab((0.1, 0.25), (0.3, 0.5), 0.93)  # lying flat: a small layer over the top
    sides = np.vstack([_wall(0.0, (0.0, 0.03), (0.0, 0.9)), _wall(0.0, (1.17, 1.2), (0.0, 0.9))])
    top = find_top(np.vstack([low, high, book, sides]))
    assert top is not None
    assert top.z == pytest.approx(0.9, abs=0.002)
    assert top.blocked_near(np.array([0.17, 0.4]), 0.02)


def test_a_wall_alone_is_no_top():
    assert find_top(_wall(1.0, (0.0, 1.2), (0.0, 1.2))) is None
    assert find_top(np.zeros((0, 3))) is None


def test_near_finds_the_same_top_again_among_others():
    coffee = _slab((0.0, 0.45), (0.0, 0.8), 0.45)
    counter = _slab((1.0, 1.45), (0.0, 1.2), 0.9)
    both = np.vstack([coffee, counter])
    assert find_top(both).z == pytest.approx(0.9, abs=0.002)  # the highest large layer
    again = find_top(both, near=(np.array([0.2, 0.4]), 0.46))
    assert again is not None and again.z == pytest.approx(0.45, abs=0.002)
    assert again.on_top(np.array([[0.2, 0.4], [1.2, 0.5]])).tolist() == [True, False]
    assert find_top(both, near=(np.array([0.2, 0.4]), 0.6)) is None  # no top within 4 cm of that height
