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
and height (a knife lies flat, a toaster stands) that no box of another name explains (`eliminable`; where
none, that only a box of a name the program does not ask about explains: `_eliminated`). And
where the detector saw some objects of the name but not all (a row of carrots, one of them boxed), the places
that look like one it saw, in colour and size, and that nothing else explains are more of it (`alike`). What
they give has the low score it earned, and the trace says how it was taken. Only detectors that read pixels
look harder (a zoomed view shows them more); the oracle reads the simulator's segmentation.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cache, partial

import numpy as np

from attribot.boxes import at_edge, center, intersection, iou, overlap_of_smaller
from attribot.control.base import Capture
from attribot.control.candidates import LOW_RISE_M, STRIDE, Candidate, StandingMap
from attribot.control.spatial import nearest_surface, projected_box, to_base, to_world
from attribot.errors import InputError
from attribot.frame import CameraInfo, Frame
from attribot.lexicon import SURFACE_WORDS
from attribot.models.base import Detection, Detector, detect_in_views, evidence_of
from attribot.priors import Kind, Priors, priors
from attribot.skills.fits import (
    box_area,
    class_of_name,
    colour_fits,
    depth_sees_whole,
    fits_class,
    fits_kind,
    fits_size,
    fitted_to_depth,
    framed_by,
    grown_to_candidates,
    inside_box,
    is_furniture,
    name_sizes,
    on_candidate,
    shaped_as_class,
    shaped_as_kind,
    stands_in_depth,
)
from attribot.skills.lookalikes import (
    alike,
    eliminable,
    faint_pick,
    one_name_each,
    one_object,
    visit_order,
)
from attribot.skills.params import LOOK_HARDER, LookHarderParams

__all__ = [
    "LookHarderReport",
    "Nearer",
    "acting_find",
    "carried_back",
    "closed_world",
    "confirmed",
    "look_harder",
    "standing_in",
    "zoom_views",
]

Nearer = Callable[[str, list[Candidate]], tuple[list[Detection], int]]
"""Drives nearer to candidates in turn and looks for a name there: (detections in the first image, visits)."""

_STANDING: weakref.WeakKeyDictionary[Frame, tuple[Capture, StandingMap, list[Candidate]]]
_STANDING = weakref.WeakKeyDictionary()


