#!/usr/bin/env python3
"""Embodied items with a real detector against the oracle, in one process: wall time per item and the ratio.

The weight_embodied items of three objects drawn for the coco detector (every object a class it can name,
as `attribot eval --detector coco` draws them) are answered by the rules planner with `--detector coco` and
with the simulator's own `oracle`, one after the other, each item in a fresh world. Each figure is the median
wall time per item, and the coco figure is printed as a ratio to the oracle's of the same run (the machine
is shared and noisy). Issue "Right with real eyes" asks for at most 3x, and no item at the program limit.
Each backend's right answers are counted as an evaluation counts them (the chosen object, its box at IoU
>= 0.5 with the truth's).

    .venv/bin/python benchmarks/bench_real_eyes.py [--items 4] [--checks all] [--clock cpu] [--detector SPEC]
"""

from __future__ import annotations

import argparse
import statistics
import time

from attribot.boxes import iou
from attribot.config import load_settings
from attribot.eval.datasets import build_items
from attribot.models.base import build_backend, findable_categories
from attribot.session import Scene, ask


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--items", type=int, default=4, help="weight items of three objects to answer")
    parser.add_argument("--checks", default="all", help="the error-catching mechanisms (as --checks)")
    parser.add_argument("--clock", choices=("wall", "cpu"), default="wall")
    parser.add_argument(
        "--detector", default="coco", help="the real detector's spec, e.g. coco?part_size=416"
    )
    args = parser.parse_args()
    clock = time.perf_counter if args.clock == "wall" else time.process_time
    real_eyes = load_settings(detector=args.detector, checks=args.checks)
    vocabulary = findable_categories(build_backend("detector", args.detector, real_eyes))
    items = [
        i for i in build_items(["weight_embodied"], 30, vocabulary=vocabulary) if len(i.candidates) == 3
    ][: args.items]
    times: dict[str, list[float]] = {"oracle": [], args.detector: []}
    limit = 0
    right = dict.fromkeys(times, 0)
    for item in items:
        for name in ("oracle", args.detector):
            settings = load_settings(detector=name, checks=args.checks)
            start = clock()
            answer = ask(item.query, Scene(item.scene(), sensors=tuple(item.sensors)), settings)
            times[name].append(clock() - start)
            if answer.error is not None and "longer than" in answer.error.message:
                limit += 1
            chosen = answer.object
            if chosen is not None and iou(chosen.box, item.true_box) >= 0.5:
                right[name] += chosen.id is None or chosen.id == item.true_id
    oracle, real = statistics.median(times["oracle"]), statistics.median(times[args.detector])
    print(
        f"reference oracle: {oracle:.2f} s per weight item of three objects "
        f"({len(items)} items, {args.clock} clock)"
    )
    print(f"{args.detector}: {real:.2f} s per item = {real / oracle:.1f}x the oracle (target <= 3x)")
    print(f"items at the program limit: {limit} of {len(items)} (target 0)")
    print(f"right answers: oracle {right['oracle']}, {args.detector} {right[args.detector]} of {len(items)}")


if __name__ == "__main__":
    main()
