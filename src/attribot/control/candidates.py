"""Where objects may stand, from depth (and what lies flat, from colour): the candidates a detector is asked
to look at more closely.

A household object stands on something horizontal (the floor, a table's top, a shelf's board) and rises a
little above it. In a depth image that shows as points a few millimetres to a few decimetres above one of
the horizontal levels the image holds, cut off from what is behind them by a jump in depth. A fork or a
knife lying on a table rises too little for depth: given the image's colours, a region of a level whose
colour stands out from that level's own around it is one too. Nothing here reads a simulator's truth: only
depth, colour, the pinhole intrinsics and where the camera looked from.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from attribot.boxes import enclosing, overlap_of_smaller
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
"""A level is a piece of a 1 cm band of heights holding at least this many horizontal pixels of the map,
spread over at least this much of the floor plan (a book lying flat is an object on a level, not a level)."""
LEVEL_CELL_M = 0.05
PLAN_MAX_CELLS = 400
LEVEL_MARGIN_CELLS = 3
"""Levels are told apart on a floor plan of cells this wide (at most this many along a side), a piece of
a band being the points in touching cells; a level covers its points' hull and this many cells around it
(15 cm: an object standing at a table's edge hides the top under it)."""
RISE_M = (0.006, 0.6)
"""An object's points stand this far above the level under them (a knife lying flat to a backpack)."""
MAX_EXTENT_M = 0.7
"""A candidate spans at most this much across the floor: wider is furniture or a wall."""
MIN_PIXELS = 3
LYING_WINDOW = 11
LYING_CONTRAST = 45.0
LYING_LEVEL_SHARE = 0.6
"""A pixel of a level lies out of it where its colour is this far (RGB, 0-255 each) from the mean colour of
the level's pixels in the window of map pixels around it, where the window holds at least this share of
the level (a grey fork on a dark table: about 90; a table's grain and light: under 30)."""
LYING_MIN_PIXELS = 4
LYING_MAX_M = 0.4
SHADOW_PX = 6
LOW_RISE_M = 0.03
"""What lies flat is at least this many map pixels and at most this long (a rug or a board is longer), and
no nearer than this many pixels to something standing (its shadow, its foot), unless that rises under
`LOW_RISE_M` (then it is that thing's flat part)."""
BOARD_M = 0.04
"""A shelf's or a table's board is at most this thick: what rises to this under a level over it holds it
up."""
FINER_JUMP = 0.4
SLIVER = 2.5
SPLIT_MIN_SIDE = 3
"""A region too wide for an object is split again where depth jumps by this share of the usual tolerance;
of its parts, those more than `SLIVER` times taller than wide in the image, or under `SPLIT_MIN_SIDE` map
pixels across, are panels' edges."""


@dataclass(frozen=True)
class Candidate:
    """A region of the image where depth sees something stand on a level: its box (pixels, xyxy, y down),
    how high it rises over the level (metres), how many map pixels it holds, its longest side as depth
    sees it (its rise or its span across the floor, metres; 0 where not measured), that span across the
    floor, the height of its lowest point over the floor (metres; None where not measured), and whether its
    top meets a level over it (`capped`: it holds that level up, as a bookcase's side between two boards
    does)."""

    box: Box
    rise: float
    pixels: int
    size: float = 0.0
    across: float = 0.0
    bottom: float | None = None
    capped: bool = False


@dataclass(frozen=True)
class StandingMap:
    """One depth image read for what stands on its levels, once: its point map (every `STRIDE`-th pixel,
    base frame), each map pixel's height over the level under it (None where the image holds no level), and
    the levels themselves on their floor plan. `candidates()` and `stands_out(box)` both read it."""

    points: np.ndarray
    rise: np.ndarray | None
    depth: np.ndarray
    rgb: np.ndarray | None = None
    levels: tuple[tuple[float, np.ndarray], ...] = ()
    plan: _Plan | None = None

    @classmethod
    def of(
        cls, depth: np.ndarray, camera: CameraInfo, view: CameraPose, rgb: np.ndarray | None = None
    ) -> StandingMap:
        """The map of one depth image; given the image's `rgb` too, its candidates hold what lies flat."""
        points, rise, levels, plan = _rise_map(depth, camera, view)
        return cls(points, rise, depth, None if rgb is None else rgb[::STRIDE, ::STRIDE], tuple(levels), plan)

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
        lying = self._lying(found)
        found = sorted((c for c in found if c.pixels), key=lambda c: -c.pixels)
        return found + lying

    def _lying(self, standing: list[Candidate]) -> list[Candidate]:
        """What lies flat on a level (a fork, a knife: too thin to rise out of it in depth), seen by its
        colour (`_odd_on_levels`), in regions no longer than an object. A region beside something low that
        stands is that thing's flat part (a knife's blade beside its raised handle): the two are one
        candidate; beside anything else, it is a shadow or a foot, and left out, as it is beside what stands
        and is no candidate (a bookcase's foot on the floor: furniture is too wide). `standing` (those
        candidates) is updated in place; the regions on their own are returned, largest first."""
        odd = self._odd_on_levels()
        if odd is None:
            return []
        count, labels, stats, _ = cv2.connectedComponentsWithStats(odd, connectivity=8)
        found: list[Candidate] = []
        for k in range(1, count):
            x, y, w, h, area = (int(v) for v in stats[k])
            box = (float(x * STRIDE), float(y * STRIDE), float((x + w) * STRIDE), float((y + h) * STRIDE))
            near = [
                i
                for i, c in enumerate(standing)
                if c.pixels and overlap_of_smaller(box, _grown(c.box, SHADOW_PX)) > 0
            ]
            xyz = self.points[y : y + h, x : x + w][labels[y : y + h, x : x + w] == k]
            xyz = xyz[np.isfinite(xyz).all(axis=1)]
            if area < LYING_MIN_PIXELS or len(xyz) == 0:
                continue
            if near:
                if all(standing[i].rise < LOW_RISE_M for i in near):
                    parts = [xyz, *(self._points_in(standing[i].box) for i in near[1:])]
                    boxes = [box, *(standing[i].box for i in near[1:])]
                    standing[near[0]] = self._joined(standing[near[0]], boxes, np.concatenate(parts))
                    for i in near[1:]:
                        standing[i] = replace(standing[i], pixels=0)  # joined: dropped below
                continue
            if self._next_to_standing(box):
                continue  # the foot or shadow of what stands and is no candidate: furniture
            span = float(np.ptp(xyz[:, :2], axis=0).max())
            if 0.0 < span <= LYING_MAX_M:
                found.append(Candidate(box, 0.0, area, span, span, float(np.percentile(xyz[:, 2], 5))))
        found.sort(key=lambda c: -c.pixels)
        return found

    def _next_to_standing(self, box: Box) -> bool:
        """Whether a few map pixels within `SHADOW_PX` of `box` stand higher than something flat's raised
        part (`LOW_RISE_M`)."""
        around = self._inside(_grown(box, SHADOW_PX))
        if around is None:
            return False
        with np.errstate(invalid="ignore"):
            return int((_standing(around) & (around >= LOW_RISE_M)).sum()) >= MIN_PIXELS

    def _odd_on_levels(self) -> np.ndarray | None:
        """Map pixels of a level whose colour stands out from the level's own around them (uint8 mask), or
        None without the image's colours or a level."""
        if self.rgb is None or self.rise is None:
            return None
        rise, rgb = self.rise, self.rgb.astype(np.float32)
        with np.errstate(invalid="ignore"):
            on = np.isfinite(rise) & (np.abs(rise) < RISE_M[0])
            level = np.where(on, np.round((self.points[..., 2] - rise) / LEVEL_BIN_M), np.nan)
        odd = np.zeros(on.shape, bool)
        window = (LYING_WINDOW, LYING_WINDOW)
        for value in np.unique(level[on]):
            mine = on & (level == value)
            if int(mine.sum()) < LYING_WINDOW**2:
                continue
            weight = cv2.blur(mine.astype(np.float32), window)
            around = cv2.blur(rgb * mine[..., None], window) / np.maximum(weight, 1e-6)[..., None]
            contrast = np.linalg.norm(rgb - around, axis=-1)
            # within a level, away from its edges (where the window holds little of it)
            odd |= mine & (weight >= LYING_LEVEL_SHARE) & (contrast > LYING_CONTRAST)
        return cv2.morphologyEx(odd.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8))

    def _points_in(self, box: Box) -> np.ndarray:
        """The points (N, 3) that stand on a level inside `box`."""
        assert self.rise is not None
        c0, r0, c1, r1 = (int(v) // STRIDE for v in box)
        inside = self.points[r0:r1, c0:c1][_standing(self.rise[r0:r1, c0:c1])]
        return inside[np.isfinite(inside).all(axis=1)]

    def _joined(self, cand: Candidate, boxes: list[Box], xyz: np.ndarray) -> Candidate:
        """`cand` with the regions of `boxes` and their points `xyz` (N, 3) joined to it."""
        both = np.concatenate([self._points_in(cand.box), xyz])
        span = float(np.ptp(both[:, :2], axis=0).max())
        union = enclosing([cand.box, *boxes])
        return Candidate(union, cand.rise, cand.pixels + len(xyz), max(span, cand.rise), span, cand.bottom)

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
            xyz = pts[y : y + h, x : x + w][inside]
            bottom = float(np.percentile(xyz[:, 2], 5))
            box = (float(x * STRIDE), float(y * STRIDE), float((x + w) * STRIDE), float((y + h) * STRIDE))
            found.append(Candidate(box, top, area, max(span, top), span, bottom, self._capped(xyz)))
        return wide

    def _capped(self, xyz: np.ndarray) -> bool:
        """Whether the top of the points `xyz` (N, 3) meets the lowest level over them, under a board's
        thickness below it: what holds a board up (a bookcase's side between two of its boards), not a thing
        standing under it with room above."""
        if self.plan is None or len(xyz) == 0:
            return False
        top = float(np.percentile(xyz[:, 2], 98))
        cells = self.plan.cells_of(xyz)
        over = [height for height, place in self.levels if height > top and place[cells].mean() >= 0.5]
        return bool(over) and min(over) - top <= BOARD_M

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
) -> tuple[np.ndarray, np.ndarray | None, list[tuple[float, np.ndarray]], _Plan]:
    """The point map and each of its pixels' height over the level under it (NaN where depth is not valid
    or no level is under it; None for the heights where the image holds no level), the levels (`_levels`)
    and their floor plan. The level under a point is the highest one below it whose place on the floor plan
    holds the point; where none within an object's height does (a level hidden by what stands on it), the
    highest level below it anywhere."""
    pts = point_map(depth, camera, view, STRIDE)
    valid = np.isfinite(pts[..., 2])
    plan = _Plan.of(pts[valid])
    levels = _levels(pts[_horizontal(pts) & valid], plan)
    if not levels:
        return pts, None, levels, plan
    z = np.where(valid, pts[..., 2], -np.inf)
    cells = plan.cells_of(np.where(valid[..., None], pts, 0.0))
    under = np.full(z.shape, np.nan)
    for height, place in levels:  # ascending: a higher level under the point replaces a lower one
        under = np.where((z + LEVEL_BIN_M / 2 >= height) & place[cells], height, under)
    heights = np.array([h for h, _ in levels])  # ascending, as `_levels` gives them
    anywhere = np.searchsorted(heights, z + LEVEL_BIN_M / 2, side="right") - 1
    nearest = np.where(anywhere >= 0, heights[np.clip(anywhere, 0, None)], np.nan)
    with np.errstate(invalid="ignore"):
        under = np.where(np.isnan(under) | (z - under > RISE_M[1]), nearest, under)
    rise = np.where(valid, z - under, np.nan)
    return pts, rise, levels, plan


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


