"""The coco detector's recall in the embedded world's robot-camera frames, on tuning and held-out seeds.

Run: `MUJOCO_GL=egl .venv/bin/python benchmarks/bench_coco.py [--set tuning|held-out|both] [--seeds 60]
[--quick] [--categories] [--looks detailed,primitive] [--tiles N] [--threshold T] [--all-tiles] [--verbose]`

Frames: the robot camera's first frame (640x480, fast profile) of household scenes and triplets drawn in the
categories the coco detector can find (`SceneConfig.vocabulary`, as the embodied tasks are drawn for a coco
run): household objects 1 to 3.5 m away on furniture and the floor, triplets 0.7-0.9 m away on a table.
With `--categories`, instead, each category the detector can find on its own: a row of three close up
(arrangement, about 0.8 m) and one object in a household scene (1 to 3.5 m), per seed.

Seeds 0..N-1 of each layout are dealt into a tuning set (every third seed, 0, 3, 6, ...: the only frames to
look at while changing looks) and a held-out set (the others: reported, never looked at to change a look).
Truth comes from the world: every object that shows at least `MIN_PIXELS` pixels, boxed by the
segmentation. An object is found when a detection of its class overlaps its box with IoU >= 0.5 (each
detection matches one object at most). Prints one line per set, looks and layout, one per category (its
recall, near and far of 1.5 m), and the ratio of the looks' recall to the primitives' (the objects drawn as
their body primitives: the reference measured in the same run). The detector is the one `--detector coco`
builds (its default tiles and threshold); `--tiles` and `--threshold` try others, and `--all-tiles` looks at
every tile (`coco?all_tiles=1`), not only at those where the whole image shows a trace."""

from __future__ import annotations

import argparse
from collections import defaultdict
from collections.abc import Iterator

from attribot import boxes as boxmath
from attribot.config import SceneConfig
from attribot.errors import InputError
from attribot.models.base import can_find, findable_categories
from attribot.models.coco import DEFAULT_TILES, CocoDetector
from attribot.models.oracle import visible_objects
from attribot.sim.catalog import categories
from attribot.sim.world import SimWorld

__all__ = ["main", "deal", "recall_of_frame", "Hit"]

MIN_PIXELS = 100
NEAR_M = 1.5
Hit = tuple[str, float, bool, float]  # category, distance (m), found, best IoU with a detection of its class


def deal(n: int) -> dict[str, list[int]]:
    """Seeds 0..n-1 dealt into "tuning" (every third: 0, 3, 6, ...) and "held-out" (the others): a seed
    stays in its set whatever n, and in every mode."""
    return {"tuning": list(range(0, n, 3)), "held-out": [s for s in range(n) if s % 3]}


def recall_of_frame(detector: CocoDetector, world: SimWorld) -> list[Hit]:
    """One hit per object of the first frame of `world` that the detector can find and that shows."""
    frame = world.observe()
    truth = []
    for v in visible_objects(frame, MIN_PIXELS):
        obj = world.objects[v.key]
        cls = detector.class_of(obj.category.name)
        if cls is not None:
            truth.append((v, obj, cls))
    if not truth:
        return []
    detections = detector.detect(frame, sorted({c for _, _, c in truth}))
    distances = {o.id: o.distance_m for o in world.scene_info(frame).objects}
    used: set[int] = set()
    hits: list[Hit] = []
    for v, obj, cls in truth:
        best, pick = 0.0, -1
        for i, d in enumerate(detections):
            if d.label == cls and i not in used:
                iou = boxmath.iou(d.box, v.box)
                if iou > best:
                    best, pick = iou, i
        if best >= 0.5:
            used.add(pick)
        hits.append((obj.category.name, distances[obj.id], best >= 0.5, best))
    return hits


