"""Looking harder: when `find` comes back empty or unsure for a named object, the robot looks more closely at
where depth says objects stand, and sets aside what depth says is no object.

A real detector misses objects that are small in the frame (YOLOv3-tiny sees a 25-pixel apple poorly at its
608-pixel input). Depth does not need to know what an object is to see that something stands on a table
(`control.candidates`): each such region is shown to the detector on its own, in a view a few times its size,
so that the object fills the detector's input ("zooming by cropping"). A detection found this way counts only
where depth sees something stand; and any detection of the find inside whose box depth sees nothing rise from
a level (a box on a wall, on the floor's tiles) is set aside, unless it is sure and its box lies on a level (a
phone lying on a table rises too little to stand out). Where zooming finds nothing and the robot can drive, it
drives nearer to a few of the places in turn (`visit_order`), looks there, carries what it sees back into the
first image (`carried_back`: where it lands on the place, the place's box is its box) and drives back (the
Robot's `_nearer`). Where even that finds nothing, two weaker kinds of evidence are weighed, each only where
it points at one place: a box of the name fainter than the detector's threshold that frames one candidate and
no other candidate nearly as well (`faint_pick`), and, by elimination, the one candidate of the name's size
and height (a knife lies flat, a toaster stands) that no box of another name explains (`by_elimination`). And
where the detector saw some objects of the name but not all (a row of carrots, one of them boxed), the places
that look like one it saw, in colour and size, and that nothing else explains are more of it (`alike`). What
they give has the low score it earned, and the trace says how it was taken. Only detectors that read pixels
look harder (a zoomed view shows them more); the oracle reads the simulator's segmentation.
"""

from __future__ import annotations

import colorsys
import math
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cache

import cv2
import numpy as np

from attribot.boxes import at_edge, center, crop_array, enclosing, iou, overlap_of_smaller
from attribot.control.base import Capture
from attribot.control.candidates import Candidate, StandingMap
from attribot.control.spatial import nearest_surface, projected_box, to_base, to_world
from attribot.errors import InputError
from attribot.frame import CameraInfo, Frame
from attribot.lexicon import SURFACE_WORDS
from attribot.models.base import SURE_SCORE, Detection, Detector, detect_in_views
from attribot.priors import Kind, Priors, priors

__all__ = [
    "LookHarderReport",
    "Nearer",
    "alike",
    "acting_find",
    "by_elimination",
    "class_sizes",
    "colour_fits",
    "carried_back",
    "closed_world",
    "confirmed",
    "faint_pick",
    "one_name_each",
    "one_object",
    "look_harder",
    "visit_order",
    "zoom_views",
]

Nearer = Callable[[str, list[Candidate]], tuple[list[Detection], int]]
"""Drives nearer to candidates in turn and looks for a name there: (detections in the first image, visits)."""

UNSURE = SURE_SCORE
"""A find whose best detection scores under this looks harder: no sure box (`models.base.SURE_SCORE`, the
closed-set detectors' own `SURE`)."""
ZOOM = 3.5
"""A zoomed view is this many times its candidate's larger side..."""
MIN_VIEW = 112
"""...and at least this many pixels square (a 30-pixel object fills about a quarter of it)."""
MAX_VIEWS = 10
"""The most zoomed views one find looks at (a forward pass each)."""
FAINT = 0.005
"""The faintest box of a name weighed on a candidate (the detector's threshold is 0.1): YOLOv3-tiny scores a
30-pixel apple 0.04 as an apple (and 0.7 as an orange), and a flat book 0.009."""
FAINT_MARGIN = 2.0
"""A faint box is taken only where its score is this many times that of the name on any other candidate."""
ELIMINATED_SCORE = 0.001
"""The score of a candidate taken by elimination: no detector saw it as the name."""
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
    faint: float | None = None  # the score of the faint box taken, where one was
    eliminated: int = 0  # candidates of the name's size no other name explains, where one was taken
    alike: int = 0  # candidates that look like an object of the name the detector saw, taken as more of it
    yielded: int = 0  # boxes left to another name whose object is there (`one_name_each`)
    fitted: int = 0  # boxes cut to what depth sees of the object in them (`fitted_to_depth`)
    confirmed: int = 0  # inferences (elimination, likeness) the detector confirmed from nearer
    unconfirmed: int = 0  # inferences dropped: from nearer the detector did not name them
    closed: int = 0  # inferences kept unconfirmed, since everything else depth sees here is named
    took: list[Detection] = field(default_factory=list)  # what the find took on that weaker evidence

    @property
    def taken(self) -> bool:
        """Whether weaker evidence gave the find an object: a faint box, elimination, or a likeness."""
        return self.faint is not None or bool(self.eliminated) or bool(self.alike)

    def describe(self) -> str:
        text = f"depth sees {self.candidates} things stand"
        if self.views:
            text += f"; zoomed in on {self.views} of them: {self.added} found"
        if self.visits:
            text += f"; drove nearer to {self.visits} of them: {self.found_nearer} found"
        if self.faint is not None:
            text += f"; took the one framed by a faint box of the name (score {self.faint:.3f})"
        if self.eliminated:
            text += "; took by elimination the one thing of the name's size that no other name explains"
        if self.alike:
            text += f"; took {self.alike} more that look like the one it saw (their colours, their size)"
        if self.set_aside:
            text += f"; {self.set_aside} set aside where depth sees nothing stand"
        if self.yielded:
            text += f"; {self.yielded} left to another name whose object is there"
        if self.fitted:
            text += f"; {self.fitted} boxes cut to what depth sees of the object in them"
        if self.confirmed:
            text += f"; {self.confirmed} of them confirmed: seen as the name from nearer"
        if self.unconfirmed:
            text += f"; {self.unconfirmed} dropped: from nearer the detector did not see the name there"
        if self.closed:
            text += (
                f"; {self.closed} kept though not seen as the name from nearer: everything else here is named"
            )
        return text