@dataclass
class LookHarderReport:
    """What looking harder did for one find: shown in the trace and the answer's checks."""

    candidates: int  # regions where depth sees something stand
    views: int  # zoomed views looked at
    added: int  # detections found in them
    set_aside: int  # boxes on one thing of a size no object of the name has (`_misfits`)
    visits: int = 0  # places the robot drove nearer to
    found_nearer: int = 0  # detections seen from nearer
    faint: float | None = None  # the score of the faint box taken, where one was
    eliminated: int = 0  # candidates of the name's size no other name explains, where one was taken
    # the name the detector gives the one taken by elimination, where it names it as something the program
    # does not ask about (a toaster boxed as a suitcase)
    named_otherwise: str | None = None
    alike: int = 0  # candidates that look like an object of the name the detector saw, taken as more of it
    yielded: int = 0  # boxes left to another name whose object is there (`one_name_each`)
    doubled: int = 0  # faint boxes on the object a surer box of the name is on (`_one_box_each_object`)
    fitted: int = 0  # boxes fitted to what depth sees of the object in them (`fitted_to_depth`)
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
        if self.eliminated and self.named_otherwise:
            text += (
                "; took by elimination the one thing of the name's size and shape, which the detector calls"
                f" only a {self.named_otherwise}, a name the program does not ask about"
            )
        elif self.eliminated:
            text += "; took by elimination the one thing of the name's size that no other name explains"
        if self.alike:
            text += f"; took {self.alike} more that look like the one it saw (their colours, their size)"
        if self.set_aside:
            text += f"; {self.set_aside} set aside: the thing there is of a size its kind never has"
        if self.yielded:
            text += f"; {self.yielded} left to another name whose object is there"
        if self.doubled:
            text += f"; {self.doubled} faint boxes dropped: each on the object a surer box of the name is on"
        if self.fitted:
            text += f"; {self.fitted} boxes fitted to what depth sees of the object in them"
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
    boxes: Sequence[tuple[float, float, float, float]],
    width: int,
    height: int,
    params: LookHarderParams = LOOK_HARDER,
) -> list[tuple[int, int, int, int]]:
    """Square views around the boxes (the candidates', largest first), inside the image; a view much like
    one already chosen is left out."""
    views: list[tuple[int, int, int, int]] = []
    for x0, y0, x1, y1 in boxes:
        side = int(min(max(params.zoom * max(x1 - x0, y1 - y0), params.min_view), width, height))
        left = int(np.clip((x0 + x1) / 2 - side / 2, 0, width - side))
        top = int(np.clip((y0 + y1) / 2 - side / 2, 0, height - side))
        view = (left, top, left + side, top + side)
        if all(iou(view, v) < 0.5 for v in views):
            views.append(view)
        if len(views) >= params.max_views:
            break
    return views


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
    params: LookHarderParams = LOOK_HARDER,
) -> tuple[list[Detection], LookHarderReport] | None:
    """The find's detections after looking harder (module docstring) and what it did; None without depth and
    a camera pose. `nearer` (a robot that drives) looks from nearer at the candidates in `visit_order`;
    `claimed`: the boxes other names' finds took here, each its object's (if of another class); `sought`:
    the other names looked for; `table`: the perception priors (default: unscaled); `params`: the values."""
    if frame.depth is None or capture.camera is None or capture.view is None:
        return None
    table = table if table is not None else priors()
    standing, candidates = standing_in(frame, capture)
    kept = _standing(detections, name, frame, standing, params)
    report = LookHarderReport(len(candidates), 0, 0, len(detections) - len(kept))

    @cache
    def best_rivals() -> list[Detection]:  # the other sought names' best boxes, looked for once
        return _best_of(detector, frame, name, sought or [], [])

    mine = class_of_name(detector, name)

    def one_each(found: list[Detection]) -> list[Detection]:
        if not found:
            return found
        taken = [d for d in claimed or [] if class_of_name(detector, d.label) != mine]
        left = one_name_each(found, [*taken, *(best_rivals() if sought else [])], candidates, params.unsure)
        report.yielded += len(found) - len(left)
        return _one_box_each_object(left, candidates, report, params)

    kept = one_each(kept)
    if not candidates:
        return kept, report
    kept = _without_misfits(detector, name, kept, candidates, report, table, params)
    if all(d.score < params.unsure for d in kept):
        merged, views = _zoomed_in(detector, frame, name, candidates, kept, params)
        report.views, report.added = len(views), len(merged) - len(kept)
        if not merged:  # nothing of the name seen at all: weaker evidence, and a closer look
            claimed = [*(claimed or []), *_best_of(detector, frame, name, sought or [], views)]
            weighed = (candidates, views, nearer, claimed, sought or [], report, table, params)
            merged = _unseen(detector, frame, capture.camera, name, *weighed)
            report.took = list(merged) if report.taken else []
        merged.sort(key=lambda d: -d.score)
        kept = one_each(merged)
    kept = _fitted(detector, name, kept, candidates, report, table, params)
    kept = _without_misfits(detector, name, kept, candidates, report, table, params)  # the zoomed views' too
    # each sought name's best box explains its place, as in one_each (alike takes nothing with no example)
    explained = best_rivals() if sought and any(d.score >= params.exemplar for d in kept) else []
    rivals = [*(claimed or []), *explained]
    more = alike(detector, frame, name, candidates, kept, rivals, sought or [], table, params)
    report.alike, more = len(more), confirmed(more, candidates, name, nearer, report)
    report.took = [*report.took, *more]
    return kept + more, report


def _one_box_each_object(
    found: list[Detection], candidates: list[Candidate], report: LookHarderReport, params: LookHarderParams
) -> list[Detection]:
    """`found` (one name's boxes) less each faint box on the object a surer box of the name is on
    (`one_object`), counted in `report`: a bookcase boxed faintly as a book around the book on its shelf, or
    a table around the book on it, would be measured as one more book, and the gripper sent to it closes on
    nothing."""
    surest_first = sorted(found, key=lambda d: -d.score)
    doubled = [
        d
        for i, d in enumerate(surest_first)
        if d.score < params.unsure and any(one_object(d, surer, candidates) for surer in surest_first[:i])
    ]
    report.doubled += len(doubled)
    return [d for d in found if not any(d is x for x in doubled)]


def _standing(
    detections: list[Detection], name: str, frame: Frame, standing: StandingMap, params: LookHarderParams
) -> list[Detection]:
    """`detections` less the small boxes where depth sees nothing stand (`stands_in_depth`); a surface's
    name (a table, the floor) keeps them all."""
    if name.lower() in SURFACE_WORDS:
        return detections
    small = frame.width * frame.height * params.small_box
    return [d for d in detections if box_area(d.box) >= small or stands_in_depth(d, standing, params)]


