"""Frames for tests: random pixels, one bright box, the box of the bright pixels, and a box grown about its
middle (what holds an object, boxed with it)."""

from __future__ import annotations

import numpy as np

from attribot.frame import Frame

__all__ = ["random_frame", "frame_with_box", "bright_box", "grown_box"]


def random_frame(h: int, w: int, seed: int = 0) -> Frame:
    """A frame of uniform random pixels."""
    return Frame(rgb=np.random.default_rng(seed).integers(0, 256, (h, w, 3), dtype=np.uint8))


def frame_with_box(h: int, w: int, box: tuple[int, int, int, int]) -> Frame:
    """A black frame with one bright rectangle (x0, y0, x1, y1): what `bright_box` finds again."""
    rgb = np.zeros((h, w, 3), np.uint8)
    x0, y0, x1, y1 = box
    rgb[y0:y1, x0:x1] = 200
    return Frame(rgb=rgb)


def bright_box(rgb: np.ndarray) -> tuple[float, float, float, float]:
    """The box of the bright pixels: stand-in detectors answer with it, so a frame that crossed a pipe or
    a wire can be checked against the one that was sent."""
    ys, xs = np.nonzero(rgb.max(axis=2) > 40)
    return float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1)


def grown_box(
    box: tuple[float, ...], times: float, width: int, height: int
) -> tuple[float, float, float, float]:
    """`box` grown `times` about its middle, within a `width` x `height` image: the furniture that holds an
    object, as a detector boxes it with the object (a table under a book, a bookcase round it)."""
    cx, cy = (box[0] + box[2]) / 2, (box[1] + box[3]) / 2
    hw, hh = (box[2] - box[0]) * times / 2, (box[3] - box[1]) * times / 2
    return (max(cx - hw, 0.0), max(cy - hh, 0.0), min(cx + hw, width - 1.0), min(cy + hh, height - 1.0))
