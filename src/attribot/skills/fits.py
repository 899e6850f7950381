"""How what depth and colour see of a place fits what the priors say of a kind: sizes, heights and
proportions (`fits_size`, `fits_height`, `shaped_like`), colours (`colour_fits`), where things are put and
what is furniture (`is_misplaced`, `is_furniture`), and how boxes sit on the places depth sees stand
(`framed_by`, `on_place`). Looking harder (`attribot.skills.harder`) weighs its evidence with these; the
values they weigh with are a `LookHarderParams` (`LOOK_HARDER` by default).
"""

from __future__ import annotations

import colorsys
from collections.abc import Callable, Sequence
from functools import cache

import cv2
import numpy as np

from attribot.boxes import Box, center, crop_array, enclosing, intersection
from attribot.control.candidates import Candidate, StandingMap
from attribot.frame import CameraInfo, Frame
from attribot.models.base import Detection, Detector
from attribot.priors import Kind, Priors, priors
from attribot.skills.params import LOOK_HARDER, LookHarderParams

__all__ = [
    "box_area",
    "class_kinds",
    "class_of_name",
    "class_proportions",
    "class_sizes",
    "colour_fits",
    "colours_of",
    "correlation",
    "could_be",
    "depth_sees_whole",
    "fits_class",
    "fits_height",
    "fits_kind",
    "fits_size",
    "fitted_to_depth",
    "framed_by",
    "grown_to_candidates",
    "hue_sat",
    "inside_box",
    "is_furniture",
    "is_misplaced",
    "kind_proportions",
    "name_sizes",
    "on_candidate",
    "on_place",
    "proportion",
    "proportion_of",
    "shaped_as_class",
    "shaped_as_kind",
    "shaped_like",
    "standing_out",
    "stands_in_depth",
]


def fits_class(
    detector: Detector,
    det: Detection,
    frame: Frame,
    camera: CameraInfo,
    table: Priors,
    params: LookHarderParams = LOOK_HARDER,
) -> bool:
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
    return fits_size(metres, sizes, params.size_slack)


@cache
def class_kinds(class_of: Callable[[str], str | None], label: str, table: Priors) -> tuple[Kind, ...]:
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
    kinds = class_kinds(class_of, label, table if table is not None else priors())
    return (min(k.size_m[0] for k in kinds), max(k.size_m[1] for k in kinds)) if kinds else None


def name_sizes(detector: Detector, name: str, table: Priors | None = None) -> tuple[float, float] | None:
    """The sizes an object called `name` has: its kind's in the priors, else those of the priors' kinds of
    the class the detector gives it; None where neither is known."""
    table = table if table is not None else priors()
    kind = table.find(name)
    return class_sizes(detector, class_of_name(detector, name), table) if kind is None else kind.size_m


def class_of_name(detector: Detector, name: str | None) -> str | None:
    """The one class a closed-set detector reaches with `name` (a mug: "cup"), else the name itself."""
    class_of = getattr(detector, "class_of", None)
    return (class_of(name) if class_of is not None and name else None) or name


def fits_size(
    size: float, size_range: tuple[float, float], slack: tuple[float, float] = LOOK_HARDER.size_slack
) -> bool:
    """Whether `size` (metres, as depth sees it) fits `size_range` within `slack`."""
    return size_range[0] * slack[0] <= size <= size_range[1] * slack[1]


def fits_height(
    rise: float, height_range: tuple[float, float], params: LookHarderParams = LOOK_HARDER
) -> bool:
    """Whether what depth sees rise `rise` metres over its level can be an object of `height_range` as it
    is put: a knife lying flat rises a centimetre or two, a toaster standing twenty."""
    low, high = height_range[0] * params.size_slack[0], height_range[1] * params.size_slack[1]
    return low - params.height_margin <= rise <= high + params.height_margin


def grown_to_candidates(
    det: Detection,
    candidates: list[Candidate],
    size_range: tuple[float, float] | None,
    params: LookHarderParams = LOOK_HARDER,
) -> Detection:
    """`det` (a faint box) grown to hold the candidates it frames whose size fits the name's: a faint box
    often frames a part of the object (a thin book's spine, the scissors' handles), where depth and colour
    see its whole extent."""
    if size_range is None:
        return det
    boxes = [
        det.box,
        *(
            candidates[i].box
            for i in framed_by(det, candidates)
            if fits_size(candidates[i].size, size_range, params.size_slack)
        ),
    ]
    if len(boxes) == 1:
        return det
    return det.model_copy(update={"box": enclosing(boxes)})


