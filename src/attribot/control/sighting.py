"""Which of a detector's boxes is the target: the one nearest the image centre, or nearest where the
camera's own motion says it must be now; and the target seen again in a new frame (`reacquire`), with what
is known of that frame (`capture_now`). Boxes are xyxy pixels, y down."""

from __future__ import annotations

import math
from collections.abc import Callable

from attribot.control.base import Capture, Target
from attribot.control.world import ServoWorld
from attribot.errors import UnsupportedAction
from attribot.frame import CameraInfo, Frame

__all__ = [
    "Box",
    "off_centre",
    "gap",
    "nearest_to",
    "by_centre",
    "nearest_to_centre",
    "carried",
    "capture_now",
    "reacquire",
]

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


Sightings = Callable[[Frame], list[tuple[Box, str | None]]]
"""A frame's boxes of the target's name, with the world's id of each where the detector gives ids."""


def capture_now(world: ServoWorld, frame: Frame, index: int, camera: CameraInfo | None) -> Capture:
    """What is known of `frame`, taken just now: the head's angles (on a head), the base's odometry pose,
    where the camera was (where the robot states its body) and the arm's pose (a camera may ride on it)."""
    js, pose = world.joint_states(), world.base_pose()
    head = (float(js["head_pan"]), float(js["head_tilt"])) if "head_pan" in js and "head_tilt" in js else None
    arm = (float(js["lift"]), float(js["arm"])) if "lift" in js and "arm" in js else None
    try:
        view = world.body().camera_pose(js)
    except UnsupportedAction:  # a robot that does not state where its camera sits
        view = None
    return Capture(
        index=index,
        camera=camera,
        head=head,
        base=(float(pose.x), float(pose.y), float(pose.yaw)),
        depth=frame.scene_depth,
        view=view,
        arm=arm,
    )


def reacquire(
    world: ServoWorld,
    sightings: Sightings,
    label: str,
    object_id: str | None,
    index: int,
    by_id: bool = True,
) -> Target | None:
    """The target in a new frame (its capture numbered `index`): the box of the world's id `object_id`
    where it is known (and `by_id`), else the box nearest the image centre (where the aim put it), within a
    quarter of the image's smaller side; None where it is not seen, or the robot states no camera."""
    frame = world.observe()
    try:
        camera = frame.camera or world.camera_info()
    except UnsupportedAction:
        return None
    capture = capture_now(world, frame, index, camera)
    seen = sightings(frame)
    if by_id and object_id is not None:
        boxes = [box for box, seen_id in seen if seen_id == object_id]
    else:
        boxes = by_centre([box for box, _ in seen], camera)
    if not boxes:
        return None
    return Target(box=boxes[0], capture=capture, object_id=object_id, label=label)
