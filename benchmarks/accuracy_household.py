#!/usr/bin/env python3
"""Accuracy of `ask` on household scenes against the simulator's truth, with and without the sensors.

For each seed: "Which object is the closest to me?" (truth: the smallest camera distance among visible
objects), "Which object is the heaviest?" (truth: the largest mass among visible pickable objects), and
"Out of the A, the B and the C, which one is the most lightweight?" over up to three pickable objects.
With sensors the programs measure (rangefinder, wrist force sensor); with the camera alone they reason
(visual proxies, VQA + language model), as the paper's baselines do. Offline defaults throughout.

    .venv/bin/python benchmarks/accuracy_household.py [--seeds 15]
"""

from __future__ import annotations

import argparse
import time

from attribot.config import SceneConfig, load_settings
from attribot.embodiments.mujoco import MujocoWorld
from attribot.planning.ask import Scene, ask


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
    args = parser.parse_args()
    settings = load_settings()
    t0 = time.perf_counter()
    tally: dict[tuple[str, bool], list[int]] = {}
    for seed in range(args.seeds):
        for task, query, truth, sensor in cases(seed):
            for measured in (True, False):
                sensors = ["camera", sensor] if measured else ["camera"]
                answer = ask(
                    query, Scene(SceneConfig(layout="household", seed=seed), sensors=sensors), settings
                )
                right = answer.object is not None and answer.object.id == truth
                counts = tally.setdefault((task, measured), [0, 0])
                counts[0] += int(right)
                counts[1] += 1
    for (task, measured), (right, total) in sorted(tally.items()):
        how = "measured (perception-action API)" if measured else "camera only (reasoned)"
        print(f"{task:18s} {how:34s} {right}/{total} = {right / total:.2f}")
    print(f"# {args.seeds} seeds in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
