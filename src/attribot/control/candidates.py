"""Where objects may stand, from depth alone: the candidates a detector is asked to look at more closely.

A household object stands on something horizontal (the floor, a table's top, a shelf's board) and rises a
little above it. In a depth image that shows as points a few millimetres to a few decimetres above one of
the horizontal levels the image holds, cut off from what is behind them by a jump in depth. Nothing here
reads a simulator's truth: only depth, the pinhole intrinsics and where the camera looked from.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from attribot.control.body import CameraPose
from attribot.control.spatial import point_map
from attribot.frame import CameraInfo

__all__ = ["Candidate", "StandingMap"]

Box = tuple[float, float, float, float]

STRIDE = 2
"""Every second pixel in rows and columns: a 640x480 frame is looked at as 320x240 (a few milliseconds)."""
FLAT_NZ = 0.9
"""A surface is horizontal where its normal's vertical part is at least this (within about 25 degrees)."""
LEVEL_BIN_M = 0.01
LEVEL_MIN_PIXELS = 12
LEVEL_MIN_SPAN_M = 0.45
"""A level is a 1 cm band of heights holding at least this many horizontal pixels of the map, spread over
at least this much of the floor plan (a book lying flat is an object on a level, not a level)."""
RISE_M = (0.006, 0.6)
"""An object's points stand this far above the level under them (a knife lying flat to a backpack)."""
MAX_EXTENT_M = 0.7
"""A candidate spans at most this much across the floor: wider is furniture or a wall."""
MIN_PIXELS = 3
FINER_JUMP = 0.4
SLIVER = 2.5
SPLIT_MIN_SIDE = 3
"""A region too wide for an object is split again where depth jumps by this share of the usual tolerance;
of its parts, those more than `SLIVER` times taller than wide in the image, or under `SPLIT_MIN_SIDE` map
pixels across, are panels' edges."""


@dataclass(frozen=True)
class Candidate:
    """A region of the image where depth sees something stand on a level: its box (pixels, xyxy, y down),
    how high it rises over the level (metres), how many map pixels it holds, and its longest side as depth
    sees it (its rise or its span across the floor, metres; 0 where not measured)."""

    box: Box
    rise: float
    pixels: int
    size: float = 0.0


