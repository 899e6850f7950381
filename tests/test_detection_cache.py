"""Detections kept per view (attribot.models.cache): a view seen before is answered from memory with the very
answer the detector gave, and a frame taken after the head turned or an object moved is a new view."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from attribot.api import Perception
from attribot.config import SceneConfig, load_settings
from attribot.frame import Frame
from attribot.models.base import Detection
from attribot.models.cache import CachedDetector
from attribot.sim.world import SimWorld


class Brightest:
    """A detector that reads the pixels alone: a box around the brightest pixel of each query's colour
    channel, so that its answer changes with the view. Counts the frames it was asked about."""

    name = "test:brightest"
    pixels_only = True

    def __init__(self) -> None:
        self.asked = 0

    def detect(self, frame: Frame, queries: list[str]) -> list[Detection]:
        self.asked += 1
        out = []
        for q in queries:
            channel = frame.rgb[:, :, {"red": 0, "green": 1, "blue": 2}[q]].astype(int)
            y, x = np.unravel_index(int(np.argmax(channel)), channel.shape)
            out.append(Detection(box=(x - 5.0, y - 5.0, x + 5.0, y + 5.0), score=0.5, label=q))
        return out


@pytest.fixture(scope="module")
def world():
    w = SimWorld(SceneConfig(layout="triplet", seed=3, width=160, height=120))
    try:
        yield w
    finally:
        w.close()


def test_a_view_seen_before_is_answered_from_memory_with_the_same_answer(world):
    inner = Brightest()
    cached = CachedDetector(inner)
    first = cached.detect(world.observe(), ["red"])
    again = world.observe()  # the robot has not moved: a new frame of the same view
    assert cached.detect(again, ["red"]) == first == Brightest().detect(again, ["red"])
    assert inner.asked == 1
    assert cached.counts() == {"detector_calls": 2, "detector_calls_cached": 1}
    # another query about the same view is another question
    cached.detect(again, ["blue"])
    assert inner.asked == 2


def test_after_the_head_turns_or_an_object_moves_the_view_is_new(world):
    inner = Brightest()
    cached = CachedDetector(inner)
    before = world.observe()
    cached.detect(before, ["red", "green"])
    pan, tilt = world.head()
    world.set_head(pan + 0.3, tilt)
    world.step(0.5)
    turned = world.observe()
    assert cached.detect(turned, ["red", "green"]) == Brightest().detect(turned, ["red", "green"])
    assert inner.asked == 2
    # an object moved (nothing of the robot did): the pixels differ, so the detector is asked again
    body = next(iter(world.body_of.values()))
    adr = int(world.model.jnt_qposadr[world.model.body_jntadr[body]])
    world.data.qpos[adr : adr + 2] += 0.05
    mujoco.mj_forward(world.model, world.data)
    moved = world.observe()
    assert not np.array_equal(moved.rgb, turned.rgb)
    assert cached.detect(moved, ["red", "green"]) == Brightest().detect(moved, ["red", "green"])
    assert inner.asked == 3 and cached.hits == 0


def test_each_caller_gets_its_own_list_and_the_memory_is_bounded(world):
    inner = Brightest()
    cached = CachedDetector(inner, size=2)
    frame = world.observe()
    mine = cached.detect(frame, ["red"])
    mine.clear()  # a caller that cuts its list does not cut the next caller's
    assert len(cached.detect(frame, ["red"])) == 1
    cached.detect(frame, ["green"])
    cached.detect(frame, ["blue"])  # three views' answers in a memory of two: the oldest goes
    cached.detect(frame, ["red"])
    assert inner.asked == 4


def test_a_batch_asks_the_inner_detector_only_about_the_views_it_has_not_seen(world):
    inner = Brightest()
    cached = CachedDetector(inner)
    a = world.observe()
    cached.detect(a, ["red"])
    out = cached.detect_batch([a, a, a], [["red"], ["blue"], ["blue"]])
    plain = Brightest()
    assert out == [plain.detect(a, ["red"]), plain.detect(a, ["blue"]), plain.detect(a, ["blue"])]
    assert inner.asked == 2  # "red" before, "blue" once for both


def test_perception_keeps_a_pixels_only_detector_behind_the_cache_and_asks_the_oracle_every_time():
    settings = load_settings(detector="oracle", vqa="oracle", language="catalog")
    oracle = Perception.from_settings(settings)
    assert not isinstance(oracle.detector, CachedDetector)  # it reads the segmentation: not cacheable
    assert oracle.counts() == {}
    wrapped = Perception(Brightest(), oracle.vqa, oracle.language)
    assert isinstance(wrapped.detector, CachedDetector) and wrapped.detector.name == "test:brightest"
    assert wrapped.counts() == {"detector_calls": 0, "detector_calls_cached": 0}