def _without_misfits(
    detector: Detector,
    name: str,
    found: list[Detection],
    candidates: list[Candidate],
    report: LookHarderReport,
    table: Priors,
    params: LookHarderParams,
) -> list[Detection]:
    """`found` less its `_misfits`, counted as set aside in `report`; what weaker evidence took stays (it
    was taken for its size)."""
    misfits = [
        d
        for d in _misfits(detector, name, found, candidates, table, params)
        if not any(d is t for t in report.took)
    ]
    report.set_aside += len(misfits)
    return [d for d in found if not any(d is m for m in misfits)]


def _misfits(
    detector: Detector,
    name: str,
    found: list[Detection],
    candidates: list[Candidate],
    table: Priors,
    params: LookHarderParams,
) -> list[Detection]:
    """The boxes of `found` on one thing whose size, as depth sees it, no object called `name` has
    (`fits_size`): YOLOv3-tiny boxes a 6 cm potato faintly as a sports ball and YOLOv5s surely, and a
    basketball is 24 cm across. A box on several things or on none is left as it is (depth sees it with its
    neighbour, or not at all), and so is one where depth sees only a part of its thing (`depth_sees_whole`):
    a far bottle's foot, the near end of a banana lying on a shelf."""
    sizes = name_sizes(detector, name, table)
    if sizes is None:
        return []
    out = []
    for det in found:
        framed = framed_by(det, candidates)
        if len(framed) != 1:
            continue
        cand = candidates[framed[0]]
        whole = depth_sees_whole(det.box, intersection(det.box, cand.box), params)
        if cand.size > 0 and whole and not fits_size(cand.size, sizes, params.size_slack):
            out.append(det)
    return out


def _zoomed_in(
    detector: Detector,
    frame: Frame,
    name: str,
    candidates: list[Candidate],
    kept: list[Detection],
    params: LookHarderParams,
) -> tuple[list[Detection], list[tuple[int, int, int, int]]]:
    """`kept` and the boxes of the name that views zoomed in on the candidates show on them (a box on an
    object kept already is that one), and those views."""
    views = zoom_views([c.box for c in candidates], frame.width, frame.height, params)
    zoomed = [d for d in detect_in_views(detector, frame, [name], views) if on_candidate(d, candidates)]
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
    params: LookHarderParams,
) -> list[Detection]:
    """`kept` with what the detector boxed fitted to what depth sees (`fitted_to_depth`), counted in `report`;
    what weaker evidence took (a candidate's box, a faint box grown to it) as it was taken."""
    sizes = name_sizes(detector, name, table)
    fitted = [
        d if any(d is t for t in report.took) else fitted_to_depth(d, candidates, sizes, params) for d in kept
    ]
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
    sought: list[str],
    report: LookHarderReport,
    table: Priors,
    params: LookHarderParams,
) -> list[Detection]:
    """For a name the zoomed views did not show: a faint box that points at one candidate no other name's
    find took, else what the robot sees from nearer, else the one candidate left by elimination (noted in
    `report`). `sought`: the program's other names, whose objects no box shows may be what else is left."""
    # a place another name's find took holds that object
    free = [c for c in candidates if not any(inside_box(center(c.box), d.box) for d in claimed)]
    kind = table.find(name)
    sizes = None if kind is None else kind.size_m
    explaining, closed = _world_check(
        detector, frame, camera, name, candidates, views, claimed, sought, table, params
    )

    faint = faint_pick(detect_in_views(detector, frame, [name], views, threshold=params.faint), free, params)
    if faint is not None:
        report.faint = faint.score
        grown = grown_to_candidates(faint, free, sizes, params).model_copy(update={"evidence": "faint box"})
        return confirmed([grown], candidates, name, nearer, report, closed)
    others = explaining()
    placement = None if kind is None else kind.placement
    if nearer is not None:
        seen = _seen_nearer(nearer, name, visit_order(candidates, others, sizes, placement, params), report)
        if seen:
            return seen if _stands(seen, report, closed) else []
    colours = () if kind is None else kind.colours

    def coloured(cand: Candidate) -> bool:
        return colour_fits(frame.rgb, cand.box, colours, table, params)

    weigh = partial(
        eliminable,
        size_range=sizes,
        width=frame.width,
        height=frame.height,
        placement=placement,
        coloured=coloured,
        height_range=None if kind is None else kind.height_m,
        params=params,
        shaped=None if kind is None else partial(shaped_as_kind, kind=kind, params=params),
    )
    left = _eliminated(detector, weigh, candidates, others, claimed, sought, report, params)
    if left is None:
        return []
    eliminated = Detection(box=left.box, score=params.eliminated_score, label=name, evidence="elimination")
    return confirmed([eliminated], candidates, name, nearer, report, closed)


