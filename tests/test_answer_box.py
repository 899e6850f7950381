"""An answer's box is the robot's best estimate of the object when it answers (issue 51): the detection
looked at again around it in the image and averaged, not the first jittered box; the answer says which.
Truths: the world's own boxes (`scene_info()`)."""

from __future__ import annotations

import numpy as np
import pytest

from attribot.api import Perception, Robot
from attribot.boxes import iou
from attribot.config import SceneConfig, load_settings
from attribot.embodiments.mujoco import MujocoWorld
from attribot.session import Scene, run_program
from attribot.skills.safeguards import Safeguards


def _ious(checks: str) -> tuple[list[float], list[float]]:
    """The IoU with the true box of each object found in a household scene, seen by a detector whose boxes
    jitter by 5 px: of the detection's box, and of the box an answer gives."""
    config = SceneConfig(layout="household", seed=21, objects=5)
    settings = load_settings(detector="oracle?jitter_px=5")
    first, best = [], []
    with MujocoWorld(config) as world:
        truth = {o.id: tuple(o.box) for o in world.scene_info().objects if o.box}
        robot = Robot(sensors=["camera"], world=world, safeguards=Safeguards(checks))
        image = robot.look(Perception.from_settings(settings))
        for patch in image.find("object"):
            if patch.object_id in truth:
                first.append(iou(patch.box, truth[patch.object_id]))
                best.append(iou(patch.best_box()[0], truth[patch.object_id]))
    return first, best


def test_the_answer_box_is_nearer_the_truth_than_the_jittered_detection():
    first, best = _ious("all")
    assert len(first) >= 4
    assert np.mean(best) > np.mean(first) + 0.03, (first, best)
    assert sum(b >= f for f, b in zip(first, best, strict=True)) >= len(first) - 1
    off_first, off_best = _ious("all,-look_again")  # the mechanism off: the detection stands
    assert off_best == off_first


def test_an_answer_says_what_its_box_is_and_a_clean_box_stays_exact(empty_settings):
    config = SceneConfig(layout="triplet", seed=3)
    program = "def execute_command(image, robot):\n    return image.find('object')[0]\n"
    answer = run_program(program, Scene(config), load_settings(), query="an object")
    assert answer.error is None and answer.object is not None
    assert "mean of 5 looks" in answer.object.box_from, answer.object
    with MujocoWorld(config) as world:
        (true,) = [o.box for o in world.scene_info().objects if o.id == answer.object.id]
    assert iou(tuple(answer.object.box), tuple(true)) == pytest.approx(1.0, abs=0.02)  # the oracle's, exact


class _FaintInCrops:
    """Boxes one object surely in the whole image, and in any crop of it faintly and a third of its size
    off, as YOLOv5s boxed a book it named at 0.6 (0.12 to 0.19 in crops)."""

    name = "faint-in-crops"
    BOX = (260.0, 330.0, 350.0, 396.0)

    def __init__(self, crop_score: float) -> None:
        self.crop_score = crop_score

    def detect(self, frame, queries):
        from attribot.models.base import Detection

        ox, oy = frame.origin
        if (ox, oy, frame.width, frame.height) == (0, 0, 640, 480):
            return [Detection(box=self.BOX, score=0.6, label=queries[0])]
        x0, y0, x1, y1 = self.BOX
        off = (x0 - 30 - ox, y0 - 20 - oy, x1 - 30 - ox, y1 - 20 - oy)
        return [Detection(box=off, score=self.crop_score, label=queries[0])]


def test_a_crops_box_joins_the_answer_box_only_where_the_detector_is_as_sure_of_it():
    from attribot.skills.looking import refit
    from conftest import random_frame

    frame = random_frame(480, 640)
    box = _FaintInCrops.BOX
    assert refit(_FaintInCrops(0.15), frame, box, "book", 0.6) == (box, 1)  # faint in crops: it stands
    fused, looks = refit(_FaintInCrops(0.5), frame, box, "book", 0.6)  # sure in crops: they count
    assert looks == 5 and fused[0] == pytest.approx(box[0] - 24)
    # a detection itself faint is looked at again by crops as sure of it as it is
    assert refit(_FaintInCrops(0.15), frame, box, "book", 0.15)[1] == 5
