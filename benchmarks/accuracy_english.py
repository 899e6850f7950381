#!/usr/bin/env python3
"""Everyday English, second round: new phrasings answered on generated scenes and checked against the world.

tests/data/generalisation_english.jsonl holds phrasings written before the rules planner was changed to
read them, of the forms a new user types: contractions ("which one's the heaviest?", "the mug's hot?"),
fillers and politeness ("lightest item pls", "weigh the tin for me"), units and measures ("how many kilos
is the carrot?", "is there anything in the mug?"), surfaces and places ("what's sitting on the bottom
shelf?", "which bowl is in the top right corner?"), yes/no without a leading verb ("tissue box heavier than
the hammer?"), the odd one out ("spot the odd one out") and others (capitals, no apostrophes, a sentence of
context first, negations). Each row names its form (`form`, the grouping of the report) and states its
meaning in the world's terms, in the schema of tests/data/generalisation.jsonl for weight, distance, size
and left-right position and of tests/data/generalisation_senses.jsonl for temperature, stiffness and
fullness, and adds:

- `scope` "top shelf" / "bottom shelf": the upper or lower board of a shelf (any other scope as before;
  "table" is a table or a coffee table, and a scene with objects on both is not used);
- `region` [row, column], e.g. ["top", "right"]: the object in that corner of an arrangement grid (the
  layout's own `row` and `col` as seen in the image), of the noun's category when one is named.

Scenes and truths are those of benchmarks/accuracy_generalisation.py (and of benchmarks/accuracy_senses.py
for the senses); a measurement given in grams or centimetres is converted before it is judged. `--split`
deals the set, with a fixed seed, into a tuning part (generalisation_english_tuning.jsonl), the only one
looked at while changing the parser, and a test part (generalisation_english_test.jsonl), scored and
reported but not tuned on.

    .venv/bin/python benchmarks/accuracy_english.py --split          # (re)write the two parts
    .venv/bin/python benchmarks/accuracy_english.py --part tuning
    .venv/bin/python benchmarks/accuracy_english.py --part test
"""

from __future__ import annotations

import argparse
import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import accuracy_generalisation as everyday
import accuracy_senses as senses
from attribot.config import SceneConfig
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import AttribotError
from attribot.lexicon import COLOR_WORDS, words

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"
ALL = DATA / "generalisation_english.jsonl"
PARTS = {
    "tuning": DATA / "generalisation_english_tuning.jsonl",
    "test": DATA / "generalisation_english_test.jsonl",
}
SPLIT_SEED = 30
SENSORS = ["camera", "distance", "force", "temperature", "grip"]
SENSES = set(senses.FIELD)
LEVELS = {"top shelf": re.compile(r"shelf_\d+$"), "bottom shelf": re.compile(r"shelf_\d+_low$")}
TO_BASE = {"g": ("kg", 0.001), "cm": ("m", 0.01), "mm": ("m", 0.001)}
"""A measurement in a smaller unit, as the benchmarks' judges read it: (their unit, the factor)."""


def _on(o: Any, scope: str) -> bool:
    if scope in LEVELS:
        return bool(LEVELS[scope].match(o.surface))
    return everyday._surface_kind(o.surface) == scope


def _config(row: dict[str, Any], seed: int) -> SceneConfig:
    if "region" in row:
        named = None if everyday._generic(row) else (row["noun"],)
        return SceneConfig(layout="arrangement", seed=seed, categories=named, options={"pattern": "grid"})
    if row.get("scope") in LEVELS:  # scenes as for "on the shelf"
        row = {**row, "scope": "shelf"}
    if row.get("attr") in SENSES:
        return senses._config(row, seed)
    return everyday._config(row, seed)


def _corner(row: dict[str, Any], visible: list[Any]) -> Any:
    vertical, horizontal = row["region"]
    rows = [o.row for o in visible if o.row is not None]
    cols = [o.col for o in visible if o.col is not None]
    if not rows or not cols:
        return None
    r = min(rows) if vertical == "top" else max(rows)
    c = min(cols) if horizontal == "left" else max(cols)
    found = [o for o in visible if o.row == r and o.col == c]
    if len(found) != 1 or (not everyday._generic(row) and found[0].category != row["noun"]):
        return None
    return found[0]


def _truth(row: dict[str, Any], visible: list[Any]) -> Any:
    if "region" in row:
        return _corner(row, visible)
    if "scope" in row:
        if row["scope"] == "table" and {o.surface.split("_")[0] for o in visible} >= {"table", "coffee"}:
            return None  # "the table" could be either
        pool = [o for o in visible if _on(o, row["scope"])]
        if row["kind"] == "ground":  # one object there, and others elsewhere, so that the scope is tested
            return pool[0] if len(pool) == 1 and len(visible) > 1 else None
        if not pool:
            return None
        row = {k: v for k, v in row.items() if k != "scope"}
        visible = pool
    if row.get("attr") in SENSES:
        return senses._truth(row, visible)
    return everyday._truth(row, visible)


def scene_for(
    row: dict[str, Any],
    seed: int,
    config_of: Callable[[dict[str, Any], int], SceneConfig] | None = None,
    truth_of: Callable[[dict[str, Any], list[Any]], Any] | None = None,
) -> tuple[SceneConfig, Any] | None:
    """A scene the phrasing applies to and its truth, or None when none could be generated. `config_of` and
    `truth_of` draw a row's scene and read its truth (default: this set's own), for sets that build on it."""
    config_of, truth_of = config_of or _config, truth_of or _truth
    for tries in range(60):
        config = config_of(row, seed * 100 + tries)
        try:
            with MujocoWorld(config) as world:
                info = world.scene_info()
        except AttribotError:
            continue  # the layout could not place these objects on this seed
        visible = [o for o in info.objects if o.box is not None]
        colours = [w for w in words(row["query"]) if w in COLOR_WORDS]
        if colours and not all(o.color == colours[0] for o in visible):
            continue
        truth = truth_of(row, visible)
        if truth is not None:
            return config, truth
    return None


def judge(row: dict[str, Any], truth: Any, answer: Any) -> str:
    """ "right", "refused" or "misread"."""
    if answer.error is None and answer.value is not None and answer.unit in TO_BASE:
        unit, factor = TO_BASE[answer.unit]
        answer = answer.model_copy(update={"value": answer.value * factor, "unit": unit})
    if row.get("attr") in SENSES:
        return senses.judge(row, truth, answer)
    if row["kind"] == "state":
        raise ValueError(f"a state of {row.get('attr')!r}: only the senses have states")
    return everyday.judge(row, truth, answer)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=sorted(PARTS), default="tuning")
    parser.add_argument("--split", action="store_true", help="(re)write the two parts from the whole set")
    parser.add_argument("--seed", type=int, default=0, help="the draw of the scenes")
    parser.add_argument("--form", default=None, help="only rows of this form")
    args = parser.parse_args()
    if args.split:
        everyday.split(ALL, PARTS, SPLIT_SEED)
        return
    rows = [json.loads(line) for line in PARTS[args.part].read_text().splitlines()]
    if args.form:
        rows = [r for r in rows if r["form"] == args.form]
    everyday.score(rows, scene_for, judge, SENSORS, "form", args.seed, f"# english {args.part}")


if __name__ == "__main__":
    main()