def zoom_views(
    boxes: Sequence[tuple[float, float, float, float]], width: int, height: int
) -> list[tuple[int, int, int, int]]:
    """Square views around the boxes (the candidates', largest first), inside the image; a view much like
    one already chosen is left out."""
    views: list[tuple[int, int, int, int]] = []
    for x0, y0, x1, y1 in boxes:
        side = int(min(max(ZOOM * max(x1 - x0, y1 - y0), MIN_VIEW), width, height))
        left = int(np.clip((x0 + x1) / 2 - side / 2, 0, width - side))
        top = int(np.clip((y0 + y1) / 2 - side / 2, 0, height - side))
        view = (left, top, left + side, top + side)
        if all(iou(view, v) < 0.5 for v in views):
            views.append(view)
        if len(views) >= MAX_VIEWS:
            break
    return views


_STANDING: weakref.WeakKeyDictionary[Frame, tuple[Capture, StandingMap, list[Candidate]]]
_STANDING = weakref.WeakKeyDictionary()


def standing_in(frame: Frame, capture: Capture) -> tuple[StandingMap, list[Candidate]]:
    """What depth sees stand in a frame taken as `capture` says, and its candidates: read once per frame
    (while the frame lives), since every find of a program's image asks for the same map."""
    kept = _STANDING.get(frame)
    if kept is None or kept[0] is not capture:
        assert frame.depth is not None and capture.camera is not None and capture.view is not None
        standing = StandingMap.of(frame.depth, capture.camera, capture.view, frame.rgb)
        kept = _STANDING[frame] = (capture, standing, standing.candidates())
    return kept[1], list(kept[2])


def look_harder(
    detector: Detector,
    frame: Frame,
    capture: Capture,
    name: str,
    detections: list[Detection],
    nearer: Nearer | None = None,
    claimed: list[Detection] | None = None,
    sought: list[str] | None = None,
    table: Priors | None = None,
) -> tuple[list[Detection], LookHarderReport] | None:
    """The find's detections after looking harder (module docstring) and what it did; None without depth and
    a camera pose. `nearer` (a robot that drives) looks from nearer at the candidates in `visit_order`;
    `claimed`: the boxes other names' finds took here, each its object's (if of another class); `sought`:
    the other names looked for; `table`: the perception priors (`attribot.priors`; default: unscaled)."""
    if frame.depth is None or capture.camera is None or capture.view is None:
        return None
    table = table if table is not None else priors()
    standing, candidates = standing_in(frame, capture)
    kept = detections
    if name.lower() not in SURFACE_WORDS:
        small = frame.width * frame.height * SMALL_BOX
        kept = [d for d in detections if _area(d.box) >= small or _stands(d, standing)]
    report = LookHarderReport(len(candidates), 0, 0, len(detections) - len(kept))

    @cache
    def best_rivals() -> list[Detection]:  # the other sought names' best boxes, looked for once
        return _best_of(detector, frame, name, sought or [], [])

    def one_each(found: list[Detection]) -> list[Detection]:
        if len(found) < 2:
            return found
        taken = [d for d in claimed or [] if _class(detector, d.label) != _class(detector, name)]
        left = one_name_each(found, [*taken, *(best_rivals() if sought else [])], candidates)
        report.yielded += len(found) - len(left)
        return left

    kept = one_each(kept)
    if not candidates:
        return kept, report
    kept = _without_misfits(detector, name, kept, candidates, report, table)
    if all(d.score < UNSURE for d in kept):
        merged, views = _zoomed_in(detector, frame, name, candidates, kept)
        report.views, report.added = len(views), len(merged) - len(kept)
        if not merged:  # nothing of the name seen at all: weaker evidence, and a closer look
            claimed = [*(claimed or []), *_best_of(detector, frame, name, sought or [], views)]
            merged = _unseen(
                detector, frame, capture.camera, name, candidates, views, nearer, claimed, report, table
            )
            report.took = list(merged) if report.taken else []
        merged.sort(key=lambda d: -d.score)
        kept = one_each(merged)
    kept = _fitted(detector, name, kept, candidates, report, table)
    kept = _without_misfits(detector, name, kept, candidates, report, table)  # the zoomed views' too
    # each sought name's best box explains its place, as in one_each (alike takes nothing with no example)
    explained = best_rivals() if sought and any(d.score >= EXEMPLAR for d in kept) else []
    more = alike(detector, frame, name, candidates, kept, [*(claimed or []), *explained], sought or [], table)
    report.alike, more = len(more), confirmed(more, candidates, name, nearer, report)
    report.took = [*report.took, *more]
    return kept + more, report


def _without_misfits(
    detector: Detector,
    name: str,
    found: list[Detection],
    candidates: list[Candidate],
    report: LookHarderReport,
    table: Priors,
) -> list[Detection]:
    """`found` less its `_misfits`, counted as set aside in `report`; what weaker evidence took stays (it
    was taken for its size)."""
    misfits = [
        d for d in _misfits(detector, name, found, candidates, table) if not any(d is t for t in report.took)
    ]
    report.set_aside += len(misfits)
    return [d for d in found if not any(d is m for m in misfits)]


def _misfits(
    detector: Detector, name: str, found: list[Detection], candidates: list[Candidate], table: Priors
) -> list[Detection]:
    """The boxes of `found` on one thing whose size, as depth sees it, no object called `name` has
    (`fits_size`): YOLOv3-tiny boxes a 6 cm potato faintly as a sports ball and YOLOv5s surely, and a
    basketball is 24 cm across. A box on several things or on none is left as it is (depth sees it with its
    neighbour, or not at all)."""
    sizes = name_sizes(detector, name, table)
    if sizes is None:
        return []
    out = []
    for det in found:
        framed = _framed(det, candidates)
        if len(framed) != 1:
            continue
        size = candidates[framed[0]].size
        if size > 0 and not fits_size(size, sizes):
            out.append(det)
    return out


