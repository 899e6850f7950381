"""The coco detector's recall in the embedded world, objects drawn with their old and their new looks.

Run: `MUJOCO_GL=egl .venv/bin/python benchmarks/bench_coco.py [--seeds 30] [--quick] [--tiles N]
[--threshold T]`

For each household and triplet seed, the robot camera's first frame (640x480, fast profile) is rendered
twice, the objects drawn as their body primitives (`looks=primitive`, as earlier releases drew them) and
with their looks (`looks=detailed`); physics and placement are the same in both. Truth comes from the
world: every object whose category has a COCO class and that shows at least `MIN_PIXELS` pixels, boxed by
the segmentation. An object is found when a detection of its class overlaps its box with IoU >= 0.5 (each
detection matches one object at most). Prints one line per layout and look, the total per look, and the
ratio of the new recall to the old (acceptance: new recall >= 0.5). The detector is the one `--detector coco`
builds (its default tiles and threshold); `--tiles` and `--threshold` try others.
"""

from __future__ import annotations

import argparse
from collections import defaultdict

import numpy as np

from attribot import boxes as boxmath
from attribot.models.coco import COCO_CLASS_OF, DEFAULT_TILES, CocoDetector
from attribot.models.oracle import visible_objects
from attribot.sim.world import SimWorld

__all__ = ["main", "recall_of_frame"]

MIN_PIXELS = 100


def recall_of_frame(detector: CocoDetector, world: SimWorld) -> tuple[int, int, list[str]]:
    """(found, total, one note per object) for the first frame of `world`."""
    frame = world.observe()
    truth = [
        (v, COCO_CLASS_OF[world.objects[v.key].category.name])
        for v in visible_objects(frame, MIN_PIXELS)
        if world.objects[v.key].category.name in COCO_CLASS_OF
    ]
    if not truth:
        return 0, 0, []
    classes = sorted({c for _, c in truth})
    detections = detector.detect(frame, classes)
    used: set[int] = set()
    found, notes = 0, []
    for v, cls in truth:
        best, pick = 0.0, -1
        for i, d in enumerate(detections):
            if d.label == cls and i not in used:
                iou = boxmath.iou(d.box, v.box)
                if iou > best:
                    best, pick = iou, i
        hit = best >= 0.5
        if hit:
            used.add(pick)
        found += hit
        notes.append(f"{world.objects[v.key].category.name}({cls}){'+' if hit else '-'}{best:.2f}")
    return found, len(truth), notes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=30, help="seeds per layout (0 .. N-1)")
    ap.add_argument("--quick", action="store_true", help="5 seeds per layout (a smoke run)")
    ap.add_argument("--verbose", action="store_true", help="one line per frame")
    ap.add_argument("--tiles", type=int, default=DEFAULT_TILES, help="views per side besides the whole image")
    ap.add_argument("--threshold", type=float, default=0.1, help="the detector's score threshold")
    args = ap.parse_args()
    seeds = range(5 if args.quick else args.seeds)
    detector = CocoDetector(tiles=args.tiles, threshold=args.threshold)
    tally: dict[tuple[str, str], list[int]] = defaultdict(lambda: [0, 0])
    for layout in ("household", "triplet"):
        for seed in seeds:
            for looks in ("primitive", "detailed"):
                world = SimWorld(layout=layout, seed=seed, width=640, height=480, looks=looks)
                try:
                    found, total, notes = recall_of_frame(detector, world)
                finally:
                    world.close()
                tally[layout, looks][0] += found
                tally[layout, looks][1] += total
                if args.verbose:
                    print(f"  {layout} seed {seed} {looks}: {' '.join(notes)}", flush=True)
    totals = {looks: np.sum([tally[lay, looks] for lay in ("household", "triplet")], axis=0) for looks in
              ("primitive", "detailed")}  # fmt: skip
    for (layout, looks), (found, total) in sorted(tally.items()):
        print(f"recall {layout:<10s} {looks:<10s} {found:4d} / {total:<4d} {found / max(total, 1):6.3f}")
    old = totals["primitive"][0] / max(totals["primitive"][1], 1)
    for looks, (found, total) in totals.items():
        print(f"recall {'all':<10s} {looks:<10s} {found:4d} / {total:<4d} {found / max(total, 1):6.3f}")
    new = totals["detailed"][0] / max(totals["detailed"][1], 1)
    print(f"recall detailed over primitive: ratio {new / old if old else float('inf'):6.2f} "
          f"(new {new:.3f}, target >= 0.5)")  # fmt: skip


if __name__ == "__main__":
    main()
