#!/usr/bin/env python3
"""Cold `attribot ask`: a fresh process answering a non-embodied query on the embedded world.

Each figure is the median wall time of N fresh processes, printed with its ratio to a bare Python start
(`python -c pass`) measured in the same run, since this machine is shared and noisy. Target: a cold ask
answers in under 2 s.

    .venv/bin/python benchmarks/bench_ask.py [--runs 5]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

QUERIES = {
    "location (arrangement)": ["the second item from the left", "--layout", "arrangement", "--seed", "3"],
    "size (arrangement)": ["the tallest item", "--layout", "arrangement", "--seed", "3"],
    "weight by VQA + language (triplet)": [
        "the heaviest item",
        "--layout",
        "triplet",
        "--seed",
        "3",
        "--sensors",
        "camera",
    ],
}
TARGET_S = 2.0


def wall(cmd: list[str], runs: int) -> float:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        done = subprocess.run(cmd, capture_output=True, text=True)
        times.append(time.perf_counter() - start)
        if done.returncode != 0:
            raise SystemExit(f"{' '.join(cmd)} failed ({done.returncode}): {done.stderr.strip()}")
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    bare = wall([sys.executable, "-c", "pass"], args.runs)
    print(f"reference bare python start: {bare * 1000:.0f} ms")
    for name, argv in QUERIES.items():
        cold = wall([sys.executable, "-m", "attribot.cli", "ask", *argv], args.runs)
        verdict = "met" if cold < TARGET_S else "NOT met"
        print(
            f"cold ask, {name}: {cold * 1000:.0f} ms = {cold / bare:.1f}x bare python "
            f"(target < {TARGET_S:.0f} s: {verdict})"
        )


if __name__ == "__main__":
    main()
