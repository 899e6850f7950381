"""Where things are, from a depth image: back-projection, object estimates, a perceived floor map, paths.

Everything here comes from what a robot with a depth camera (or a rangefinder) and odometry has: depth
along the optical axis, the pinhole intrinsics, the camera's pose in the base frame (a `CameraPose`, from
its head's or arm's joints), the base pose from odometry and the body geometry. Nothing reads a
simulator's object poses or segmentation.

Frames: camera (forward, left, up) before the camera's pan and tilt; base (x forward, y left, z up, on the
floor at the base's centre); world (the odometry frame of `base_pose`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from attribot.control.body import BodyGeometry, CameraPose
from attribot.frame import CameraInfo
from attribot.gridpath import Cell, astar, shortcut

__all__ = [
    "ObjectEstimate",
    "FloorMap",
    "base_points",
    "point_map",
    "nearest_surface",
    "projected_box",
    "to_world",
    "to_base",
    "estimate_object",
    "point_from_range",
    "ray_through",
    "head_towards",
    "project",
]

Pose = tuple[float, float, float]


def _rotate_head(fwd: np.ndarray, left: np.ndarray, up: np.ndarray, head: tuple[float, float]) -> np.ndarray:
    """Camera-frame vectors rotated by tilt (about the left axis, up positive), then pan (about up)."""
    pan, tilt = head
    ct, st, cp, sp = math.cos(tilt), math.sin(tilt), math.cos(pan), math.sin(pan)
    f1 = fwd * ct - up * st
    u1 = fwd * st + up * ct
    return np.stack([f1 * cp - left * sp, f1 * sp + left * cp, u1], axis=-1)


def base_points(
    depth: np.ndarray,
    camera: CameraInfo,
    view: CameraPose,
    box: tuple[float, float, float, float] | None = None,
    stride: int = 1,
) -> np.ndarray:
    """(N, 3) base-frame points of the valid depth pixels (inside `box` when given, every `stride`-th)."""
    h, w = depth.shape
    x0, y0, x1, y1 = (0, 0, w, h) if box is None else box
    c0, r0 = max(int(math.floor(x0)), 0), max(int(math.floor(y0)), 0)
    c1, r1 = min(int(math.ceil(x1)), w), min(int(math.ceil(y1)), h)
    if c1 <= c0 or r1 <= r0:
        return np.zeros((0, 3))
    rows, cols = np.mgrid[r0:r1:stride, c0:c1:stride]
    d = depth[rows, cols].astype(np.float64)
    ok = np.isfinite(d) & (d > 0.05) & (d < 20.0)
    d, u, v = d[ok], cols[ok] + 0.5, rows[ok] + 0.5
    pts = _rotate_head(d, -(u - camera.cx) / camera.fx * d, -(v - camera.cy) / camera.fy * d, view.angles)
    return pts + np.asarray(view.xyz)


def point_map(depth: np.ndarray, camera: CameraInfo, view: CameraPose, stride: int = 1) -> np.ndarray:
    """(H', W', 3) base-frame points of every `stride`-th pixel in rows and columns, laid out as the image
    is (pixel (r, c) of the map is pixel (r * stride, c * stride)); NaN where the depth is not valid."""
    rows, cols = np.mgrid[0 : depth.shape[0] : stride, 0 : depth.shape[1] : stride]
    d = depth[rows, cols].astype(np.float64)
    ok = np.isfinite(d) & (d > 0.05) & (d < 20.0)
    d = np.where(ok, d, np.nan)
    u, v = cols + 0.5, rows + 0.5
    pts = _rotate_head(d, -(u - camera.cx) / camera.fx * d, -(v - camera.cy) / camera.fy * d, view.angles)
    return pts + np.asarray(view.xyz)


def nearest_surface(
    depth: np.ndarray, camera: CameraInfo, view: CameraPose, box: tuple[float, float, float, float]
) -> np.ndarray | None:
    """(N, 3) base-frame points of the nearest surface in the middle of a box (its middle half each way):
    the object the box frames, not what shows behind it around its edges; None without depth there."""
    x0, y0, x1, y1 = box
    qx, qy = (x1 - x0) / 4.0, (y1 - y0) / 4.0
    inner = base_points(depth, camera, view, (x0 + qx, y0 + qy, x1 - qx, y1 - qy))
    if len(inner) == 0:
        return None
    rng = np.linalg.norm(inner - np.asarray(view.xyz), axis=1)
    return inner[rng <= np.quantile(rng, 0.2) + 0.08]


def projected_box(
    points_base: np.ndarray, camera: CameraInfo, view: CameraPose
) -> tuple[float, float, float, float] | None:
    """The box, clipped to the image, that base-frame points fill in the image of a camera at `view`; None
    where any of them is behind the camera, or the box is under a pixel wide or tall."""
    uv, front = project(points_base, camera, view)
    if not front.all():
        return None
    w, h = camera.width, camera.height
    u0, v0 = np.clip(uv.min(axis=0), 0, [w, h])
    u1, v1 = np.clip(uv.max(axis=0), 0, [w, h])
    if u1 - u0 < 1 or v1 - v0 < 1:
        return None
    return float(u0), float(v0), float(u1), float(v1)


def point_from_range(metres: float, camera: CameraInfo, view: CameraPose, u: float, v: float) -> np.ndarray:
    """Base-frame point at range `metres` along the ray through pixel (u, v) of a camera at `view` (a
    rangefinder's reading along its optical axis)."""
    ray = np.array([1.0, -(u - camera.cx) / camera.fx, -(v - camera.cy) / camera.fy])
    ray /= np.linalg.norm(ray)
    p = _rotate_head(
        np.array([ray[0] * metres]), np.array([ray[1] * metres]), np.array([ray[2] * metres]), view.angles
    )[0]
    return p + np.asarray(view.xyz)


def ray_through(camera: CameraInfo, view: CameraPose, u: float, v: float) -> np.ndarray:
    """Unit direction, in the base frame, of the ray from a camera at `view` through pixel (u, v)."""
    return point_from_range(1.0, camera, view, u, v) - np.asarray(view.xyz)


def to_world(points: np.ndarray, base: Pose) -> np.ndarray:
    """Base-frame points (N, 3) or (3,) in the world frame of the base pose `(x, y, yaw)`."""
    x, y, yaw = base
    c, s = math.cos(yaw), math.sin(yaw)
    p = np.asarray(points, float)
    out = p.copy()
    out[..., 0] = x + c * p[..., 0] - s * p[..., 1]
    out[..., 1] = y + s * p[..., 0] + c * p[..., 1]
    return out


def to_base(points: np.ndarray, base: Pose) -> np.ndarray:
    """World points (N, 3) or (3,) in the frame of the base at pose `(x, y, yaw)`."""
    x, y, yaw = base
    c, s = math.cos(yaw), math.sin(yaw)
    p = np.asarray(points, float)
    out = p.copy()
    dx, dy = p[..., 0] - x, p[..., 1] - y
    out[..., 0] = c * dx + s * dy
    out[..., 1] = -s * dx + c * dy
    return out


def head_towards(point_world: np.ndarray, base: Pose, body: BodyGeometry) -> tuple[float, float]:
    """Head (pan, tilt) that puts a world point on the optical axis, from the base pose `base`."""
    p = to_base(point_world, base) - np.asarray(body.camera_xyz)
    return math.atan2(p[1], p[0]), math.atan2(p[2], math.hypot(p[0], p[1]))


@dataclass(frozen=True)
class ObjectEstimate:
    """An object as depth sees it, world frame: centre (x, y, z), the height of what it stands on, its top,
    its horizontal radius, how many depth points it rests on, and its top above the centre."""

    centre: tuple[float, float, float]
    support_z: float
    top_z: float
    radius: float
    points: int
    local_top_z: float | None = None  # the object's top right above its centre, where depth saw it

    @property
    def grip_z(self) -> float:
        """Where the fingers close: halfway up the material under the centre (an open laptop: its base,
        not the middle of its screen), or halfway up the object when depth did not see its centre."""
        top = self.top_z if self.local_top_z is None else self.local_top_z
        return (self.support_z + top) / 2

    def xy(self) -> np.ndarray:
        return np.array(self.centre[:2])


def estimate_object(
    depth: np.ndarray,
    camera: CameraInfo,
    view: CameraPose,
    base: Pose,
    box: tuple[float, float, float, float],
    ignore: Callable[[np.ndarray], np.ndarray] | None = None,
) -> ObjectEstimate | None:
    """The object inside `box` from depth: the pixels near the depth of the box's middle are the object and
    what it stands on; the lowest of them is the support, those above it the object. `ignore` masks world
    points that are not it (what the gripper holds in front of it). None when the box holds no valid
    depth."""
    x0, y0, x1, y1 = box
    mx, my = (x1 - x0) * 0.3, (y1 - y0) * 0.3
    cam = np.asarray(view.xyz)

    def kept(b: tuple[float, float, float, float]) -> np.ndarray:
        p = base_points(depth, camera, view, b)
        return p[~ignore(to_world(p, base))] if ignore is not None and len(p) else p

    pts = kept(box)
    middle = kept((x0 + mx, y0 + my, max(x1 - mx, x0 + mx + 1), max(y1 - my, y0 + my + 1)))
    if len(middle) == 0:
        middle = pts
    if len(pts) == 0:
        return None
    # the nearest thing in the middle of the box: a thin object (a lamp's pole) leaves most of its box
    # to the background
    d0 = float(np.percentile(np.linalg.norm(middle - cam, axis=1), 15))
    ranges = np.linalg.norm(pts - cam, axis=1)
    # the box's metric size bounds how far behind the middle the object may reach
    span = max(camera.metres_across((x0, y0, x1, y1), d0))
    near = pts[np.abs(ranges - d0) <= max(0.12, span)]
    if len(near) < 3:
        near = pts
    support = float(np.percentile(near[:, 2], 2))
    above = near[near[:, 2] > support + 0.01]
    if len(above) < 3:  # a flat thing: it is all the object
        above = near
    # an object is a stack without gaps from its support up: what hangs above a gap (a shelf's board
    # over it) is something else
    zs = np.sort(above[:, 2])
    gaps = np.nonzero(np.diff(zs) > 0.05)[0]
    if len(gaps):
        above = above[above[:, 2] <= zs[gaps[0]]]
    top = float(np.percentile(above[:, 2], 98))
    c, radius = _footprint(above, cam[:2], ignore is None)
    centre = to_world(np.array([c[0], c[1], (support + top) / 2]), base)
    local = above[np.hypot(above[:, 0] - c[0], above[:, 1] - c[1]) <= max(0.03, radius * 0.3)]
    return ObjectEstimate(
        centre=(float(centre[0]), float(centre[1]), float(centre[2])),
        support_z=support,
        top_z=top,
        radius=max(radius, 0.01),
        points=len(above),
        local_top_z=float(np.percentile(local[:, 2], 98)) if len(local) >= 3 else None,
    )


def _footprint(above: np.ndarray, cam: np.ndarray, middle_seen: bool) -> tuple[np.ndarray, float]:
    """The object's centre (x, y in the base frame) and horizontal radius from its points `above`, seen
    from the camera at `cam` (x, y); `middle_seen`: no points were masked out of the view."""
    # the visible faces lie towards the camera: the centre is half the object's depth behind the front
    view = above[:, :2].mean(axis=0) - cam
    view /= max(float(np.linalg.norm(view)), 1e-9)
    side = np.array([-view[1], view[0]])
    along = (above[:, :2] - cam) @ view
    across = (above[:, :2] - cam) @ side
    radius = float(np.percentile(across, 95) - np.percentile(across, 5)) / 2
    front, back = float(np.percentile(along, 3)), float(np.percentile(along, 97))
    centre_along = max((front + back) / 2, front + radius)
    centre_across = float(np.percentile(across, 95) + np.percentile(across, 5)) / 2
    c = cam + view * centre_along + side * centre_across
    # the middle of a thin or bent thing (a ladle, a ring) may be empty: then the grip goes to the
    # nearest part of it (from above, the top of a solid object covers its middle); not where ignored
    # points hide the middle (it is unseen, not empty)
    gap = np.hypot(above[:, 0] - c[0], above[:, 1] - c[1])
    if middle_seen and float(gap.min()) > 0.01:
        c = above[int(np.argmin(gap)), :2]
    return c, radius


@dataclass
class FloorMap:
    """A 2-D grid of the floor around the robot in the world frame: a cell is occupied when depth saw
    something above the floor in it (furniture, objects, walls); unseen cells count as free.

    cell: metres per cell; half: the grid covers [-half, half] around `centre`; floor_z: heights below
    this are floor; ceiling_z: heights above this are ignored (they do not block the base).
    """

    centre: tuple[float, float]
    half: float = 4.0
    cell: float = 0.05
    floor_z: float = 0.03
    ceiling_z: float = 2.0
    occupied: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        n = int(round(2 * self.half / self.cell))
        self.occupied = np.zeros((n, n), bool)

    def index(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ij = np.floor((np.asarray(xy, float) - np.asarray(self.centre) + self.half) / self.cell).astype(int)
        n = self.occupied.shape[0]
        return np.clip(ij[..., 0], 0, n - 1), np.clip(ij[..., 1], 0, n - 1)

    def centre_of(self, i: int, j: int) -> np.ndarray:
        return np.array(self.centre) - self.half + (np.array([i, j]) + 0.5) * self.cell

    def add(self, points_world: np.ndarray) -> None:
        """Mark the cells of world points that stand above the floor (and below the ceiling)."""
        p = points_world[(points_world[:, 2] > self.floor_z) & (points_world[:, 2] < self.ceiling_z)]
        inside = np.all(np.abs(p[:, :2] - np.asarray(self.centre)) < self.half, axis=1)
        i, j = self.index(p[inside, :2])
        self.occupied[i, j] = True

    def clear_disc(self, xy: np.ndarray, radius: float) -> None:
        """Forget what lies within `radius` of `xy` (an object that will be moved, or is held)."""
        offsets = (np.arange(self.occupied.shape[0]) + 0.5) * self.cell - self.half
        xs, ys = self.centre[0] + offsets, self.centre[1] + offsets
        near = (xs[:, None] - xy[0]) ** 2 + (ys[None, :] - xy[1]) ** 2 <= radius**2
        self.occupied[near] = False

    def footprint_free(self, pose: Pose, half: tuple[float, float], margin: float) -> bool:
        """True when the base's rectangle at `pose`, grown by `margin`, covers no occupied cell."""
        x, y, yaw = pose
        hx, hy = half[0] + margin, half[1] + margin
        r = math.hypot(hx, hy)
        i0, j0 = self.index(np.array([x - r, y - r]))
        i1, j1 = self.index(np.array([x + r, y + r]))
        cells = np.argwhere(self.occupied[i0 : i1 + 1, j0 : j1 + 1])
        if len(cells) == 0:
            return True
        pts = np.array(self.centre) - self.half + (cells + np.array([i0, j0]) + 0.5) * self.cell
        local = to_base(np.column_stack([pts, np.zeros(len(pts))]), pose)
        return not bool(np.any((np.abs(local[:, 0]) <= hx) & (np.abs(local[:, 1]) <= hy)))

    def path(self, start: np.ndarray, goal: np.ndarray, radius: float) -> list[np.ndarray] | None:
        """Waypoints from start to goal that keep the base's centre `radius` from every occupied cell (A*
        on the grid, shortened by line of sight), or None when there is none. Near the start and the goal
        the clearance is relaxed, since a robot starts and ends next to things."""
        grow = int(math.ceil(radius / self.cell))
        blocked = _dilate(self.occupied, grow)
        si, sj = self.index(start)
        gi, gj = self.index(goal)
        s, g = (int(si), int(sj)), (int(gi), int(gj))
        relax = grow + 2

        def cost(c: Cell) -> float | None:
            if not blocked[c]:
                return 1.0
            near = min(max(abs(c[0] - e[0]), abs(c[1] - e[1])) for e in (s, g)) <= relax
            return 3.0 if near and not self.occupied[c] else None

        cells = astar(blocked.shape, s, g, cost)
        if cells is None:
            return None
        keep = shortcut(blocked, cells)
        return [self.centre_of(*c) for c in keep[1:-1]] + [np.asarray(goal, float)]


def _dilate(grid: np.ndarray, cells: int) -> np.ndarray:
    """Grid cells within `cells` (a disc) of an occupied one."""
    out = grid.copy()
    n = grid.shape[0]
    for di in range(-cells, cells + 1):
        for dj in range(-cells, cells + 1):
            if di * di + dj * dj > cells * cells or (di == 0 and dj == 0):
                continue
            src = grid[max(-di, 0) : n - max(di, 0), max(-dj, 0) : n - max(dj, 0)]
            out[max(di, 0) : n - max(-di, 0), max(dj, 0) : n - max(-dj, 0)] |= src
    return out


def project(points_base: np.ndarray, camera: CameraInfo, view: CameraPose) -> tuple[np.ndarray, np.ndarray]:
    """Pixels `(u, v)` (y down) of base-frame points (N, 3) in a camera at `view`, and a mask of the
    points in front of it: the inverse of `base_points`."""
    p = np.atleast_2d(np.asarray(points_base, float)) - np.asarray(view.xyz)
    pan, tilt = view.angles
    cp, sp, ct, st = math.cos(pan), math.sin(pan), math.cos(tilt), math.sin(tilt)
    # undo the pan (about up), then the tilt (about left)
    f1, left, up1 = cp * p[:, 0] + sp * p[:, 1], -sp * p[:, 0] + cp * p[:, 1], p[:, 2]
    fwd, up = ct * f1 + st * up1, -st * f1 + ct * up1
    front = fwd > 0.05
    safe = np.where(front, fwd, 1.0)
    return np.stack([camera.cx - left / safe * camera.fx, camera.cy - up / safe * camera.fy], -1), front
