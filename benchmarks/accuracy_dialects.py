#!/usr/bin/env python3
"""How often programs written as LLMs write them from each prompt dialect answer right, by the world's truth.

The programs are the held-out style set of tests/data/dialect_programs.jsonl: attribot's prompt
(`execute_command(image, robot)`), ViperGPT's habits and the paper authors' prompt (bare functions, names,
`put_on(patch)` given the object just weighed). Each runs as `attribot exec` would run it, on its own scene
and optionally under noise; it is right when it chose the object its truth names (the world's own state,
`scene_info()`) and its box has IoU 0.5 or more with that object's.

    .venv/bin/python benchmarks/accuracy_dialects.py [--world-noise realistic]
        [--detector 'oracle?miss=0.1&false_pos=0.05&jitter_px=5&confuse=0.05'] [--vqa 'oracle?wrong=0.1']

One line per program (dialect, name, right or what went wrong, wall seconds), then one per dialect: k/n.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from attribot.boxes import iou
from attribot.config import SceneConfig, load_settings
from attribot.embodiments.mujoco import MujocoWorld
from attribot.noise import world_noise
from attribot.session import Scene, run_program

DATA = Path(__file__).resolve().parent.parent / "tests" / "data" / "dialect_programs.jsonl"


def _centre_x(o: Any) -> float:
    return o.box[0] + o.box[2]


TRUTHS = {  # the id of the right object, from the scene's objects
    "heaviest": lambda objects: max(objects, key=lambda o: o.mass_kg),
    "lightest": lambda objects: min(objects, key=lambda o: o.mass_kg),
    "closest": lambda objects: min(objects, key=lambda o: o.distance_m),
    "rightmost": lambda objects: max((o for o in objects if o.box), key=_centre_x),
    "second_from_right": lambda objects: sorted((o for o in objects if o.box), key=lambda o: -_centre_x(o))[
        1
    ],
}


def truth_of(row: dict[str, Any], config: SceneConfig) -> Any:
    with MujocoWorld(config) as world:
        objects = list(world.scene_info().objects)
    name = row["truth"]
    if name.startswith("category:"):
        (found,) = [o for o in objects if o.category == name.split(":", 1)[1]]
        return found
    return TRUTHS[name](objects)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--world-noise", default=None, help="a noise preset or KEY=VALUE pairs (seeded per scene)"
    )
    parser.add_argument("--detector", default="oracle")
    parser.add_argument("--vqa", default="oracle")
    args = parser.parse_args()
    settings = load_settings(detector=args.detector, vqa=args.vqa)
    tally: dict[str, list[bool]] = defaultdict(list)
    for line in DATA.read_text(encoding="utf-8").splitlines():
        row = json.loads(line)
        config = SceneConfig(**row["scene"])
        if args.world_noise:
            config = config.model_copy(update={"noise": world_noise(args.world_noise, config.seed)})
        truth = truth_of(row, config)
        started = time.perf_counter()
        answer = run_program(row["program"], Scene(config), settings, query=row["query"])
        wall = time.perf_counter() - started
        if answer.error is not None:
            said = f"failed: {answer.error.message[:120]}"
        elif answer.object is None or answer.object.id != truth.id:
            said = f"wrong: chose {answer.object.id if answer.object else None}, truth {truth.id}"
        elif iou(tuple(answer.object.box), tuple(truth.box)) < 0.5:
            said = f"wrong box: IoU {iou(tuple(answer.object.box), tuple(truth.box)):.2f}"
        else:
            said = "right"
        tally[row["dialect"]].append(said == "right")
        print(f"{row['dialect']:9s} {row['name'][:60]:60s} {said} ({wall:.1f} s)", flush=True)
    for dialect, right in tally.items():
        print(f"{dialect}: {sum(right)}/{len(right)} right")


if __name__ == "__main__":
    main()
