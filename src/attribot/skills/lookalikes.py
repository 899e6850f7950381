"""Looking harder's weaker evidence, for a name the detector did not see surely: a faint box that points
at one place (`faint_pick`), the one place left by elimination (`eliminable`), places that look like
one the detector saw (`alike`), the order to drive nearer to places in (`visit_order`), and one name for
each object (`one_name_each`, `one_object`). `attribot.skills.harder` weighs them in this order.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from attribot.boxes import at_edge, center, iou
from attribot.control.candidates import Candidate
from attribot.frame import Frame
from attribot.models.base import Detection, Detector, detect_in_views
from attribot.priors import Priors, priors
from attribot.skills.fits import (
    class_of_name,
    colours_of,
    correlation,
    could_be,
    fits_height,
    fits_size,
    framed_by,
    inside_box,
    is_furniture,
    is_misplaced,
    name_sizes,
    on_candidate,
    on_place,
    shaped_as_class,
    shaped_like,
)
from attribot.skills.params import LOOK_HARDER, LookHarderParams

__all__ = ["alike", "eliminable", "faint_pick", "one_name_each", "one_object", "visit_order"]


def one_name_each(
    found: list[Detection],
    rivals: list[Detection],
    candidates: Sequence[Candidate] = (),
    sure: float = LOOK_HARDER.unsure,
) -> list[Detection]:
    """`found` (one name's boxes) less those on the object of another name's box in `rivals` (the best box
    of another name the program looks for, or what another name's find took), one object, one name: a box
    that is not the name's best yields to the other name there (YOLOv3-tiny boxes a computer mouse as a
    clock at 0.19 and as a mouse at 0.18, beside the alarm clock it boxes at 0.63; a bowl as a sports ball
    at 0.18, beside a basketball it boxes at 0.29), and so does its best where the other name scores
    higher there (an orange boxed as an apple at 0.17 and as an orange at 0.31, beside an apple boxed at
    0.11; a cactus's pot boxed as a vase, under the cactus's box: `one_object`). The best box is kept
    whatever yields, unless it is faint (under `sure`) and the other name's box there is sure: then the
    object there is the other name's, and nothing of this name is seen (asked whether the scissors or the
    knife is closer in a room with no scissors, YOLOv5s boxes the knife as scissors at 0.12 and as a knife
    at 0.55)."""
    if not found:
        return []
    best = max(found, key=lambda d: d.score)

    def yields(d: Detection) -> bool:
        return any(one_object(d, r, candidates) and (d is not best or r.score > d.score) for r in rivals)

    def taken_surely(d: Detection) -> bool:
        return d.score < sure and any(one_object(d, r, candidates) and r.score >= sure for r in rivals)

    kept = [d for d in found if not yields(d)]
    return kept or ([] if taken_surely(best) else [best])


def one_object(a: Detection, b: Detection, candidates: Sequence[Candidate] = ()) -> bool:
    """Whether two boxes are on one object: they overlap by IoU 0.5 or more, or each frames one place depth
    sees stand (`candidates`), the same one (a cactus's pot and the cactus)."""
    if iou(a.box, b.box) >= 0.5:
        return True
    places = [framed_by(d, list(candidates)) for d in (a, b)]
    return len(places[0]) == 1 and places[0] == places[1]


def faint_pick(
    faint: list[Detection], candidates: list[Candidate], params: LookHarderParams = LOOK_HARDER
) -> Detection | None:
    """The best of `faint` (boxes of one name under the detector's threshold) where it frames a candidate,
    and the name's best box on every other candidate scores under 1 / `faint_margin` of it; else None."""
    best: dict[int, Detection] = {}
    for det in faint:
        for at in framed_by(det, candidates):
            if at not in best or det.score > best[at].score:
                best[at] = det
    # one box framing two candidates (an object depth sees in two parts) points at one place
    ranked = sorted({id(d): d for d in best.values()}.values(), key=lambda d: -d.score)
    if not ranked or (len(ranked) > 1 and ranked[1].score * params.faint_margin > ranked[0].score):
        return None
    return ranked[0]


def eliminable(
    candidates: list[Candidate],
    others: list[Detection],
    size_range: tuple[float, float] | None,
    width: int,
    height: int,
    placement: str | None = None,
    coloured: Callable[[Candidate], bool] | None = None,
    height_range: tuple[float, float] | None = None,
    params: LookHarderParams = LOOK_HARDER,
    shaped: Callable[[Candidate], bool] | None = None,
) -> list[Candidate]:
    """The candidates that can be the object looked for by elimination: one to take, else (none, or several)
    no argument by elimination. A candidate no box of another name explains (over its middle, with a score
    of `unsure`), whose size as depth sees it fits `size_range` (`fits_size`) and whose rise fits
    `height_range` (`fits_height`: a knife lies flat, a toaster stands; None: any), whole in the image (a
    candidate cut by the image's edge is most often the furniture the robot stands at), no part of the
    furniture, and where the object is put (`placement`: "surface", on furniture; "floor"; None: anywhere),
    of the object's proportions (`shaped`: None, any). Where several are left, those of them whose colour is
    the object's (`coloured`: a carrot is orange), where some are."""
    if size_range is None:
        return []
    sure = [d for d in others if d.score >= params.unsure]
    left = [
        c
        for c in candidates
        if fits_size(c.size, size_range, params.size_slack)
        and (height_range is None or fits_height(c.rise, height_range, params))
        and not is_furniture(c, params)
        and not is_misplaced(c, placement, params)
        and not at_edge(c.box, width, height)
        and not any(inside_box(center(c.box), d.box) for d in sure)
        and (shaped is None or shaped(c))
    ]
    if len(left) > 1 and coloured is not None:
        left = [c for c in left if coloured(c)] or left
    return left


def alike(
    detector: Detector,
    frame: Frame,
    name: str,
    candidates: list[Candidate],
    found: list[Detection],
    claimed: list[Detection],
    sought: Sequence[str] = (),
    table: Priors | None = None,
    params: LookHarderParams = LOOK_HARDER,
) -> list[Detection]:
    """More of what `found` (a find's detections) saw, where the detector missed them: the candidates whose
    colours are those of an object it saw surely enough (`alike`, `exemplar`), whose size as depth sees it
    fits the name's (`alike_slack`), that stand on the level one of those stands on (`same_level_m`) and are
    of its proportions (`alike_shape`), whole in the image, no part of the furniture, where the object is
    put, and that no box explains: none of `found`, none of `claimed` (what other names' finds took), and no
    box the detector gives another class in the whole image with a score of `unsure` where the candidate is
    of that class's proportions; nor one that could be another of the `sought` names by its size and colour
    (a red apple beside a red mug). A closed-set detector only: it names every class it knows in one pass,
    so a thing it calls something else surely is that. `table`: the perception priors (default: ours)."""
    table = table if table is not None else priors()
    mine = class_of_name(detector, name)
    kind = table.find(name)
    sizes = name_sizes(detector, name, table)
    if sizes is None or getattr(detector, "class_of", None) is None:
        return []
    exemplars = [d for d in found if d.score >= params.exemplar and on_candidate(d, candidates)]
    shown = [h for h in (colours_of(frame.rgb, d.box, params) for d in exemplars) if h is not None]
    if not shown:
        return []
    examples = [candidates[i] for d in exemplars for i in framed_by(d, candidates)]
    levels = [c.bottom for c in examples]
    whole = (0, 0, frame.width, frame.height)
    seen = [d for d in detect_in_views(detector, frame, ["object"], [whole]) if d.label != mine]
    # a class the detector gives the examples too is its confusion about their kind (YOLOv3-tiny boxes
    # a small apple as an orange at 0.7): it explains no candidate
    confused = {d.label for d in seen for e in exemplars if inside_box(center(e.box), d.box)}
    rivals = [d for d in seen if d.label not in confused and d.score >= params.unsure]
    taken: list[Detection] = []
    for cand in candidates:
        if (
            not fits_size(cand.size, sizes, params.alike_slack)
            or is_furniture(cand, params)
            or is_misplaced(cand, None if kind is None else kind.placement, params)
            or at_edge(cand.box, frame.width, frame.height)
            or any(on_place(cand, d) for d in [*found, *claimed, *taken])
            # another class's box explains a place depth sees shaped as that class's objects can be only
            # (YOLOv3-tiny boxes a small bowl as a sports ball; no ball lies three times wider than it rises)
            or any(
                on_place(cand, d) and shaped_as_class(detector, d.label, cand, table, params) for d in rivals
            )
            or any(could_be(frame.rgb, cand, other, table, params) for other in sought)
            or not _on_level_of(cand, levels, params.same_level_m)
            or not shaped_like(cand, examples, params)
        ):
            continue
        colours = colours_of(frame.rgb, cand.box, params)
        if colours is not None and max(correlation(colours, h) for h in shown) >= params.alike:
            taken.append(Detection(box=cand.box, score=params.alike_score, label=name, evidence="look-alike"))
    return taken


def _on_level_of(cand: Candidate, levels: list[float | None], within: float) -> bool:
    """Whether a candidate stands on one of the `levels` (the heights over the floor the examples stand at,
    within `within` metres: `same_level_m`); False where depth does not say."""
    return cand.bottom is not None and any(
        level is not None and abs(cand.bottom - level) <= within for level in levels
    )


def visit_order(
    candidates: list[Candidate],
    others: list[Detection],
    size_range: tuple[float, float] | None = None,
    placement: str | None = None,
    params: LookHarderParams = LOOK_HARDER,
) -> list[Candidate]:
    """The candidates worth driving nearer to, in the order to visit them: those no other name explains
    first (by the best score of a box of another name over their middle), then those whose size as depth
    sees it is nearest the size of what is looked for (`size_range`, metres: a mug is 8 to 12 cm), then the
    smaller (a detector misses the small ones); furniture legs left out."""

    def explained(cand: Candidate) -> float:
        middle = center(cand.box)
        return round(max((d.score for d in others if inside_box(middle, d.box)), default=0.0), 1)

    def misfit(cand: Candidate) -> float:
        if size_range is None or cand.size <= 0:
            return 0.0
        # how far outside the size range (as a ratio): depth may see only part of an object (its near
        # side, its top), so a candidate somewhat smaller comes next, not last
        lo, hi = size_range
        return round(abs(math.log(min(max(cand.size, lo), hi) / cand.size)), 1)

    worth = [c for c in candidates if not is_furniture(c, params)]
    return sorted(
        worth, key=lambda c: (is_misplaced(c, placement, params), explained(c), misfit(c), c.pixels)
    )
