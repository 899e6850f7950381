"""Which of a detector's boxes is the target: the one nearest the image centre, or nearest where the
camera's own motion says it must be now. Boxes are xyxy pixels, y down."""

from __future__ import annotations

import math

from attribot.frame import CameraInfo

__all__ = ["Box", "off_centre", "gap", "nearest_to", "by_centre", "nearest_to_centre", "carried"]

Box = tuple[float, float, float, float]


def off_centre(box: Box, camera: CameraInfo, across_only: bool = False) -> float:
    """Pixels from the box's centre to the image centre (left-right only with `across_only`)."""
    dx = (box[0] + box[2]) / 2 - camera.cx
    return abs(dx) if across_only else math.hypot(dx, (box[1] + box[3]) / 2 - camera.cy)


def gap(a: Box, b: Box) -> float:
    """Distance between two boxes' centres, pixels."""
    return math.hypot((a[0] + a[2] - b[0] - b[2]) / 2, (a[1] + a[3] - b[1] - b[3]) / 2)


def nearest_to(boxes: list[Box], predicted: Box) -> Box | None:
    """The box nearest the predicted one, within the predicted box's own size (farther is another thing:
    a false positive, another object of the kind); None if none."""
    reach = max(predicted[2] - predicted[0], predicted[3] - predicted[1], 8.0)
    near = [b for b in boxes if gap(b, predicted) <= reach]
    return min(near, key=lambda b: gap(b, predicted)) if near else None


def by_centre(boxes: list[Box], camera: CameraInfo, within: float = 0.25) -> list[Box]:
    """The boxes within `within` of the image's smaller side from its centre, nearest first."""
    radius = min(camera.width, camera.height) * within
    return sorted((b for b in boxes if off_centre(b, camera) <= radius), key=lambda b: off_centre(b, camera))


def nearest_to_centre(boxes: list[Box], camera: CameraInfo, within: float = 0.25) -> Box | None:
    """The box whose centre is nearest the image centre, within `within` of the image's smaller side;
    None if none."""
    near = by_centre(boxes, camera, within)
    return near[0] if near else None


def carried(box: Box, camera: CameraInfo, turned: tuple[float, float]) -> Box:
    """The box moved by the camera's own rotation (pan, tilt; left and up positive): where a still object
    is now seen."""
    du, dv = camera.fx * math.tan(turned[0]), camera.fy * math.tan(turned[1])
    return (box[0] + du, box[1] + dv, box[2] + du, box[3] + dv)
