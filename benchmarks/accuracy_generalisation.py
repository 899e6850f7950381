#!/usr/bin/env python3
"""Phrasings the parser was not written from, answered on generated scenes, checked against the world.

tests/data/generalisation.jsonl holds everyday phrasings written apart from the rules parser (extremes of
weight, distance, size and left-right position; scopes to a surface; yes/no and named comparisons;
measurements; requests with an action; ranks and compositions; the odd one out; plain look-ups), each with
its meaning in the world's terms, never in the parser's. `--split` deals them, with a fixed seed, into a
tuning part (tests/data/generalisation_tuning.jsonl), the only one to look at while changing the parser,
and a test part (tests/data/generalisation_test.jsonl), scored and reported but not tuned on.

Each phrasing is asked in a scene built for it, with every sensor; the truth comes from the world's state:

- the attribute's world value: weight `mass_kg` (pickable objects only), distance `distance_m`, size `size_m`
  (in an arrangement row of one category where one is clearly odd in size, as benchmarks/
  accuracy_paraphrases.py explains), left-right the centre of the object's box in the rendered image;
- `scope`: only the objects standing on that kind of surface (`surface` in the scene's truth; "table" is
  a table or a coffee table, and a scene with objects on both is not used);
- `rank` k: the k-th from the end asked; `among`: first the k objects at one end of another attribute;
- yes/no: right when `Answer.boolean` says what the two named objects' values say;
- measurements: a weight within 3% of the mass, a distance within half the object's size (+3 cm) of the
  camera's distance to its centre, a size within 35% of the object's longest extent `size_m`;
- a colour the phrasing names ("the blue box") is the colour of the scene's objects;
- a value too close to call at the end asked about (weight 5%, distance 8 cm, size 15%, position 12 px)
  makes the scene unusable: another seed is drawn.

An answer is right, refused (an error that names the query as unread, or any other failure) or a misread
(an answer about another object or another attribute). A phrasing with no scene in 40 seeds is counted
apart.

    .venv/bin/python benchmarks/accuracy_generalisation.py --split            # (re)write the two parts
    .venv/bin/python benchmarks/accuracy_generalisation.py --part tuning
    .venv/bin/python benchmarks/accuracy_generalisation.py --part test
"""

from __future__ import annotations

import argparse
import json
import random
import re
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

from attribot.config import SceneConfig, load_settings
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import AttribotError
from attribot.lexicon import COLOR_WORDS, GENERIC_NOUNS, words
from attribot.session import Scene, ask

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"
ALL = DATA / "generalisation.jsonl"
PARTS = {"tuning": DATA / "generalisation_tuning.jsonl", "test": DATA / "generalisation_test.jsonl"}
SPLIT_SEED = 17
SENSORS = ["camera", "distance", "force"]
GAPS = {"weight": 0.05, "distance": 0.08, "size": 0.15, "x": 12.0}  # relative for weight and size


def split(whole: Path = ALL, parts: dict[str, Path] = PARTS, seed: int = SPLIT_SEED) -> None:
    """Deal the set `whole` into its two `parts`, half and half, with a fixed seed."""
    rows = whole.read_text().splitlines()
    order = list(range(len(rows)))
    random.Random(seed).shuffle(order)
    half = len(rows) // 2
    for name, picked in (("tuning", order[:half]), ("test", order[half:])):
        parts[name].write_text("".join(rows[i] + "\n" for i in sorted(picked)))
        print(f"{name}: {len(picked)} phrasings -> {parts[name]}")


def _surface_kind(surface: str) -> str:
    kind = re.sub(r"_\d+(?:_low)?$", "", surface)
    return "table" if kind == "coffee_table" else kind


def _value(o: Any, attr: str) -> float:
    if attr == "weight":
        return float(o.mass_kg)
    if attr == "distance":
        return float(o.distance_m)
    if attr == "size":
        return float(o.size_m)
    return (o.box[0] + o.box[2]) / 2


def _apart(a: float, b: float, attr: str) -> bool:
    gap = GAPS[attr] * max(abs(a), abs(b)) if attr in ("weight", "size") else GAPS[attr]
    return abs(a - b) >= gap


def _generic(row: dict[str, Any]) -> bool:
    return row.get("noun") in GENERIC_NOUNS or row.get("noun") is None


