"""Beyond the paper's senses (its closing proposal, "more sensors, e.g. a temperature sensor"): which object
is hot or cold, soft or hard, empty or full, each a task of its own in the suite `senses`.

Every scene holds objects that look alike (two kettles, one just boiled; three balls, one foam; three
bottles, one empty), so that neither the camera nor a prior settles the answer: a detector or a language
model picks one of them at chance, and only measuring tells. The truth is the world's own state: each
object's temperature, stiffness and fill in the scene's truth, never a planner's reading; an item is made
only where the object at the end asked stands clearly apart from the next (10 degC, three times as stiff,
half a container) and every candidate is in view.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

from attribot.config import SceneConfig
from attribot.errors import InputError
from attribot.eval.datasets import HEIGHT, WIDTH, Item, scene_info
from attribot.eval.suite import Task, register_task
from attribot.sensors import sense_of
from attribot.sim.scene import plan_scene, resolve_categories
from attribot.sim.scene_plan import SceneRequest
from attribot.sim.world import ObjectInfo

__all__: list[str] = []

_METHODS = ("ovd", "vqa", "vqa+llm", "attr-api", "vlm", "pa-api")
"""The paper's rows: a detector and a VQA model cannot see these senses, a language model guesses from
priors, the attribute API has the camera alone, the perception-action API measures."""


@dataclass(frozen=True)
class _Form:
    """One way a task asks: the query, the objects of its scenes, the state field it is about and the end."""

    query: str
    categories: tuple[str, ...]
    field: str  # the ObjectInfo field of the state
    most: bool  # the object with the most of it is the answer


_FORMS: dict[str, tuple[_Form, ...]] = {
    "temperature_embodied": (
        _Form("Which kettle is hot?", ("kettle", "kettle"), "temperature_c", True),
        _Form("Which mug is hot?", ("mug", "mug", "mug"), "temperature_c", True),
        _Form("Which can is the coldest?", ("can", "can", "can"), "temperature_c", False),
        _Form("the coldest bottle", ("bottle", "bottle", "bottle"), "temperature_c", False),
    ),
    "softness_embodied": (
        _Form("Which ball is the softest?", ("ball", "ball", "ball"), "stiffness_n_per_mm", False),
        _Form("Which ball is the hardest?", ("ball", "ball", "ball"), "stiffness_n_per_mm", True),
        _Form("the squishiest ball", ("ball", "ball", "ball"), "stiffness_n_per_mm", False),
    ),
    "fullness_embodied": (
        _Form("Which bottle is empty?", ("bottle", "bottle", "bottle"), "fill", False),
        _Form("Which bottle is full?", ("bottle", "bottle", "bottle"), "fill", True),
        _Form("Which mug is empty?", ("mug", "mug", "mug"), "fill", False),
        _Form("Which box is full?", ("box", "box"), "fill", True),
    ),
}
_QUANTITY = {
    "temperature_embodied": "temperature",
    "softness_embodied": "stiffness",
    "fullness_embodied": "fullness",
}
"""The sense (`attribot.sensors`) each task is about: its items give the robot the camera and the sensor
that settles it."""


def _sensors(task: str) -> list[str]:
    found = sense_of(_QUANTITY[task])
    if found is None:
        raise InputError(
            f"task {task}: no registered sensor measures {_QUANTITY[task]}",
            "keep attribot's built-in sensors",
        )
    return ["camera", found[0].name]


def _apart(end: float, next_: float, field: str) -> bool:
    """The end object stands clearly apart from the next one."""
    if field == "stiffness_n_per_mm":
        return max(end, next_) >= 3.0 * min(end, next_)
    return abs(end - next_) >= (10.0 if field == "temperature_c" else 0.5)


def _ends(values: list[float], form: _Form) -> int | None:
    """Which of `values` is the answer, when it stands clearly apart from the next; None otherwise."""
    order = sorted(range(len(values)), key=lambda i: values[i], reverse=form.most)
    if len(order) < 2 or not _apart(values[order[0]], values[order[1]], form.field):
        return None
    return order[0]


def _planned(form: _Form, seed: int) -> bool:
    """Whether the scene's plan (cheap: no world is built) can give an item, for the first attempt's draw:
    the world itself decides, this only skips seeds that cannot."""
    try:
        request = SceneRequest(len(form.categories), resolve_categories(form.categories))
        plan = plan_scene("household", seed, request)
    except InputError:
        return True  # redrawn by the world: let it decide
    values = [getattr(o, form.field) for o in plan.objects]  # the plan's objects carry the same fields
    return None not in values and _ends([float(v) for v in values], form) is not None


def _item(task: str, made: int, form: _Form, seed: int) -> Item | None:
    """The item of `form` on the scene of `seed`, with its truth from the world; None where that scene
    gives none (an object out of view, or no clear answer)."""
    config = SceneConfig(
        layout="household",
        seed=seed,
        categories=form.categories,
        objects=len(form.categories),
        width=WIDTH,
        height=HEIGHT,
    )
    try:
        info = scene_info(config)
    except InputError:
        return None
    seen: list[ObjectInfo] = [o for o in info.objects if o.box is not None and o.visible_pixels >= 40]
    if len(seen) != len(form.categories):
        return None
    values = [getattr(o, form.field) for o in seen]
    end = _ends([float(v) for v in values], form) if None not in values else None
    if end is None:
        return None
    truth = seen[end]
    return Item(
        id=f"{task}-{made:03d}",
        task=task,
        query=form.query,
        form="superlative" if form.query.startswith("the ") else "comparative",
        phrasing="template",
        layout="household",
        seed=seed,
        objects=len(form.categories),
        categories=list(form.categories),
        sensors=_sensors(task),
        embodied=True,
        true_id=truth.id,
        true_box=truth.box or [],
        candidates=[o.id for o in seen],
    )


def _items(task: str, n: int, start_seed: int) -> Iterator[Item]:
    forms = _FORMS[task]
    made, seed = 0, start_seed
    while made < n:
        seed += 1
        form = forms[made % len(forms)]
        if not _planned(form, seed):
            continue
        item = _item(task, made, form, seed)
        if item is not None:
            yield item
            made += 1


def _temperature_items(n: int, start_seed: int) -> Iterator[Item]:
    return _items("temperature_embodied", n, start_seed)


def _softness_items(n: int, start_seed: int) -> Iterator[Item]:
    return _items("softness_embodied", n, start_seed)


def _fullness_items(n: int, start_seed: int) -> Iterator[Item]:
    return _items("fullness_embodied", n, start_seed)


_WHY = (
    " The objects look alike, so a detector or a language model picks one at chance; the truth is the "
    "world's own state."
)
register_task(
    Task(
        name="temperature_embodied",
        size=50,
        seed_base=60_000,
        build=_temperature_items,
        methods=_METHODS,
        why='"Which kettle is hot?", "Which mug is hot?", "Which can is the coldest?", "the coldest bottle" '
        "in a household scene, with the infrared thermometer on the head (the object centred first)." + _WHY,
        tags=frozenset({"senses"}),
        suite="senses",
    )
)
register_task(
    Task(
        name="softness_embodied",
        size=50,
        seed_base=70_000,
        build=_softness_items,
        methods=_METHODS,
        why='"Which ball is the softest?", "Which ball is the hardest?", "the squishiest ball" among three '
        "balls (foam, rubber or plastic), squeezed in the gripper on MuJoCo's soft contacts." + _WHY,
        tags=frozenset({"senses"}),
        suite="senses",
    )
)
register_task(
    Task(
        name="fullness_embodied",
        size=50,
        seed_base=80_000,
        build=_fullness_items,
        methods=_METHODS,
        why='"Which bottle is empty?", "Which bottle is full?", "Which mug is empty?", "Which box is full?", '
        "told by weighing each with the wrist force sensor against the empty mass of its kind." + _WHY,
        tags=frozenset({"senses"}),
        suite="senses",
    )
)
