"""The COCO detectors' recall in the embedded world's robot-camera frames, on tuning and held-out seeds.

Run: `MUJOCO_GL=egl .venv/bin/python benchmarks/bench_coco.py [--detector coco,yolov5s] [--set
tuning|held-out|both] [--seeds 60] [--first-seed 0] [--quick] [--categories] [--looks detailed,primitive]
[--tiles N] [--threshold T] [--all-tiles] [--verbose]`

`--detector` takes one spec or several, comma-separated (`coco`, `yolov5s`, `yolov5s?tiles=1`); each is run on
the same frames, the first is the reference: each other's recall and its mean time a frame (the detector's
`detect` alone, its kept outputs of other frames of no use) are printed as ratios to the first's.

Frames: the robot camera's first frame (640x480, fast profile) of household scenes and triplets drawn in the
categories the coco detector can find (`SceneConfig.vocabulary`, as the embodied tasks are drawn for a coco
run): household objects 1 to 3.5 m away on furniture and the floor, triplets 0.7-0.9 m away on a table.
With `--categories`, instead, each category the detector can find on its own: a row of three close up
(arrangement, about 0.8 m) and one object in a household scene (1 to 3.5 m), per seed.

Seeds 0..N-1 of each layout are dealt into a tuning set (every third seed, 0, 3, 6, ...: the only frames to
look at while changing looks) and a held-out set (the others: reported, never looked at to change a look).
`--first-seed N` deals seeds N..N+S-1 the same way: once a held-out set has served a choice, a fresh one.
Truth comes from the world: every object that shows at least `MIN_PIXELS` pixels, boxed by the
segmentation. An object is found when a detection of its class overlaps its box with IoU >= 0.5 (each
detection matches one object at most). Prints one line per set, looks and layout, one per category (its
recall, near and far of 1.5 m), and the ratio of the looks' recall to the primitives' (the objects drawn as
their body primitives: the reference measured in the same run). Each detector is the one its spec builds
(its default tiles and threshold); `--tiles`, `--part-size` and `--threshold` try others for every spec, and
`--all-tiles` looks at every tile (`coco?all_tiles=1`), not only at those where the whole image shows a
trace. The scenes are drawn in the categories the first detector can find."""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from collections import defaultdict
from collections.abc import Iterator
from typing import Any

from attribot import boxes as boxmath
from attribot.config import SceneConfig, load_settings
from attribot.errors import InputError
from attribot.frame import Frame
from attribot.models.base import build_backend, can_find, findable_categories, parse_spec
from attribot.models.noise import split_options
from attribot.models.oracle import visible_objects
from attribot.sim.catalog import categories
from attribot.sim.world import SimWorld

__all__ = ["main", "deal", "recall_of_frame", "Hit"]

MIN_PIXELS = 100
NEAR_M = 1.5
Hit = tuple[str, float, bool, float]  # category, distance (m), found, best IoU with a detection of its class


def deal(n: int, first: int = 0) -> dict[str, list[int]]:
    """Seeds first..first+n-1 dealt into "tuning" (every third from `first`: 0, 3, 6, ...) and "held-out"
    (the others): a seed stays in its set whatever n, and in every mode. A `first` past every seed used so
    far deals frames no one has looked at: a fresh held-out set once the old one has served a choice."""
    return {
        "tuning": list(range(first, first + n, 3)),
        "held-out": [s for s in range(first, first + n) if (s - first) % 3],
    }


def recall_of_frame(
    detector: Any, world: SimWorld, frame: Frame | None = None, seconds: list[float] | None = None
) -> list[Hit]:
    """One hit per object of the first frame of `world` (or of `frame`, that world's) that the detector can
    find and that shows; the time `detect` took is appended to `seconds`."""
    frame = world.observe() if frame is None else frame
    truth = []
    for v in visible_objects(frame, MIN_PIXELS):
        obj = world.objects[v.key]
        cls = detector.class_of(obj.category.name)
        if cls is not None:
            truth.append((v, obj, cls))
    if not truth:
        return []
    start = time.perf_counter()
    detections = detector.detect(frame, sorted({c for _, _, c in truth}))
    if seconds is not None:
        seconds.append(time.perf_counter() - start)
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
    which: list[int], vocabulary: tuple[str, ...], detector: Any, per_category: bool
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


def _header(argv: list[str], dealt: dict[str, list[int]], sets: list[str]) -> str:
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=False
        ).stdout.strip()
    except OSError:
        commit = "?"
    seeds = "; ".join(f"{name} seeds {dealt[name]}" for name in sets)
    return (
        f"# command: MUJOCO_GL=egl python benchmarks/bench_coco.py {' '.join(argv)}\n"
        f"# commit: {commit or '?'}   date: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}\n"
        f"# {seeds} (per layout)"
    )


