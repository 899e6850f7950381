"""Servo convergence: how fast and how well the `servo` controller centres objects in household scenes.

Run: `.venv/bin/python benchmarks/bench_servo.py [--seeds 30] [--width 320 --height 240]`

For every object of every seed, from the scene's first view, in two modes:
- closed loop alone (`preaim=False`, the paper's way): track the first view's box with KLT and servo the
  head on it with the PID until the box centre is within 1.5 px of the image centre;
- geometric pre-aim then closed loop (the default): the pointing controller's open-loop aim, one detection,
  then the loop.
It prints the success rate (centred within 5 px by the simulator's truth, checked after the controller
says it is done), the mean and worst sim seconds and control steps to centre, and the mean final error;
and the distance each mode measures against the privileged controller's on the same objects (the
reference: the ratio of mean absolute differences is what compares across runs). Target: centred within
2 s of sim time.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

from attribot.api import Perception, Robot
from attribot.config import SceneConfig, load_settings
from attribot.control.base import build_controller
from attribot.control.servo import ServoController
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import AttribotError

__all__ = ["main"]


def _truth_error(world: MujocoWorld, object_id: str, width: int, height: int) -> float:
    box = next(o.box for o in world.scene_info().objects if o.id == object_id)
    if box is None:
        return math.inf
    return math.hypot((box[0] + box[2]) / 2 - width / 2, (box[1] + box[3]) / 2 - height / 2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    args = ap.parse_args()
    perception = Perception.from_settings(load_settings())
    rows: dict[str, list[tuple[bool, float, int, float, float]]] = {"closed loop": [], "pre-aim + loop": []}
    reference: list[float] = []
    t0 = time.perf_counter()
    for seed in range(args.seeds):
        config = SceneConfig(layout="household", seed=seed, width=args.width, height=args.height)
        with MujocoWorld(config) as world:
            count = len(Robot(world=world).look(perception).find("object"))
        for k in range(count):
            with MujocoWorld(config) as world:
                robot = Robot(sensors=["camera", "distance"], world=world, controller=build_controller(world))
                patch = robot.look(perception).find("object")[k]
                try:
                    reference.append(robot.measure_distance(patch))
                except AttribotError:  # the privileged controller cannot measure it: no reference for it
                    reference.append(math.nan)
            for mode, preaim in (("closed loop", False), ("pre-aim + loop", True)):
                with MujocoWorld(config) as world:
                    servo = ServoController(world, preaim=preaim)
                    robot = Robot(sensors=["camera", "distance"], world=world, controller=servo)
                    patch = robot.look(perception).find("object")[k]
                    try:
                        metres = robot.measure_distance(patch)
                    except Exception:  # noqa: BLE001 (a failure is counted, not raised)
                        rows[mode].append((False, math.nan, 0, math.inf, math.nan))
                        continue
                    last = servo.last
                    err = _truth_error(world, str(patch.object_id), args.width, args.height)
                    seconds = last.seconds if last else 0.0
                    steps = last.steps if last else 0
                    rows[mode].append((err <= 5.0, seconds, steps, err, metres))
    n = len(reference)
    print(
        f"{args.seeds} household seeds, {n} objects at {args.width}x{args.height}, "
        f"{time.perf_counter() - t0:.0f} s wall"
    )
    for mode, results in rows.items():
        ok = [r for r in results if r[0]]
        secs = [r[1] for r in ok]
        steps = [r[2] for r in ok]
        diffs = [
            abs(r[4] - ref) for r, ref in zip(results, reference, strict=True) if r[0] and math.isfinite(ref)
        ]
        print(
            f"{mode:<15s} centred {len(ok)}/{n} ({len(ok) / max(n, 1):.3f}); "
            f"sim s mean {statistics.fmean(secs) if secs else math.nan:.2f} "
            f"max {max(secs, default=math.nan):.2f}; "
            f"steps mean {statistics.fmean(steps) if steps else math.nan:.1f} max {max(steps, default=0)}; "
            f"final error mean {statistics.fmean([r[3] for r in ok]) if ok else math.nan:.2f} px; "
            f"distance vs privileged mean |diff| {statistics.fmean(diffs) if diffs else math.nan:.4f} m"
        )


if __name__ == "__main__":
    main()
