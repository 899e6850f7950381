#!/usr/bin/env python3
"""What catching errors costs: pa-api's mean wall seconds per item under realistic noise, against the same
items clean, measured in this one command (target: realistic at most 2.5x clean). Also realistic with the
mechanisms off (`--checks none`), which shows what they cost and what they buy, and the accuracy of each
condition, with truth from the world.

    .venv/bin/python benchmarks/bench_safeguards.py [--limit 12] [--tasks weight_embodied,distance_embodied]
"""

from __future__ import annotations

import argparse
import statistics

from attribot.config import load_settings
from attribot.eval.datasets import build_items
from attribot.eval.methods import Condition, run_method


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--limit", type=int, default=12, help="items per task")
    ap.add_argument("--tasks", default="weight_embodied,distance_embodied")
    args = ap.parse_args()
    items = build_items(args.tasks.split(","), args.limit)
    settings = load_settings()
    conditions = {
        "clean": (settings, Condition("clean")),
        "realistic": (settings, Condition("realistic")),
        "realistic, checks none": (settings.model_copy(update={"checks": ()}), Condition("realistic")),
    }
    print(f"{len(items)} items ({args.tasks}), pa-api; wall seconds per item (mean, median), accuracy")
    means = {}
    for name, (condition_settings, noise) in conditions.items():
        walls, right = [], 0
        for item in items:
            record = run_method(item, "pa-api", condition_settings, noise)
            walls.append(record.wall_s)
            right += record.right
        means[name] = statistics.fmean(walls)
        print(
            f"{name:>24}: {means[name]:.2f} s mean, {statistics.median(walls):.2f} s median, "
            f"accuracy {right}/{len(items)}"
        )
    print(f"realistic / clean: {means['realistic'] / means['clean']:.2f}x (target at most 2.5x)")
    print(f"realistic, checks none / clean: {means['realistic, checks none'] / means['clean']:.2f}x")


if __name__ == "__main__":
    main()