def _household(
    seed: int, categories: tuple[str, ...] | None = None, objects: int | None = None
) -> SceneConfig:
    options = {"min_gap": 0.08}  # room for small objects seen from afar; distance truths keep their own gap
    return SceneConfig(layout="household", seed=seed, categories=categories, objects=objects, options=options)


def _config(row: dict[str, Any], seed: int) -> SceneConfig:
    kind, attr, noun = row["kind"], row.get("attr"), row.get("noun")
    if kind == "odd":
        return SceneConfig(layout="arrangement", seed=seed)
    if kind == "extreme" and attr == "size" and "scope" not in row:
        options = {"pattern": "row", "odd": "size", "size_variation": 0.03}
        named = None if _generic(row) else (noun,)
        return SceneConfig(layout="arrangement", seed=seed, categories=named, objects=3, options=options)
    if row.get("named"):
        return _household(seed, tuple(row["named"]), len(row["named"]))
    if row.get("scope") == "floor" and kind != "ground":  # most things stand on furniture: bring some
        return _household(seed, ("backpack", "basketball", "mug", "book", "dumbbell"), 5)
    if kind == "ground" and "scope" in row:
        return _household(seed, None, 3)
    if _generic(row):
        many = "scope" in row or "among" in row or "rank" in row
        return _household(seed, None, 5 if many else None)
    if kind in ("measure", "ground"):
        return _household(seed, (noun,), 1)
    return _household(seed, (noun,), 4 if "scope" in row else 3)


def _pick_end(pool: list[Any], attr: str, most: bool, k: int) -> list[Any] | None:
    """The k objects at the end asked for, or None when the cut after the k-th is too close to call."""
    ranked = sorted(pool, key=lambda o: _value(o, attr), reverse=most)
    if len(ranked) < k:
        return None
    if len(ranked) > k and not _apart(_value(ranked[k - 1], attr), _value(ranked[k], attr), attr):
        return None
    return ranked[:k]


def _truth(row: dict[str, Any], visible: list[Any]) -> Any:
    kind, attr = row["kind"], row.get("attr")
    if kind == "odd":
        odd = [o for o in visible if o.odd_one_out]
        return odd[0].id if len(odd) == 1 else None
    pool = visible
    if "scope" in row:
        kinds = {_surface_kind(o.surface) for o in visible}
        if row["scope"] == "table" and {o.surface.split("_")[0] for o in visible} >= {"table", "coffee"}:
            return None  # "the table" could be either
        if row["scope"] not in kinds:
            return None
        pool = [o for o in visible if _surface_kind(o.surface) == row["scope"]]
    if kind == "ground":
        if "scope" in row and len(pool) == len(visible):
            return None  # nothing elsewhere: the scope would not be tested
        return pool[0] if len(pool) == 1 else None
    if kind == "measure":
        return visible[0] if len(visible) == 1 else None
    if kind in ("yesno", "compare"):
        by_name = {o.category: o for o in visible}
        if sorted(by_name) != sorted(row["named"]) or len(visible) != len(row["named"]):
            return None
        objs = [by_name[n] for n in row["named"]]
        if attr == "weight" and not all(o.pickable for o in objs):
            return None
        values = [_value(o, attr) for o in objs]
        if any(not _apart(a, b, attr) for i, a in enumerate(values) for b in values[i + 1 :]):
            return None
        best = (max if row["dir"] == "max" else min)(range(len(objs)), key=lambda i: values[i])
        if kind == "yesno":
            return best == 0
        return objs[best].id
    if attr == "weight":
        pool = [o for o in pool if o.pickable]
    if "among" in row:
        among = row["among"]
        narrowed = _pick_end(pool, among["attr"], among["dir"] == "max", among["k"])
        if narrowed is None or len(pool) <= among["k"]:
            return None
        pool = narrowed
    k = int(row.get("rank", 1))
    if len(pool) < max(2, k):
        return None
    ends = _pick_end(pool, attr, row["dir"] == "max", k)
    if ends is None:
        return None
    if k > 1 and not _apart(_value(ends[-1], attr), _value(ends[-2], attr), attr):
        return None
    return ends[-1].id


