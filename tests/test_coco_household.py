"""A weight and a distance query answered end to end with the real coco detector (YOLOv3-tiny, the registry
weights) in the household world, checked against the world's truth. The detector sees the whole image only
(`coco?tiles=1`, one forward pass per look) to keep the servo's many looks quick on a 2-core machine.

A comparative weight query, "Which is heavier, the bottle or the vase?", fails in this scene: YOLOv3-tiny
also calls the vase a bottle (score 0.29), the program drives to that "bottle" too, and the servo loses it
when a later look no longer calls it one. That is a real perception error, left visible, not tested away.
"""

from __future__ import annotations

import pytest

from attribot.config import SceneConfig, load_settings
from attribot.embodiments.mujoco import MujocoWorld
from attribot.session import Scene, ask

SCENE = SceneConfig(layout="household", seed=3, categories=("bottle", "vase"), objects=2)


@pytest.fixture(scope="module")
def truth() -> dict[str, dict]:
    with MujocoWorld(SCENE) as world:
        return {o.category: o.model_dump() for o in world.scene_info().objects}


def _centre_inside(box: tuple[float, ...], truth_box: list[float]) -> bool:
    cx, cy = (box[0] + box[2]) / 2, (box[1] + box[3]) / 2
    return truth_box[0] <= cx <= truth_box[2] and truth_box[1] <= cy <= truth_box[3]


def _ask(query: str, sensors: tuple[str, ...]):
    answer = ask(query, Scene(SCENE, sensors=sensors), load_settings(detector="coco?tiles=1"))
    assert answer.error is None, answer.error
    assert answer.backends["detector"] == "coco:yolov3-tiny"
    # a real detector's answer rests on no simulator truth: `ask` gives it no oracle VQA either
    assert answer.backends["vqa"] == "none", answer.backends
    return answer


def test_a_distance_query_with_the_real_detector_picks_the_truly_closer_object(empty_settings, truth):
    answer = _ask("Is the bottle or the vase closer to me?", ("camera", "distance"))
    expected = min(truth, key=lambda c: truth[c]["distance_m"])
    # the detector knows no world ids: the chosen box must be the expected object's in the first frame
    assert answer.object is not None and answer.object.category == expected
    assert _centre_inside(answer.object.box, truth[expected]["box"]), (answer.object.box, truth[expected])
    readings = [t["result"] for t in answer.trace if t["call"] == "Robot.measure_distance"]
    assert readings and min(readings) == pytest.approx(truth[expected]["distance_m"], abs=0.25)


def test_a_weight_query_with_the_real_detector_weighs_the_object_it_names(empty_settings, truth):
    answer = _ask("How heavy is the bottle?", ("camera", "force"))
    assert answer.object is not None and answer.object.category == "bottle"
    assert _centre_inside(answer.object.box, truth["bottle"]["box"]), (answer.object.box, truth["bottle"])
    weights = [t["result"] for t in answer.trace if t["call"] == "Robot.measure_weight"]
    assert weights == [pytest.approx(truth["bottle"]["mass_kg"], rel=0.05)]