def _zoomed_in(
    detector: Detector, frame: Frame, name: str, candidates: list[Candidate], kept: list[Detection]
) -> tuple[list[Detection], list[tuple[int, int, int, int]]]:
    """`kept` and the boxes of the name that views zoomed in on the candidates show on them (a box on an
    object kept already is that one), and those views."""
    views = zoom_views([c.box for c in candidates], frame.width, frame.height)
    zoomed = [d for d in detect_in_views(detector, frame, [name], views) if _on_candidate(d, candidates)]
    merged = list(kept)
    for det in sorted(zoomed, key=lambda d: -d.score):
        if not any(one_object(det, other, candidates) for other in merged):
            merged.append(det)
    return merged, views


def _fitted(
    detector: Detector,
    name: str,
    kept: list[Detection],
    candidates: list[Candidate],
    report: LookHarderReport,
    table: Priors,
) -> list[Detection]:
    """`kept` with what the detector boxed cut to what depth sees (`fitted_to_depth`), counted in `report`;
    what weaker evidence took (a candidate's box, a faint box grown to it) as it was taken."""
    sizes = name_sizes(detector, name, table)
    fitted = [d if any(d is t for t in report.took) else fitted_to_depth(d, candidates, sizes) for d in kept]
    report.fitted = sum(1 for d, f in zip(kept, fitted, strict=True) if f is not d)
    return fitted


def _unseen(
    detector: Detector,
    frame: Frame,
    camera: CameraInfo,
    name: str,
    candidates: list[Candidate],
    views: list[tuple[int, int, int, int]],
    nearer: Nearer | None,
    claimed: list[Detection],
    report: LookHarderReport,
    table: Priors,
) -> list[Detection]:
    """For a name the zoomed views did not show: a faint box that points at one candidate no other name's
    find took, else what the robot sees from nearer, else the one candidate left by elimination (noted in
    `report`)."""
    # a place another name's find took holds that object
    free = [c for c in candidates if not any(_inside(center(c.box), d.box) for d in claimed)]
    kind = table.find(name)
    sizes = None if kind is None else kind.size_m
    explaining = cache(lambda: _explaining(detector, frame, camera, name, views, claimed, table))

    def closed() -> bool:
        return closed_world(candidates, explaining(), frame.width, frame.height)

    faint = faint_pick(detect_in_views(detector, frame, [name], views, threshold=FAINT), free)
    if faint is not None:
        report.faint = faint.score
        grown = grown_to_candidates(faint, free, sizes).model_copy(update={"evidence": "faint box"})
        return confirmed([grown], candidates, name, nearer, report, closed)
    others = explaining()
    placement = None if kind is None else kind.placement
    if nearer is not None:
        seen, report.visits = nearer(name, visit_order(candidates, others, sizes, placement))
        # boxes of one object seen from two places land on each other: one object
        kept_seen: list[Detection] = []
        for det in seen:
            if all(overlap_of_smaller(det.box, o.box) < 0.5 for o in kept_seen):
                kept_seen.append(det)
        report.found_nearer = len(kept_seen)
        if kept_seen:
            return kept_seen
    colours = () if kind is None else kind.colours

    def coloured(cand: Candidate) -> bool:
        return colour_fits(frame.rgb, cand.box, colours, table)

    heights = None if kind is None else kind.height_m
    left = by_elimination(candidates, others, sizes, frame.width, frame.height, placement, coloured, heights)
    if left is None:
        return []
    report.eliminated = 1
    eliminated = Detection(box=left.box, score=ELIMINATED_SCORE, label=name, evidence="elimination")
    return confirmed([eliminated], candidates, name, nearer, report, closed)


def _explaining(
    detector: Detector,
    frame: Frame,
    camera: CameraInfo,
    name: str,
    views: list[tuple[int, int, int, int]],
    claimed: list[Detection],
    table: Priors,
) -> list[Detection]:
    """The boxes that explain a place when `name` is sought: every other class's in the image and the
    zoomed views, and what other names' finds took (`claimed`, each its object whatever its score)."""
    # a box of the name's own class, or of a class another name of the program stands for, explains no
    # place: each of those names is one object, its best box (in `claimed`)
    mine = {_class(detector, name), *(_class(detector, d.label) for d in claimed)}
    seen = detect_in_views(detector, frame, ["object"], [(0, 0, frame.width, frame.height), *views])
    # nor does a box of a size no object of its class has (a bowl 3 m away boxed as a 7 cm carrot)
    found = [d for d in seen if d.label not in mine and _fits_class(detector, d, frame, camera, table)]
    return found + [d.model_copy(update={"score": 1.0}) for d in claimed]


def closed_world(candidates: list[Candidate], explaining: list[Detection], width: int, height: int) -> bool:
    """Whether depth sees at most one thing here that no sure box explains (furniture and what the image's
    edge cuts aside): a world closed enough for an argument by elimination, where everything else is
    named. A room with things the detector cannot name leaves several unexplained."""
    sure = [d for d in explaining if d.score >= UNSURE]
    unexplained = [
        c
        for c in candidates
        if not _furniture(c)
        and not at_edge(c.box, width, height)
        and not any(_inside(center(c.box), d.box) for d in sure)
    ]
    return len(unexplained) <= 1


