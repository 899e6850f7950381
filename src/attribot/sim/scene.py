"""Seeded scenes: a room, furniture, objects and the robot, planned by a layout.

A layout is a function `(rng, request) -> ScenePlan` registered in `LAYOUTS` (the plan's records and the
steps layouts share: `scene_plan.py`; the layouts: `table_layouts.py`, `room_layouts.py`). It decides
everything that is random (furniture, categories, colours, sizes, masses, positions, the robot's pose and
head angles) from one `numpy.random.Generator` seeded with the scene's seed, so the same layout and seed
give the same plan, the same model and the same pixels. `attribot.sim.model.build_model(plan)` turns a
plan into a compiled `MjModel`; this module imports no MuJoCo, so that a `SceneConfig` is checked against
the layouts (`check_request`, run by its validator) without loading the simulator.

Layouts (the stand-ins for the paper's experiments):
- `arrangement`: a row, a column or a grid of the same kind of object on a table, with controlled size
  variation and one odd one out (another category, size or colour), seen from a fixed camera. Each
  object's truth carries its `row` and `col` as seen in the image (row 0 at the top, col 0 at the left).
- `triplet`: three objects of clearly increasing weight side by side on a table, in a shuffled order;
  the truth carries each object's `weight_rank` (0 = lightest).
- `household`: a room with two or three pieces of furniture and 2 to 6 candidate objects at different
  distances from the robot, all in the robot camera's first view.

The robot is the mast robot (`attribot.sim.robot`) unless the request names another registered body
(`attribot.sim.bodies`). A body whose gripper reaches only the floor (the RoboMaster-EP-like one,
`SceneRequest(robot="ep")`) gets `household` and `triplet` scenes with the candidates on the floor, ones
its gripper can hold, where it can drive straight to each (it has no depth camera to see its way); a layout
not made for it (`arrangement`, a grid seen from above) is refused. The other layouts are drawn for the
mast robot's head and camera.

Objects rest on their surface: each is placed with its lowest point on the surface, without overlapping
another object's footprint, and the world lets them settle before the first frame.

What no camera sees is drawn after the layout, from a generator of its own (so that a layout's draws, and
every scene planned before these states existed, stay as they were): the room's temperature and each
object's temperature, stiffness and, for a container, how full it is (its mass is then its empty mass plus
its contents). See `attribot.sim.catalog` for the states each category can be in.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from attribot.config import MAX_OBJECTS, MAX_SEED, SCENE_CHECKS, SceneConfig
from attribot.errors import InputError
from attribot.lexicon import temperature_state
from attribot.sim.catalog import RIGID_N_PER_MM, ROOM_TEMPERATURE_C, Category, get_category
from attribot.sim.scene_plan import LAYOUTS, ScenePlan, SceneRequest

__all__ = [
    "plan_scene",
    "check_request",
    "scene_request",
    "scene_requests",
    "what_fits",
    "MAX_OBJECTS",
    "LAYOUT_OPTIONS",
    "check_seed",
    "resolve_categories",
]


def _pick(rng: np.random.Generator, states: Sequence[tuple[str, Any]]) -> tuple[str, Any]:
    """One of `states`, equally likely; one draw whatever their number."""
    u = float(rng.uniform())
    return states[min(int(u * len(states)), len(states) - 1)]


def _draw_hidden_states(plan: ScenePlan, seed: int, attempt: int) -> None:
    """The room's temperature, and each object's temperature, stiffness and fill (see the module docstring),
    from generators of their own: one for the room, one per object, so that an object's states do not
    depend on the others'."""
    room = float(np.random.default_rng([seed, attempt, 0x7E3]).uniform(*ROOM_TEMPERATURE_C))
    plan.room_temperature_c = round(room, 2)
    for o in plan.objects:
        rng = np.random.default_rng([seed, attempt, o.key, 0x7E3])
        cat = o.category
        _, span = _pick(rng, cat.temperatures) if cat.temperatures else ("room", None)
        near_room = room + float(rng.normal(0.0, 0.3))  # drawn always: the next draws keep their place
        o.temperature_c = round(float(rng.uniform(*span)) if span is not None else near_room, 2)
        # its word by the thresholds the planner reads, not the state's name: a kettle not switched on
        # is at the room's temperature, never "cold"
        o.thermal = temperature_state(o.temperature_c)
        o.softness, stiff = _pick(rng, cat.stiffness) if cat.stiffness else ("rigid", None)
        share = float(rng.uniform())
        o.stiffness_n_per_mm = (
            RIGID_N_PER_MM if stiff is None else round(stiff[0] + (stiff[1] - stiff[0]) * share, 3)
        )
        if not cat.container or cat.empty_kg is None:
            continue
        if cat.mass_variants:  # its mass variant is how full it is (a jar drawn "full")
            o.fill = 1.0 if o.variant == "full" else 0.0
            continue
        _, o.fill = _pick(rng, cat.fill_states)
        if plan.layout == "triplet":  # its weights rise with the category by construction: kept empty
            o.fill = 0.0
        lo, hi = cat.empty_kg
        o.mass_kg = round(lo + (hi - lo) * o.mass_share + o.fill * cat.capacity_kg, 4)


LAYOUT_OPTIONS: dict[str, tuple[str, ...]] = {
    "arrangement": ("pattern", "odd", "size_variation"),
    "triplet": (),
    "household": ("min_gap",),
}
"""The `--option` names each layout reads (by its function's name); any other is refused."""


