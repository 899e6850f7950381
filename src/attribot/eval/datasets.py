"""Datasets of the evaluation suite: items generated in the embedded world, with truth from the world.

An item is one query on one scene: the layout, seed and options that regenerate the scene byte for byte,
the query and where its phrasing comes from (`paper`: a released query of the same family and form, its
category swapped for the scene's; `template`: ours), the sensors the robot has, and the true object (id and
box) read from the world's truth. A dataset is a manifest (`manifest.jsonl`, one item a line, and
`dataset.json` with the version) and the rendered images. The tasks that build items are registered
records (`attribot.eval.suite`, `attribot.eval.tasks`).

Each item names the categories of the objects its query chooses among (`object_categories`): a run
with a closed-set detector keeps the items whose categories it can find (`attribot.eval.subset`). The items
of a task that can be drawn in a vocabulary (the embodied ones) are drawn, for such a run, in scenes whose
objects are all of the categories that detector can find; such an item records them (`vocabulary`), its
scene is regenerated from them, and a run refuses items drawn in another vocabulary than its own.

`DATASET_VERSION` is a digest of the code and data that generate items and their truth (this module, the
suite and its tasks, the released queries and their written meanings, the simulator's scenes, catalog,
rendering and truth): it changes whenever generation may change, and a run refuses to mix items of two
versions. No planner is digested: no planner takes part in generating an item or its truth.
"""

from __future__ import annotations

import hashlib
import io
import json
from collections.abc import Callable, Iterator
from importlib import resources
from pathlib import Path
from typing import Annotated, Any

import numpy as np
from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    FiniteFloat,
    StringConstraints,
    ValidationError,
)

from attribot.config import SceneConfig
from attribot.errors import InputError
from attribot.eval.suite import TASKS, task_names
from attribot.files import make_folder, read_capped, write_whole
from attribot.sim.world import SceneInfo

__all__ = [
    "Item",
    "DATASET_VERSION",
    "build_items",
    "item_count",
    "write_dataset",
    "read_dataset",
    "read_jsonl",
    "scene_info",
    "Name",
    "Box",
    "TrueBox",
    "drawn_in",
]

WIDTH, HEIGHT = 640, 480
MAX_JSONL_BYTES = 256 * 1024 * 1024
"""The largest manifest or records file read (a whole paper-suite run writes a few MB a file)."""

Name = Annotated[str, StringConstraints(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.+-]{0,199}$")]
"""An item's id, a task's, method's or noise level's name: each becomes part of a file name (an image, a
records file), so it is letters, digits and `_.+-` only, never a path."""


def _ordered(box: list[float]) -> list[float]:
    if box[2] < box[0] or box[3] < box[1]:
        raise ValueError("a box is x0, y0, x1, y1 with x1 >= x0 and y1 >= y0")
    return box


Box = Annotated[list[FiniteFloat], Field(min_length=4, max_length=4), AfterValidator(_ordered)]
"""A box in pixels, x0, y0, x1, y1."""
TrueBox = Box | Annotated[list[FiniteFloat], Field(max_length=0)]
"""The true object's box, or none (empty) where the truth is that the object is not there."""


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
        *(("attribot.eval", f) for f in ("datasets.py", "suite.py", "corpus.py")),
        *_package_files("attribot.eval.tasks"),
        # the released phrasings and their meanings, written down once: the location and size truth
        *(("attribot.eval", f"data/{f}") for f in ("paper_queries.jsonl", "paper_meanings.jsonl")),
        # the scenes, their images and their truth (boxes, distances, masses): every module of the world,
        # so that a module split off another (the layouts, the meshes) still counts
        *_package_files("attribot.sim"),
    ):
        digest.update(resources.files(package).joinpath(name).read_bytes())
    return "paper-" + digest.hexdigest()[:12]


DATASET_VERSION = _version()