def confirmed(
    inferred: list[Detection],
    candidates: list[Candidate],
    name: str,
    nearer: Nearer | None,
    report: LookHarderReport,
    closed: Callable[[], bool] | None = None,
) -> list[Detection]:
    """What of `inferred` (objects the detector never named at its threshold: a box fainter than that,
    elimination, likeness) acting confirms: the robot drives nearer to each and looks; where the detector
    names it there, its box seen nearer stands in its place. Where it does not, the inference is dropped, in
    a room with things no detector can name (the one place left, a likeness or a box at 0.02 is as often
    something else there: a dumbbell taken for an absent toaster, a CD for an absent bowl), and kept as it
    is where the world is closed (`closed`: everything else depth sees is named, so the one thing left is
    the one sought, a toaster the detector never names). A robot that cannot drive there keeps them as they
    are. An answer resting on a kept elimination or likeness says that it is a guess."""
    if nearer is None or not inferred:
        return inferred
    kept: list[Detection] = []
    for det in inferred:
        place = next((c for c in candidates if c.box == det.box), Candidate(box=det.box, rise=0.0, pixels=0))
        seen, visits = nearer(name, [place])
        report.visits += visits
        if seen:
            report.confirmed += 1
            kept.extend(s.model_copy(update={"label": name}) for s in seen)
        elif visits == 0:
            kept.append(det)  # no way there: still an inference
        elif closed is not None and closed():
            report.closed += 1
            kept.append(det)
        else:
            report.unconfirmed += 1
    return kept


def _best_of(
    detector: Detector, frame: Frame, name: str, others: list[str], views: list[tuple[int, int, int, int]]
) -> list[Detection]:
    """The best box of each of the `others` names in the image and in `views` (the outputs the find
    already had). A closed-set detector's names are left out where they reach no one class (a generic
    word: "object") or the class of `name` ("the red mug" and "the blue mug")."""
    class_of = getattr(detector, "class_of", None)
    best = []
    for other in others:
        if class_of is not None and class_of(other) in (None, class_of(name)):
            continue
        try:  # the find's own looks at the image (its tiles too) and its zoomed views: kept outputs
            found = detector.detect(frame, [other]) + detect_in_views(detector, frame, [other], views)
        except InputError:  # a name this detector cannot look for: the program's find will say so
            continue
        if found:
            best.append(max(found, key=lambda d: d.score))
    return best


def one_name_each(
    found: list[Detection], rivals: list[Detection], candidates: Sequence[Candidate] = ()
) -> list[Detection]:
    """`found` (one name's boxes) less those on the object of another name's box in `rivals` (the best box
    of another name the program looks for, or what another name's find took), one object, one name: a box
    that is not the name's best yields to the other name there (YOLOv3-tiny boxes a computer mouse as a
    clock at 0.19 and as a mouse at 0.18, beside the alarm clock it boxes at 0.63; a bowl as a sports ball
    at 0.18, beside a basketball it boxes at 0.29), and so does its best where the other name scores
    higher there (an orange boxed as an apple at 0.17 and as an orange at 0.31, beside an apple boxed at
    0.11; a cactus's pot boxed as a vase, under the cactus's box: `one_object`). One box at least is
    kept."""
    best = max(found, key=lambda d: d.score)

    def yields(d: Detection) -> bool:
        return any(one_object(d, r, candidates) and (d is not best or r.score > d.score) for r in rivals)

    kept = [d for d in found if not yields(d)]
    return kept or [best]


def one_object(a: Detection, b: Detection, candidates: Sequence[Candidate] = ()) -> bool:
    """Whether two boxes are on one object: they overlap by IoU 0.5 or more, or each frames one place depth
    sees stand (`candidates`), the same one (a cactus's pot and the cactus)."""
    if iou(a.box, b.box) >= 0.5:
        return True
    places = [_framed(d, list(candidates)) for d in (a, b)]
    return len(places[0]) == 1 and places[0] == places[1]


def _fits_class(detector: Detector, det: Detection, frame: Frame, camera: CameraInfo, table: Priors) -> bool:
    """Whether the box's longer side, in metres at the depth of what it frames, fits an object of its class
    (the sizes of the priors' kinds of that class, from half the smallest to 1.5 times the largest); True
    where the class or the depth does not say."""
    sizes = class_sizes(detector, det.label, table)
    if sizes is None or frame.depth is None:
        return True
    x0, y0, x1, y1 = (int(v) for v in det.box)
    depth = frame.depth[max(y0, 0) : max(y1, y0 + 1), max(x0, 0) : max(x1, x0 + 1)]
    depth = depth[np.isfinite(depth) & (depth > 0)]
    if depth.size == 0:
        return True
    # the nearer quarter of what the box holds: the object, not the wall behind it
    metres = max(camera.metres_across((x0, y0, x1, y1), float(np.percentile(depth, 25))))
    return fits_size(metres, sizes)


@cache
def _class_kinds(class_of: Callable[[str], str | None], label: str, table: Priors) -> tuple[Kind, ...]:
    """The priors' kinds of the closed-set class `label`: those the table files under it (`Kind.coco`) and
    those whose name the detector reaches it with."""
    return tuple(k for k in table.kinds.values() if k.coco == label or class_of(k.name) == label)


def class_sizes(
    detector: Detector, label: str | None, table: Priors | None = None
) -> tuple[float, float] | None:
    """The smallest and largest size (metres) of the priors' kinds of the closed-set class `label` (a sports
    ball: a tennis ball to a basketball); None for an open-vocabulary detector or a class no kind is of."""
    class_of = getattr(detector, "class_of", None)
    if class_of is None or not label:
        return None
    kinds = _class_kinds(class_of, label, table if table is not None else priors())
    return (min(k.size_m[0] for k in kinds), max(k.size_m[1] for k in kinds)) if kinds else None


