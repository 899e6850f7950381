"""Drawing boxes and labels on images: the one place that does it (scene renders, answers, reports)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from attribot.frame import check_rgb

__all__ = ["draw_boxes", "PALETTE"]

PALETTE: tuple[tuple[int, int, int], ...] = (
    (255, 196, 0), (0, 200, 83), (41, 121, 255), (255, 61, 0), (213, 0, 249),
    (0, 229, 255), (255, 234, 0), (118, 255, 3), (255, 145, 0), (240, 98, 146),
)


def draw_boxes(
    rgb: np.ndarray,
    boxes: Sequence[tuple[Sequence[float], str]],
    *,
    width: int = 2,
    colors: Sequence[tuple[int, int, int]] = PALETTE,
) -> Image.Image:
    """A copy of `rgb` with each `(xyxy box, label)` drawn as an outline and a filled label tag."""
    image = Image.fromarray(check_rgb(rgb).copy())
    pen = ImageDraw.Draw(image)
    font = ImageFont.load_default()
    for i, (box, label) in enumerate(boxes):
        color = tuple(colors[i % len(colors)])
        x0, y0, x1, y1 = (float(v) for v in box)
        pen.rectangle((x0, y0, x1, y1), outline=color, width=width)
        if label:
            tx0, ty0, tx1, ty1 = pen.textbbox((0, 0), label, font=font)
            tw, th = tx1 - tx0 + 4, ty1 - ty0 + 4
            ty = y0 - th if y0 - th >= 0 else y0
            pen.rectangle((x0, ty, x0 + tw, ty + th), fill=color)
            luminance = 0.299 * color[0] + 0.587 * color[1] + 0.114 * color[2]
            pen.text((x0 + 2, ty + 2 - ty0), label, fill=(0, 0, 0) if luminance > 128 else (255, 255, 255),
                     font=font)
    return image
