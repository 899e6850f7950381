#!/usr/bin/env python3
"""The paraphrase set answered on generated scenes and checked against the simulator's truth.

tests/data/paraphrases.jsonl gives each phrasing with its meaning (family, direction, noun or named objects);
the tests check that the rules planner reads that meaning. This asks every phrasing in a scene built for
it and checks the answer against the world, with every sensor:

- weight / distance: a household scene with three objects of the noun's category (the layout's own objects
  for "object", "item", "thing"; one of each named category for named objects); truth: the heaviest or
  lightest pickable object, the nearest or farthest visible one;
- size: a row of three objects of the category (the layout's choice for "object") at about one distance,
  one clearly bigger or smaller (the arrangement layout's odd size); truth: the largest or smallest `size_m`
  when it is that odd one (one category's objects are scaled as a whole, so the biggest is also the tallest
  and the widest; across categories `size_m`, an object's longest extent, says nothing of which is
  "tallest", so sizes are not compared across categories here);
- measurement: one object of the category; right when the value is within 3% of the mass, or within half
  the object's size (+3 cm) of the camera's distance to its centre (the rangefinder meets its surface);
- grounding: one object of the category, of the colour the phrasing names if it names one;
- odd one out: an arrangement scene; truth: the object the layout made odd.

A phrasing whose scene cannot be generated (a category the catalog lacks, no placement in 20 seeds) is
counted apart, never as right.

    .venv/bin/python benchmarks/accuracy_paraphrases.py [--sample 120] [--seed 0]
"""

from __future__ import annotations

import argparse
import json
import random
import time
from collections import Counter
from pathlib import Path
from typing import Any

from attribot.config import SceneConfig, load_settings
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import AttribotError
from attribot.lexicon import COLOR_WORDS, GENERIC_NOUNS
from attribot.session import Scene, ask
from attribot.sim.scene import resolve_categories

ROWS = Path(__file__).resolve().parents[1] / "tests" / "data" / "paraphrases.jsonl"
SENSORS = ["camera", "distance", "force"]


def _scene_for(row: dict[str, Any], seed: int) -> tuple[SceneConfig, Any] | None:
    """A scene the phrasing applies to and its truth, or None when none could be generated."""
    family, noun = row["family"], row.get("noun")
    generic = noun in GENERIC_NOUNS or noun is None
    try:
        resolve_categories(row.get("named") or ([] if generic else [noun]))
    except AttribotError:
        return None  # a category the catalog does not have
    for tries in range(20):
        s = seed * 100 + tries
        if family == "odd":
            config = SceneConfig(layout="arrangement", seed=s)
        elif family == "size":
            # one row of one category at about one distance, one of them clearly bigger or smaller: what is
            # largest in the image is then largest in the world, in every dimension
            options = {"pattern": "row", "odd": "size", "size_variation": 0.03}
            named = None if generic else (noun,)
            config = SceneConfig(layout="arrangement", seed=s, categories=named, objects=3, options=options)
        elif row.get("named"):
            config = SceneConfig(
                layout="household", seed=s, categories=tuple(row["named"]), objects=len(row["named"])
            )
        elif generic:
            config = SceneConfig(layout="household", seed=s)
        else:
            n = 1 if family in ("measurement", "grounding") else 3
            config = SceneConfig(layout="household", seed=s, categories=(noun,), objects=n)
        try:
            with MujocoWorld(config) as world:
                info = world.scene_info()
        except AttribotError:
            continue  # the layout could not place these objects on this seed
        visible = [o for o in info.objects if o.box is not None]
        if row.get("named") and sorted(o.category for o in visible) != sorted(row["named"]):
            continue  # a named object hidden behind another: not this phrasing's scene
        colours = [w for w in row["query"].lower().replace("?", " ").split() if w in COLOR_WORDS]
        if colours and not all(o.color == colours[0] for o in visible):
            continue  # "the teal apple": a scene whose apple is teal
        truth = _truth(row, visible)
        if truth is not None:
            return config, truth
    return None


def _truth(row: dict[str, Any], visible: list[Any]) -> Any:
    family, most = row["family"], row.get("most")
    if family == "odd":
        odd = [o for o in visible if o.odd_one_out]
        return odd[0].id if len(odd) == 1 else None
    if family in ("measurement", "grounding"):
        return visible[0] if len(visible) == 1 else None
    if family == "weight":
        pool = [o for o in visible if o.pickable]
        key = "mass_kg"
    elif family == "distance":
        pool, key = visible, "distance_m"
        most = not most  # "most" is the nearest: the smallest distance
    else:
        pool, key = visible, "size_m"
    if len(pool) < 2:
        return None
    ranked = sorted(pool, key=lambda o: getattr(o, key))
    values = [getattr(o, key) for o in ranked]
    gap = 0.15 * values[-1] if family == "size" else 1e-6  # size: only the clearly odd one
    if (values[-1] - values[-2] if most else values[1] - values[0]) < gap:
        return None  # a tie, or too close to call, at the end asked about
    return (ranked[-1] if most else ranked[0]).id


def _right(row: dict[str, Any], truth: Any, answer: Any) -> bool:
    if row["family"] == "measurement":
        if answer.value is None:
            return False
        if row["quantity"] == "weight":
            return abs(answer.value - truth.mass_kg) <= 0.03 * truth.mass_kg
        # the rangefinder meets the object's surface, up to half its size nearer than its centre
        return abs(answer.value - truth.distance_m) <= truth.size_m / 2 + 0.03
    want = truth.id if row["family"] == "grounding" else truth
    return answer.object is not None and answer.object.id == want


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sample", type=int, default=0, help="ask this many rows drawn at random (0: all)")
    parser.add_argument("--seed", type=int, default=0, help="the draw of the sample and of the scenes")
    args = parser.parse_args()
    rows = [json.loads(line) for line in ROWS.read_text().splitlines()]
    if args.sample:
        rows = random.Random(args.seed).sample(rows, min(args.sample, len(rows)))
    settings = load_settings()
    tally: Counter[tuple[str, str]] = Counter()
    t0 = time.perf_counter()
    for i, row in enumerate(rows):
        built = _scene_for(row, args.seed * 10_000 + i)
        if built is None:
            tally[(row["family"], "no scene")] += 1
            continue
        config, truth = built
        answer = ask(row["query"], Scene(config, sensors=SENSORS), settings)
        right = _right(row, truth, answer)
        tally[(row["family"], "right" if right else "wrong")] += 1
        if not right:
            got = answer.error.message if answer.error else answer.answer
            print(f"  wrong: {row['query']!r} seed {config.seed}: {got}"[:300], flush=True)
    asked = sum(v for (_, k), v in tally.items() if k != "no scene")
    right = sum(v for (_, k), v in tally.items() if k == "right")
    for family in sorted({f for f, _ in tally}):
        r, w, n = (tally[(family, k)] for k in ("right", "wrong", "no scene"))
        print(f"{family:12s} right {r:4d}  wrong {w:3d}  no scene {n:3d}")
    print(f"# {right}/{asked} = {right / max(asked, 1):.3f} answered right; {len(rows)} phrasings in "
          f"{time.perf_counter() - t0:.0f} s")  # fmt: skip


if __name__ == "__main__":
    main()
