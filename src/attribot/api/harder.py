"""Looking harder: when `find` comes back empty or unsure for a named object, the robot looks more closely
at where depth says objects stand, and sets aside what depth says is no object.

A real detector misses objects that are small in the frame (YOLOv3-tiny sees a 25-pixel apple poorly at
its 608-pixel input). Depth does not need to know what an object is to see that something stands on a
table (`control.candidates`): each such region is shown to the detector on its own, in a view a few times
its size, so that the object fills the detector's input ("zooming by cropping"). A detection found this
way counts only where depth sees something stand; and any detection of the find inside whose box depth
sees nothing rise from a level (a box on a wall, on the floor's tiles) is set aside. Where zooming finds
nothing and the robot can drive, it drives nearer to a few of the places in turn (`visit_order`), looks
there, carries what it sees back into the first image (`carried_back`) and drives back (the Robot's
`_nearer`). Only detectors that read pixels look harder (a zoomed view shows them more); the oracle reads
the simulator's segmentation.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from attribot.boxes import iou, overlap_of_smaller
from attribot.control.base import Capture
from attribot.control.candidates import Candidate, StandingMap
from attribot.control.spatial import nearest_surface, projected_box, to_base, to_world
from attribot.frame import Frame
from attribot.lexicon import SURFACE_WORDS
from attribot.models.base import Detection, Detector, detect_in_views
from attribot.sim.catalog import find_category

__all__ = [
    "LookHarderReport",
    "Nearer",
    "acting_find",
    "carried_back",
    "look_harder",
    "visit_order",
    "zoom_views",
]

Nearer = Callable[[str, list[Candidate]], tuple[list[Detection], int]]
"""Drives nearer to candidates in turn and looks for a name there: (detections in the first image, visits)."""

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
    visits: int = 0  # places the robot drove nearer to
    found_nearer: int = 0  # detections seen from nearer

    def describe(self) -> str:
        text = f"depth sees {self.candidates} things stand"
        if self.views:
            text += f"; zoomed in on {self.views} of them: {self.added} found"
        if self.visits:
            text += f"; drove nearer to {self.visits} of them: {self.found_nearer} found"
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
    detector: Detector,
    frame: Frame,
    capture: Capture,
    name: str,
    detections: list[Detection],
    nearer: Nearer | None = None,
) -> tuple[list[Detection], LookHarderReport] | None:
    """The find's detections after looking harder (see the module docstring), and what it did; None where
    the capture gives no depth and camera pose to look by. `nearer`, where the robot can drive, is asked
    to look from nearer at the candidates in `visit_order` when zooming found nothing sure."""
    if frame.depth is None or capture.camera is None or capture.view is None:
        return None
    standing = StandingMap.of(frame.depth, capture.camera, capture.view)
    candidates = standing.candidates()
    kept = detections
    if name.lower() not in SURFACE_WORDS:
        small = frame.width * frame.height * SMALL_BOX
        kept = [d for d in detections if _area(d.box) >= small or standing.stands_out(d.box) is not False]
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
    if nearer is not None and not merged:  # only where nothing of the name is seen at all
        others = [d for d in detect_in_views(detector, frame, ["object"], views) if d.label != name]
        category = find_category(name)
        sizes = None if category is None else category.size_range_m
        seen, report.visits = nearer(name, visit_order(candidates, others, sizes))
        # boxes of one object seen from two places land on each other: one object
        kept_seen: list[Detection] = []
        for det in seen:
            if all(overlap_of_smaller(det.box, o.box) < 0.5 for o in kept_seen):
                kept_seen.append(det)
        seen = kept_seen
        report.found_nearer = len(seen)
        merged += seen
    merged.sort(key=lambda d: -d.score)
    return merged, report


LEG_RISE_M, LEG_ASPECT = 0.35, 2.5
"""A candidate this tall over its level and this many times taller than wide (in the image) is a leg of the
furniture it stands under, not an object: not worth a drive."""


def visit_order(
    candidates: list[Candidate], others: list[Detection], size_range: tuple[float, float] | None = None
) -> list[Candidate]:
    """The candidates worth driving nearer to, in the order to visit them: those no other name explains
    first (by the best score of a box of another name over their middle), then those whose size as depth
    sees it fits the size of what is looked for (`size_range`, metres: a mug is 8 to 12 cm), then the
    smaller (a detector misses the small ones); furniture legs left out."""

    def explained(cand: Candidate) -> float:
        x0, y0, x1, y1 = cand.box
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        inside = [d.score for d in others if d.box[0] <= cx <= d.box[2] and d.box[1] <= cy <= d.box[3]]
        return round(max(inside, default=0.0), 1)

    def misfit(cand: Candidate) -> float:
        if size_range is None or cand.size <= 0:
            return 0.0
        # depth sees part of an object (its near side, its top): half the smallest size still fits
        lo, hi = size_range[0] * 0.5, size_range[1] * 1.5
        return round(abs(math.log(min(max(cand.size, lo), hi) / cand.size)), 1)

    def leg(cand: Candidate) -> bool:
        x0, y0, x1, y1 = cand.box
        return cand.rise > LEG_RISE_M and (y1 - y0) > LEG_ASPECT * max(x1 - x0, 1.0)

    worth = [c for c in candidates if not leg(c)]
    return sorted(worth, key=lambda c: (explained(c), misfit(c), c.pixels))


def carried_back(
    box: tuple[float, float, float, float], frame: Frame, capture: Capture, first: Capture
) -> tuple[float, float, float, float] | None:
    """Where the object in `box` of a frame taken from elsewhere (`capture`) lies in the first image: the
    nearest surface in the box's middle, placed in the world by depth and odometry and projected into the
    first image; None without depth or pose there, or where it falls outside the first image."""
    if frame.depth is None or capture.camera is None or capture.view is None or capture.base is None:
        return None
    if first.camera is None or first.view is None or first.base is None:
        return None
    surface = nearest_surface(frame.depth, capture.camera, capture.view, box)
    if surface is None:
        return None
    return projected_box(to_base(to_world(surface, capture.base), first.base), first.camera, first.view)


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
