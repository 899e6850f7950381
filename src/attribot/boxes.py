"""Box maths, and the one place where box conventions are converted.

Inside the project a box is `(x0, y0, x1, y1)` in pixels, origin top-left, y down (OpenCV/PIL).
`ImagePatch` speaks the paper's convention, `left, lower, right, upper` with y growing upward; the
conversions between the two live here and nowhere else.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = [
    "Box",
    "as_boxes",
    "area",
    "intersection",
    "iou",
    "iou_matrix",
    "overlap_of_smaller",
    "nms",
    "clip",
    "center",
    "enclosing",
    "crop_array",
    "to_upward",
    "from_upward",
]

Box = tuple[float, float, float, float]


def as_boxes(boxes: Sequence[Sequence[float]] | np.ndarray) -> np.ndarray:
    """An (N, 4) float array of xyxy boxes; raises ValueError on a wrong shape or x1 < x0."""
    arr = np.asarray(boxes, dtype=np.float64).reshape(-1, 4) if len(boxes) else np.zeros((0, 4))
    if np.any(arr[:, 2] < arr[:, 0]) or np.any(arr[:, 3] < arr[:, 1]):
        raise ValueError("boxes must be (x0, y0, x1, y1) with x1 >= x0 and y1 >= y0")
    return arr


def area(boxes: np.ndarray) -> np.ndarray:
    """Areas of xyxy boxes, in square pixels."""
    b = as_boxes(boxes)
    return (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])


def iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pairwise intersection over union, shape (len(a), len(b)); 0 where both boxes are empty."""
    a, b = as_boxes(a), as_boxes(b)
    x0 = np.maximum(a[:, None, 0], b[None, :, 0])
    y0 = np.maximum(a[:, None, 1], b[None, :, 1])
    x1 = np.minimum(a[:, None, 2], b[None, :, 2])
    y1 = np.minimum(a[:, None, 3], b[None, :, 3])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    union = area(a)[:, None] + area(b)[None, :] - inter
    return np.divide(inter, union, out=np.zeros_like(inter), where=union > 0)


def iou(a: Sequence[float], b: Sequence[float]) -> float:
    """Intersection over union of two xyxy boxes.

    >>> iou((0, 0, 2, 2), (1, 0, 3, 2))
    0.3333333333333333
    """
    return float(iou_matrix(np.asarray([a]), np.asarray([b]))[0, 0])


def overlap_of_smaller(a: Sequence[float], b: Sequence[float]) -> float:
    """The share of the smaller of two xyxy boxes that the other covers (1.0: one holds the other).

    >>> overlap_of_smaller((0, 0, 4, 4), (1, 1, 2, 3))
    1.0
    """
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    smaller = min((a[2] - a[0]) * (a[3] - a[1]), (b[2] - b[0]) * (b[3] - b[1]))
    return float(max(w, 0.0) * max(h, 0.0) / smaller) if smaller > 0 else 0.0


def nms(
    boxes: np.ndarray, scores: np.ndarray, iou_threshold: float = 0.5, max_keep: int | None = None
) -> np.ndarray:
    """Indices of the boxes kept by greedy non-maximum suppression, highest score first.

    `max_keep` stops after that many boxes: the same first boxes as a full run (a kept box depends only
    on better ones), at a fraction of the cost when thousands of boxes pass a low score threshold.
    """
    b = as_boxes(boxes)
    areas = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])  # once, not per step: this loop is hot
    order = np.argsort(-np.asarray(scores, dtype=np.float64), kind="stable")
    keep: list[int] = []
    while order.size and (max_keep is None or len(keep) < max_keep):
        i = int(order[0])
        keep.append(i)
        rest = order[1:]
        if not rest.size:
            break
        w = np.clip(np.minimum(b[i, 2], b[rest, 2]) - np.maximum(b[i, 0], b[rest, 0]), 0, None)
        h = np.clip(np.minimum(b[i, 3], b[rest, 3]) - np.maximum(b[i, 1], b[rest, 1]), 0, None)
        inter = w * h
        union = areas[i] + areas[rest] - inter
        overlaps = np.divide(inter, union, out=np.zeros_like(inter), where=union > 0)
        order = rest[overlaps <= iou_threshold]
    return np.asarray(keep, dtype=np.int64)


def clip(boxes: np.ndarray, width: int, height: int) -> np.ndarray:
    """Boxes clipped to the image `[0, width] x [0, height]`."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4).copy()
    b[:, [0, 2]] = np.clip(b[:, [0, 2]], 0, width)
    b[:, [1, 3]] = np.clip(b[:, [1, 3]], 0, height)
    return b


def center(box: Sequence[float]) -> tuple[float, float]:
    """Centre `(x, y)` of an xyxy box, in pixels, y down."""
    x0, y0, x1, y1 = box
    return (x0 + x1) / 2.0, (y0 + y1) / 2.0


EDGE_PX = 2
"""A box within this many pixels of the image's edge is cut by it: the object may go on past it."""


def at_edge(box: Sequence[float], width: int, height: int) -> bool:
    """Whether an xyxy box reaches the edge of a `width` x `height` image (within `EDGE_PX`)."""
    x0, y0, x1, y1 = box
    return x0 <= EDGE_PX or y0 <= EDGE_PX or x1 >= width - EDGE_PX or y1 >= height - EDGE_PX


def enclosing(boxes: Sequence[Sequence[float]]) -> Box:
    """The smallest xyxy box holding all of `boxes` (at least one)."""
    return (
        float(min(b[0] for b in boxes)),
        float(min(b[1] for b in boxes)),
        float(max(b[2] for b in boxes)),
        float(max(b[3] for b in boxes)),
    )


def intersection(a: Sequence[float], b: Sequence[float]) -> Box:
    """The xyxy box two boxes share (empty, its far corner not past its near one, where they do not
    overlap)."""
    return (float(max(a[0], b[0])), float(max(a[1], b[1])), float(min(a[2], b[2])), float(min(a[3], b[3])))


def crop_array(array: np.ndarray, box: Sequence[float]) -> np.ndarray:
    """The pixels of `array` (H, W, ...) inside the xyxy box, rounded outward and clipped; never empty."""
    h, w = array.shape[:2]
    x0, y0, x1, y1 = box
    ix0 = int(np.clip(np.floor(x0), 0, max(w - 1, 0)))
    iy0 = int(np.clip(np.floor(y0), 0, max(h - 1, 0)))
    ix1 = int(np.clip(np.ceil(x1), ix0 + 1, w))
    iy1 = int(np.clip(np.ceil(y1), iy0 + 1, h))
    return array[iy0:iy1, ix0:ix1]


def to_upward(box: Sequence[float], image_height: int) -> tuple[float, float, float, float]:
    """xyxy (y down) to `(left, lower, right, upper)` with y growing upward, as ImagePatch has it.

    >>> to_upward((10, 0, 20, 5), image_height=100)
    (10.0, 95.0, 20.0, 100.0)
    """
    x0, y0, x1, y1 = (float(v) for v in box)
    return x0, image_height - y1, x1, image_height - y0


def from_upward(left: float, lower: float, right: float, upper: float, image_height: int) -> Box:
    """`(left, lower, right, upper)` with y upward back to xyxy pixels with y down.

    >>> from_upward(10, 95, 20, 100, image_height=100)
    (10.0, 0.0, 20.0, 5.0)
    """
    return float(left), float(image_height - upper), float(right), float(image_height - lower)
