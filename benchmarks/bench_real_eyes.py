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
        "--detector",
        default="coco",
        help="the real detector's spec, e.g. coco?part_size=416, or several, comma-separated (coco,yolov5s): "
        "each answers every item right after the oracle, and the items are drawn for the first",
    )
    parser.add_argument("--verbose", action="store_true", help="one line per item and backend")
    args = parser.parse_args()
    clock = time.perf_counter if args.clock == "wall" else time.process_time
    specs = [s.strip() for s in args.detector.split(",") if s.strip()]
    real_eyes = load_settings(detector=specs[0], checks=args.checks)
    vocabulary = findable_categories(build_backend("detector", specs[0], real_eyes))
    items = [
        i for i in build_items(["weight_embodied"], 30, vocabulary=vocabulary) if len(i.candidates) == 3
    ][: args.items]
    times: dict[str, list[float]] = {name: [] for name in ("oracle", *specs)}
    limit = dict.fromkeys(times, 0)
    right = dict.fromkeys(times, 0)
    for item in items:
        for name in times:
            settings = load_settings(detector=name, checks=args.checks)
            start = clock()
            answer = ask(item.query, Scene(item.scene(), sensors=tuple(item.sensors)), settings)
            times[name].append(clock() - start)
            if answer.error is not None and "longer than" in answer.error.message:
                limit[name] += 1
            chosen = answer.object
            ok = chosen is not None and iou(chosen.box, item.true_box) >= 0.5
            ok = ok and chosen is not None and (chosen.id is None or chosen.id == item.true_id)
            right[name] += ok
            if args.verbose:
                print(f"  {item.id} {name}: {times[name][-1]:.1f} s {'right' if ok else 'wrong'}", flush=True)
    oracle = statistics.median(times["oracle"])
    print(
        f"reference oracle: {oracle:.2f} s per weight item of three objects "
        f"({len(items)} items, {args.clock} clock)"
    )
    for name in specs:
        real = statistics.median(times[name])
        print(f"{name}: {real:.2f} s per item = {real / oracle:.1f}x the oracle (target <= 3x)")
    for name in times:
        print(f"{name}: items at the program limit {limit[name]} of {len(items)} (target 0), right answers "
              f"{right[name]} of {len(items)}")  # fmt: skip


if __name__ == "__main__":
    main()