def name_sizes(detector: Detector, name: str, table: Priors | None = None) -> tuple[float, float] | None:
    """The sizes an object called `name` has: its kind's in the priors, else those of the priors' kinds of
    the class the detector gives it; None where neither is known."""
    table = table if table is not None else priors()
    kind = table.find(name)
    return class_sizes(detector, _class(detector, name), table) if kind is None else kind.size_m


def _class(detector: Detector, name: str | None) -> str | None:
    """The one class a closed-set detector reaches with `name` (a mug: "cup"), else the name itself."""
    class_of = getattr(detector, "class_of", None)
    return (class_of(name) if class_of is not None and name else None) or name


SIZE_SLACK = (0.5, 1.5)
"""A size as depth sees it fits a name's size range from this share of its smallest (depth may see only a
part: an object's near side, its top) to this share of its largest."""


def fits_size(size: float, size_range: tuple[float, float], slack: tuple[float, float] = SIZE_SLACK) -> bool:
    """Whether `size` (metres, as depth sees it) fits `size_range` within `slack`."""
    return size_range[0] * slack[0] <= size <= size_range[1] * slack[1]


HEIGHT_MARGIN = 0.02
"""A rise as depth sees it fits a name's height range (`SIZE_SLACK` of it) give or take this much (metres):
depth's noise, a level that is not quite flat."""


def fits_height(rise: float, height_range: tuple[float, float]) -> bool:
    """Whether what depth sees rise `rise` metres over its level can be an object of `height_range` as it
    is put: a knife lying flat rises a centimetre or two, a toaster standing twenty."""
    low, high = height_range[0] * SIZE_SLACK[0], height_range[1] * SIZE_SLACK[1]
    return low - HEIGHT_MARGIN <= rise <= high + HEIGHT_MARGIN


def grown_to_candidates(
    det: Detection, candidates: list[Candidate], size_range: tuple[float, float] | None
) -> Detection:
    """`det` (a faint box) grown to hold the candidates it frames whose size fits the name's: a faint box
    often frames a part of the object (a thin book's spine, the scissors' handles), where depth and colour
    see its whole extent."""
    if size_range is None:
        return det
    boxes = [
        det.box,
        *(candidates[i].box for i in _framed(det, candidates) if fits_size(candidates[i].size, size_range)),
    ]
    if len(boxes) == 1:
        return det
    return det.model_copy(update={"box": enclosing(boxes)})


FIT_KEEPS = 0.25
"""A box is cut to its candidates only where the cut keeps this share of its area at least: less, and the
candidates are a part of the object or another thing in its box."""
FIT_ALONG = 0.8
"""...and this share of its extent along one of its sides at least: a detector's loose box errs along one
side (across a fork, along a knife: kept 0.99 and 0.83 of the other), where depth seeing only a piece of a
far, thin, curved thing (a banana 15 pixels long) is short of the box both ways (0.60 and 0.58)."""


def fitted_to_depth(
    det: Detection, candidates: list[Candidate], size_range: tuple[float, float] | None
) -> Detection:
    """`det` cut to the candidates it frames whose size fits the name's as a look-alike's must (`ALIKE_SLACK`:
    things of one kind differ in size more than the priors' range). YOLOv3-tiny boxes a fork or a knife
    lying on a table up to twice as wide as it is, where depth and colour see its extent. A box is never
    grown here; one framing no such candidate, or one the cut would leave under `FIT_KEEPS` of its area or
    short of it both ways (`FIT_ALONG`), is kept as the detector gave it."""
    if size_range is None:
        return det
    framed = [
        candidates[i].box
        for i in _framed(det, candidates)
        if fits_size(candidates[i].size, size_range, ALIKE_SLACK)
    ]
    if not framed:
        return det
    x0, y0, x1, y1 = det.box
    e0, f0, e1, f1 = enclosing(framed)
    cut = (max(x0, e0), max(y0, f0), min(x1, e1), min(y1, f1))
    if cut == det.box or cut[2] <= cut[0] or cut[3] <= cut[1] or _area(cut) < FIT_KEEPS * _area(det.box):
        return det
    along = max((cut[2] - cut[0]) / (x1 - x0), (cut[3] - cut[1]) / (y1 - y0))
    return det if along < FIT_ALONG else det.model_copy(update={"box": cut})


def faint_pick(faint: list[Detection], candidates: list[Candidate]) -> Detection | None:
    """The best of `faint` (boxes of one name under the detector's threshold) where it frames a candidate,
    and the name's best box on every other candidate scores under 1 / `FAINT_MARGIN` of it; else None."""
    best: dict[int, Detection] = {}
    for det in faint:
        for at in _framed(det, candidates):
            if at not in best or det.score > best[at].score:
                best[at] = det
    # one box framing two candidates (an object depth sees in two parts) points at one place
    ranked = sorted({id(d): d for d in best.values()}.values(), key=lambda d: -d.score)
    if not ranked or (len(ranked) > 1 and ranked[1].score * FAINT_MARGIN > ranked[0].score):
        return None
    return ranked[0]


def by_elimination(
    candidates: list[Candidate],
    others: list[Detection],
    size_range: tuple[float, float] | None,
    width: int,
    height: int,
    placement: str | None = None,
    coloured: Callable[[Candidate], bool] | None = None,
    height_range: tuple[float, float] | None = None,
) -> Candidate | None:
    """The one candidate that can be the object looked for by elimination, or None where none or several
    can: a candidate no box of another name explains (over its middle, with a score of `UNSURE`), whose
    size as depth sees it fits `size_range` (`fits_size`) and whose rise fits `height_range` (`fits_height`:
    a knife lies flat, a toaster stands; None: any), whole in the image (a candidate cut by the image's
    edge is most often the furniture the robot stands at), no part of the furniture, and where the object
    is put (`placement`: "surface", on furniture; "floor"; None: anywhere). Where several are left, the one
    of them whose colour is the object's (`coloured`: a carrot is orange), if one is."""
    if size_range is None:
        return None
    sure = [d for d in others if d.score >= UNSURE]
    left = [
        c
        for c in candidates
        if fits_size(c.size, size_range)
        and (height_range is None or fits_height(c.rise, height_range))
        and not _furniture(c)
        and not _misplaced(c, placement)
        and not at_edge(c.box, width, height)
        and not any(_inside(center(c.box), d.box) for d in sure)
    ]
    if len(left) > 1 and coloured is not None:
        left = [c for c in left if coloured(c)] or left
    return left[0] if len(left) == 1 else None


