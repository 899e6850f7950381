"""The tuned values of the perception mechanisms, one typed record each.

`LookHarderParams` holds every threshold, margin and score looking harder (`attribot.skills.harder`) weighs
depth, colour and the priors with; `LOOK_HARDER` is the default the `look_harder` strategy uses. A lab that
tries other values makes its own record (`dataclasses.replace(LOOK_HARDER, faint=0.01)`) and sets it as its
strategy's `params`. `LookAgainParams` (`LOOK_AGAIN`) holds looking again's (`attribot.skills.looking`).
"""

from __future__ import annotations

from dataclasses import dataclass

from attribot.models.base import SURE_SCORE

__all__ = ["LookHarderParams", "LOOK_HARDER", "LookAgainParams", "LOOK_AGAIN"]


@dataclass(frozen=True)
class LookHarderParams:
    """What looking harder weighs with. Lengths in metres, scores as the detector's, shares from 0 to 1."""

    # ---- when to look harder, and how closely --------------------------------------------------------------
    unsure: float = SURE_SCORE
    """A find whose best detection scores under this looks harder: no sure box (`models.base.SURE_SCORE`,
    the closed-set detectors' own `SURE`)."""
    zoom: float = 3.5
    """A zoomed view is this many times its candidate's larger side..."""
    min_view: int = 112
    """...and at least this many pixels square (a 30-pixel object fills about a quarter of it)."""
    max_views: int = 10
    """The most zoomed views one find looks at (a forward pass each)."""
    nearer_visits: int = 2
    """The most places one find drives nearer to, to look again (a robot with a base)..."""
    nearer_m: float = 0.9
    """...and how far from each of them it stops to look."""
    small_box: float = 1 / 6
    """Only a box under this share of the image is set aside for standing on nothing: a larger one may be
    furniture or a wall-sized object, whose own depth is its surface."""

    # ---- weaker evidence: a faint box, elimination ---------------------------------------------------------
    faint: float = 0.005
    """The faintest box of a name weighed on a candidate (under the detector's own threshold of 0.1): a small
    object far away is often boxed this faintly under its name, and more surely under a look-alike's."""
    faint_margin: float = 2.0
    """A faint box is taken only where its score is this many times that of the name on any other
    candidate."""
    eliminated_score: float = 0.001
    """The score of a candidate taken by elimination: no detector saw it as the name."""

    # ---- sizes and heights against the priors --------------------------------------------------------------
    size_slack: tuple[float, float] = (0.5, 1.5)
    """A size as depth sees it fits a name's size range from this share of its smallest (depth may see only
    a part: an object's near side, its top) to this share of its largest."""
    height_margin: float = 0.02
    """A rise as depth sees it fits a name's height range (`size_slack` of it) give or take this much:
    depth's noise, a level that is not quite flat."""
    fit_keeps: float = 0.25
    """A box is cut to its candidates only where the cut keeps this share of its area at least: less, and
    the candidates are a part of the object or another thing in its box."""
    fit_along: float = 0.8
    """...and this share of its extent along one of its sides at least: a detector's loose box errs along
    one side (across a fork, along a knife), where depth seeing only a piece of a far, thin, curved thing
    is short of the box both ways."""

    # ---- look-alikes: more of what the detector saw --------------------------------------------------------
    alike: float = 0.9
    """A candidate looks like an object the detector saw where the hue-saturation histograms of what stands
    out in their boxes correlate at least this much (another of one category scores near 1, other things
    far lower); what the detector names as another class, surely, is not taken."""
    exemplar: float = 0.1
    """A detection is an example of its name to look for more of where it scores at least this (the coco
    detector's threshold: a faint box or elimination is no example)."""
    alike_score: float = 0.002
    """The score of a candidate taken for its likeness: no detector saw it as the name."""
    alike_slack: tuple[float, float] = (0.5, 2.0)
    """A candidate alike in colour is one more of the name where its size is within this share of the
    name's size range: things of one kind differ in size more than a typical range says, and a thing over
    twice the largest of its kind is no longer one."""
    same_level_m: float = 0.05
    """...and where it stands on the level one it saw stands on (within this): more of a kind seen together
    stand together (a row on a table)."""
    alike_shape: float = 2.0
    """...and where its proportions are one's it saw, within this factor: things of one kind share a shape,
    and a carrot lying flat is not one more of a round orange that the size range alone lets through."""

    # ---- colours -------------------------------------------------------------------------------------------
    colour_off: float = 40.0
    """A pixel of a box whose colour is this far (RGB, 0-255) from the median of the box's rim is the
    object's."""
    hue_tolerance: float = 25.0
    """An object's colour is a named colour's where, both saturated over `chromatic`, their hues lie within
    this many degrees..."""
    chromatic: float = 0.3
    """...or where both are under it (silver, white, grey, black: light tells them apart)."""

    # ---- furniture and places ------------------------------------------------------------------------------
    leg_rise_m: float = 0.35
    """A candidate this tall over its level and `leg_aspect` times taller than wide (in the image) is a leg
    of the furniture it stands under, not an object: not worth a drive..."""
    leg_aspect: float = 2.5
    """(in the image, or as depth measures its rise against its width across the floor: a leg seen from
    above, near, is foreshortened in the image)"""
    floor_leg_rise_m: float = 0.15
    """...or this tall where it stands on the floor (a low table's leg)."""
    panel_across: float = 0.03
    """Metres across the floor under which a candidate that stands is the edge of a panel (a bookcase's
    side)."""
    floor_m: float = 0.05
    """A candidate whose lowest point is this high at most stands on the floor (a leg reaches it too)."""


LOOK_HARDER = LookHarderParams()
"""The values the `look_harder` mechanism uses unless given others."""


@dataclass(frozen=True)
class LookAgainParams:
    """What looking again (`attribot.skills.looking`) weighs with: when the head has stopped, when boxes of
    two views show one object, and how a box is fitted again."""

    settle_s: float = 0.05
    """The head is checked this often (seconds) while it turns to a survey view..."""
    settle_steps: int = 30
    """...at most this many times..."""
    same_rad: float = 0.004
    """...and has stopped when it moves less than this (radians) between two checks."""
    same_iou: float = 0.3
    """Boxes of two views that overlap this much in the first image show one object..."""
    same_inside: float = 0.6
    """...or a thin thing's box this much inside the wider one another view gives it..."""
    same_place_m: float = 0.1
    """...both within this many metres of each other in the world."""
    side_views: int = 2
    """The survey views every find asks (the head turned to either side); the views up and down are asked
    only where those leave an object undecided: asked on every find, they doubled its passes."""
    refit_iou: float = 0.1
    """A box of a crop around an object is its box again where it overlaps the first this much at least."""
    refit_shifts: tuple[tuple[float, float], ...] = ((-0.5, -0.5), (0.5, 0.5), (-0.5, 0.5), (0.5, -0.5))
    """Where the object sits in each crop around it: off the middle by half its size towards each corner."""


LOOK_AGAIN = LookAgainParams()
"""The values looking again uses."""