@dataclass(frozen=True)
class StandingMap:
    """One depth image read for what stands on its levels, once: its point map (every `STRIDE`-th pixel,
    base frame) and each map pixel's height over the level under it (None where the image holds no level).
    `candidates()` and `stands_out(box)` both read it."""

    points: np.ndarray
    rise: np.ndarray | None
    depth: np.ndarray

    @classmethod
    def of(cls, depth: np.ndarray, camera: CameraInfo, view: CameraPose) -> StandingMap:
        points, rise = _rise_map(depth, camera, view)
        return cls(points, rise, depth)

    def candidates(self) -> list[Candidate]:
        """Regions of the image where something stands on a horizontal level (see the module docstring),
        largest first. Empty where the depth shows no level."""
        pts, rise = self.points, self.rise
        if rise is None:
            return []
        valid = np.isfinite(pts[..., 2])
        d = np.where(valid, self.depth[::STRIDE, ::STRIDE].astype(np.float64), np.nan)
        standing = _standing(rise)
        found: list[Candidate] = []
        wide = self._regions(standing & ~_jumps(d), found)
        # a region too wide for an object is most often furniture with an object before it (a bowl 10 cm
        # before a shelf's back panel, 3 m away): split it again where depth jumps less
        split: list[Candidate] = []
        self._regions(wide & standing & ~_jumps(d, FINER_JUMP), split)
        # what the finer split leaves as a sliver or a crumb is the edge of a panel, not an object
        for c in split:
            w, h = c.box[2] - c.box[0], c.box[3] - c.box[1]
            if min(w, h) >= SPLIT_MIN_SIDE * STRIDE and h <= SLIVER * w:
                found.append(c)
        found.sort(key=lambda c: -c.pixels)
        return found

    def _regions(self, mask: np.ndarray, found: list[Candidate]) -> np.ndarray:
        """Adds the connected regions of `mask` an object can be to `found`; the mask of those too wide."""
        pts, rise = self.points, self.rise
        assert rise is not None
        wide = np.zeros(mask.shape, bool)
        count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
        for k in range(1, count):
            x, y, w, h, area = (int(v) for v in stats[k])
            if area < MIN_PIXELS:
                continue
            inside = labels[y : y + h, x : x + w] == k
            xy = pts[y : y + h, x : x + w][inside][:, :2]
            span = float(np.ptp(xy, axis=0).max())
            if span > MAX_EXTENT_M:
                wide[y : y + h, x : x + w] |= inside
                continue
            top = float(rise[y : y + h, x : x + w][inside].max())
            box = (float(x * STRIDE), float(y * STRIDE), float((x + w) * STRIDE), float((y + h) * STRIDE))
            found.append(Candidate(box, top, area, max(span, top)))
        return wide

    def stands_out(self, box: Box) -> bool | None:
        """Whether depth sees something stand on a level inside `box` (pixels, xyxy): a few of its pixels
        rise as an object's do. None where the image shows no level to tell it by."""
        inside = self._inside(box)
        if inside is None:
            return None
        return int(_standing(inside).sum()) >= max(MIN_PIXELS, 0.03 * inside.size)

    def lies_on_level(self, box: Box) -> bool | None:
        """Whether most of `box` is a level itself (no higher than an object's least rise over it): where a
        flat object (a phone, a knife lying down) lies, which does not stand out. None as `stands_out`."""
        inside = self._inside(box)
        if inside is None:
            return None
        with np.errstate(invalid="ignore"):
            flat = np.abs(inside) < RISE_M[0]
        return int(flat.sum()) >= 0.5 * inside.size

    def _inside(self, box: Box) -> np.ndarray | None:
        """The rise map's pixels inside `box`; None where the image holds no level."""
        rise = self.rise
        if rise is None:
            return None
        h, w = rise.shape
        c0, r0 = int(np.clip(box[0] // STRIDE, 0, w - 1)), int(np.clip(box[1] // STRIDE, 0, h - 1))
        c1 = int(np.clip(-(-box[2] // STRIDE), c0 + 1, w))
        r1 = int(np.clip(-(-box[3] // STRIDE), r0 + 1, h))
        return rise[r0:r1, c0:c1]


def _rise_map(
    depth: np.ndarray, camera: CameraInfo, view: CameraPose
) -> tuple[np.ndarray, np.ndarray | None]:
    """The point map and each of its pixels' height over the level under it (NaN where depth is not valid
    or no level is under it); None for the heights where the image holds no level."""
    pts = point_map(depth, camera, view, STRIDE)
    valid = np.isfinite(pts[..., 2])
    levels = _levels(pts[_horizontal(pts) & valid])
    if len(levels) == 0:
        return pts, None
    z = np.where(valid, pts[..., 2], -np.inf)
    under = np.searchsorted(levels, z + LEVEL_BIN_M / 2, side="right") - 1
    rise = np.where(valid & (under >= 0), z - levels[np.clip(under, 0, None)], np.nan)
    return pts, rise


def _standing(rise: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        return (rise >= RISE_M[0]) & (rise <= RISE_M[1])


def _horizontal(pts: np.ndarray) -> np.ndarray:
    """Where the surface through a map pixel is horizontal, from its neighbours' points."""
    flat = np.zeros(pts.shape[:2], bool)
    across = pts[1:-1, 2:] - pts[1:-1, :-2]
    down = pts[2:, 1:-1] - pts[:-2, 1:-1]
    normal = np.cross(across, down)
    length = np.linalg.norm(normal, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        nz = np.abs(normal[..., 2]) / length
    flat[1:-1, 1:-1] = np.nan_to_num(nz, nan=0.0) >= FLAT_NZ
    return flat


def _levels(points: np.ndarray) -> np.ndarray:
    """The heights of the horizontal levels among horizontal surface points (N, 3): 1 cm bands holding
    enough of them over enough of the floor plan, each at the middle of its points' heights, ascending."""
    if len(points) == 0:
        return np.zeros(0)
    bins = np.floor(points[:, 2] / LEVEL_BIN_M).astype(np.int64)
    values, counts = np.unique(bins, return_counts=True)
    out = []
    for value in values[counts >= LEVEL_MIN_PIXELS]:
        band = points[bins == value]
        if float(np.ptp(band[:, :2], axis=0).max()) >= LEVEL_MIN_SPAN_M:
            out.append(float(np.median(band[:, 2])))
    return np.array(sorted(out))


def _jumps(d: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """Where depth jumps between neighbouring map pixels (an object's outline against what is behind it),
    by more than `scale` times the usual tolerance."""
    jump = np.zeros(d.shape, bool)
    tol = (0.04 + 0.03 * np.nan_to_num(d, nan=0.0)) * scale
    dx = np.abs(np.diff(d, axis=1))
    dy = np.abs(np.diff(d, axis=0))
    jx, jy = np.nan_to_num(dx, nan=0.0) > tol[:, 1:], np.nan_to_num(dy, nan=0.0) > tol[1:, :]
    jump[:, 1:] |= jx
    jump[:, :-1] |= jx
    jump[1:, :] |= jy
    jump[:-1, :] |= jy
    return jump
