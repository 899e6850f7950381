#!/usr/bin/env python3
"""Phrasings of the senses beyond the paper's (temperature, softness, fullness), answered on generated
scenes and checked against the world: the generalisation protocol of benchmarks/accuracy_generalisation.py,
held out in a set of its own.

tests/data/generalisation_senses.jsonl was written before the rules planner read any of these senses: the
hot and cold end of temperature, the soft and hard end of stiffness, the empty and full end of fullness;
yes/no questions about one object's state ("is the kettle hot?") and comparisons of two; measurements
("how hot is the kettle?"); named comparisons; scopes and requests with an action. Each row states its
meaning in the world's terms. `--split` deals it, with a fixed seed, into a tuning part
(generalisation_senses_tuning.jsonl), the only one looked at while writing the planner's sense family, and a
test part (generalisation_senses_test.jsonl), scored and reported but not tuned on. The phrasings of
tests/data/generalisation.jsonl are not touched.

Each phrasing is asked in a household scene built for it, with every sensor; the truth is the world's state
(`temperature_c`, `stiffness_n_per_mm`, `fill` of each object in the scene's truth):

- an extreme: the object at the end asked, when it is clearly apart from the next (5 degC, a factor of two
  in stiffness, half a container);
- a state ("hot", "soft", "empty"): hot is 40 degC or more, warm 30 or more, cold 12 or less; soft is under
  1 N/mm, firm 1 or more, hard 5 or more; full is more than half full, empty less than half; right when
  `Answer.boolean` says what the world's state says;
- a yes/no comparison or a named comparison: as an extreme among the named objects;
- a measurement: the value within 2 degC, within 35% of the stiffness, within 0.2 of the fill.

    .venv/bin/python benchmarks/accuracy_senses.py --split          # (re)write the two parts
    .venv/bin/python benchmarks/accuracy_senses.py --part tuning
    .venv/bin/python benchmarks/accuracy_senses.py --part test
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from accuracy_generalisation import score, split
from attribot.config import SceneConfig
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import AttribotError

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"
ALL = DATA / "generalisation_senses.jsonl"
PARTS = {
    "tuning": DATA / "generalisation_senses_tuning.jsonl",
    "test": DATA / "generalisation_senses_test.jsonl",
}
SPLIT_SEED = 29
SENSORS = ["camera", "distance", "force", "temperature", "grip"]
FIELD = {"temperature": "temperature_c", "stiffness": "stiffness_n_per_mm", "fullness": "fill"}
STATES = {
    "hot": ("temperature", 40.0, True),
    "warm": ("temperature", 30.0, True),
    "cold": ("temperature", 12.0, False),
    "soft": ("stiffness", 1.0, False),
    "firm": ("stiffness", 1.0, True),
    "hard": ("stiffness", 5.0, True),
    "full": ("fullness", 0.5, True),
    "empty": ("fullness", 0.5, False),
}
"""A state word: (the attribute, its threshold, whether the state is at or above it)."""
MIXED = {
    "temperature": ("kettle", "mug", "can", "mug", "can"),
    "stiffness": ("ball", "apple", "foam ball", "ball", "tennis ball"),
    "fullness": ("bottle", "mug", "jar", "bottle", "mug"),
}
"""The objects of a scene for a phrasing about any object ("the hottest thing on the table"); with a scope,
all five, so that some stand on the surface named; three otherwise."""
UNITS = {"temperature": "°C", "stiffness": "N/mm", "fullness": "full"}


def _value(o: Any, attr: str) -> float | None:
    value = getattr(o, FIELD[attr])
    return None if value is None else float(value)


def _apart(a: float, b: float, attr: str) -> bool:
    if attr == "stiffness":
        return max(a, b) >= 2.0 * min(a, b)
    return abs(a - b) >= (5.0 if attr == "temperature" else 0.5)


def _config(row: dict[str, Any], seed: int) -> SceneConfig:
    kind, attr, noun = row["kind"], row["attr"], row.get("noun")
    if row.get("named"):
        named = tuple(row["named"])
    elif kind in ("state", "measure"):
        named = (noun,)
    elif noun in ("object", "thing", "item"):
        named = MIXED[attr] if "scope" in row else MIXED[attr][:3]
    else:
        named = (noun,) * (2 if noun in ("kettle", "teapot") else 3)
    return SceneConfig(layout="household", seed=seed, categories=named, objects=len(named))


def _truth(row: dict[str, Any], visible: list[Any]) -> Any:
    kind, attr = row["kind"], row["attr"]
    if "scope" in row:
        visible = [o for o in visible if o.surface.startswith(row["scope"]) and "coffee" not in o.surface]
    if kind in ("state", "measure"):
        if len(visible) != 1 or _value(visible[0], attr) is None:
            return None
        if kind == "measure":
            return visible[0]
        field, threshold, above = STATES[row["state"]]
        value = _value(visible[0], field)
        assert value is not None
        return value >= threshold if above else value < threshold
    pool = [o for o in visible if _value(o, attr) is not None]
    if row.get("named"):
        by_name = {o.category: o for o in pool}
        if sorted(by_name) != sorted(row["named"]) or len(pool) != len(row["named"]):
            return None
        pool = [by_name[n] for n in row["named"]]
    if len(pool) < 2:
        return None
    ranked = sorted(pool, key=lambda o: _value(o, attr), reverse=row["dir"] == "max")
    if not _apart(_value(ranked[0], attr), _value(ranked[1], attr), attr):  # type: ignore[arg-type]
        return None
    if kind == "yesno":
        return ranked[0] is pool[0]
    return ranked[0].id


def scene_for(row: dict[str, Any], seed: int) -> tuple[SceneConfig, Any] | None:
    """A scene the phrasing applies to and its truth, or None when none could be generated."""
    for tries in range(60):
        config = _config(row, seed * 100 + tries)
        try:
            with MujocoWorld(config) as world:
                info = world.scene_info()
        except AttribotError:
            continue  # the layout could not place these objects on this seed
        truth = _truth(row, [o for o in info.objects if o.box is not None])
        if truth is not None:
            return config, truth
    return None


def judge(row: dict[str, Any], truth: Any, answer: Any) -> str:
    """ "right", "refused" or "misread"."""
    if answer.error is not None:
        return "refused"
    kind, attr = row["kind"], row["attr"]
    if kind in ("state", "yesno"):
        got = getattr(answer, "boolean", None)
        return "misread" if got is None or got != truth else "right"
    if kind == "measure":
        want = _value(truth, attr)
        if answer.value is None or answer.unit != UNITS[attr] or want is None:
            return "misread"
        tolerance = {"temperature": 2.0, "stiffness": 0.35 * want, "fullness": 0.2}[attr]
        return "right" if abs(answer.value - want) <= tolerance else "misread"
    return "right" if answer.object is not None and answer.object.id == truth else "misread"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=sorted(PARTS), default="tuning")
    parser.add_argument("--split", action="store_true", help="(re)write the two parts from the whole set")
    parser.add_argument("--seed", type=int, default=0, help="the draw of the scenes")
    args = parser.parse_args()
    if args.split:
        split(ALL, PARTS, SPLIT_SEED)
        return
    rows = [json.loads(line) for line in PARTS[args.part].read_text().splitlines()]
    score(rows, scene_for, judge, SENSORS, "attr", args.seed, f"# senses {args.part}")


if __name__ == "__main__":
    main()
