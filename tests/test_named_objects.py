"""A name in a question means one object: where a program measured several objects under one name and took
the extreme of all, the answer is the program's comparison made again among the objects the detector is
surest of under each name (`Measuring.as_named`)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from attribot.config import SceneConfig, Settings
from attribot.embodiments.mujoco import MujocoWorld
from attribot.frame import Frame
from attribot.models.base import Detection, evidence_of
from attribot.planning.answer import with_chosen
from attribot.session import Scene, run_program
from attribot.skills.measuring import Measuring
from attribot.skills.perception import Perception
from attribot.skills.robot_core import Measurement
from attribot.skills.sighting import Sighting
from conftest import wrap_detector

_FRAME = Frame(rgb=np.zeros((200, 300, 3), dtype=np.uint8))


def _measured(*readings: tuple[str, float, float]) -> tuple[Measuring, list[Sighting]]:
    """A session's readings of distance, one object each, side by side: (label, detector score, metres)."""
    perception = Perception.from_settings(Settings())
    out: list[tuple[Measurement, Sighting]] = []
    for i, (label, score, metres) in enumerate(readings):
        box = (i * 30.0, 10.0, i * 30.0 + 20.0, 40.0)
        detection = Detection(box=box, score=score, label=label)
        patch = Sighting(
            _FRAME, perception, box=box, label=label, score=score, evidence=evidence_of(detection)
        )
        m = Measurement(kind="distance", object_id=None, label=label, value=metres, unit="m", box=box)
        out.append((m, patch))
    return Measuring(SimpleNamespace(measured=out), acting=None), [p for _, p in out]  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("readings", "chosen", "becomes"),
    [
        # a jug boxed as a second vase, closer than the vase: the vase the detector is surest of is meant
        ([("bottle", 0.85, 2.70), ("vase", 0.89, 1.25), ("vase", 0.40, 1.19)], 2, 1),
        # the heaviest: the same, with the largest value
        ([("mug", 0.6, 0.30), ("book", 0.7, 0.55), ("book", 0.3, 0.90)], 2, 1),
        # the vase it is surest of is farther than the clock: the clock is the closer of the two named
        ([("alarm clock", 0.66, 1.35), ("vase", 0.90, 2.36), ("vase", 0.59, 1.18)], 2, 0),
        # a name that ends in "s" and is no plural ("cactus") is one object too
        ([("bowl", 0.61, 0.42), ("cactus", 0.18, 0.64), ("apple", 0.46, 0.17), ("apple", 0.31, 0.12)], 3, 2),
        ([("cactus", 0.9, 0.5), ("cactus", 0.3, 0.9), ("mug", 0.6, 0.7)], 1, 2),
        # a faint box is less sure than a sure one whatever the numbers
        ([("apple", 0.30, 1.5), ("orange", 0.20, 1.1), ("orange", 0.26, 1.4)], 1, 2),
    ],
)
def test_each_name_means_the_object_the_detector_is_surest_of(readings, chosen, becomes):
    measuring, patches = _measured(*readings)
    named = measuring.as_named(patches[chosen])
    assert named is not None and named[0] is patches[becomes]
    name = readings[chosen][0]
    said = f"the program chose the {name} at [{round(patches[chosen].box[0])}"
    assert f"the question names one {name}: " in named[1] and said in named[1], named[1]


