"""Drawing boxes and labels on images: the one place that does it (scene renders, saved answers, figures)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from attribot.frame import check_rgb

__all__ = ["draw_boxes"]

_PALETTE = [
    (230, 25, 75),
    (60, 180, 75),
    (0, 130, 200),
    (245, 130, 48),
    (145, 30, 180),
    (70, 240, 240),
    (240, 50, 230),
    (210, 245, 60),
    (0, 128, 128),
    (170, 110, 40),
]


def draw_boxes(rgb: np.ndarray, items: Sequence[tuple[Sequence[float], str]]) -> np.ndarray:
    """A copy of `rgb` with each xyxy box (pixels, origin top-left) outlined and labelled."""
    import cv2

    img = np.ascontiguousarray(check_rgb(rgb).copy())
    scale = max(img.shape[0] / 480.0, 0.35) * 0.45
    thick = max(1, round(img.shape[0] / 320))
    for i, (box, label) in enumerate(items):
        color = _PALETTE[i % len(_PALETTE)]
        x0, y0, x1, y1 = (int(round(v)) for v in box)
        cv2.rectangle(img, (x0, y0), (x1 - 1, y1 - 1), color, thick)
        (tw, th), base = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
        ty = y0 - 3 if y0 - th - base - 3 >= 0 else min(y1 + th + 3, img.shape[0] - base)
        cv2.rectangle(img, (x0, ty - th - 2), (x0 + tw + 2, ty + base - 1), color, -1)
        cv2.putText(
            img, label, (x0 + 1, ty - 1), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 1, cv2.LINE_AA
        )
    return img