class Item(BaseModel):
    """One query on one generated scene, with its truth (see the module docstring)."""

    model_config = ConfigDict(frozen=True)

    id: Name
    task: Name
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
    true_box: TrueBox
    candidates: list[str] = []  # the named objects' ids, where the query names them
    # the categories of the objects the query chooses among (the true object's among them), from the world's
    # truth: what a detector must be able to find for the item to be fair to it
    object_categories: list[str] = []
    # the only categories its scene drew objects from (those a closed-set detector can find); None: any
    vocabulary: list[str] | None = None
    # the names the query asks about that the scene does not hold: the truth is that they are not there, and
    # only an answer that chose no object is right (`true_id` and `true_box` are then empty)
    absent: list[str] = []
    version: str = DATASET_VERSION

    def scene(self) -> SceneConfig:
        return SceneConfig(
            layout=self.layout,
            seed=self.seed,
            objects=self.objects,
            categories=tuple(self.categories) if self.categories else None,
            vocabulary=None if self.vocabulary is None else tuple(self.vocabulary),
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


def item_count(task: str, limit: int | None = None) -> int:
    """How many items `build_items([task], limit)` gives (the size task has two per query)."""
    return TASKS.get(task).item_count(limit)


def drawn_in(task: str, vocabulary: tuple[str, ...] | None) -> list[str] | None:
    """The vocabulary `task`'s items are drawn in when a run asks for `vocabulary` (None: the catalog's): the
    vocabulary itself for a task that can be drawn in one, else None."""
    if vocabulary is None or TASKS.get(task).build_in_vocabulary is None:
        return None
    return list(vocabulary)


SEED_STRIDE = 1_000_000
"""How far apart the seeds of two root seeds lie: each task draws its scenes from its `seed_base` upward,
far fewer than this many."""
MAX_ROOT_SEED = 4000
"""The largest root seed: its scenes' seeds stay within the simulator's (`attribot.config.MAX_SEED`)."""


def check_root_seed(root: int) -> int:
    """`root` if it is a root seed (a whole number from 0 to MAX_ROOT_SEED), else an `InputError`."""
    if not isinstance(root, int) or isinstance(root, bool) or not 0 <= root <= MAX_ROOT_SEED:
        raise InputError(
            f"the root seed {root!r} is out of range", f"give a whole number from 0 to {MAX_ROOT_SEED}"
        )
    return root


def task_seeds(task: str, root: int = 0) -> int:
    """Where `task`'s scene seeds start for the root seed `root` (0: the suite's own items). Every seed of
    an item (its scene, its world's and its perception's noise) derives from this one."""
    return TASKS.get(task).seed_base + check_root_seed(root) * SEED_STRIDE


def build_items(
    tasks: list[str] | None = None,
    limit: int | None = None,
    on_item: Callable[[Item], None] | None = None,
    vocabulary: tuple[str, ...] | None = None,
    seed: int = 0,
) -> list[Item]:
    """The suite's items, task by task (`limit`: at most that many queries per task). Deterministic.
    `on_item` is called as each item is made (generation takes minutes: a progress bar). `vocabulary`: the
    categories a closed-set detector can find; the tasks that can be drawn in it are (see the module
    docstring), the others are built as always. `seed`: the root seed (0: the suite's own items; another
    draws other scenes for every task, `task_seeds`)."""
    chosen = task_names() if tasks is None else tasks
    unknown = [t for t in chosen if t not in TASKS]
    if unknown:
        raise InputError(f"unknown task {', '.join(unknown)}", f"choose from: {', '.join(task_names(None))}")
    items: list[Item] = []
    for name in chosen:
        task = TASKS.get(name)
        n = task.size if limit is None else min(limit, task.size)
        within = drawn_in(name, vocabulary)
        start = task_seeds(name, seed)
        built = (
            task.build(n, start)
            if within is None or task.build_in_vocabulary is None
            else task.build_in_vocabulary(n, start, tuple(within))
        )
        for item in built:
            items.append(item)
            if on_item is not None:
                on_item(item)
    return items


def write_dataset(
    items: list[Item],
    out: Path,
    images: bool = True,
    on_image: Callable[[Item], None] | None = None,
    drawn_for: str | None = None,
) -> None:
    """`out/manifest.jsonl`, `out/dataset.json` and, with `images`, `out/images/<id>.png` (the view the
    item's query is asked on); `on_image` is called as each image is written. `drawn_for`: the detector
    whose vocabulary drew the items that can be drawn in one, said in `dataset.json`."""
    out.mkdir(parents=True, exist_ok=True)
    if images:
        from PIL import Image

        from attribot.embodiments.mujoco import MujocoWorld

        make_folder(out / "images", "the dataset's images folder", "build the dataset into a new --out")
        for item in items:
            with MujocoWorld(item.scene()) as world:
                rgb = world.observe().rgb
            png = io.BytesIO()
            Image.fromarray(np.ascontiguousarray(rgb)).save(png, format="PNG")
            write_whole(out / "images" / f"{item.id}.png", png.getvalue())  # whole, or absent (a full disk)
            if on_image is not None:
                on_image(item)
    write_whole(out / "manifest.jsonl", "".join(i.model_dump_json() + "\n" for i in items).encode())
    about: dict[str, Any] = {"suite": "paper", "version": DATASET_VERSION, "items": len(items)}
    drawn = list(dict.fromkeys(i.task for i in items if i.vocabulary is not None))
    if drawn:  # which tasks' scenes draw only what a detector can find (each item lists the categories)
        about["drawn_in_vocabulary"] = {"detector": drawn_for, "tasks": drawn}
    write_whole(out / "dataset.json", (json.dumps(about, indent=2) + "\n").encode())


def read_dataset(path: Path) -> list[Item]:
    """The items of a dataset directory; refuses a manifest of another dataset version, and one that is no
    manifest attribot wrote (too large, a line that is no item), naming the line."""
    manifest = path / "manifest.jsonl"
    if not manifest.is_file():
        raise InputError(
            f"{path} holds no dataset (no manifest.jsonl)",
            "build one: attribot dataset build --suite paper --out DIR",
        )
    fix = "build the dataset again with attribot dataset build"
    items = [item for _, item in read_jsonl(manifest, Item, "the dataset manifest", fix, torn_last=False)]
    versions = {i.version for i in items}
    if versions - {DATASET_VERSION}:
        raise InputError(
            f"the dataset at {path} was generated by version {', '.join(sorted(versions))[:200]}, this "
            f"attribot generates {DATASET_VERSION}",
            "rebuild it with attribot dataset build, so that its scenes and truth match this code",
        )
    return items


def read_jsonl(
    path: Path, model: type[BaseModel], what: str, fix: str, torn_last: bool = True
) -> Iterator[tuple[int, Any]]:
    """(line number, record) for each line of the JSON-lines file `path`, each validated as `model`. The
    file is read within bounds (a regular file, at most `MAX_JSONL_BYTES`); a line that is no record is an
    `InputError` naming it, but for an unfinished last line when `torn_last` (a crash mid-write), which is
    left out."""
    data = read_capped(path, what, MAX_JSONL_BYTES, fix)
    lines = data.split(b"\n")
    torn = torn_last and not data.endswith(b"\n")
    for number, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            yield number, model.model_validate_json(line)
        except ValueError as exc:  # pydantic's ValidationError, bad JSON, nesting past its limit
            if torn and number == len(lines):
                return
            first = exc.errors()[0] if isinstance(exc, ValidationError) else {"msg": str(exc), "loc": ()}
            where = ".".join(str(p) for p in first.get("loc", ()))
            raise InputError(
                f"{what} {str(path)!r}, line {number}, is not one attribot wrote: "
                f"{where + ': ' if where else ''}{str(first.get('msg', 'invalid'))[:200]}",
                fix,
            ) from None