ALIKE = 0.9
"""A candidate looks like an object the detector saw where the hue-saturation histograms of what stands out
in their boxes correlate at least this much: in arrangements of one category, another of it scores 0.95 to
1.0 and other things under 0.5; a red apple beside a red mug scores over it, which is why what the detector
names as another class, surely, is not taken."""
EXEMPLAR = 0.1
"""A detection is an example of its name to look for more of where it scores at least this (the coco
detector's threshold: a faint box or elimination is no example)."""
ALIKE_SCORE = 0.002
"""The score of a candidate taken for its likeness: no detector saw it as the name."""
ALIKE_SLACK = (SIZE_SLACK[0], 2.0)
"""A candidate alike in colour is one more of the name where its size is within this share of the name's
size range: things of one kind differ in size more than a typical range says (a large stapler among
small ones), and a thing over twice the largest of its kind is no longer one."""
SAME_LEVEL_M = 0.05
"""...and where it stands on the level one it saw stands on (within this): more of a kind seen together
stand together (a row on a table), and a red toaster on a shelf is not one more of the red vase on the
table below it."""
ALIKE_SHAPE = 2.0
"""...and where its proportions are one's it saw, within this factor (`_proportion`): things of one kind
share a shape, and an orange carrot lying flat (four times as long as it rises) is not one more of a round
orange that the size range alone lets through."""


def alike(
    detector: Detector,
    frame: Frame,
    name: str,
    candidates: list[Candidate],
    found: list[Detection],
    claimed: list[Detection],
    sought: Sequence[str] = (),
    table: Priors | None = None,
) -> list[Detection]:
    """More of what `found` (a find's detections) saw, where the detector missed them: the candidates whose
    colours are those of an object it saw surely enough (`ALIKE`, `EXEMPLAR`), whose size as depth sees it
    fits the name's (`ALIKE_SLACK`), that stand on the level one of those stands on (`SAME_LEVEL_M`) and are
    of its proportions (`ALIKE_SHAPE`), whole in the image, no part of the furniture, where the object is
    put, and that no box explains: none of `found`, none of `claimed` (what other names' finds took), and no
    box the detector gives another class in the whole image with a score of `UNSURE` where the candidate is
    of that class's proportions; nor one that could be another of the `sought` names by its size and colour
    (a red apple beside a red mug). A closed-set detector only: it names every class it knows in one pass,
    so a thing it calls something else surely is that. `table`: the perception priors (default: the
    package's)."""
    table = table if table is not None else priors()
    mine = _class(detector, name)
    kind = table.find(name)
    sizes = name_sizes(detector, name, table)
    if sizes is None or getattr(detector, "class_of", None) is None:
        return []
    exemplars = [d for d in found if d.score >= EXEMPLAR and _on_candidate(d, candidates)]
    shown = [h for h in (_colours(frame.rgb, d.box) for d in exemplars) if h is not None]
    if not shown:
        return []
    examples = [candidates[i] for d in exemplars for i in _framed(d, candidates)]
    levels = [c.bottom for c in examples]
    whole = (0, 0, frame.width, frame.height)
    seen = [d for d in detect_in_views(detector, frame, ["object"], [whole]) if d.label != mine]
    # a class the detector gives the examples too is its confusion about their kind (YOLOv3-tiny boxes
    # a small apple as an orange at 0.7): it explains no candidate
    confused = {d.label for d in seen for e in exemplars if _inside(center(e.box), d.box)}
    rivals = [d for d in seen if d.label not in confused and d.score >= UNSURE]
    taken: list[Detection] = []
    for cand in candidates:
        if (
            not fits_size(cand.size, sizes, ALIKE_SLACK)
            or _furniture(cand)
            or _misplaced(cand, None if kind is None else kind.placement)
            or at_edge(cand.box, frame.width, frame.height)
            or any(_on(cand, d) for d in [*found, *claimed, *taken])
            # another class's box explains a place depth sees shaped as that class's objects can be only
            # (YOLOv3-tiny boxes a small bowl as a sports ball; no ball lies three times wider than it rises)
            or any(_on(cand, d) and _shaped_as_class(detector, d.label, cand, table) for d in rivals)
            or any(_could_be(frame.rgb, cand, other, table) for other in sought)
            or not _on_level_of(cand, levels)
            or not _shaped_like(cand, examples)
        ):
            continue
        colours = _colours(frame.rgb, cand.box)
        if colours is not None and max(_correlation(colours, h) for h in shown) >= ALIKE:
            taken.append(Detection(box=cand.box, score=ALIKE_SCORE, label=name, evidence="look-alike"))
    return taken


def _on_level_of(cand: Candidate, levels: list[float | None]) -> bool:
    """Whether a candidate stands on one of the `levels` (the heights over the floor the examples stand at,
    within `SAME_LEVEL_M`); False where depth does not say."""
    return cand.bottom is not None and any(
        level is not None and abs(cand.bottom - level) <= SAME_LEVEL_M for level in levels
    )


def _proportion(cand: Candidate) -> float | None:
    """A candidate's `_proportion_of`; None where its span is not measured."""
    return _proportion_of(cand.across, cand.rise) if cand.across > 0.0 else None


