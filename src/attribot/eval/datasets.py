"""The paper's five evaluation tasks as seeded datasets generated in the embedded world.

An item is one query on one scene: the layout, seed and options that regenerate the scene byte for byte,
the query and where its phrasing comes from (`paper`: a released query of the same family and form, its
category swapped for the scene's when the paper's is not in the catalog; `template`: ours), the sensors
the robot has, and the true object (id and box) read from the world's truth. A dataset is a manifest
(`manifest.jsonl`, one item a line, and `dataset.json` with the version) and the rendered images.

Tasks (sizes as in the paper): `location` (100, arrangements: "the second mug from the right"), `size`
(100 queries, each in its superlative and its absolute form: 200 items), `weight_image` (100 triplets
seen in a still image, no robot), `distance_embodied` (50) and `weight_embodied` (50) in household
scenes, with the distance or force sensor.

`DATASET_VERSION` is a digest of the code that generates items and their truth (this module, the
simulator's scenes, catalog, rendering and truth, and the rules parser with its lexicon, which reads the
location and size phrasings): it changes whenever generation may change, and a run refuses to mix items of
two versions.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Callable, Iterator
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict

from attribot.config import SceneConfig
from attribot.errors import InputError
from attribot.eval.corpus import paper_queries
from attribot.files import write_whole
from attribot.planning.rules import LocationQuery, SizeQuery, UnsupportedQuery, parse_query
from attribot.sim.world import ObjectInfo, SceneInfo

__all__ = [
    "Item",
    "TASKS",
    "TASK_SIZES",
    "DATASET_VERSION",
    "build_items",
    "item_count",
    "write_dataset",
    "read_dataset",
    "scene_info",
]

TASKS = ("location", "size", "weight_image", "distance_embodied", "weight_embodied")
TASK_SIZES = {
    "location": 100,
    "size": 100,
    "weight_image": 100,
    "distance_embodied": 50,
    "weight_embodied": 50,
}
"""Queries per task (the size task has each in two forms)."""

WIDTH, HEIGHT = 640, 480


def _package_files(package: str) -> list[tuple[str, str]]:
    """Every module of `package` and of its subpackages, as (package, file name)."""
    out = []
    for f in sorted(resources.files(package).iterdir(), key=lambda f: f.name):
        if f.name.endswith(".py"):
            out.append((package, f.name))
        elif f.is_dir() and f.joinpath("__init__.py").is_file():
            out.extend(_package_files(f"{package}.{f.name}"))
    return out


def _version() -> str:
    digest = hashlib.sha256()
    for package, name in (
        ("attribot.eval", "datasets.py"),
        # the scenes, their images and their truth (boxes, distances, masses)
        *(
            ("attribot.sim", f)
            for f in ("scene.py", "catalog.py", "shapes.py", "looks.py", "robot.py", "world.py", "render.py")
        ),
        # the location and size truth is the parser's meaning of the released phrasing, in its vocabulary
        *_package_files("attribot.planning.rules"),
        ("attribot", "lexicon.py"),
    ):
        digest.update(resources.files(package).joinpath(name).read_bytes())
    return "paper-" + digest.hexdigest()[:12]


DATASET_VERSION = _version()


class Item(BaseModel):
    """One query on one generated scene, with its truth (see the module docstring)."""

    model_config = ConfigDict(frozen=True)

    id: str
    task: str
    query: str
    form: str  # superlative | absolute | comparative | n/a
    phrasing: str  # paper | template
    layout: str
    seed: int
    objects: int | None = None
    categories: list[str] | None = None
    options: dict[str, Any] = {}
    sensors: list[str]
    embodied: bool
    true_id: str
    true_box: list[float]
    candidates: list[str] = []  # the named objects' ids, where the query names them
    version: str = DATASET_VERSION

    def scene(self) -> SceneConfig:
        return SceneConfig(
            layout=self.layout,
            seed=self.seed,
            objects=self.objects,
            categories=tuple(self.categories) if self.categories else None,
            options=self.options,
            width=WIDTH,
            height=HEIGHT,
        )


def scene_info(config: SceneConfig) -> SceneInfo:
    """The scene's truth, by building it (the one place datasets touch the simulator)."""
    from attribot.embodiments.mujoco import MujocoWorld

    world = MujocoWorld(config)
    try:
        return world.scene_info()
    finally:
        world.close()


# ---- the tasks ------------------------------------------------------------------------------------------


def _visible(info: SceneInfo) -> list[ObjectInfo]:
    return [o for o in info.objects if o.box is not None and o.visible_pixels >= 40]


def _swap_noun(query: str, noun: str, category: str) -> str:
    """The paper's query with its noun (and its plural) swapped for the scene's category."""
    return re.sub(rf"\b{re.escape(noun)}(?:e?s)?\b", category, query, count=1)