def check_seed(seed: object) -> int:
    """`seed` as an int when it is a whole number from 0 to 2**32 - 1; otherwise an InputError."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed <= MAX_SEED:
        raise InputError(f"seed {seed!r} is not valid", "give a whole number between 0 and 4294967295")
    return int(seed)


def check_request(layout: str, req: SceneRequest) -> None:
    """Refuse a request `layout` cannot draw, naming the fix: too few objects, an option the layout does not
    read, a layout not made for the robot's body, a category its gripper cannot hold, or one outside the
    vocabulary. `SceneConfig`'s validator and `plan_scene` both ask it."""
    fn = LAYOUTS.get(layout)
    if req.n_objects is not None and not 1 <= req.n_objects <= MAX_OBJECTS:  # each layout's range is narrower
        raise InputError(f"{req.n_objects} objects requested", f"ask for 1 to {MAX_OBJECTS} objects")
    known = LAYOUT_OPTIONS.get(fn.__name__, ())
    unknown = sorted(set(req.options) - set(known))
    if unknown:
        raise InputError(
            f"the {fn.__name__} layout has no option {', '.join(unknown)} (it would be ignored)",
            f"its options are: {', '.join(known)}" if known else "it takes no --option",
        )
    body = req.body
    if body.layouts is not None and fn.__name__ not in body.layouts:
        raise InputError(
            f"the {fn.__name__} layout is not made for {body.called} ({body.layouts_why})",
            f"use the {' or '.join(body.layouts)} layout with {body.called}",
        )
    unfit = [c.name for c in req.categories or () if not body.holds(c)]
    if unfit:
        raise InputError(f"{body.called}'s gripper cannot hold {', '.join(unfit)}", body.holds_fix)
    if req.vocabulary is not None:
        outside = [c.name for c in req.categories or () if c.name not in req.vocabulary]
        if outside:
            raise InputError(
                f"{', '.join(outside)} is not among the categories this scene may draw from",
                "leave it out of the categories, or draw from a vocabulary that holds it",
            )


def scene_request(config: SceneConfig) -> SceneRequest:
    """What `config` asks of the scene's layout."""
    vocabulary = config.vocabulary
    return SceneRequest(
        config.objects,
        resolve_categories(config.categories),
        dict(config.options),
        config.robot,
        None if vocabulary is None else frozenset(c.name for c in resolve_categories(vocabulary) or ()),
    )


@SCENE_CHECKS.register("drawable")
def _drawable(config: SceneConfig) -> None:
    """A config whose layout cannot draw what it asks (`check_request`) is refused as it is made: the check
    lives here, with the layouts, so that making a config imports no more of the simulator than them."""
    check_request(config.layout, scene_request(config))


def plan_scene(layout: str, seed: int, request: SceneRequest | None = None, attempt: int = 0) -> ScenePlan:
    """The plan of `layout` for `seed` (and `attempt`, for layouts whose plans can be rejected and redrawn):
    same arguments, same plan."""
    check_seed(seed)
    fn = LAYOUTS.get(layout)
    req = request or SceneRequest()
    check_request(layout, req)
    rng = np.random.default_rng(int(seed) if attempt == 0 else [int(seed), int(attempt)])
    plan = fn(rng, req)
    plan.seed = int(seed)
    plan.robot_kind = req.robot
    _draw_hidden_states(plan, int(seed), int(attempt))
    return plan


CROWDED_MIN_GAP = 0.08
"""The spacing of the candidates' distances (m) a household scene falls back to when none of its attempts
places them at the default one: a crowded request of small objects ("three cans") fits only closer together,
on the one table near enough for them to be seen (the spacing the benchmarks' household scenes ask for)."""


def scene_requests(layout: str, request: SceneRequest, attempts: int) -> Iterator[tuple[int, SceneRequest]]:
    """The (attempt, request) pairs a world tries in turn for one seed: the request as asked, then, for a
    household scene whose `min_gap` was not asked for, the same with `CROWDED_MIN_GAP` (so that every seed
    that was placed at the default spacing keeps its scene)."""
    for attempt in range(attempts):
        yield attempt, request
    if LAYOUTS.get(layout) is LAYOUTS.get("household") and "min_gap" not in request.options:
        crowded = replace(request, options={**request.options, "min_gap": CROWDED_MIN_GAP})
        for attempt in range(attempts, 2 * attempts):
            yield attempt, crowded


def what_fits(layout: str, seed: int, request: SceneRequest, attempts: int) -> str:
    """The fix for a request no attempt could place: how many of its objects do fit on this seed, or that
    smaller categories are needed."""
    n = request.n_objects or len(request.categories or ())
    spacing = request.options.get("min_gap", CROWDED_MIN_GAP)
    for k in range(n - 1, 0, -1):
        fewer = replace(
            request,
            n_objects=k,
            categories=request.categories[:k] if request.categories else None,
            options={**request.options, "min_gap": spacing},
        )
        for attempt in range(attempts):
            try:
                plan_scene(layout, seed, fewer, attempt)
            except InputError:
                continue
            return (
                f"at most {k} of these can be placed on seed {seed}: ask for {k} (--objects {k}) or smaller"
            )
    return "none of these objects fits in view on a surface of this layout: choose smaller categories"


def resolve_categories(names: Sequence[str] | None) -> tuple[Category, ...] | None:
    """Categories for names (UnknownName for an unknown one); None stays None."""
    if names is None:
        return None
    cats = tuple(get_category(n) for n in names)
    return cats or None
