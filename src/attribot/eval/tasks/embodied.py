"""The paper's embodied tasks (its Table I): which named object is closer, which is the most lightweight, in
household scenes, with the rangefinder or the wrist force sensor. The truth is the world's distance from the
camera and the objects' masses.

Both can be drawn in a vocabulary (`Task.build_in_vocabulary`): for a run with a closed-set detector, every
object of every scene, the candidates and the others, is of a category the detector can find, so that the
run keeps every item; the same seeds are tried in the same order, and the items keep the same properties
(distinct categories, pickable candidates for weight, distances 15 cm apart, visible)."""

from __future__ import annotations

from collections.abc import Iterator

from attribot.config import SceneConfig
from attribot.errors import InputError
from attribot.eval.datasets import HEIGHT, WIDTH, Item, scene_info
from attribot.eval.suite import Task, register_task
from attribot.sim.world import ObjectInfo, SceneInfo

__all__ = ["asked_about"]


def _visible(info: SceneInfo) -> list[ObjectInfo]:
    return [o for o in info.objects if o.box is not None and o.visible_pixels >= 40]


def _named(objects: list[ObjectInfo]) -> str:
    names = [f"the {o.category}" for o in objects]
    return ", ".join(names[:-1]) + f" and {names[-1]}" if len(names) > 2 else f"{names[0]} and {names[1]}"


def _candidates(seed: int, pickable: bool, vocabulary: tuple[str, ...] | None) -> list[ObjectInfo] | None:
    """Up to three visible objects of the household scene of `seed` (drawn in `vocabulary`, None: any
    category), one per category (so that a name picks one object); None where the scene has too few, or no
    room for its objects."""
    config = SceneConfig(layout="household", seed=seed, width=WIDTH, height=HEIGHT, vocabulary=vocabulary)
    try:
        info = scene_info(config)
    except InputError:
        return None  # the layout found no room for this seed's objects
    seen = [o for o in _visible(info) if o.pickable or not pickable]
    if len({o.category for o in seen}) != len(seen) or len(seen) < 2:
        return None
    return seen[:3]


def _distance_query(made: int, chosen: list[ObjectInfo]) -> tuple[str, list[ObjectInfo]] | None:
    """The query and its candidates; None when two candidates stand within 15 cm of the same distance."""
    gaps = sorted(o.distance_m for o in chosen)
    if min(b - a for a, b in zip(gaps, gaps[1:], strict=False)) < 0.15:
        return None
    if made % 2 == 0:  # the paper's AI2-THOR form
        pair = sorted(chosen[:2], key=lambda o: o.id)
        return f"Is the {pair[0].category} or the {pair[1].category} closer to me?", pair
    # the paper's prompt template
    return f"Out of {_named(chosen)}, which one is closer to me?", chosen


def asked_about(
    made: int, chosen: list[ObjectInfo], distance: bool
) -> tuple[str, list[ObjectInfo], ObjectInfo, list[str]] | None:
    """The query of the `made`-th item over `chosen` (which is closer, in the paper's two forms, or which is
    the most lightweight), the objects it names, its truth from the world (the closest, the lightest) and
    the sensors it needs; None where two candidates stand within 15 cm of the same distance."""
    if distance:
        asked = _distance_query(made, chosen)
        if asked is None:
            return None
        query, named = asked
        return query, named, min(named, key=lambda o: o.distance_m), ["camera", "distance"]
    query = f"Out of {_named(chosen)}, which one is the most lightweight?"
    return query, chosen, min(chosen, key=lambda o: o.mass_kg), ["camera", "force"]


def _embodied_items(
    task: str, n: int, start_seed: int, vocabulary: tuple[str, ...] | None = None
) -> Iterator[Item]:
    distance = task == "distance_embodied"
    made, seed = 0, start_seed
    while made < n:
        seed += 1
        chosen = _candidates(seed, not distance, vocabulary)
        if chosen is None:
            continue
        asked = asked_about(made, chosen, distance)
        if asked is None:
            continue
        query, chosen, truth, sensors = asked
        yield Item(
            id=f"{task}-{made:03d}",
            task=task,
            query=query,
            form="comparative",
            phrasing="paper",
            layout="household",
            seed=seed,
            sensors=sensors,
            embodied=True,
            true_id=truth.id,
            true_box=truth.box or [],
            candidates=[o.id for o in chosen],
            object_categories=sorted({o.category for o in chosen}),
            vocabulary=None if vocabulary is None else list(vocabulary),
        )
        made += 1


def _distance_items(n: int, start_seed: int, vocabulary: tuple[str, ...] | None = None) -> Iterator[Item]:
    return _embodied_items("distance_embodied", n, start_seed, vocabulary)


def _weight_items(n: int, start_seed: int, vocabulary: tuple[str, ...] | None = None) -> Iterator[Item]:
    return _embodied_items("weight_embodied", n, start_seed, vocabulary)


register_task(
    Task(
        name="distance_embodied",
        size=50,
        seed_base=40_000,
        build=_distance_items,
        build_in_vocabulary=_distance_items,
        methods=("ovd", "vqa", "attr-api", "vlm", "pa-api"),
        paper={
            "ovd": (("OVD", 0.64),),
            "vqa": (("VQA", 0.56),),
            "attr-api": (("attribute API", 0.22),),
            "vlm": (("GPT-4o", 0.70),),
            "pa-api": (("perception-action API", 0.94),),
        },
        why='"Is the X or the Y closer to me?" and "Out of the ..., which one is closer to me?" in a '
        "household scene, with the rangefinder. The truth is the world's distance from the camera.",
        tags=frozenset({"embodied"}),
    )
)
register_task(
    Task(
        name="weight_embodied",
        size=50,
        seed_base=50_000,
        build=_weight_items,
        build_in_vocabulary=_weight_items,
        methods=("ovd", "vqa", "attr-api", "vlm", "pa-api"),
        paper={
            "ovd": (("OVD", 0.14),),
            "vqa": (("VQA", 0.64),),
            "attr-api": (("attribute API", 0.90),),
            "vlm": (("GPT-4o", 0.88),),
            "pa-api": (("perception-action API", 0.96),),
        },
        why='"Out of the ..., which one is the most lightweight?" in a household scene, with the wrist force '
        "sensor. The truth is the objects' masses.",
        tags=frozenset({"embodied"}),
    )
)
