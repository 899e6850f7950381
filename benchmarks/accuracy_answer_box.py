"""How close an answer's box is to the object's true box: the detection in the robot's image against the box
fused from the views that saw it (`ImagePatch.best_box`), under a jittery detector.

Each item is a triplet scene; the program picks the object the query names by the world's own truth (its
id, read from `scene_info()`), so every item measures the box alone. Prints, per box, the mean IoU with the
true box and how many items reach IoU 0.5, and the ratio of the fused mean to the detection's.

    PYTHONPATH=src python benchmarks/accuracy_answer_box.py --seeds 12 --detector 'oracle?jitter_px=5'
"""

from __future__ import annotations

import argparse

from attribot.boxes import iou
from attribot.config import SceneConfig, load_settings
from attribot.embodiments.mujoco import MujocoWorld
from attribot.session import Scene, run_program

PROGRAM = """
def execute_command(image, robot):
    return sorted(image.find("object"), key=lambda p: p.horizontal_center)[INDEX]
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=12)
    parser.add_argument("--first-seed", type=int, default=100)
    parser.add_argument("--detector", default="oracle?jitter_px=5")
    parser.add_argument("--layout", default="triplet")
    args = parser.parse_args()
    settings = load_settings(detector=args.detector)
    first_ious, fused_ious, sources = [], [], []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        config = SceneConfig(layout=args.layout, seed=seed)
        with MujocoWorld(config) as world:
            objects = sorted(
                (o for o in world.scene_info().objects if o.box), key=lambda o: o.box[0] + o.box[2]
            )
        index = seed % len(objects)
        answer = run_program(
            PROGRAM.replace("INDEX", str(index)), Scene(config), settings, query="the object"
        )
        if answer.object is None or answer.object.id != objects[index].id:
            print(f"seed {seed}: not the object meant ({answer.answer}); left out")
            continue
        found = next(t for t in answer.trace if t["call"] == "ImagePatch.find")["result"]
        first = next(p["box"] for p in found if p.get("object_id") == answer.object.id)
        truth = tuple(objects[index].box)
        first_ious.append(iou(tuple(first), truth))
        fused_ious.append(iou(tuple(answer.object.box), truth))
        sources.append(answer.object.box_from)
        print(
            f"seed {seed}: detection IoU {first_ious[-1]:.3f}, answer IoU {fused_ious[-1]:.3f} "
            f"({sources[-1]})"
        )
    n = len(first_ious)
    if not n:
        print("no item answered with the object meant")
        return
    mean_first, mean_fused = sum(first_ious) / n, sum(fused_ious) / n
    print(f"detection box: mean IoU {mean_first:.3f}, {sum(v >= 0.5 for v in first_ious)}/{n} at IoU >= 0.5")
    print(f"answer box:    mean IoU {mean_fused:.3f}, {sum(v >= 0.5 for v in fused_ious)}/{n} at IoU >= 0.5")
    print(f"answer / detection mean IoU: {mean_fused / mean_first:.3f}")


if __name__ == "__main__":
    main()