@dataclass(frozen=True)
class _Plan:
    """A grid of cells over the floor plan of an image's points (x, y in the base frame), `LEVEL_CELL_M`
    wide (wider where the points span too far for `PLAN_MAX_CELLS` of them)."""

    origin: tuple[float, float]
    cell: float
    shape: tuple[int, int]

    @classmethod
    def of(cls, points: np.ndarray) -> _Plan:
        if len(points) == 0:
            return cls((0.0, 0.0), LEVEL_CELL_M, (1, 1))
        low, high = points[:, :2].min(axis=0), points[:, :2].max(axis=0)
        cell = max(LEVEL_CELL_M, float((high - low).max()) / PLAN_MAX_CELLS)
        rows, cols = (int((high - low)[k] // cell) + 1 for k in (1, 0))
        return cls((float(low[0]), float(low[1])), cell, (rows, cols))

    def cells_of(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The (row, column) cell of each point (..., 3), clipped to the grid."""
        col = np.clip(((points[..., 0] - self.origin[0]) // self.cell).astype(np.int64), 0, self.shape[1] - 1)
        row = np.clip(((points[..., 1] - self.origin[1]) // self.cell).astype(np.int64), 0, self.shape[0] - 1)
        return row, col


def _levels(points: np.ndarray, plan: _Plan) -> list[tuple[float, np.ndarray]]:
    """The horizontal levels among horizontal surface points (N, 3), ascending: in each 1 cm band of
    heights, each piece whose points touch on the floor plan, holding enough of them over enough of it
    (a book lying flat is not a level, even where a shelf elsewhere stands at the height of its top). A
    level is its height (the middle of its points') and the cells of the plan it covers: its points' hull,
    grown by `LEVEL_MARGIN_CELLS` (an object at its edge hides what is under it)."""
    if len(points) == 0:
        return []
    bins = np.floor(points[:, 2] / LEVEL_BIN_M).astype(np.int64)
    values, counts = np.unique(bins, return_counts=True)
    near = np.ones((3, 3), np.uint8)
    margin = np.ones((2 * LEVEL_MARGIN_CELLS + 1,) * 2, np.uint8)
    out = []
    for value in values[counts >= LEVEL_MIN_PIXELS]:
        band = points[bins == value]
        row, col = plan.cells_of(band)
        occupied = np.zeros(plan.shape, np.uint8)
        occupied[row, col] = 1
        count, labels = cv2.connectedComponents(cv2.dilate(occupied, near), connectivity=8)
        piece_of = labels[row, col]
        for k in range(1, count):
            piece = band[piece_of == k]
            if len(piece) < LEVEL_MIN_PIXELS or float(np.ptp(piece[:, :2], axis=0).max()) < LEVEL_MIN_SPAN_M:
                continue
            hull = cv2.convexHull(cv2.findNonZero(((labels == k) & (occupied > 0)).astype(np.uint8)))
            place = np.zeros(plan.shape, np.uint8)
            cv2.fillConvexPoly(place, hull, 1)
            out.append((float(np.median(piece[:, 2])), cv2.dilate(place, margin).astype(bool)))
    return sorted(out, key=lambda level: level[0])


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


def _grown(box: Box, by: float) -> Box:
    return (box[0] - by, box[1] - by, box[2] + by, box[3] + by)
