#!/usr/bin/env python3
"""How often put_on lands the held object on a piece of furniture's top, by the simulator's truth.

For each household seed and each piece of furniture in it (the coffee table, the counter or the shelf), the
robot picks up the first visible pickable object that does not stand on that piece's top and puts it on the
piece, acting on perception alone (the servo controller, the oracle detector by default). The truth is the
simulator's state afterwards: not held, standing on the top (`SimWorld.support_of`: its lowest point
within 1 cm of the top's height, its middle over the piece), still. Each placement is tried twice on the
same scene: `top` (a free spot of the top near the robot, found in depth: what put_on does with
furniture) and `middle` (the receptacle's middle, what it does with a plate or a bowl, and did with
furniture before), with the same sim fix and carrying.

    .venv/bin/python benchmarks/accuracy_put_on.py [--seeds 20] [--first-seed 100]
        [--world-noise realistic] [--strategies top,middle]

One line per placement (seed, piece, object, strategy, landed or the error), then one summary line per
strategy and piece kind: landed k/n, and the mean wall and sim seconds of a put_on.
"""

from __future__ import annotations

import argparse
import math
import time
from collections import defaultdict

import numpy as np

from attribot.api import Perception, Robot
from attribot.config import SceneConfig, load_settings
from attribot.control.servo import ServoController
from attribot.control.tuning import ServoTuning
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import AttribotError, InputError
from attribot.lexicon import surface_kind
from attribot.noise import world_noise

STRATEGIES = {"top": ServoTuning(), "middle": ServoTuning(large_top_m2=math.inf)}


def landed(world: MujocoWorld, object_id: str, furniture: str) -> str | None:
    """None when the simulator has the object standing still on the furniture's top, else what is wrong."""
    sim = world.sim
    key = sim.key_of_id[object_id]
    if world.held_object() == object_id:
        return "still held"
    before = sim.object_bounds(key).copy()
    world.step(0.5)
    if sim.support_of(key) != furniture:
        return f"on {sim.support_of(key)}"
    if np.abs(sim.object_bounds(key) - before).max() > 0.005:
        return "still moving"
    return None


def place(
    config: SceneConfig, furniture: str, strategy: str, perception: Perception
) -> tuple[str, str, float, float]:
    """(object id, outcome, wall s, sim s of put_on) of one placement; outcome "landed" or why not."""
    with MujocoWorld(config) as world:
        robot = Robot(
            sensors=["camera", "force"],
            world=world,
            controller=ServoController(world, tuning=STRATEGIES[strategy]),
        )
        image = robot.look(perception)
        targets = [p for p in image.find(surface_kind(furniture)) if p.object_id == furniture]
        if not targets:
            return "-", "receptacle not seen", 0.0, 0.0
        on = {o.id: o.surface for o in world.sim.plan.objects}
        pickable = {o.id for o in world.scene_info().objects if o.pickable}
        patches = [
            p for p in image.find("object") if p.object_id in pickable and on[p.object_id] != furniture
        ]
        if not patches:
            return "-", "nothing to carry", 0.0, 0.0
        patch = patches[0]
        try:
            robot.go_to_object(patch)
            robot.pick_up(patch)
        except AttribotError as exc:
            return str(patch.object_id), f"pick failed: {exc.message}", 0.0, 0.0
        wall, sim = time.perf_counter(), world.world_time()
        try:
            robot.put_on(targets[0])
            outcome = None
        except AttribotError as exc:
            outcome = exc.message
        wall, sim = time.perf_counter() - wall, world.world_time() - sim
        truth = landed(world, str(patch.object_id), furniture)
        if outcome is None:
            return str(patch.object_id), "landed" if truth is None else f"said done, but {truth}", wall, sim
        return str(patch.object_id), f"error ({outcome}); truth: {truth or 'landed'}", wall, sim


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--first-seed", type=int, default=100)
    parser.add_argument("--world-noise", default="clean")
    parser.add_argument("--strategies", default="top,middle")
    parser.add_argument("--width", type=int, default=320)
    args = parser.parse_args()
    perception = Perception.from_settings(load_settings(detector="oracle", vqa="oracle", language="catalog"))
    tally: dict[tuple[str, str], list[tuple[bool, float, float]]] = defaultdict(list)
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        config = SceneConfig(
            layout="household",
            seed=seed,
            width=args.width,
            height=args.width * 3 // 4,
            noise=world_noise(args.world_noise, seed),
        )
        try:
            with MujocoWorld(config) as world:
                pieces = [f.name for f in world.sim.plan.furniture]
        except InputError as exc:
            print(f"seed {seed}: no scene ({exc.message})")
            continue
        for furniture in pieces:
            for strategy in args.strategies.split(","):
                obj, outcome, wall, sim = place(config, furniture, strategy, perception)
                print(f"seed {seed} {furniture} {obj} {strategy}: {outcome}", flush=True)
                if obj != "-" and not outcome.startswith("pick failed"):
                    tally[(strategy, surface_kind(furniture))].append((outcome == "landed", wall, sim))
    for (strategy, kind), runs in sorted(tally.items()):
        ok = sum(r[0] for r in runs)
        wall = sum(r[1] for r in runs) / len(runs)
        sim = sum(r[2] for r in runs) / len(runs)
        print(f"{strategy:6s} {kind:12s} landed {ok}/{len(runs)}  put_on {wall:.1f} s wall, {sim:.1f} s sim")


if __name__ == "__main__":
    main()