def fitted_to_depth(
    det: Detection,
    candidates: list[Candidate],
    size_range: tuple[float, float] | None,
    params: LookHarderParams = LOOK_HARDER,
) -> Detection:
    """`det` fitted to the candidates it frames whose size fits the name's as a look-alike's must
    (`alike_slack`: things of one kind differ in size more than the priors' range). YOLOv3-tiny boxes a fork
    or a knife lying on a table up to twice as wide as it is, where depth and colour see its extent: the box
    is cut to them. YOLOv5s boxes the head of a fork lying flat, a carrot's body without its leaves, the
    lower half of a clock: where the box frames one candidate, of the name's size as the priors give it
    (`size_slack`), that candidate is the object the detector boxed a part of, and its box the object's. A
    box framing no such candidate, or one the cut would leave under `fit_keeps` of its area or short of it
    both ways (`fit_along`: depth sees a piece of the object), is kept as the detector gave it."""
    if size_range is None:
        return det
    framed = [
        candidates[i]
        for i in framed_by(det, candidates)
        if fits_size(candidates[i].size, size_range, params.alike_slack)
    ]
    if not framed:
        return det
    seen = enclosing([c.box for c in framed])
    cut = intersection(det.box, seen)
    if not depth_sees_whole(det.box, cut, params):
        return det
    one = len(framed) == 1 and fits_size(framed[0].size, size_range, params.size_slack)
    fitted = seen if one else cut
    return det if fitted == det.box else det.model_copy(update={"box": fitted})


def depth_sees_whole(box: Box, seen: Box, params: LookHarderParams = LOOK_HARDER) -> bool:
    """Whether what depth sees in a detection's `box` (`seen`, inside it) is the whole object, not a part:
    it keeps `fit_keeps` of the box's area at least and `fit_along` of its extent along one side."""
    if seen[2] <= seen[0] or seen[3] <= seen[1] or box_area(seen) < params.fit_keeps * box_area(box):
        return False
    along = max((seen[2] - seen[0]) / (box[2] - box[0]), (seen[3] - seen[1]) / (box[3] - box[1]))
    return along >= params.fit_along


def proportion(cand: Candidate, params: LookHarderParams = LOOK_HARDER) -> float | None:
    """A candidate's `proportion_of`; None where its span is not measured."""
    return proportion_of(cand.across, cand.rise, params) if cand.across > 0.0 else None


def proportion_of(across: float, rise: float, params: LookHarderParams = LOOK_HARDER) -> float:
    """How much longer a thing spans across its level than it rises, each with `height_margin` added
    (depth's noise on what lies flat): what depth sees of a place and what the priors say of a kind are
    set side by side in one measure."""
    return (across + params.height_margin) / (rise + params.height_margin)


def shaped_as_class(
    detector: Detector, label: str, cand: Candidate, table: Priors, params: LookHarderParams = LOOK_HARDER
) -> bool:
    """Whether a candidate's proportions (`proportion`) are within `alike_shape` of those the priors' kinds
    of the closed-set class `label` have as they rest; True where neither says."""
    class_of = getattr(detector, "class_of", None)
    mine = proportion(cand, params)
    shapes = None if class_of is None else class_proportions(class_of, label, table, params)
    if mine is None or shapes is None:
        return True
    return shapes[0] / params.alike_shape <= mine <= shapes[1] * params.alike_shape


@cache
def class_proportions(
    class_of: Callable[[str], str | None], label: str, table: Priors, params: LookHarderParams
) -> tuple[float, float] | None:
    shapes = [p for k in class_kinds(class_of, label, table) for p in kind_proportions(k, params)]
    return (min(shapes), max(shapes)) if shapes else None