def _eliminated(
    detector: Detector,
    weigh: Callable[[list[Candidate], list[Detection]], list[Candidate]],
    candidates: list[Candidate],
    others: list[Detection],
    claimed: list[Detection],
    sought: list[str],
    report: LookHarderReport,
    params: LookHarderParams,
) -> Candidate | None:
    """The one candidate left by elimination (`weigh`: `eliminable` with the name's priors), noted in
    `report`. Where no box leaves one, a closed-set detector may name the object as something else: a
    toaster, which no detector here names, boxed surely as a suitcase or a book. So where no place nothing
    explains fits, the one that fits and that only a box of a name the program does not ask about explains
    is taken (`named_otherwise`), as weak as any elimination: confirmed from nearer, kept only in a closed
    world, said to be a guess. Where several fit, none is taken."""
    left = weigh(candidates, others)
    if not left:
        asked = {class_of_name(detector, n) for n in sought}
        theirs = [d for d in others if class_of_name(detector, d.label) in asked]
        left = weigh(candidates, [*theirs, *(d.model_copy(update={"score": 1.0}) for d in claimed)])
        if len(left) == 1:
            there = [d for d in others if d.score >= params.unsure and inside_box(center(left[0].box), d.box)]
            report.named_otherwise = max(there, key=lambda d: d.score).label if there else None
    if len(left) != 1:
        return None
    report.eliminated = 1
    return left[0]


def _seen_nearer(
    nearer: Nearer, name: str, places: list[Candidate], report: LookHarderReport
) -> list[Detection]:
    """What the robot sees of `name` driving nearer to `places` in turn, one box per object (boxes of one
    object seen from two places land on each other), counted in `report`."""
    seen, report.visits = nearer(name, places)
    kept: list[Detection] = []
    for det in seen:
        if all(overlap_of_smaller(det.box, o.box) < 0.5 for o in kept):
            kept.append(det)
    report.found_nearer = len(kept)
    return kept


def _stands(seen: list[Detection], report: LookHarderReport, closed: Callable[[Detection], bool]) -> bool:
    """Whether what was seen from nearer stands: a sure box does; boxes all under the sure score are an
    inference like any faint box (in a room of things the detector cannot name, a feather seen nearer as a
    spoon at 0.13 while no spoon is there), standing only where the world is closed around them."""
    if any(evidence_of(d) != "faint box" for d in seen) or all(closed(d) for d in seen):
        return True
    report.unconfirmed += len(seen)
    return False


def _world_check(
    detector: Detector,
    frame: Frame,
    camera: CameraInfo,
    name: str,
    candidates: list[Candidate],
    views: list[tuple[int, int, int, int]],
    claimed: list[Detection],
    sought: list[str],
    table: Priors,
    params: LookHarderParams,
) -> tuple[Callable[[], list[Detection]], Callable[[Detection], bool]]:
    """The boxes that explain a place while `name` is sought (`_explaining`, looked for once), and whether
    the world is closed around what an inference took (`closed_world`)."""
    explaining = cache(lambda: _explaining(detector, frame, camera, name, views, claimed, table, params))

    def explains(place: Candidate, box: Detection) -> bool:
        # another name's object explains its place whatever its shape (that find's own evidence); a box the
        # detector gave only where depth sees a thing of its class's shape (a CD lying flat, boxed surely
        # as a sports ball, is no ball: it stays one more thing no name explains)
        mine = any(box.box == c.box for c in claimed)
        return mine or shaped_as_class(detector, box.label, place, table, params)

    def closed(taken: Detection) -> bool:
        others = _unboxed(detector, name, sought, claimed, table)
        return closed_world(
            candidates, explaining(), frame.width, frame.height, params, others, taken.box, explains
        )

    return explaining, closed


def _unboxed(
    detector: Detector, name: str, sought: list[str], claimed: list[Detection], table: Priors
) -> list[Kind]:
    """The kinds of the program's other names (`sought`) that no box here shows (`claimed`)."""
    boxed = {class_of_name(detector, d.label) for d in claimed} | {class_of_name(detector, name)}
    kinds = [table.find(n) for n in sought if class_of_name(detector, n) not in boxed]
    return [k for k in kinds if k is not None]


