"""KLT box tracking speed on real simulator frames, against the two alternatives it replaces or wraps.

Run: `.venv/bin/python benchmarks/bench_tracking.py [--frames 60] [--repeats 5]`

Frames: the household scene (seed 7) rendered while the head pans and tilts slowly, so every object moves
across the image; the box to track is the oracle detector's box of the first object on the first frame.
The frames are rendered once, before any timing, and played back and forth. At 320x240 and 640x480 it
prints, one line each:
- tracker: `BoxTracker.update` per frame (RGB to grey, forward-backward LK, box scale and move, re-seeding
  when fewer than 15 features survive), frames per second;
- bare LK: one forward `cv2.calcOpticalFlowPyrLK` of the same number of points on the same grey frames
  (the floor: no check, no box, no re-seeding); the tracker's ratio to it says what the rest costs;
- detector: the configured detector (oracle: the simulator's segmentation; a real model is far slower) on
  every frame; the tracker's ratio to it is what tracking saves.
Target: the tracker at >= 1,000 fps at 320x240 (the paper's NumPy KLT ran at about 54 fps here).
"""

from __future__ import annotations

import argparse
import time

import cv2
import numpy as np

from attribot.config import SceneConfig
from attribot.control.tracker import BoxTracker
from attribot.embodiments.mujoco import MujocoWorld
from attribot.frame import Frame
from attribot.models.oracle import OracleDetector

__all__ = ["main"]


def _frames(width: int, height: int, n: int) -> tuple[list[Frame], str]:
    with MujocoWorld(SceneConfig(layout="household", seed=7, width=width, height=height)) as world:
        first = world.observe()
        label = next(iter(first.objects.values())).category
        pan0, tilt0 = world.sim.head()
        frames = []
        for k in range(n):
            world.set_head(pan0 + 0.004 * k, tilt0 - 0.002 * k)
            world.step(0.05)
            frames.append(world.observe())
    return frames, label


def _track_fps(frames: list[np.ndarray], box: tuple[float, float, float, float]) -> tuple[float, int, int]:
    """Frames per second of `BoxTracker.update`, the features it started with, and the frames it lost."""
    tracker = BoxTracker()
    seeded = tracker.start(frames[0], box).features
    lost = 0
    t = time.perf_counter()
    for image in frames:
        lost += tracker.update(image).lost
    return len(frames) / (time.perf_counter() - t), seeded, lost


def _bare_fps(gray: list[np.ndarray], points: np.ndarray) -> float:
    """Frames per second of one forward calcOpticalFlowPyrLK of `points` between consecutive frames."""
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 20, 0.03)
    t = time.perf_counter()
    for prev, nxt in zip(gray[:-1], gray[1:], strict=True):
        cv2.calcOpticalFlowPyrLK(prev, nxt, points, None, winSize=(15, 15), maxLevel=3, criteria=criteria)
    return (len(gray) - 1) / (time.perf_counter() - t)


def _detector_fps(detector: OracleDetector, frames: list[Frame], label: str) -> float:
    t = time.perf_counter()
    for frame in frames:
        detector.detect(frame, [label])
    return len(frames) / (time.perf_counter() - t)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=60, help="distinct frames rendered (played back and forth)")
    ap.add_argument("--repeats", type=int, default=5, help="passes over the frames per figure")
    args = ap.parse_args()
    detector = OracleDetector()
    for width, height in ((320, 240), (640, 480)):
        frames, label = _frames(width, height, args.frames)
        order = (list(range(len(frames))) + list(range(len(frames) - 2, 0, -1))) * args.repeats
        gray = [cv2.cvtColor(frames[i].rgb, cv2.COLOR_RGB2GRAY) for i in order]
        box = max(detector.detect(frames[0], [label]), key=lambda d: d.score).box
        tracker_fps, seeded, lost = _track_fps([frames[i].rgb for i in order], box)
        points = BoxTracker()._seed(gray[0], box)
        assert points is not None, "no features in the first box"
        bare_fps = _bare_fps(gray, points)
        detector_fps = _detector_fps(detector, frames, label)
        size = f"{width}x{height}"
        print(
            f"tracker {size} ({label}, {seeded} features, lost {lost} of {len(order)} frames)"
            f"  {tracker_fps:9.0f} fps"
        )
        print(
            f"bare calcOpticalFlowPyrLK {size} ({len(points)} points)  {bare_fps:9.0f} fps"
            f"  tracker ratio {tracker_fps / bare_fps:6.3f}"
        )
        print(
            f"detector ({detector.name}) every frame {size}  {detector_fps:9.0f} fps"
            f"  tracker ratio {tracker_fps / detector_fps:6.2f}"
        )


if __name__ == "__main__":
    main()