def scene_for(row: dict[str, Any], seed: int) -> tuple[SceneConfig, Any] | None:
    """A scene the phrasing applies to and its truth, or None when none could be generated."""
    for tries in range(40):
        config = _config(row, seed * 100 + tries)
        try:
            with MujocoWorld(config) as world:
                info = world.scene_info()
        except AttribotError:
            continue  # the layout could not place these objects on this seed, or no such category
        visible = [o for o in info.objects if o.box is not None]
        colours = [w for w in words(row["query"]) if w in COLOR_WORDS]
        if colours and not all(o.color == colours[0] for o in visible):
            continue  # "the blue box": a scene whose box is blue
        truth = _truth(row, visible)
        if truth is not None:
            return config, truth
    return None


def judge(row: dict[str, Any], truth: Any, answer: Any) -> str:
    """ "right", "refused" or "misread"."""
    if answer.error is not None:
        return "refused"
    if row["kind"] == "yesno":
        got = getattr(answer, "boolean", None)
        return "misread" if got is None or got != truth else "right"
    if row["kind"] == "measure":
        if answer.value is None:
            return "misread"
        attr = row["attr"]
        if attr == "weight":
            ok = answer.unit == "kg" and abs(answer.value - truth.mass_kg) <= 0.03 * truth.mass_kg
        elif attr == "distance":
            ok = answer.unit == "m" and abs(answer.value - truth.distance_m) <= truth.size_m / 2 + 0.03
        else:
            ok = answer.unit == "m" and abs(answer.value - truth.size_m) <= 0.35 * truth.size_m
        return "right" if ok else "misread"
    want = truth.id if row["kind"] == "ground" else truth
    return "right" if answer.object is not None and answer.object.id == want else "misread"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=sorted(PARTS), default="tuning")
    parser.add_argument("--split", action="store_true", help="(re)write the two parts from the whole set")
    parser.add_argument("--seed", type=int, default=0, help="the draw of the scenes")
    parser.add_argument("--kind", default=None, help="only rows of this kind")
    args = parser.parse_args()
    if args.split:
        split()
        return
    rows = [json.loads(line) for line in PARTS[args.part].read_text().splitlines()]
    if args.kind:
        rows = [r for r in rows if r["kind"] == args.kind]
    score(rows, scene_for, judge, SENSORS, "kind", args.seed, f"# {args.part}")


def score(
    rows: list[dict[str, Any]],
    scene_for: Callable[[dict[str, Any], int], tuple[SceneConfig, Any] | None],
    judge: Callable[[dict[str, Any], Any, Any], str],
    sensors: list[str],
    group: str,
    seed: int,
    title: str,
) -> None:
    """Ask every phrasing in the scene drawn for it and print each one not answered right, a line per
    group of rows (the row field `group`) and the total: the scoring loop of this benchmark and of
    accuracy_senses.py."""
    settings = load_settings()
    tally: Counter[tuple[str, str]] = Counter()
    t0 = time.perf_counter()
    for i, row in enumerate(rows):
        built = scene_for(row, seed * 10_000 + i)
        if built is None:
            tally[(row[group], "no scene")] += 1
            print(f"  no scene: {row['query']!r}", flush=True)
            continue
        config, truth = built
        try:
            answer = ask(row["query"], Scene(config, sensors=sensors), settings)
        except AttribotError as exc:  # the planner could not read it: a refusal
            tally[(row[group], "refused")] += 1
            print(f"  refused: {row['query']!r}: {exc}"[:260], flush=True)
            continue
        verdict = judge(row, truth, answer)
        tally[(row[group], verdict)] += 1
        if verdict != "right":
            got = answer.error.message if answer.error else answer.answer
            print(f"  {verdict}: {row['query']!r} seed {config.seed}: {got}"[:260], flush=True)
    asked = sum(v for (_, k), v in tally.items() if k != "no scene")
    right = sum(v for (_, k), v in tally.items() if k == "right")
    misread = sum(v for (_, k), v in tally.items() if k == "misread")
    width = max((len(g) for g, _ in tally), default=0)
    for name in sorted({g for g, _ in tally}):
        r, f, m, n = (tally[(name, k)] for k in ("right", "refused", "misread", "no scene"))
        print(f"{name:{width}s} right {r:3d}  refused {f:3d}  misread {m:3d}  no scene {n:3d}")
    print(
        f"{title}: {right}/{asked} = {right / max(asked, 1):.3f} right, {misread} misread; "
        f"{len(rows)} phrasings in {time.perf_counter() - t0:.0f} s"
    )


if __name__ == "__main__":
    main()