def _proportion_of(across: float, rise: float) -> float:
    """How much longer a thing spans across its level than it rises, each with `HEIGHT_MARGIN` added
    (depth's noise on what lies flat): what depth sees of a place and what the priors say of a kind are
    set side by side in one measure."""
    return (across + HEIGHT_MARGIN) / (rise + HEIGHT_MARGIN)


def _on(cand: Candidate, det: Detection) -> bool:
    """Whether a box is on a candidate's place: either's middle inside the other's box."""
    return _inside(center(cand.box), det.box) or _inside(center(det.box), cand.box)


def _shaped_as_class(detector: Detector, label: str, cand: Candidate, table: Priors) -> bool:
    """Whether a candidate's proportions (`_proportion`) are within `ALIKE_SHAPE` of those the priors' kinds
    of the closed-set class `label` have as they rest; True where neither says."""
    class_of = getattr(detector, "class_of", None)
    mine = _proportion(cand)
    shapes = None if class_of is None else _class_proportions(class_of, label, table)
    if mine is None or shapes is None:
        return True
    return shapes[0] / ALIKE_SHAPE <= mine <= shapes[1] * ALIKE_SHAPE


@cache
def _class_proportions(
    class_of: Callable[[str], str | None], label: str, table: Priors
) -> tuple[float, float] | None:
    # each range's low end is a small one of the kind, its high end a large one: paired, they are the shapes
    # of a small and a large one as they rest
    shapes = [
        _proportion_of(across, height)
        for k in _class_kinds(class_of, label, table)
        for across, height in zip(k.across_m, k.height_m, strict=True)
    ]
    return (min(shapes), max(shapes)) if shapes else None


def _shaped_like(cand: Candidate, examples: list[Candidate]) -> bool:
    """Whether a candidate's proportions are within `ALIKE_SHAPE` of one of the `examples`' (True where
    neither says: nothing rules it out)."""
    mine = _proportion(cand)
    theirs = [p for p in map(_proportion, examples) if p is not None]
    if mine is None or not theirs:
        return True
    return any(max(mine / p, p / mine) <= ALIKE_SHAPE for p in theirs)


def _could_be(rgb: np.ndarray, cand: Candidate, name: str, table: Priors) -> bool:
    """Whether a candidate may be an object called `name` by what the priors know of its kind: its size and
    its colour fit (True for a name the priors do not know, or a kind of no usual colour: nothing rules it
    out)."""
    kind = table.find(name)
    if kind is None:
        return True
    fits_colour = not kind.colours or colour_fits(rgb, cand.box, kind.colours, table)
    return fits_size(cand.size, kind.size_m) and fits_colour


def _colours(rgb: np.ndarray, box: tuple[float, float, float, float]) -> np.ndarray | None:
    """The hue-saturation histogram (18 x 8 bins, unit length) of what stands out in `box` from its rim;
    None where nothing does."""
    own = _standing_out(rgb, box)
    if own is None:
        return None
    hsv = cv2.cvtColor(own.astype(np.uint8)[None], cv2.COLOR_RGB2HSV)[0]
    hist, _, _ = np.histogram2d(hsv[:, 0], hsv[:, 1], bins=(18, 8), range=((0, 180), (0, 256)))
    flat = hist.ravel()
    return flat / max(float(np.linalg.norm(flat)), 1e-9)


def _correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson's correlation of two histograms (1: the same shape)."""
    a, b = a - a.mean(), b - b.mean()
    return float(a @ b / max(float(np.linalg.norm(a) * np.linalg.norm(b)), 1e-12))


COLOUR_OFF = 40.0
"""A pixel of a box whose colour is this far (RGB, 0-255) from the median of the box's rim is the object's."""
HUE_TOLERANCE = 25.0
CHROMATIC = 0.3
"""An object's colour is a named colour's where, both saturated over `CHROMATIC`, their hues lie within
`HUE_TOLERANCE` degrees, or where both are under it (silver, white, grey, black: light tells them apart)."""


def colour_fits(
    rgb: np.ndarray,
    box: tuple[float, float, float, float],
    colours: Sequence[str],
    table: Priors | None = None,
) -> bool:
    """Whether what stands out in `box` of the image from the box's rim has one of the named `colours`
    (colour words whose sRGB the priors give, `Priors.colours`); False where nothing stands out or no
    colour is named."""
    own = _standing_out(rgb, box) if colours else None
    if own is None:
        return False
    known = (table if table is not None else priors()).colours
    hue, sat = _hue_sat(np.median(own, axis=0) / 255.0)
    for name in colours:
        if name not in known:
            continue
        ref_hue, ref_sat = _hue_sat(np.asarray(known[name]) / 255.0)
        if (sat >= CHROMATIC) != (ref_sat >= CHROMATIC):
            continue
        if sat < CHROMATIC or min(abs(hue - ref_hue), 360 - abs(hue - ref_hue)) <= HUE_TOLERANCE:
            return True
    return False


def _standing_out(rgb: np.ndarray, box: tuple[float, float, float, float]) -> np.ndarray | None:
    """The pixels of `box` (RGB, 0-255, float) whose colour is `COLOUR_OFF` from the median of the box's
    rim: the object's, not what lies around it; None where fewer than 3 do."""
    grid = crop_array(rgb, box).astype(np.float64)
    if grid.shape[0] < 3 or grid.shape[1] < 3:
        return None
    rim = np.concatenate([grid[0], grid[-1], grid[:, 0], grid[:, -1]])
    patch = grid.reshape(-1, 3)
    own = patch[np.linalg.norm(patch - np.median(rim, axis=0), axis=1) > COLOUR_OFF]
    return own if len(own) >= 3 else None