def kind_proportions(kind: Kind, params: LookHarderParams = LOOK_HARDER) -> tuple[float, float]:
    """The `proportion_of` a small and a large one of `kind` as they rest: each range's low end is a small
    one's, its high end a large one's."""
    small, large = (proportion_of(a, h, params) for a, h in zip(kind.across_m, kind.height_m, strict=True))
    return small, large


def fits_kind(cand: Candidate, kind: Kind, params: LookHarderParams = LOOK_HARDER) -> bool:
    """Whether a candidate can be an object of `kind` as depth sees it: its size, its rise and its
    proportions."""
    return (
        fits_size(cand.size, kind.size_m, params.size_slack)
        and fits_height(cand.rise, kind.height_m, params)
        and shaped_as_kind(cand, kind, params)
    )


def shaped_as_kind(cand: Candidate, kind: Kind, params: LookHarderParams = LOOK_HARDER) -> bool:
    """Whether a candidate's proportions are within `alike_shape` of those of `kind` as it rests (a candle,
    thin and standing, is no backpack of the candle's height); True where depth did not measure its span."""
    mine = proportion(cand, params)
    if mine is None:
        return True
    shapes = kind_proportions(kind, params)
    return min(shapes) / params.alike_shape <= mine <= max(shapes) * params.alike_shape


def shaped_like(cand: Candidate, examples: list[Candidate], params: LookHarderParams = LOOK_HARDER) -> bool:
    """Whether a candidate's proportions are within `alike_shape` of one of the `examples`' (True where
    neither says: nothing rules it out)."""
    mine = proportion(cand, params)
    theirs = [p for p in (proportion(e, params) for e in examples) if p is not None]
    if mine is None or not theirs:
        return True
    return any(max(mine / p, p / mine) <= params.alike_shape for p in theirs)


def could_be(
    rgb: np.ndarray, cand: Candidate, name: str, table: Priors, params: LookHarderParams = LOOK_HARDER
) -> bool:
    """Whether a candidate may be an object called `name` by what the priors know of its kind: its size and
    its colour fit (True for a name the priors do not know, or a kind of no usual colour: nothing rules it
    out)."""
    kind = table.find(name)
    if kind is None:
        return True
    fits_colour = not kind.colours or colour_fits(rgb, cand.box, kind.colours, table, params)
    return fits_size(cand.size, kind.size_m, params.size_slack) and fits_colour


def colours_of(
    rgb: np.ndarray, box: tuple[float, float, float, float], params: LookHarderParams = LOOK_HARDER
) -> np.ndarray | None:
    """The hue-saturation histogram (18 x 8 bins, unit length) of what stands out in `box` from its rim;
    None where nothing does."""
    own = standing_out(rgb, box, params)
    if own is None:
        return None
    hsv = cv2.cvtColor(own.astype(np.uint8)[None], cv2.COLOR_RGB2HSV)[0]
    hist, _, _ = np.histogram2d(hsv[:, 0], hsv[:, 1], bins=(18, 8), range=((0, 180), (0, 256)))
    flat = hist.ravel()
    return flat / max(float(np.linalg.norm(flat)), 1e-9)


def correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson's correlation of two histograms (1: the same shape)."""
    a, b = a - a.mean(), b - b.mean()
    return float(a @ b / max(float(np.linalg.norm(a) * np.linalg.norm(b)), 1e-12))


def colour_fits(
    rgb: np.ndarray,
    box: tuple[float, float, float, float],
    colours: Sequence[str],
    table: Priors | None = None,
    params: LookHarderParams = LOOK_HARDER,
) -> bool:
    """Whether what stands out in `box` of the image from the box's rim has one of the named `colours`
    (colour words whose sRGB the priors give, `Priors.colours`); False where nothing stands out or no
    colour is named."""
    own = standing_out(rgb, box, params) if colours else None
    if own is None:
        return False
    known = (table if table is not None else priors()).colours
    hue, sat = hue_sat(np.median(own, axis=0) / 255.0)
    for name in colours:
        if name not in known:
            continue
        ref_hue, ref_sat = hue_sat(np.asarray(known[name]) / 255.0)
        if (sat >= params.chromatic) != (ref_sat >= params.chromatic):
            continue
        if (
            sat < params.chromatic
            or min(abs(hue - ref_hue), 360 - abs(hue - ref_hue)) <= params.hue_tolerance
        ):
            return True
    return False


