#!/usr/bin/env python3
"""The evaluation runner's speed, as ratios measured in one command on the same items:

1. `--workers 2` against `--workers 1` (target: at least 1.7x on 2 cores);
2. a finished run run again (resume: every record found, nothing recomputed; target under 5 s);
3. `--executor ray` (a local Ray instance, started and stopped by the run) against `--workers 2`.

The dataset is generated once beforehand and copied into each run, so that only running is timed.

    .venv/bin/python benchmarks/bench_eval.py [--limit 6] [--tasks weight_image,weight_embodied]
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

from attribot.config import load_settings
from attribot.eval.run import EvalPlan, read_records, run_eval


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--limit", type=int, default=6)
    ap.add_argument("--tasks", default="location,size,weight_image,distance_embodied,weight_embodied")
    ap.add_argument("--no-ray", action="store_true")
    args = ap.parse_args()
    settings = load_settings()
    plan = EvalPlan(tasks=tuple(args.tasks.split(",")), noise=("clean", "realistic"), limit=args.limit)
    root = Path(tempfile.mkdtemp(prefix="bench-eval-"))
    try:
        # the dataset once: generating it is not what is measured
        seed_run = root / "dataset-only"
        run_eval(EvalPlan(tasks=plan.tasks, methods=("ovd",), limit=args.limit), settings, seed_run)

        def timed(name: str, **kw: object) -> tuple[float, int]:
            out = root / name
            out.mkdir()
            shutil.copytree(seed_run / "dataset", out / "dataset")
            shutil.copy(seed_run / "run.json", out / "run.json")
            t0 = time.perf_counter()
            run_eval(plan, settings, out, **kw)  # type: ignore[arg-type]
            return time.perf_counter() - t0, len(read_records(out))

        one, n = timed("one", workers=1)
        two, _ = timed("two", workers=2)
        print(f"{n} records ({len(plan.tasks)} tasks, {args.limit} items each, clean and realistic)")
        print(f"workers 1: {one:.1f} s, workers 2: {two:.1f} s, speed-up {one / two:.2f}x")
        t0 = time.perf_counter()
        again = run_eval(plan, settings, root / "two", workers=2)
        print(f"resume of the finished run: {time.perf_counter() - t0:.2f} s, {again.done} recomputed")
        if not args.no_ray:
            ray_s, _ = timed("ray", executor="ray")
            print(
                f"ray (local instance, started and stopped): {ray_s:.1f} s, "
                f"{ray_s / two:.2f}x the time of workers 2"
            )
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
