#!/usr/bin/env python3
"""Accuracy of `ask` on household scenes against the simulator's truth, with and without the sensors.

For each seed: "Which object is the closest to me?" (truth: the smallest camera distance among visible
objects), "Which object is the heaviest?" (truth: the largest mass among visible pickable objects), and
"Out of the A, the B and the C, which one is the most lightweight?" over up to three pickable objects.
With sensors the programs measure (rangefinder, wrist force sensor); with the camera alone they reason
(visual proxies, VQA + language model), as the paper's baselines do. Offline defaults throughout.

    .venv/bin/python benchmarks/accuracy_household.py [--seeds 15]
        [--controllers servo,privileged] [--measured-only] [--first-seed 0]

`--controllers` answers the measured queries once per robot controller (`servo` acts on perception alone,
`privileged` reads the simulator's state), to compare them on the same scenes and queries; the answers'
robot backend is checked to be the one asked for.
"""

from __future__ import annotations

import argparse
import time

from attribot.config import SceneConfig, load_settings
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import InputError
from attribot.session import Scene, ask


def cases(seed: int) -> list[tuple[str, str, str, str]]:
    """(task, query, true object id, sensor needed)."""
    with MujocoWorld(layout="household", seed=seed) as world:
        info = world.scene_info()
    visible = [o for o in info.objects if o.box is not None]
    pickable = [o for o in visible if o.pickable]
    out = [
        (
            "closest",
            "Which object is the closest to me?",
            min(visible, key=lambda o: o.distance_m).id,
            "distance",
        )
    ]
    if pickable:
        out.append(
            ("heaviest", "Which object is the heaviest?", max(pickable, key=lambda o: o.mass_kg).id, "force")
        )
    named = pickable[:3]
    if len(named) >= 2 and len({o.category for o in named}) == len(named):
        listed = ", the ".join(o.category for o in named[:-1]) + f" and the {named[-1].category}"
        out.append(
            (
                "lightest of named",
                f"Out of the {listed}, which one is the most lightweight?",
                min(named, key=lambda o: o.mass_kg).id,
                "force",
            )
        )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=15)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--controllers", default="", help="comma-separated; empty: the world's default")
    parser.add_argument("--measured-only", action="store_true", help="skip the camera-only runs")
    args = parser.parse_args()
    settings = load_settings()
    controllers = [c or None for c in args.controllers.split(",")] if args.controllers else [None]
    t0 = time.perf_counter()
    tally: dict[tuple[str, str, bool], list[int]] = {}
    wall: dict[str, list[float]] = {}
    skipped = []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        config = SceneConfig(layout="household", seed=seed)
        try:
            seed_cases = cases(seed)
        except InputError:  # the layout could not place its objects for this seed: no scene to ask in
            skipped.append(seed)
            continue
        for task, query, truth, sensor in seed_cases:
            runs = [(c, True) for c in controllers] + ([] if args.measured_only else [(None, False)])
            for controller, measured in runs:
                sensors = ["camera", sensor] if measured else ["camera"]
                started = time.perf_counter()
                answer = ask(query, Scene(config, sensors=sensors, controller=controller), settings)
                robot = answer.backends.get("robot", "")
                if measured and controller and robot != CONTROLLER_NAMES.get(controller, controller):
                    raise SystemExit(f"asked for controller {controller}, the answer names {robot!r}")
                name = robot if measured else "-"
                wall.setdefault(name, []).append(time.perf_counter() - started)
                right = answer.object is not None and answer.object.id == truth
                counts = tally.setdefault((task, name, measured), [0, 0])
                counts[0] += int(right)
                counts[1] += 1
                if measured and not right:
                    why = answer.error or answer.answer
                    print(f"  wrong: seed {seed} {task} {name}: {why}"[:300], flush=True)
    for (task, name, measured), (right, total) in sorted(tally.items()):
        how = f"measured, robot {name}" if measured else "camera only (reasoned)"
        print(f"{task:18s} {how:34s} {right}/{total} = {right / total:.2f}")
    for name, times in sorted(wall.items()):
        print(f"# wall per query, robot {name}: mean {sum(times) / len(times):.1f} s, max {max(times):.1f} s")
    print(f"# {args.seeds} seeds in {time.perf_counter() - t0:.0f} s; no scene for seeds {skipped or 'none'}")


CONTROLLER_NAMES = {"privileged": "sim-privileged"}


if __name__ == "__main__":
    main()