def _scenes(
    which: list[int], vocabulary: tuple[str, ...], detector: CocoDetector, per_category: bool
) -> Iterator[tuple[str, SceneConfig]]:
    if not per_category:
        for layout in ("household", "triplet"):
            for seed in which:
                yield layout, SceneConfig(layout=layout, seed=seed, vocabulary=vocabulary)
        return
    # every category it can find on its own, those that share a class with another (a ball) included
    for cat in (c.name for c in categories() if c.drawn and can_find(detector, c.name)):
        for seed in which:
            row: dict[str, str | int | float | bool] = {"pattern": "row", "odd": "size"}
            close = SceneConfig(layout="arrangement", seed=seed, categories=(cat,), objects=3, options=row)
            yield "close", close
            yield "room", SceneConfig(layout="household", seed=seed, categories=(cat,), objects=1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("tuning", "held-out", "both"), default="both", help="which seeds")
    ap.add_argument("--seeds", type=int, default=60, help="seeds per layout before dealing (0 .. N-1)")
    ap.add_argument("--quick", action="store_true", help="6 seeds per layout (a smoke run)")
    ap.add_argument("--categories", action="store_true", help="each category on its own, close and far")
    ap.add_argument("--looks", default="detailed,primitive", help="detailed, primitive or both")
    ap.add_argument("--verbose", action="store_true", help="one line per frame")
    ap.add_argument("--tiles", type=int, default=DEFAULT_TILES, help="views per side besides the whole image")
    ap.add_argument("--threshold", type=float, default=0.1, help="the detector's score threshold")
    ap.add_argument("--all-tiles", action="store_true", help="every tile, not only those showing a trace")
    ap.add_argument("--part-size", type=int, help="the side a tile is seen at (default: the whole image's)")
    args = ap.parse_args()
    detector = CocoDetector(
        tiles=args.tiles, threshold=args.threshold, all_tiles=args.all_tiles, part_size=args.part_size
    )
    vocabulary = findable_categories(detector) or ()
    dealt = deal(6 if args.quick else args.seeds)
    sets = ["tuning", "held-out"] if args.set == "both" else [args.set]
    looks = [lk.strip() for lk in args.looks.split(",") if lk.strip()]
    recall: dict[tuple[str, str], float] = {}
    for name in sets:
        tally: dict[tuple[str, str], list[int]] = defaultdict(lambda: [0, 0])
        per_cat: dict[tuple[str, str, bool], list[int]] = defaultdict(lambda: [0, 0])
        for layout, config in _scenes(dealt[name], vocabulary, detector, args.categories):
            for look in looks:
                try:
                    world = SimWorld(config.model_copy(update={"looks": look}))
                except InputError:  # no room for this seed's objects: the same for every look
                    continue
                try:
                    hits = recall_of_frame(detector, world)
                finally:
                    world.close()
                for cat, dist, hit, _ in hits:
                    for key in ((layout, look), ("all", look)):
                        tally[key][0] += hit
                        tally[key][1] += 1
                    per_cat[cat, look, dist < NEAR_M][0] += hit
                    per_cat[cat, look, dist < NEAR_M][1] += 1
                if args.verbose:
                    notes = " ".join(f"{c}{'+' if f else '-'}{iou:.2f}@{d:.1f}m" for c, d, f, iou in hits)
                    print(f"  {name} {layout} seed {config.seed} {look}: {notes}", flush=True)
        for (layout, look), (found, total) in sorted(tally.items()):
            share = found / max(total, 1)
            print(f"recall {name:<8s} {look:<9s} {layout:<9s} {found:4d} / {total:<4d} {share:6.3f}")
            recall[name, look] = tally["all", look][0] / max(tally["all", look][1], 1)
        for cat in sorted({c for c, _, _ in per_cat}):
            for look in looks:
                near, far = per_cat[cat, look, True], per_cat[cat, look, False]
                found, total = near[0] + far[0], near[1] + far[1]
                share = found / max(total, 1)
                print(f"  {name:<8s} {look:<9s} {cat:<15s} {found:3d} / {total:<3d} {share:5.2f}   "
                      f"near {near[0]}/{near[1]}   far {far[0]}/{far[1]}")  # fmt: skip
    for name in sets:
        if ("detailed" in looks) and ("primitive" in looks) and recall[name, "primitive"]:
            ratio = recall[name, "detailed"] / recall[name, "primitive"]
            print(f"recall {name} detailed over primitive: ratio {ratio:6.2f} (detailed "
                  f"{recall[name, 'detailed']:.3f}, primitive {recall[name, 'primitive']:.3f})")  # fmt: skip


if __name__ == "__main__":
    main()