@pytest.mark.parametrize(
    ("readings", "chosen"),
    [
        ([("bottle", 0.85, 2.70), ("vase", 0.89, 1.19), ("vase", 0.40, 1.25)], 1),  # chose the surest
        ([("bottle", 0.85, 2.70), ("vase", 0.89, 1.25)], 1),  # one object a name
        ([("mug", 0.9, 1.0), ("mug", 0.4, 0.8), ("mug", 0.7, 1.2)], 1),  # "which mug": one name
        ([("bottle", 0.85, 2.70), ("object", 0.9, 1.25), ("object", 0.4, 1.19)], 2),  # a generic word
        ([("bottle", 0.85, 2.70), ("apples", 0.9, 1.25), ("apples", 0.4, 1.19)], 2),  # a plural name
        ([("bottle", 1.0, 2.70), ("vase", 1.0, 1.25), ("vase", 1.0, 1.19)], 2),  # equally sure (an oracle)
        ([("bottle", 0.85, 2.70), ("vase", 0.20, 1.25), ("vase", 0.12, 1.19)], 2),  # all faint
        (
            [("bottle", 0.85, 2.70), ("vase", 0.89, 1.25), ("vase", 0.40, 1.19), ("cup", 0.5, 1.0)],
            2,
        ),  # no extreme
    ],
)
def test_the_programs_choice_stands_where_no_name_is_in_doubt(readings, chosen):
    measuring, patches = _measured(*readings)
    assert measuring.as_named(patches[chosen]) is None


def test_the_chosen_patch_is_replaced_wherever_a_program_returned_it_but_in_its_own_words():
    a, b, c = object(), object(), object()
    assert with_chosen(a, a, b) is b
    assert with_chosen((a, 0.3), a, b) == (b, 0.3)
    assert with_chosen([c, a], a, b) == [c, b]
    assert with_chosen({"object": a, "text": "the cup at [1, 2, 3, 4]"}, a, b) is None  # its own words
    assert with_chosen({"cup": a, "kg": 1}, a, b) == {"cup": b, "kg": 1}
    assert with_chosen("a", a, b) == "a"


_CLOSEST_OF_ALL = """
def execute_command(image, robot):
    candidates = image.find("{a}") + image.find("{b}")
    distances = []
    for patch in candidates:
        robot.focus_on_patch(patch)
        distances.append(robot.measure_distance(patch))
    best = 0
    for index in range(1, len(candidates)):
        if distances[index] < distances[best]:
            best = index
    return candidates[best]
"""


class _AlsoNames:
    """Wraps a detector: asked for `name`, it gives that name's own boxes sure, and `other`'s object as
    one more, fainter box of `name` (a jug boxed as a second vase)."""

    def __init__(self, inner: object, name: str, other: str) -> None:
        self.inner, self.meant, self.other = inner, name, other
        self.name = "also-names"

    def detect(self, frame: Frame, queries: list[str]) -> list[Detection]:
        found = self.inner.detect(frame, queries)  # type: ignore[attr-defined]
        if list(queries) != [self.meant]:
            return found
        own = [d.model_copy(update={"score": 0.9}) for d in found]
        extra = self.inner.detect(frame, [self.other])  # type: ignore[attr-defined]
        return own + [d.model_copy(update={"label": self.meant, "score": 0.4}) for d in extra]


@pytest.mark.parametrize("confused", [False, True])
def test_an_answer_is_the_object_named_not_a_closer_look_alike_of_it(monkeypatch, confused):
    """ "Is the A or the B closer?" in a world where a third object, closer than both, is boxed as one
    more B (fainter than B's own box): a program that takes the closest box of all would answer with it;
    the answer is the closer of A and B, as the world has them, and says why it is not the program's."""
    config = SceneConfig(layout="triplet", seed=5, width=320, height=240)
    with MujocoWorld(config) as w:
        objects = sorted((o for o in w.scene_info().objects if o.box is not None), key=lambda o: o.distance_m)
    assert len(objects) == 3
    nearest, a, b = objects
    if confused:
        wrap_detector(monkeypatch, lambda inner: _AlsoNames(inner, b.category, nearest.category))
    program = _CLOSEST_OF_ALL.format(a=a.category, b=b.category)
    answer = run_program(program, Scene(config, sensors=["camera", "distance"]), Settings(checks="none"))
    assert answer.error is None and answer.object is not None, answer.answer
    assert answer.object.id == a.id, answer.answer  # a is the closer of the two the question names
    assert ("the question names one" in answer.answer) is confused
    if confused:
        assert answer.returned["object_id"] == nearest.id  # what the program returned is kept as it was