def _with_options(spec: str, args: argparse.Namespace) -> str:
    """`spec` with `--tiles`, `--part-size` and `--all-tiles` added where given and the spec has none."""
    _, options = split_options(parse_spec(spec)[1])
    extra = {"tiles": args.tiles, "part_size": args.part_size, "all_tiles": 1 if args.all_tiles else None}
    added = [f"{k}={v}" for k, v in extra.items() if v is not None and k not in options]
    if not added:
        return spec
    return spec + ("&" if "?" in spec else "?") + "&".join(added)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--detector", default="coco", help="detector specs, comma-separated; the first is the reference"
    )
    ap.add_argument("--set", choices=("tuning", "held-out", "both"), default="both", help="which seeds")
    ap.add_argument("--seeds", type=int, default=60, help="seeds per layout before dealing (0 .. N-1)")
    ap.add_argument("--quick", action="store_true", help="6 seeds per layout (a smoke run)")
    ap.add_argument("--first-seed", type=int, default=0, help="deal seeds from this one (a fresh set)")
    ap.add_argument("--categories", action="store_true", help="each category on its own, close and far")
    ap.add_argument("--looks", default="detailed,primitive", help="detailed, primitive or both")
    ap.add_argument("--verbose", action="store_true", help="one line per frame")
    ap.add_argument("--tiles", type=int, help="views per side besides the whole image (default: the spec's)")
    ap.add_argument("--threshold", type=float, default=0.1, help="the detector's score threshold")
    ap.add_argument("--all-tiles", action="store_true", help="every tile, not only those showing a trace")
    ap.add_argument("--part-size", type=int, help="the side a tile is seen at (default: the whole image's)")
    args = ap.parse_args()
    settings = load_settings().model_copy(update={"detector_threshold": args.threshold})
    specs = [_with_options(s.strip(), args) for s in args.detector.split(",") if s.strip()]
    detectors = [build_backend("detector", spec, settings) for spec in specs]
    vocabulary = findable_categories(detectors[0]) or ()
    dealt = deal(6 if args.quick else args.seeds, args.first_seed)
    sets = ["tuning", "held-out"] if args.set == "both" else [args.set]
    print(_header(sys.argv[1:], dealt, sets), flush=True)
    looks = [lk.strip() for lk in args.looks.split(",") if lk.strip()]
    recall: dict[tuple[str, str, str], float] = {}
    seconds: dict[str, list[float]] = {spec: [] for spec in specs}
    for name in sets:
        tally: dict[tuple[str, str, str], list[int]] = defaultdict(lambda: [0, 0])
        per_cat: dict[tuple[str, str, str, bool], list[int]] = defaultdict(lambda: [0, 0])
        for layout, config in _scenes(dealt[name], vocabulary, detectors[0], args.categories):
            for look in looks:
                try:
                    world = SimWorld(config.model_copy(update={"looks": look}))
                except InputError:  # no room for this seed's objects: the same for every look
                    continue
                try:
                    frame = world.observe()
                    found = {
                        spec: recall_of_frame(det, world, frame, seconds[spec])
                        for spec, det in zip(specs, detectors, strict=True)
                    }
                finally:
                    world.close()
                for spec, hits in found.items():
                    for cat, dist, hit, _ in hits:
                        for key in ((spec, layout, look), (spec, "all", look)):
                            tally[key][0] += hit
                            tally[key][1] += 1
                        per_cat[spec, cat, look, dist < NEAR_M][0] += hit
                        per_cat[spec, cat, look, dist < NEAR_M][1] += 1
                    if args.verbose:
                        notes = " ".join(f"{c}{'+' if f else '-'}{iou:.2f}@{d:.1f}m" for c, d, f, iou in hits)
                        print(f"  {spec} {name} {layout} seed {config.seed} {look}: {notes}", flush=True)
        for spec in specs:
            for (who, layout, look), (found_n, total) in sorted(tally.items()):
                if who != spec:
                    continue
                share = found_n / max(total, 1)
                line = f"{spec:<8s} {name:<8s} {look:<9s} {layout:<9s} {found_n:4d} / {total:<4d} "
                print(f"recall {line}{share:6.3f}")
                recall[spec, name, look] = tally[spec, "all", look][0] / max(tally[spec, "all", look][1], 1)
            for cat in sorted({c for who, c, _, _ in per_cat if who == spec}):
                for look in looks:
                    near, far = per_cat[spec, cat, look, True], per_cat[spec, cat, look, False]
                    found_n, total = near[0] + far[0], near[1] + far[1]
                    share = found_n / max(total, 1)
                    line = f"{spec:<8s} {name:<8s} {look:<9s} {cat:<15s} {found_n:3d} / {total:<3d}"
                    print(f"  {line} {share:5.2f}   near {near[0]}/{near[1]}   far {far[0]}/{far[1]}")
    for spec in specs:
        for name in sets:
            if ("detailed" in looks) and ("primitive" in looks) and recall[spec, name, "primitive"]:
                ratio = recall[spec, name, "detailed"] / recall[spec, name, "primitive"]
                detailed, primitive = recall[spec, name, "detailed"], recall[spec, name, "primitive"]
                print(f"recall {spec} {name} detailed over primitive: ratio {ratio:6.2f} (detailed "
                      f"{detailed:.3f}, primitive {primitive:.3f})")  # fmt: skip
    reference = specs[0]
    ref_time = sum(seconds[reference]) / max(len(seconds[reference]), 1)
    for spec in specs:
        mean = sum(seconds[spec]) / max(len(seconds[spec]), 1)
        print(f"time {spec}: {mean * 1000:7.1f} ms a frame over {len(seconds[spec])} frames, "
              f"ratio {mean / max(ref_time, 1e-9):5.2f} to {reference}")  # fmt: skip
        if spec == reference:
            continue
        for name in sets:
            for look in looks:
                ours, ref = recall.get((spec, name, look), 0.0), recall.get((reference, name, look), 0.0)
                print(f"recall {spec} over {reference} {name} {look}: ratio {ours / max(ref, 1e-9):5.2f} "
                      f"({ours:.3f} against {ref:.3f})")  # fmt: skip


if __name__ == "__main__":
    main()