def _location_truth(q: LocationQuery, objects: list[ObjectInfo]) -> ObjectInfo | None:
    """The object a location meaning picks in an arrangement, by the truth's rows and columns."""
    if any(o.row is None or o.col is None for o in objects):
        return None
    group = list(objects)  # every row and col below is an int
    if q.line is not None:
        key = "row" if q.line.kind == "row" else "col"
        lines: list[int] = sorted({int(getattr(o, key)) for o in group})
        if q.line.middle:
            if len(lines) % 2 == 0:
                return None
            want = lines[len(lines) // 2]
        else:
            if q.line.index > len(lines):
                return None
            want = lines[-q.line.index] if q.line.from_end else lines[q.line.index - 1]
        group = [o for o in group if getattr(o, key) == want]
    pick = q.pick
    if pick.kind == "only":
        return group[0] if len(group) == 1 else None
    if pick.kind == "central":
        rows = sorted({int(o.row or 0) for o in group})
        cols = sorted({int(o.col or 0) for o in group})
        if len(rows) % 2 == 0 or len(cols) % 2 == 0:
            return None
        centre = [o for o in group if o.row == rows[len(rows) // 2] and o.col == cols[len(cols) // 2]]
        return centre[0] if len(centre) == 1 else None
    if pick.kind == "middle":
        key = "col" if pick.axis == "x" else "row"
        if len(group) % 2 == 0 or len({getattr(o, key) for o in group}) != len(group):
            return None
        return sorted(group, key=lambda o: getattr(o, key))[len(group) // 2]
    side = pick.side
    key = "col" if side in ("left", "right") else "row"
    order = sorted(group, key=lambda o: getattr(o, key), reverse=side in ("right", "bottom"))
    if len({getattr(o, key) for o in group}) != len(group) or pick.k > len(order):
        return None
    return order[pick.k - 1]


def _location_items(n: int, start_seed: int) -> Iterator[Item]:
    phrasings: list[tuple[str, LocationQuery]] = []
    for q in paper_queries("location"):
        try:
            meaning = parse_query(q.query or "")
        except UnsupportedQuery:
            continue
        if isinstance(meaning, LocationQuery):
            phrasings.append((q.query or "", meaning))
    templates = [
        "the {ord} {cat} from the left",
        "the {ord} {cat} from the right",
        "the leftmost {cat}",
        "the rightmost {cat}",
        "the {ord} {cat} from the left in the top row",
        "the {ord} {cat} from the right in the bottom row",
    ]
    made, seed, tries = 0, start_seed, 0
    while made < n:
        seed += 1
        paper: LocationQuery | None = None
        if made % 2 == 0 and phrasings:  # every other item is a released phrasing
            text, paper = phrasings[(made // 2 + tries) % len(phrasings)]
            pattern = "grid" if paper.line is not None else "row"
            if paper.pick.side in ("top", "bottom"):
                pattern = "column" if paper.line is None else "grid"
        else:
            text = templates[(made + tries) % len(templates)]
            pattern = "grid" if "row" in text else "row"
        config = SceneConfig(
            layout="arrangement",
            seed=seed,
            options={"pattern": pattern, "odd": "size"},
            width=WIDTH,
            height=HEIGHT,
        )
        info = scene_info(config)
        objects = [o for o in info.objects if o.row is not None]
        category = objects[0].category
        if paper is not None:
            query = text if paper.obj.generic else _swap_noun(text, paper.obj.noun, category)
        else:
            query = text.format(ord=("second", "third", "first")[made % 3], cat=category)
        try:
            parsed = parse_query(query)
        except UnsupportedQuery:
            parsed = None
        truth = None
        if isinstance(parsed, LocationQuery):
            same = objects if parsed.obj.generic else [o for o in objects if o.category == category]
            truth = _location_truth(parsed, same) if all(o.box is not None for o in same) else None
        if truth is None or truth.box is None:
            tries += 1  # this scene cannot carry this phrasing: the next phrasing, the next seed
            continue
        yield Item(
            id=f"location-{made:03d}",
            task="location",
            query=query,
            form="n/a",
            phrasing="paper" if paper is not None else "template",
            layout="arrangement",
            seed=seed,
            options=dict(config.options),
            sensors=["camera"],
            embodied=False,
            true_id=truth.id,
            true_box=truth.box,
        )
        made += 1


def _size_items(n: int, start_seed: int) -> Iterator[Item]:
    phrasings: list[tuple[str, str, SizeQuery]] = []
    for q in paper_queries("size"):
        if q.form != "superlative" or not q.query:
            continue
        try:
            meaning = parse_query(q.query)
        except UnsupportedQuery:
            continue
        if isinstance(meaning, SizeQuery):
            absolute = next(
                (
                    a.query
                    for a in paper_queries("size")
                    if a.form == "absolute" and a.model_extra == q.model_extra
                ),
                None,
            )
            phrasings.append((q.query, absolute or "", meaning))
    made, seed = 0, start_seed
    while made < n:
        superlative, absolute, meaning = phrasings[made % len(phrasings)]
        seed += 1
        config = SceneConfig(
            layout="arrangement",
            seed=seed,
            options={"pattern": "row", "odd": "size"},
            width=WIDTH,
            height=HEIGHT,
        )
        info = scene_info(config)
        objects = [o for o in info.objects if o.box is not None]
        if len(objects) != len(info.objects):
            continue
        ranked = sorted(objects, key=lambda o: o.size_m, reverse=meaning.largest)
        k = meaning.rank
        if k > len(ranked) - 1:
            continue
        # decidable by eye: the k-th stands 5% apart from its neighbours in size
        sizes = [o.size_m for o in ranked]
        if abs(sizes[k - 1] - sizes[k]) < 0.05 * sizes[k] or (
            k > 1 and abs(sizes[k - 2] - sizes[k - 1]) < 0.05 * sizes[k - 1]
        ):
            continue
        if ranked[0].odd_one_out is not True:
            continue  # the odd one out stands at the extreme the query asks for
        truth = ranked[k - 1]
        category = objects[0].category
        for form, text in (("superlative", superlative), ("absolute", absolute)):
            if form == "absolute" and (not text or k != 1):
                text = re.sub(
                    r"\b(\w+?)(?:iest|est)\b", lambda m: _ABSOLUTE.get(m.group(0), m.group(0)), superlative
                )
                text = re.sub(r"^(?:first|second|third|fourth|fifth)\s+", "", text)
                truth_here = ranked[0]
            else:
                truth_here = truth
            query = text if meaning.obj.generic else _swap_noun(text, meaning.obj.noun, category)
            if not query.startswith("the "):
                query = "the " + query
            yield Item(
                id=f"size-{made:03d}-{form}",
                task="size",
                query=query,
                form=form,
                phrasing="paper",
                layout="arrangement",
                seed=seed,
                options=dict(config.options),
                sensors=["camera"],
                embodied=False,
                true_id=truth_here.id,
                true_box=truth_here.box or [],
            )
        made += 1


_ABSOLUTE = {
    "tallest": "tall", "biggest": "big", "largest": "large", "smallest": "small", "shortest": "short",
    "longest": "long", "widest": "wide", "thinnest": "thin", "thickest": "thick", "narrowest": "narrow",
    "tiniest": "tiny", "highest": "high",
}  # fmt: skip


def _weight_image_items(n: int, start_seed: int) -> Iterator[Item]:
    queries = [q.query for q in paper_queries("weight_image") if q.query] or ["the heaviest item"]
    for made in range(n):
        seed = start_seed + made
        config = SceneConfig(layout="triplet", seed=seed, width=WIDTH, height=HEIGHT)
        info = scene_info(config)
        truth = max(info.objects, key=lambda o: o.mass_kg)
        yield Item(
            id=f"weight_image-{made:03d}",
            task="weight_image",
            query=queries[made % len(queries)],
            form="superlative",
            phrasing="paper",
            layout="triplet",
            seed=seed,
            sensors=["camera"],
            embodied=False,
            true_id=truth.id,
            true_box=truth.box or [],
        )


def _named(objects: list[ObjectInfo]) -> str:
    names = [f"the {o.category}" for o in objects]
    return ", ".join(names[:-1]) + f" and {names[-1]}" if len(names) > 2 else f"{names[0]} and {names[1]}"


def _embodied_items(task: str, n: int, start_seed: int) -> Iterator[Item]:
    distance = task == "distance_embodied"
    made, seed = 0, start_seed
    while made < n:
        seed += 1
        config = SceneConfig(layout="household", seed=seed, width=WIDTH, height=HEIGHT)
        try:
            info = scene_info(config)
        except InputError:
            continue  # the layout found no room for this seed's objects
        seen = [o for o in _visible(info) if distance or o.pickable]
        by_category: dict[str, ObjectInfo] = {}
        for o in seen:
            by_category.setdefault(o.category, o)
        if len(by_category) != len(seen) or len(seen) < 2:
            continue  # names must pick one object each
        chosen = seen[:3]
        if distance:
            gaps = sorted(o.distance_m for o in chosen)
            if min(b - a for a, b in zip(gaps, gaps[1:], strict=False)) < 0.15:
                continue
            truth = min(chosen, key=lambda o: o.distance_m)
            if made % 2 == 0:  # the paper's AI2-THOR form: "Is the X or the Y closer to me?"
                chosen = sorted(chosen[:2], key=lambda o: o.id)
                truth = min(chosen, key=lambda o: o.distance_m)
                query = f"Is the {chosen[0].category} or the {chosen[1].category} closer to me?"
            else:  # the paper's prompt template: "Out of the {objects}, which one is closer to me?"
                query = f"Out of {_named(chosen)}, which one is closer to me?"
            phrasing = "paper"
            sensors = ["camera", "distance"]
        else:
            truth = min(chosen, key=lambda o: o.mass_kg)
            query, phrasing = f"Out of {_named(chosen)}, which one is the most lightweight?", "paper"
            sensors = ["camera", "force"]
        yield Item(
            id=f"{task}-{made:03d}",
            task=task,
            query=query,
            form="comparative",
            phrasing=phrasing,
            layout="household",
            seed=seed,
            sensors=sensors,
            embodied=True,
            true_id=truth.id,
            true_box=truth.box or [],
            candidates=[o.id for o in chosen],
        )
        made += 1


_BUILDERS: dict[str, Callable[[int, int], Iterator[Item]]] = {
    "location": _location_items,
    "size": _size_items,
    "weight_image": _weight_image_items,
    "distance_embodied": lambda n, s: _embodied_items("distance_embodied", n, s),
    "weight_embodied": lambda n, s: _embodied_items("weight_embodied", n, s),
}
_SEED_BASE = {
    "location": 10_000,
    "size": 20_000,
    "weight_image": 30_000,
    "distance_embodied": 40_000,
    "weight_embodied": 50_000,
}


def item_count(task: str, limit: int | None = None) -> int:
    """How many items `build_items([task], limit)` gives (the size task has two per query)."""
    n = TASK_SIZES[task] if limit is None else min(limit, TASK_SIZES[task])
    return n * (2 if task == "size" else 1)


def build_items(
    tasks: list[str] | None = None,
    limit: int | None = None,
    on_item: Callable[[Item], None] | None = None,
) -> list[Item]:
    """The suite's items, task by task (`limit`: at most that many queries per task). Deterministic.
    `on_item` is called as each item is made (generation takes minutes: a progress bar)."""
    chosen = list(TASKS) if tasks is None else tasks
    unknown = [t for t in chosen if t not in TASKS]
    if unknown:
        raise InputError(f"unknown task {', '.join(unknown)}", f"choose from: {', '.join(TASKS)}")
    items: list[Item] = []
    for task in chosen:
        n = TASK_SIZES[task] if limit is None else min(limit, TASK_SIZES[task])
        for item in _BUILDERS[task](n, _SEED_BASE[task]):
            items.append(item)
            if on_item is not None:
                on_item(item)
    return items


def write_dataset(
    items: list[Item], out: Path, images: bool = True, on_image: Callable[[Item], None] | None = None
) -> None:
    """`out/manifest.jsonl`, `out/dataset.json` and, with `images`, `out/images/<id>.png` (the view the
    item's query is asked on); `on_image` is called as each image is written."""
    out.mkdir(parents=True, exist_ok=True)
    if images:
        from PIL import Image

        from attribot.embodiments.mujoco import MujocoWorld

        (out / "images").mkdir(exist_ok=True)
        for item in items:
            with MujocoWorld(item.scene()) as world:
                rgb = world.observe().rgb
            path = out / "images" / f"{item.id}.png"
            Image.fromarray(np.ascontiguousarray(rgb)).save(path)
            if on_image is not None:
                on_image(item)
    write_whole(out / "manifest.jsonl", "".join(i.model_dump_json() + "\n" for i in items).encode())
    about = {"suite": "paper", "version": DATASET_VERSION, "items": len(items)}
    write_whole(out / "dataset.json", (json.dumps(about, indent=2) + "\n").encode())


def read_dataset(path: Path) -> list[Item]:
    """The items of a dataset directory; refuses a manifest of another dataset version."""
    manifest = path / "manifest.jsonl"
    if not manifest.is_file():
        raise InputError(
            f"{path} holds no dataset (no manifest.jsonl)",
            "build one: attribot dataset build --suite paper --out DIR",
        )
    items = [
        Item.model_validate_json(line)
        for line in manifest.read_text(encoding="utf-8").splitlines()
        if line.strip()
    ]
    versions = {i.version for i in items}
    if versions - {DATASET_VERSION}:
        raise InputError(
            f"the dataset at {path} was generated by version {', '.join(sorted(versions))}, this attribot "
            f"generates {DATASET_VERSION}",
            "rebuild it with attribot dataset build, so that its scenes and truth match this code",
        )
    return items
