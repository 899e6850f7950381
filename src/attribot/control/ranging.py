"""Locating an object without depth, with a rangefinder that does not look along the camera's axis (the
RoboMaster EP's ToF sensor on its gripper): the camera says in which direction the object is and how tall
and wide it looks, the beam says how far its front is.

The camera is first centred on the object left-right by turning the base, so the object lies straight ahead
on the arm's plane, where the level beam points. The beam's height must fall on the object: it is put at
the middle of the object's height as the image shows it, supposing first that the object stands on the
floor (the only support a RoboMaster EP's gripper reaches). Once the beam has read the distance to the
object's front, its bottom and width come from where the rays through the box's edges cross that front,
and its top from where the top edge's ray crosses the front, or the object's back when the camera looks
down on it: no floor is supposed any more.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from attribot.control.body import BodyGeometry, CameraPose
from attribot.control.sighting import Box
from attribot.control.spatial import ObjectEstimate, ray_through, to_world
from attribot.frame import CameraInfo

__all__ = ["beam_lift", "beam_estimate"]


def beam_lift(box: Box, camera: CameraInfo, view: CameraPose, body: BodyGeometry) -> float | None:
    """The arm's lift that puts the rangefinder's beam at the middle of the object in `box` (seen from
    `view`), supposing it stands on the floor; None when the box's bottom is not below the horizon (it
    cannot stand on the floor)."""
    assert body.arm is not None
    bottom = ray_through(camera, view, (box[0] + box[2]) / 2, box[3])
    if bottom[2] >= -1e-6:
        return None
    front = view.xyz[0] + -view.xyz[2] / bottom[2] * bottom[0]  # where that ray meets the floor
    seen = _silhouette(box, camera, view, front)
    if seen is None:
        return None
    lo, hi = body.lift_range
    return float(np.clip((seen.top - seen.bottom) / 2 - body.arm.rangefinder[1], lo, hi))


class _Silhouette(NamedTuple):
    """An object's extent from its box, its front at a known distance: its bottom and top heights, its
    horizontal radius, and the middle of its front (base frame)."""

    bottom: float
    top: float
    radius: float
    middle: np.ndarray


def _silhouette(box: Box, camera: CameraInfo, view: CameraPose, front: float) -> _Silhouette | None:
    """The object in `box`, its front at x = `front` in the base frame (straight ahead). The box's bottom
    is the front's bottom edge; its top is the front's top edge when the camera looks up at it, the far
    top edge (a radius behind the middle) when the camera looks down on it, as it mostly does."""
    x0, y0, x1, y1 = box
    u, v = (x0 + x1) / 2, (y0 + y1) / 2
    eye = np.asarray(view.xyz)

    def at(ray: np.ndarray, x: float) -> np.ndarray | None:
        if ray[0] <= 1e-6 or x <= eye[0]:
            return None
        return eye + (x - eye[0]) / ray[0] * ray

    middle, bottom = at(ray_through(camera, view, u, v), front), at(ray_through(camera, view, u, y1), front)
    if middle is None or bottom is None:
        return None
    tilt, pan = view.tilt, view.pan
    axis = np.array([np.cos(tilt) * np.cos(pan), np.cos(tilt) * np.sin(pan), np.sin(tilt)])
    depth = float((middle - eye) @ axis)  # along the optical axis, as the box's width scales with
    radius = max(camera.metres_across(box, depth)[0] / 2, 0.01)
    up = ray_through(camera, view, u, y0)
    top = at(up, front + 2 * radius if up[2] < 0 else front)
    if top is None:
        return None
    return _Silhouette(float(bottom[2]), float(top[2]), radius, middle)


def beam_estimate(
    metres: float,
    beam: CameraPose,
    box: Box,
    camera: CameraInfo,
    view: CameraPose,
    base: tuple[float, float, float],
) -> ObjectEstimate | None:
    """The object in `box` (seen from `view`, centred left-right) whose front the level beam at `beam`
    reads `metres` away, in the world frame of the base pose `base`; None when the box's rays do not reach
    that front (it lies behind the camera)."""
    front = beam.xyz[0] + metres
    seen = _silhouette(box, camera, view, front)
    if seen is None:
        return None
    support, top = max(seen.bottom, 0.0), max(seen.top, seen.bottom + 0.01)
    centre = to_world(np.array([front + seen.radius, seen.middle[1], (support + top) / 2]), base)
    return ObjectEstimate(
        centre=(float(centre[0]), float(centre[1]), float(centre[2])),
        support_z=support,
        top_z=top,
        radius=seen.radius,
        points=1,
    )
