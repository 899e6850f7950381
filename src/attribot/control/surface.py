"""The top of a large receptacle (a table, a counter, a shelf) from depth: how high it is, how far it
reaches, and where on it an object can be put down clear of what already stands there and inside its
edges.

A horizontal surface seen by a depth camera is a layer of points at one height. The top of a piece of
furniture is the highest such layer that is large: objects standing on it (a book lying flat, a mug's rim)
make small layers above it, and a shelf's lower boards larger ones below it (so a top crowded with things
of one height, whose tops together look as large as the top itself, is taken for the top). A spot is free
where the camera saw the top all around it, at the object's radius and a clearance: what stands on the top
and what it hides from the camera (the top behind an object, beyond the edges) are not free. Everything is
in the world frame of the base's odometry, from points a robot's own depth camera gave; nothing here reads
a simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["TopSurface", "find_top"]

_LAYER_M = 0.012  # half the thickness of the layer of points that counts as one horizontal surface
_MIN_AREA_M2 = 0.06  # the least area of a top (a 25 cm square): what stands on it makes less
_SHARE_OF_LARGEST = 0.4  # a layer this share of the largest one's area is as much a top as the largest


@dataclass(frozen=True)
class TopSurface:
    """A receptacle's top as depth saw it: its height `z`, and a grid of `cell`-metre cells from world
    `origin` (x, y of cell (0, 0)'s corner) where `seen` marks the top's cells and `blocked` those where
    something stands on it."""

    z: float
    origin: tuple[float, float]
    cell: float
    seen: np.ndarray
    blocked: np.ndarray

    @property
    def area(self) -> float:
        """Square metres of the top the camera saw."""
        return float(self.seen.sum()) * self.cell**2

    def centre_of(self, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """World (x, y) of the centres of cells (i, j): (N, 2)."""
        return np.asarray(self.origin) + (np.column_stack([i, j]) + 0.5) * self.cell

    def on_top(self, xy: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """For each world point of `xy` (N, 2): whether it lies on the seen top, or within `margin` metres
        of its cells."""
        reach = int(math.ceil(margin / self.cell))
        square = np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)
        grown = cv2.dilate(self.seen.astype(np.uint8), square).astype(bool)
        points = np.atleast_2d(np.asarray(xy, float))
        ij = np.floor((points - np.asarray(self.origin)) / self.cell).astype(int)
        n, m = grown.shape
        inside = (ij[:, 0] >= 0) & (ij[:, 0] < n) & (ij[:, 1] >= 0) & (ij[:, 1] < m)
        out = np.zeros(len(ij), bool)
        out[inside] = grown[ij[inside, 0], ij[inside, 1]]
        return out

    def blocked_near(self, xy: np.ndarray, radius: float) -> bool:
        """Whether something stands on the top within `radius` of world point `xy`."""
        i, j = np.nonzero(self.blocked)
        if len(i) == 0:
            return False
        return bool((np.linalg.norm(self.centre_of(i, j) - np.asarray(xy), axis=1) <= radius).any())

    def free_spots(self, radius: float) -> np.ndarray:
        """World (x, y) of the cells where a disc of `radius` lies on the seen top and clear of what stands
        on it: (N, 2), in no particular order."""
        free = (self.seen & ~self.blocked).astype(np.uint8)
        r = int(math.ceil(radius / self.cell))
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
        inner = cv2.erode(free, disc, borderType=cv2.BORDER_CONSTANT, borderValue=0)
        i, j = np.nonzero(inner)
        return self.centre_of(i, j)


def find_top(
    points: np.ndarray,
    near: tuple[np.ndarray, float] | None = None,
    above: float = 0.004,
    up_to: float = 1.0,
    cell: float = 0.03,
    min_area: float = _MIN_AREA_M2,
) -> TopSurface | None:
    """The top surface among world `points` (N, 3) of a receptacle (and what stands on it): the highest
    large horizontal layer, or, with `near` ((x, y), z), the layer nearest height z within 4 cm and its
    part nearest (x, y) (to see the same top again from elsewhere). Points more than `above` metres over
    the top stand on it (a knife lies 1.5 cm high, a fork 6 mm: what depth cannot tell from the top, it
    takes for the top); it must exceed the depth's noise. What stands on the top is looked for up to
    `up_to` metres over it (below what the robot itself holds over it). None when no layer is large
    enough."""
    pts = np.asarray(points, float)
    pts = pts[np.isfinite(pts).all(axis=1) & (pts[:, 2] > 0.05)]
    if len(pts) < 20:
        return None
    lo = pts[:, :2].min(axis=0) - 2 * cell
    shape = tuple(np.floor((pts[:, :2].max(axis=0) + 2 * cell - lo) / cell).astype(int) + 1)
    ij = np.floor((pts[:, :2] - lo) / cell).astype(int)
    levels = _levels(pts[:, 2], near)
    layers = []
    for z in levels:
        mask = _layer(ij[np.abs(pts[:, 2] - z) <= _LAYER_M], shape)
        part = _part(mask, None if near is None else ((np.asarray(near[0]) - lo) / cell).astype(int))
        if part is not None:
            layers.append((z, part))
    if not layers:
        return None
    largest = max(float(p.sum()) for _, p in layers) * cell**2
    need = max(min_area, _SHARE_OF_LARGEST * largest if near is None else 0.0)
    for z, part in sorted(layers, key=lambda zp: -zp[0] if near is None else abs(zp[0] - near[1])):
        if float(part.sum()) * cell**2 < need:
            continue
        # the top's height: the points of its cells in the layer, refined to their median
        on = part[ij[:, 0], ij[:, 1]] & (np.abs(pts[:, 2] - z) <= _LAYER_M)
        height = float(np.median(pts[on, 2]))
        over = ij[(pts[:, 2] > height + above) & (pts[:, 2] < height + up_to)]
        blocked = np.zeros(shape, bool)
        blocked[over[:, 0], over[:, 1]] = True
        # a cell next to something standing there is not free either: the points of its sides fall in
        # their own cells, but its footprint may reach a little beyond them
        blocked = cv2.dilate(blocked.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
        return TopSurface(height, (float(lo[0]), float(lo[1])), cell, part, blocked)
    return None


def _levels(zs: np.ndarray, near: tuple[np.ndarray, float] | None) -> list[float]:
    """Heights (1 cm apart) at which enough points lie to make a horizontal layer: peaks of the heights'
    histogram; with `near`, those within 4 cm of its height."""
    lo, hi = float(zs.min()), float(zs.max())
    if near is not None:
        lo, hi = max(lo, near[1] - 0.04), min(hi, near[1] + 0.04)
        if hi < lo:
            return []
    edges = np.arange(lo - 0.005, hi + 0.015, 0.01)
    counts, _ = np.histogram(zs, edges)
    centres = (edges[:-1] + edges[1:]) / 2
    padded = np.concatenate([[0], counts, [0]])
    peak = (counts >= padded[:-2]) & (counts >= padded[2:]) & (counts >= 10)
    return [float(z) for z in centres[peak]]


def _layer(ij: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """The cells of a layer's points, with gaps of a cell closed (depth samples a far, slanted top
    sparsely) and strips two cells wide opened away (a vertical face crosses every layer as a line)."""
    cells = np.zeros(shape, np.uint8)
    cells[ij[:, 0], ij[:, 1]] = 1
    square = np.ones((3, 3), np.uint8)
    closed = cv2.morphologyEx(cells, cv2.MORPH_CLOSE, square)
    return np.asarray(cv2.morphologyEx(closed, cv2.MORPH_OPEN, square), bool)


def _part(mask: np.ndarray, near: np.ndarray | None) -> np.ndarray | None:
    """The largest connected part of a layer, or the one nearest cell `near`; None for an empty layer."""
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if n <= 1:
        return None
    if near is None:
        best = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    else:
        i, j = np.nonzero(labels)
        k = int(np.argmin((i - near[0]) ** 2 + (j - near[1]) ** 2))
        best = int(labels[i[k], j[k]])
    return labels == best
