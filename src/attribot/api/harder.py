"""Looking harder: when `find` comes back empty or unsure for a named object, the robot looks more closely
at where depth says objects stand, and sets aside what depth says is no object.

A real detector misses objects that are small in the frame (YOLOv3-tiny sees a 25-pixel apple poorly at
its 416-pixel input). Depth does not need to know what an object is to see that something stands on a
table (`control.candidates`): each such region is shown to the detector on its own, in a view a few times
its size, so that the object fills the detector's input ("zooming by cropping"). A detection found this
way counts only where depth sees something stand; and any detection of the find inside whose box depth
sees nothing rise from a level (a box on a wall, on the floor's tiles) is set aside. Only detectors that
read pixels look harder (a zoomed view shows them more); the oracle reads the simulator's segmentation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from attribot.boxes import iou
from attribot.control.base import Capture
from attribot.control.candidates import Candidate, object_candidates, stands_out
from attribot.frame import Frame
from attribot.lexicon import SURFACE_WORDS
from attribot.models.base import Detection, Detector, detect_in_views

__all__ = ["LookHarderReport", "acting_find", "look_harder", "zoom_views"]

UNSURE = 0.25
"""A find whose best detection scores under this looks harder (the coco detector's own `SURE`)."""
ZOOM = 3.5
"""A zoomed view is this many times its candidate's larger side..."""
MIN_VIEW = 112
"""...and at least this many pixels square (a 30-pixel object fills about a quarter of it)."""
MAX_VIEWS = 10
"""The most zoomed views one find looks at (a forward pass each)."""
SMALL_BOX = 1 / 6
"""Only a box under this share of the image is set aside for standing on nothing: a larger one may be
furniture or a wall-sized object, whose own depth is its surface."""


@dataclass
class LookHarderReport:
    """What looking harder did for one find: shown in the trace and the answer's checks."""

    candidates: int  # regions where depth sees something stand
    views: int  # zoomed views looked at
    added: int  # detections found in them
    set_aside: int  # detections where depth sees nothing stand

    def describe(self) -> str:
        text = f"depth sees {self.candidates} things stand"
        if self.views:
            text += f"; zoomed in on {self.views} of them: {self.added} found"
        if self.set_aside:
            text += f"; {self.set_aside} set aside where depth sees nothing stand"
        return text


def zoom_views(candidates: list[Candidate], width: int, height: int) -> list[tuple[int, int, int, int]]:
    """Square views around the candidates, inside the image, the largest candidates first; a view much
    like one already chosen is left out."""
    views: list[tuple[int, int, int, int]] = []
    for cand in candidates:
        x0, y0, x1, y1 = cand.box
        side = int(min(max(ZOOM * max(x1 - x0, y1 - y0), MIN_VIEW), width, height))
        left = int(np.clip((x0 + x1) / 2 - side / 2, 0, width - side))
        top = int(np.clip((y0 + y1) / 2 - side / 2, 0, height - side))
        view = (left, top, left + side, top + side)
        if all(iou(view, v) < 0.5 for v in views):
            views.append(view)
        if len(views) >= MAX_VIEWS:
            break
    return views


def look_harder(
    detector: Detector, frame: Frame, capture: Capture, name: str, detections: list[Detection]
) -> tuple[list[Detection], LookHarderReport] | None:
    """The find's detections after looking harder (see the module docstring), and what it did; None where
    the capture gives no depth and camera pose to look by."""
    if frame.depth is None or capture.camera is None or capture.view is None:
        return None
    depth, camera, view = frame.depth, capture.camera, capture.view
    candidates = object_candidates(depth, camera, view)
    kept = detections
    if name.lower() not in SURFACE_WORDS:
        small = frame.width * frame.height * SMALL_BOX
        kept = [
            d
            for d in detections
            if _area(d.box) >= small or stands_out(depth, camera, view, d.box) is not False
        ]
    report = LookHarderReport(len(candidates), 0, 0, len(detections) - len(kept))
    if any(d.score >= UNSURE for d in kept) or not candidates:
        return kept, report
    views = zoom_views(candidates, frame.width, frame.height)
    zoomed = [d for d in detect_in_views(detector, frame, [name], views) if _on_candidate(d, candidates)]
    merged = list(kept)
    for det in sorted(zoomed, key=lambda d: -d.score):
        if all(iou(det.box, other.box) < 0.5 for other in merged):
            merged.append(det)
    report.views, report.added = len(views), len(merged) - len(kept)
    merged.sort(key=lambda d: -d.score)
    return merged, report


def acting_find(detector: Detector, frame: Frame, name: str) -> list[Detection]:
    """The detections a controller acts on while it servos, reaches and checks: the detector's own `detect`,
    except for a detector that looks at chosen views (`detect_views`: coco), which looks at the whole image
    and, where that leaves the object unsure, at the middle half of it, twice as large (the controller aims
    the camera at what it acts on): two forward passes at most, where tiling the whole image took ten."""
    if getattr(detector, "detect_views", None) is None:
        return detector.detect(frame, [name])
    whole = (0, 0, frame.width, frame.height)
    found = detect_in_views(detector, frame, [name], [whole])
    if any(d.score >= UNSURE for d in found):
        return found
    middle = (frame.width // 4, frame.height // 4, frame.width * 3 // 4, frame.height * 3 // 4)
    return detect_in_views(detector, frame, [name], [whole, middle])


def _on_candidate(det: Detection, candidates: list[Candidate]) -> bool:
    """Whether a detection frames one of the candidates: the candidate's middle inside the box, or the box's
    middle inside the candidate's box."""
    x0, y0, x1, y1 = det.box
    mx, my = (x0 + x1) / 2, (y0 + y1) / 2
    for cand in candidates:
        c0, r0, c1, r1 = cand.box
        cx, cy = (c0 + c1) / 2, (r0 + r1) / 2
        if (x0 <= cx <= x1 and y0 <= cy <= y1) or (c0 <= mx <= c1 and r0 <= my <= r1):
            return True
    return False


def _area(box: tuple[float, float, float, float]) -> float:
    return max(box[2] - box[0], 0.0) * max(box[3] - box[1], 0.0)