def _hue_sat(rgb: np.ndarray) -> tuple[float, float]:
    """Hue (degrees) and saturation (0-1) of an RGB colour in 0-1."""
    h, s, _ = colorsys.rgb_to_hsv(float(rgb[0]), float(rgb[1]), float(rgb[2]))
    return h * 360.0, s


LEG_RISE_M, LEG_ASPECT = 0.35, 2.5
"""A candidate this tall over its level and this many times taller than wide (in the image) is a leg of the
furniture it stands under, not an object: not worth a drive."""
FLOOR_LEG_RISE_M = 0.15
"""...or this tall where it stands on the floor (a low table's leg)."""
PANEL_ACROSS = 0.03
"""Metres across the floor under which a candidate that stands is the edge of a panel (a bookcase's side)."""


def visit_order(
    candidates: list[Candidate],
    others: list[Detection],
    size_range: tuple[float, float] | None = None,
    placement: str | None = None,
) -> list[Candidate]:
    """The candidates worth driving nearer to, in the order to visit them: those no other name explains
    first (by the best score of a box of another name over their middle), then those whose size as depth
    sees it is nearest the size of what is looked for (`size_range`, metres: a mug is 8 to 12 cm), then the
    smaller (a detector misses the small ones); furniture legs left out."""

    def explained(cand: Candidate) -> float:
        middle = center(cand.box)
        return round(max((d.score for d in others if _inside(middle, d.box)), default=0.0), 1)

    def misfit(cand: Candidate) -> float:
        if size_range is None or cand.size <= 0:
            return 0.0
        # how far outside the size range (as a ratio): depth may see only part of an object (its near
        # side, its top), so a candidate somewhat smaller comes next, not last
        lo, hi = size_range
        return round(abs(math.log(min(max(cand.size, lo), hi) / cand.size)), 1)

    worth = [c for c in candidates if not _furniture(c)]
    return sorted(worth, key=lambda c: (_misplaced(c, placement), explained(c), misfit(c), c.pixels))


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
    except for a detector that looks at chosen views (`detect_views`: coco). The controller aims the camera
    at what it acts on, so that looks at the middle half of the image first, twice as large: where it shows
    the object whole (a box not cut by the half's edge), that is the answer, one forward pass; else (nothing
    there, or only a part) the whole image is looked at too, and both answers merged: two passes at most,
    where tiling the whole image took ten. A faint box whole in the middle is answer enough: the whole image
    shows the same object no surer and nothing else the controller looks for (of 39 such looks on four bench
    items, the whole image moved no box out of the middle)."""
    if getattr(detector, "detect_views", None) is None:
        return detector.detect(frame, [name])
    middle = (frame.width // 4, frame.height // 4, frame.width * 3 // 4, frame.height * 3 // 4)
    found = detect_in_views(detector, frame, [name], [middle])
    if any(not _cut_by(d.box, middle) for d in found):
        return found
    whole = (0, 0, frame.width, frame.height)
    return detect_in_views(detector, frame, [name], [whole, middle])


def _cut_by(box: tuple[float, float, float, float], view: tuple[int, int, int, int]) -> bool:
    """Whether a box found in `view` reaches its edge (the object may go on past it)."""
    return at_edge(
        (box[0] - view[0], box[1] - view[1], box[2] - view[0], box[3] - view[1]),
        view[2] - view[0],
        view[3] - view[1],
    )


def _on_candidate(det: Detection, candidates: list[Candidate]) -> bool:
    """Whether a detection frames one of the candidates (`_framed`)."""
    return bool(_framed(det, candidates))


def _framed(det: Detection, candidates: list[Candidate]) -> list[int]:
    """The indices of the candidates a detection frames: the candidate's middle inside the box, or the
    box's middle inside the candidate's box."""
    return [i for i, cand in enumerate(candidates) if _on(cand, det)]


def _inside(point: tuple[float, float], box: tuple[float, float, float, float]) -> bool:
    return box[0] <= point[0] <= box[2] and box[1] <= point[1] <= box[3]


FLOOR_M = 0.05
"""A candidate whose lowest point is this high at most stands on the floor (a leg reaches it too)."""


def _misplaced(cand: Candidate, placement: str | None) -> bool:
    """Whether a candidate stands where the object is not put: on the floor for what is put on furniture
    (a fork, a mug), on furniture for what stands on the floor (a basketball); False where either is not
    known."""
    if placement is None or cand.bottom is None:
        return False
    return (cand.bottom <= FLOOR_M) != (placement == "floor")


def _furniture(cand: Candidate) -> bool:
    """A candidate that is part of the furniture, not an object: a leg (this tall over its level, or over
    the floor, and this much taller than wide in the image), or a panel's edge (under `PANEL_ACROSS`
    across the floor and rising more than `LEG_ASPECT` times that). A thing that thin and standing (a book
    on its spine, a candle: the priors know both) is taken for a panel: a limit of this rule."""
    x0, y0, x1, y1 = cand.box
    if (y1 - y0) > LEG_ASPECT * max(x1 - x0, 1.0):
        on_floor = cand.bottom is not None and cand.bottom <= FLOOR_M
        if cand.rise > (FLOOR_LEG_RISE_M if on_floor else LEG_RISE_M):
            return True
    return 0.0 < cand.across < PANEL_ACROSS and cand.rise > LEG_ASPECT * cand.across


def _stands(det: Detection, standing: StandingMap) -> bool:
    """Whether depth may hold the object a detection sees: something stands in its box, or (for a sure
    detection) the box lies on a level, where a flat object lies without standing out; True where depth
    cannot tell."""
    stands = standing.stands_out(det.box)
    if stands is not False:
        return True
    return det.score >= UNSURE and bool(standing.lies_on_level(det.box))


def _area(box: tuple[float, float, float, float]) -> float:
    return max(box[2] - box[0], 0.0) * max(box[3] - box[1], 0.0)