def standing_out(
    rgb: np.ndarray, box: tuple[float, float, float, float], params: LookHarderParams = LOOK_HARDER
) -> np.ndarray | None:
    """The pixels of `box` (RGB, 0-255, float) whose colour is `colour_off` from the median of the box's
    rim: the object's, not what lies around it; None where fewer than 3 do."""
    grid = crop_array(rgb, box).astype(np.float64)
    if grid.shape[0] < 3 or grid.shape[1] < 3:
        return None
    rim = np.concatenate([grid[0], grid[-1], grid[:, 0], grid[:, -1]])
    patch = grid.reshape(-1, 3)
    own = patch[np.linalg.norm(patch - np.median(rim, axis=0), axis=1) > params.colour_off]
    return own if len(own) >= 3 else None


def hue_sat(rgb: np.ndarray) -> tuple[float, float]:
    """Hue (degrees) and saturation (0-1) of an RGB colour in 0-1."""
    h, s, _ = colorsys.rgb_to_hsv(float(rgb[0]), float(rgb[1]), float(rgb[2]))
    return h * 360.0, s


def on_place(cand: Candidate, det: Detection) -> bool:
    """Whether a box is on a candidate's place: either's middle inside the other's box."""
    return inside_box(center(cand.box), det.box) or inside_box(center(det.box), cand.box)


def on_candidate(det: Detection, candidates: list[Candidate]) -> bool:
    """Whether a detection frames one of the candidates (`framed_by`)."""
    return bool(framed_by(det, candidates))


def framed_by(det: Detection, candidates: list[Candidate]) -> list[int]:
    """The indices of the candidates a detection frames: the candidate's middle inside the box, or the
    box's middle inside the candidate's box."""
    return [i for i, cand in enumerate(candidates) if on_place(cand, det)]


def inside_box(point: tuple[float, float], box: tuple[float, float, float, float]) -> bool:
    return box[0] <= point[0] <= box[2] and box[1] <= point[1] <= box[3]


def is_misplaced(cand: Candidate, placement: str | None, params: LookHarderParams = LOOK_HARDER) -> bool:
    """Whether a candidate stands where the object is not put: on the floor for what is put on furniture
    (a fork, a mug), on furniture for what stands on the floor (a basketball); False where either is not
    known."""
    if placement is None or cand.bottom is None:
        return False
    return (cand.bottom <= params.floor_m) != (placement == "floor")


def is_furniture(cand: Candidate, params: LookHarderParams = LOOK_HARDER) -> bool:
    """A candidate that is part of the furniture, not an object: a leg (this tall over its level, or over
    the floor, and this much taller than wide, in the image or across the floor), or a panel's edge (under
    `panel_across` across the floor and rising more than `leg_aspect` times that), or what holds a board up
    (`capped`: a bookcase's side between two boards). A thing that thin and standing (a book on its spine,
    a candle: the priors know both) is taken for a panel, and one that fills the room under a shelf to its
    board for a side: limits of this rule."""
    if cand.capped:
        return True
    x0, y0, x1, y1 = cand.box
    tall_in_image = (y1 - y0) > params.leg_aspect * max(x1 - x0, 1.0)
    if tall_in_image or 0.0 < params.leg_aspect * cand.across < cand.rise:
        on_floor = cand.bottom is not None and cand.bottom <= params.floor_m
        if cand.rise > (params.floor_leg_rise_m if on_floor else params.leg_rise_m):
            return True
    return 0.0 < cand.across < params.panel_across and cand.rise > params.leg_aspect * cand.across


def stands_in_depth(det: Detection, standing: StandingMap, params: LookHarderParams = LOOK_HARDER) -> bool:
    """Whether depth may hold the object a detection sees: something stands in its box, or (for a sure
    detection) the box lies on a level, where a flat object lies without standing out; True where depth
    cannot tell."""
    stands = standing.stands_out(det.box)
    if stands is not False:
        return True
    return det.score >= params.unsure and bool(standing.lies_on_level(det.box))


def box_area(box: tuple[float, float, float, float]) -> float:
    return max(box[2] - box[0], 0.0) * max(box[3] - box[1], 0.0)
