"""Looking again: one image's detections checked against views from other head poses, fused by 3-D position.

A detector errs per frame (a miss, a confusion, a spurious box) and from a viewpoint (an object it does not
see from here, a pair it mixes up from here). When the robot takes its first image it also turns its head
to either side (`Survey.take`), so that every object in the first image is seen from at least one other
angle. `Survey.fuse` then asks the detector for a name in each view, places each box in the world from
the depth inside it (the nearest surface in the box's middle, through the head angles and odometry of
that view), and groups the boxes of all views by where they are: a group seen in at least two views, or in
the only view that can see it, is an object; one seen in one view where two or more could see it was a
mistake of that view and is dropped. An object missed in the first image but seen from the other views
gets a box in the first image, projected from where it was seen. Nothing here reads the simulator's truth:
only frames, depth, head angles and odometry, as a real robot has.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from attribot.boxes import Box, iou, overlap_of_smaller
from attribot.control.base import Capture
from attribot.control.body import BodyGeometry
from attribot.control.sighting import capture_now
from attribot.control.spatial import (
    nearest_surface,
    point_from_range,
    project,
    projected_box,
    to_base,
    to_world,
)
from attribot.embodiments.base import Embodiment
from attribot.frame import Frame
from attribot.models.base import SURE_SCORE, Detection, Detector, detect_confirming, detect_in_views
from attribot.skills.harder import zoom_views
from attribot.skills.params import LOOK_AGAIN

__all__ = ["Survey", "View", "LookAgainReport", "reexamine", "ask_again", "one_object", "refit"]


@dataclass
class View:
    """One frame of the survey and what was known when it was taken."""

    frame: Frame
    capture: Capture


@dataclass
class LookAgainReport:
    """What looking again changed for one `find`: shown in the trace."""

    views: int
    first: int  # detections in the first image
    kept: int
    dropped: int  # boxes of the first image no other view confirmed
    added: int  # objects the first image missed, seen from the other views
    conflicts: int = 0  # boxes found before under another name, left out
    unconfirmed: int = 0  # kept though no other view confirmed it: nothing was, so one image's answer
    how: str = "head poses"  # what the other views were

    def describe(self) -> str:
        text = (
            f"looked again from {self.views - 1} other {self.how}: {self.first} in the first image, "
            f"{self.kept} confirmed, {self.dropped} dropped, {self.added} added"
        )
        text += f", {self.conflicts} found before under another name" if self.conflicts else ""
        text += f", {self.unconfirmed} kept unconfirmed (no view confirmed any)" if self.unconfirmed else ""
        return text


@dataclass
class Survey:
    """The first image and the views taken around it (see the module docstring)."""

    first: View
    body: BodyGeometry
    others: list[View] = field(default_factory=list)
    reports: list[LookAgainReport] = field(default_factory=list)
    claims: list[tuple[str, tuple[float, float, float, float], float]] = field(default_factory=list)
    """What earlier finds settled on: (name, box in the first image, support)."""

    @classmethod
    def take(cls, world: Embodiment, first: View, body: BodyGeometry) -> Survey:
        """Turn the head to either side of where `first` was taken (a third of the view's width by
        default: enough that every object is seen elsewhere in the image) and up and down (a quarter of its
        height), take a frame at each, and turn it back."""
        survey = cls(first=first, body=body)
        cap = first.capture
        if cap.head is None or cap.camera is None or cap.base is None or first.frame.depth is None:
            return survey
        pan, tilt = cap.head
        turn, nod = cap.camera.hfov / 3.0, cap.camera.vfov / 4.0
        for k, (d_pan, d_tilt) in enumerate(((turn, 0.0), (-turn, 0.0), (0.0, -nod), (0.0, nod))):
            _move_head(world, pan + d_pan, tilt + d_tilt)
            frame = world.observe()
            survey.others.append(View(frame, capture_now(world, frame, -(k + 1), frame.camera or cap.camera)))
        _move_head(world, pan, tilt)
        return survey

    def fuse(self, detector: Detector, name: str, first: list[Detection]) -> list[Detection]:
        """`first` (the detector's answer for `name` in the first image) checked against the views to either
        side, and against those up and down too where the side views leave an object undecided; what it
        did is added to `reports`, and the object it settled on to `claims`. Where the views see an object
        the first image missed, its box there would be carried from a turned view: the first image is
        looked at again zoomed in on it, to box it itself."""
        result, report, claim = self._fused(detector, name, first)
        added = [d.box for d in result if not any(d is f for f in first)]
        if added:
            frame = self.first.frame
            zoomed = detect_in_views(detector, frame, [name], zoom_views(added, frame.width, frame.height))
            new = [z for z in zoomed if all(iou(z.box, d.box) < 0.5 for d in first)]
            result, report, claim = self._fused(detector, name, [*first, *new])
            # a box the zoomed look found is one the first look missed: added, not in the first image
            found = sum(1 for d in result if any(d is z for z in new))
            report = replace(report, first=len(first), kept=report.kept - found, added=report.added + found)
        self.reports.append(report)
        if claim is not None:
            self.claims.append(claim)
        return result

    def _fused(
        self, detector: Detector, name: str, first: list[Detection]
    ) -> tuple[list[Detection], LookAgainReport, tuple[str, tuple[float, float, float, float], float] | None]:
        """`fuse`'s answer, what it did, and the object it settled on, recorded nowhere."""
        if not self.others:
            return first, LookAgainReport(1, len(first), len(first), 0, 0), None
        views, groups, support = self._grouped(detector, name, first, self.others[: LOOK_AGAIN.side_views])
        if len(self.others) > LOOK_AGAIN.side_views and any(_undecided(g, support[id(g)]) for g in groups):
            views, groups, support = self._grouped(detector, name, first, self.others)
        confirmed = [g for g in groups if support[id(g)] >= 1.0 or len(g.members) >= 2]
        # two calls disagree: a box found, as well or better, under another name before is not this one
        disputed = {
            id(g)
            for g in groups
            if any(n != name and iou(g.box, b) >= 0.5 and s >= support[id(g)] for n, b, s in self.claims)
        }
        conflicts = sum(1 for g in confirmed if id(g) in disputed)
        confirmed = [g for g in confirmed if id(g) not in disputed]
        fallback: _Group | None = None
        if not confirmed and groups:
            # nothing confirmed: what one image would have given, the first image's best box (the best
            # sighting elsewhere where it saw none), passing over what another name settled on before
            undisputed = [g for g in groups if id(g) not in disputed] or groups
            in_first_image = [g for g in undisputed if 0 in g.members] or undisputed
            fallback = max(in_first_image, key=lambda g: max(m.det.score for m in g.members.values()))
            confirmed = [fallback]
        kept, added = self._kept(confirmed, groups, first)
        # the detector's order, best match first, as find promises
        result = sorted(kept, key=lambda d: -d.score)
        settled = max(
            (g for g in confirmed if id(g) not in disputed), key=lambda g: support[id(g)], default=None
        )
        claim = None if settled is None else (name, settled.box, support[id(settled)])
        return result, self._report(len(views), first, result, added, conflicts, fallback), claim

    def _grouped(
        self, detector: Detector, name: str, first: list[Detection], others: list[View]
    ) -> tuple[list[View], list[_Group], dict[int, float]]:
        """The views (the first and `others`), the groups of `name`'s sightings in them that the first image
        can show (not one seen past its edge from a turned head), and each group's support by id."""
        views = [self.first, *others]
        groups = self._group(detector, name, first, views)
        groups = [g for g in groups if 0 in g.members or self._visible(g.centre, self.first)]
        return views, groups, {id(g): _support(g, views, self._visible) for g in groups}

    def _group(
        self, detector: Detector, name: str, first: list[Detection], views: list[View]
    ) -> list[_Group]:
        """The sightings of `name` in every view, grouped by the object they show (placed in the world by
        depth, boxed where the first image shows them)."""
        groups: list[_Group] = []
        for v, view in enumerate(views):
            found = first if v == 0 else self._sightings(detector, name, first, view)
            for det in found:
                where = self._place(det.box, view)
                if where is None:
                    continue
                point, points = where
                # where the first image shows it: boxes of one object land on each other there
                box = det.box if v == 0 else self._in_first(det.box, view, points)
                if box is None:
                    continue
                near = [g for g in groups if v not in g.members and g.same(box, point)]
                group = (
                    max(near, key=lambda g: iou(g.box, box) + overlap_of_smaller(g.box, box))
                    if near
                    else None
                )
                if group is None:
                    group = _Group()
                    groups.append(group)
                group.add(v, _Sighting(det, point, points, box))
        return groups

    @staticmethod
    def _sightings(detector: Detector, name: str, first: list[Detection], view: View) -> list[Detection]:
        """The detector's boxes of `name` in another view: where the first image found some, to confirm them
        (a view that shows no trace of the name confirms none), else to find what it missed."""
        if first:
            return detect_confirming(detector, view.frame, [name])
        return detector.detect(view.frame, [name])

    def _kept(
        self, confirmed: list[_Group], groups: list[_Group], first: list[Detection]
    ) -> tuple[list[Detection], int]:
        """The detections the confirmed groups keep (the first image's own box, or the least turned view's
        carried into it for an object only other views show) and how many of them are new; the first
        image's boxes with no depth to check them against are kept as seen."""
        kept: list[Detection] = []
        added = 0
        in_first = [g.members[0].box for g in confirmed if 0 in g.members]
        for group in confirmed:
            if 0 in group.members:
                det = group.members[0].det
            elif any(overlap_of_smaller(group.box, b) >= 0.5 for b in in_first):
                continue  # what the first image shows already, seen from elsewhere: not another object
            else:
                nearest = self._least_turned(group)
                best = nearest.det
                det = Detection(box=nearest.box, score=best.score, label=best.label, object_id=best.object_id)
                added += 1
            kept.append(det)
        placed = {id(m.det) for g in groups for m in g.members.values()}
        # no depth where the box is: nothing to check it against, kept as seen
        kept += [d for d in first if id(d) not in placed]
        return kept, added

    def _report(
        self,
        views: int,
        first: list[Detection],
        result: list[Detection],
        added: int,
        conflicts: int,
        fallback: _Group | None,
    ) -> LookAgainReport:
        """What one fuse did."""
        kept_first = sum(1 for d in result if any(d is f for f in first))
        # a box kept for want of better is neither confirmed nor added (nor dropped)
        unconfirmed = int(fallback is not None)
        fallback_in_first = fallback is not None and 0 in fallback.members
        kept_first -= int(fallback_in_first)
        added -= unconfirmed - int(fallback_in_first)
        return LookAgainReport(
            views=views,
            first=len(first),
            kept=kept_first,
            dropped=len(first) - kept_first - int(fallback_in_first),
            added=added,
            conflicts=conflicts,
            unconfirmed=unconfirmed,
        )

    def _place(
        self, box: tuple[float, float, float, float], view: View
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """Where the object in `box` is in the world: the centre of the nearest surface in the box's middle
        (and those surface points), or None without depth there."""
        cap = view.capture
        if cap.depth is None or cap.camera is None or cap.head is None or cap.base is None:
            return None
        surface = nearest_surface(cap.depth, cap.camera, self.body.head_view(cap.head), box)
        if surface is None:
            return None
        points = to_world(surface, cap.base)
        return points.mean(axis=0), points

    def _visible(self, point: np.ndarray, view: View) -> bool:
        cap = view.capture
        assert cap.camera is not None and cap.head is not None and cap.base is not None
        uv, front = project(to_base(point[None, :], cap.base), cap.camera, self.body.head_view(cap.head))
        u, v = uv[0]
        margin = 0.04 * cap.camera.width
        inside = margin <= u <= cap.camera.width - margin and margin <= v <= cap.camera.height - margin
        return bool(front[0]) and inside

    def _least_turned(self, group: _Group) -> _Sighting:
        """The sighting from the view whose head was turned least from the first's: a box carried over from
        a view turned far (and rolled, when the head pans while it looks down) comes out wider."""
        first = self.first.capture.head
        views = [self.first, *self.others]
        assert first is not None

        def turned(v: int) -> float:
            head = views[v].capture.head
            assert head is not None
            return abs(head[0] - first[0]) + abs(head[1] - first[1])

        return group.members[min(group.members, key=turned)]

    def _in_first(
        self, box: tuple[float, float, float, float], view: View, points: np.ndarray
    ) -> tuple[float, float, float, float] | None:
        """Where `box` of `view` lies in the first image: the ellipse inside it (an object fills its box's
        middle, not its corners), at the object's distance, projected into the first image; None when it
        falls outside it. Turning the head hardly moves the camera, so the box keeps its shape."""
        cap, seen = self.first.capture, view.capture
        assert cap.camera is not None and cap.head is not None and cap.base is not None
        assert seen.camera is not None and seen.head is not None and seen.base is not None
        eye = to_world(np.asarray(self.body.camera_xyz, float)[None, :], seen.base)[0]
        metres = float(np.median(np.linalg.norm(points - eye, axis=1)))
        x0, y0, x1, y1 = box
        angles = np.linspace(0.0, 2.0 * math.pi, 16, endpoint=False)
        cx, cy, rx, ry = (x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0) / 2, (y1 - y0) / 2
        rim = np.array(
            [
                point_from_range(
                    metres, seen.camera, self.body.head_view(seen.head), cx + rx * c, cy + ry * s
                )
                for c, s in zip(np.cos(angles), np.sin(angles), strict=True)
            ]
        )
        rim_here = to_base(to_world(rim, seen.base), cap.base)
        return projected_box(rim_here, cap.camera, self.body.head_view(cap.head))


def _undecided(group: _Group, support: float) -> bool:
    """One view alone saw the group's object, where another could see it too: that view's mistake, or an
    object the others missed (one in the first image's side third, missed there and seen from the side it
    was turned to; one a detector's noise hid in two views): more views decide."""
    return len(group.members) == 1 and support < 1.0


def _support(group: _Group, views: list[View], visible: Callable[[np.ndarray, View], bool]) -> float:
    """The share of the views that can see where the group is that did see it (1.0: every one)."""
    seen_from = sum(1 for view in views if visible(group.centre, view))
    return len(group.members) / max(seen_from, 1)


@dataclass(frozen=True)
class _Sighting:
    """One view's detection: the box, where it is in the world, its surface points, its box in the first
    image."""

    det: Detection
    point: np.ndarray
    points: np.ndarray
    box: tuple[float, float, float, float]


@dataclass
class _Group:
    """Sightings of several views that land on each other in the first image: one object."""

    members: dict[int, _Sighting] = field(default_factory=dict)

    @property
    def centre(self) -> np.ndarray:
        return np.mean([m.point for m in self.members.values()], axis=0)

    @property
    def box(self) -> tuple[float, float, float, float]:
        boxes = np.array([m.box for m in self.members.values()])
        x0, y0, x1, y1 = boxes.mean(axis=0)
        return float(x0), float(y0), float(x1), float(y1)

    def same(self, box: tuple[float, float, float, float], point: np.ndarray) -> bool:
        """A sighting at `box` (in the first image) and `point` (in the world) shows this group's object."""
        if iou(self.box, box) >= LOOK_AGAIN.same_iou:
            return True
        near = float(np.linalg.norm(self.centre - point)) <= LOOK_AGAIN.same_place_m
        return near and overlap_of_smaller(self.box, box) >= LOOK_AGAIN.same_inside

    def add(self, view: int, sighting: _Sighting) -> None:
        self.members[view] = sighting


def one_object(capture: Capture | None, a: Box, b: Box) -> bool:
    """Two boxes of one robot image frame one object: they overlap (IoU 0.3), or one lies mostly inside the
    other, and depth puts the nearest surfaces in their middles within 10 cm of each other. A detector
    that names one object twice (a cactus boxed whole as a cactus at 0.74, its pot as a vase at 0.76)
    gives a program two patches of it; measured twice, they are one object, not two that cannot be told
    apart. The survey's groups (`_Group.same`) take boxes that overlap as one object without depth; here
    depth must agree either way. False without depth or a known camera pose."""
    if capture is None or capture.depth is None or capture.camera is None or capture.view is None:
        return False
    if iou(a, b) < LOOK_AGAIN.same_iou and overlap_of_smaller(a, b) < LOOK_AGAIN.same_inside:
        return False
    near = [nearest_surface(capture.depth, capture.camera, capture.view, box) for box in (a, b)]
    if near[0] is None or near[1] is None:
        return False
    return float(np.linalg.norm(near[0].mean(axis=0) - near[1].mean(axis=0))) <= LOOK_AGAIN.same_place_m


_CROPS = "crops of the image a few pixels in"
_NAMES = re.compile(r"\s*(?:,|\band\b|\ba\b|\ban\b|\bthe\b)\s*")


def _variants(frame: Frame) -> list[tuple[Frame, float, float]]:
    """Two crops of `frame` a few pixels in from opposite corners (and their offsets): the same view, other
    pixels, as a detector sees a slightly moved camera. An object keeps its place in the view."""
    w, h = frame.width, frame.height
    dx, dy = max(2.0, round(0.02 * w)), max(2.0, round(0.02 * h))
    if w <= 4 * dx or h <= 4 * dy:
        return []
    out = []
    for box in ((dx, dy, float(w), float(h)), (0.0, 0.0, w - dx, h - dy)):
        crop = frame.crop(box)
        out.append((crop, float(crop.origin[0] - frame.origin[0]), float(crop.origin[1] - frame.origin[1])))
    return out


def reexamine(
    detector: Detector, frame: Frame, name: str, first: list[Detection]
) -> tuple[list[Detection], LookAgainReport]:
    """A still image looked at again (no head to turn): `first` checked against the detector's answers on
    two crops a few pixels in from opposite corners (test-time augmentation). Boxes that overlap in at least
    two of the three are one object, their box the mean of the three (a jittery detector's error shrinks);
    a box only one of them found is dropped. Per-frame mistakes (a miss, a confusion, a false box) rarely
    repeat; what a detector gets wrong about the view itself repeats, and stays."""
    variants = _variants(frame)
    if not variants:
        return first, LookAgainReport(
            views=1, first=len(first), kept=len(first), dropped=0, added=0, how=_CROPS
        )
    answers = [list(first)]
    for crop, ox, oy in variants:
        answers.append(
            [
                Detection(
                    box=(d.box[0] + ox, d.box[1] + oy, d.box[2] + ox, d.box[3] + oy),
                    score=d.score,
                    label=d.label,
                    object_id=d.object_id,
                )
                for d in detector.detect(crop, [name])
            ]
        )
    clusters = _clusters(answers)
    kept = [_mean_of(c) for c in clusters if len(c) >= 2]
    if not kept and first:  # nothing seen twice: the first answer, as one look would have given
        return first, LookAgainReport(
            views=3, first=len(first), kept=len(first), dropped=0, added=0, how=_CROPS
        )
    confirmed = sum(1 for c in clusters if len(c) >= 2 and 0 in c)
    report = LookAgainReport(
        views=3,
        first=len(first),
        kept=confirmed,
        dropped=len(first) - confirmed,
        added=len(kept) - confirmed,
        how=_CROPS,
    )
    return sorted(kept, key=lambda d: -d.score), report


def _clusters(answers: list[list[Detection]]) -> list[dict[int, Detection]]:
    """The boxes of several answers (one per look) grouped by object: each joins the group it overlaps most
    (IoU 0.5 or more) that has no box of its own look yet."""
    clusters: list[dict[int, Detection]] = []
    for v, found in enumerate(answers):
        for det in found:
            near = [c for c in clusters if v not in c and max(iou(det.box, o.box) for o in c.values()) >= 0.5]
            home = max(near, key=lambda c: max(iou(det.box, o.box) for o in c.values())) if near else None
            if home is None:
                clusters.append({v: det})
            else:
                home[v] = det
    return clusters


def _mean_of(cluster: dict[int, Detection]) -> Detection:
    """One object's boxes from several looks as one: their mean box and score, the first look's label (or
    the best one's), the id most of them give."""
    boxes = np.array([d.box for d in cluster.values()])
    ids = [d.object_id for d in cluster.values()]
    best = cluster.get(0) or max(cluster.values(), key=lambda d: d.score)
    x0, y0, x1, y1 = (float(v) for v in boxes.mean(axis=0))
    return Detection(
        box=(x0, y0, x1, y1),
        score=float(np.mean([d.score for d in cluster.values()])),
        label=best.label,
        object_id=max(set(ids), key=lambda i: (ids.count(i), i == best.object_id)),
    )


def refit(detector: Detector, frame: Frame, box: Box, name: str, score: float) -> tuple[Box, int]:
    """The best estimate of the box of the object of `name` at `box` in `frame` (detected at `score`):
    `box` looked at again on four crops around it (the object whole in each, at another place in the
    crop), and the mean of it and the crops' boxes of `name` that overlap it most (IoU 0.1: a thin object's
    jittered box may share a fifth of its area with a right one, as a 15 px wide bottle's box shifted by 10
    px did; a crop three times the box's size holds little else of the name) and that the detector is as
    sure of as of `box`, or sure of (`SURE_SCORE`: YOLOv5s boxes a book it named at 0.6 in the image at 0.12
    to 0.19 in crops, each box a third off it); and how many looks that mean holds (1: none confirmed it,
    and `box` stands). A detector's jitter is drawn anew for other pixels, so the mean's
    error shrinks; the crops are of the image itself, so nothing is carried from another viewpoint (boxes
    carried from the survey's turned views are a few pixels off even without noise, and their mean lost
    a tenth of a clean box's IoU)."""
    x0, y0, x1, y1 = box
    pad_x, pad_y = max(x1 - x0, 12.0), max(y1 - y0, 12.0)
    looks = [box]
    for sx, sy in LOOK_AGAIN.refit_shifts:
        window = (
            max(0.0, x0 - pad_x * (1 + sx)),
            max(0.0, y0 - pad_y * (1 + sy)),
            min(float(frame.width), x1 + pad_x * (1 - sx)),
            min(float(frame.height), y1 + pad_y * (1 - sy)),
        )
        crop = frame.crop(window)
        ox, oy = float(crop.origin[0] - frame.origin[0]), float(crop.origin[1] - frame.origin[1])
        seen = [
            (d.box[0] + ox, d.box[1] + oy, d.box[2] + ox, d.box[3] + oy)
            for d in detector.detect(crop, [name])
            if d.score >= min(score, SURE_SCORE)
        ]
        same = [b for b in seen if iou(b, box) >= LOOK_AGAIN.refit_iou]
        if same:
            looks.append(max(same, key=lambda b: iou(b, box)))
    if len(looks) == 1:
        return box, 1
    # the mean, not the median: of five looks the median of each edge lost a tenth of the mean's IoU gain
    fused = np.asarray(looks, float).mean(axis=0)
    return (float(fused[0]), float(fused[1]), float(fused[2]), float(fused[3])), len(looks)


def ask_again(answer: Callable[[Frame], str], frame: Frame) -> tuple[str, int]:
    """A visual question asked of `frame` and of two crops a few pixels in: the answer most of the three
    give (the first one's when all differ), and how many of the others disagreed with the first."""
    answers = [answer(frame)] + [answer(crop) for crop, _, _ in _variants(frame)]
    # an answer may be a list ("fork, pencil and a cup"): compared as the set of what it names
    names = [frozenset(n for n in _NAMES.split(a.strip().lower().rstrip(".")) if n.strip()) for a in answers]

    def agreement(i: int) -> float:
        return sum(
            len(names[i] & names[j]) / max(len(names[i] | names[j]), 1) for j in range(len(names)) if j != i
        )

    best = max(range(len(answers)), key=lambda i: (round(agreement(i), 6), i == 0))
    return answers[best], sum(1 for n in names[1:] if n != names[0])


def _move_head(world: Embodiment, pan: float, tilt: float) -> tuple[float, float]:
    """Command the head and wait until it stops; the angles it stopped at."""
    world.set_head(pan, tilt)
    last = None
    for _ in range(LOOK_AGAIN.settle_steps):
        world.step(LOOK_AGAIN.settle_s)
        js = world.joint_states()
        now = (float(js["head_pan"]), float(js["head_tilt"]))
        if last is not None and max(abs(now[0] - last[0]), abs(now[1] - last[1])) < LOOK_AGAIN.same_rad:
            return now
        last = now
    assert last is not None
    return last