def _explaining(
    detector: Detector,
    frame: Frame,
    camera: CameraInfo,
    name: str,
    views: list[tuple[int, int, int, int]],
    claimed: list[Detection],
    table: Priors,
    params: LookHarderParams,
) -> list[Detection]:
    """The boxes that explain a place when `name` is sought: every other class's in the image and the
    zoomed views, and what other names' finds took (`claimed`, each its object whatever its score)."""
    # a box of the name's own class, or of a class another name of the program stands for, explains no
    # place: each of those names is one object, its best box (in `claimed`)
    mine = {class_of_name(detector, name), *(class_of_name(detector, d.label) for d in claimed)}
    seen = detect_in_views(detector, frame, ["object"], [(0, 0, frame.width, frame.height), *views])
    # nor does a box of a size no object of its class has (a bowl 3 m away boxed as a 7 cm carrot)
    found = [d for d in seen if d.label not in mine and fits_class(detector, d, frame, camera, table, params)]
    return found + [d.model_copy(update={"score": 1.0}) for d in claimed]


def closed_world(
    candidates: list[Candidate],
    explaining: list[Detection],
    width: int,
    height: int,
    params: LookHarderParams = LOOK_HARDER,
    sought: Sequence[Kind] = (),
    taken: tuple[float, float, float, float] | None = None,
    explains: Callable[[Candidate, Detection], bool] | None = None,
) -> bool:
    """Whether depth sees at most one thing here that no sure box explains (furniture, what the image's
    edge cuts and lines aside): a world closed enough for an argument by elimination, where everything else
    is named. A room with things the detector cannot name leaves several unexplained. A line one map pixel
    thick (where a cabinet meets the floor, a chair's edge) is depth's finest: as often a seam between two
    surfaces as a thing, it does not open the world; an object seen whole is thicker. `sought`: the kinds of
    the program's other objects that no box shows (a fork and a toaster asked about together, neither named
    by the detector): the one place that only one of them fits is that one, not one more unnamed thing.
    `taken`: the box an inference took for the object sought; everything but what lies there must then be
    named. A faint box of a mouse on what the detector surely boxes as a sports ball, beside one thing
    nothing names, leaves that thing as likely the mouse; a toaster boxed surely as a suitcase in a room where
    all else is named is the toaster. `explains`: whether a sure box over a place explains it (by default,
    every one does); a real room's things are boxed surely under names they have nothing of. A piece of
    what the edge cuts (a chair's post beside its seat) or of what was taken (a spoon lying flat, which
    depth sees in two pieces) is no other thing."""
    sure = [d for d in explaining if d.score >= params.unsure]
    cut = [c for c in candidates if at_edge(c.box, width, height)]
    unexplained = [
        c
        for c in candidates
        if min(c.box[2] - c.box[0], c.box[3] - c.box[1]) > STRIDE
        and not is_furniture(c, params)
        and not at_edge(c.box, width, height)
        and not any(_piece_of(c, edge) for edge in cut)
        and not any(inside_box(center(c.box), d.box) and (explains is None or explains(c, d)) for d in sure)
    ]
    if taken is not None:
        of_taken = [c for c in unexplained if inside_box(center(c.box), taken) or _lying_beside(c, taken)]
        unexplained = [c for c in unexplained if c not in of_taken]
    for kind in sought:
        fitting = [c for c in unexplained if fits_kind(c, kind, params)]
        if len(fitting) == 1:
            unexplained.remove(fitting[0])
    return len(unexplained) <= (0 if taken is not None else 1)


def _piece_of(cand: Candidate, whole: Candidate) -> bool:
    """Whether `cand` is a piece of `whole` that depth parted from it: half of its box on the whole's, its
    foot within the whole's heights (a chair's post beside its seat; a thing on that seat stands above
    it)."""
    if cand.bottom is None or whole.bottom is None:
        return False
    # a foot as low as the whole's, give or take depth's 2 cm at a few metres, up to the whole's top
    within = whole.bottom - 0.02 <= cand.bottom <= whole.bottom + whole.rise
    smaller = box_area(cand.box) <= box_area(whole.box)
    return within and smaller and overlap_of_smaller(cand.box, whole.box) >= 0.5


def _lying_beside(cand: Candidate, taken: tuple[float, float, float, float]) -> bool:
    """Whether `cand` lies flat within two map pixels of `taken`: a piece of a thing lying flat (a spoon's
    bowl and its handle), which depth sees in parts where it rises least."""
    x0, y0, x1, y1 = cand.box
    gap = max(taken[0] - x1, x0 - taken[2], taken[1] - y1, y0 - taken[3])
    return cand.rise < LOW_RISE_M and gap <= 2 * STRIDE


def confirmed(
    inferred: list[Detection],
    candidates: list[Candidate],
    name: str,
    nearer: Nearer | None,
    report: LookHarderReport,
    closed: Callable[[Detection], bool] | None = None,
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
        elif closed is not None and closed(det):
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
