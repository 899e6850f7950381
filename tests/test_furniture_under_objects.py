"""A detector that boxes the furniture under an object with the object's name (a table around the book lying
on it) from nearer does not send the gripper to the furniture: a box located as the furniture is not the
object the robot came to grasp. (A faint such box in the program's image: `tests/test_look_harder.py`.)"""

from __future__ import annotations

import pytest

from attribot.config import SceneConfig, Settings
from attribot.control.locate import beneath
from attribot.control.spatial import ObjectEstimate
from attribot.frame import Frame
from attribot.models.base import Detection
from attribot.session import Scene, run_program
from conftest import grown_box, wrap_detector

# a book lying flat on a coffee table, alone in the room
BOOK_ON_TABLE = SceneConfig(
    layout="household", seed=1, categories=("book",), objects=1, width=320, height=240
)


class _BoxesWhatHoldsIt:
    """Wraps a detector: a box of `name` comes with a box of what holds it (three times its size, about
    its middle) under the same name, at `score`; only from the second image on where `later_only` (the
    robot has come nearer)."""

    def __init__(self, inner: object, name: str, score: float, later_only: bool) -> None:
        self.inner, self.meant, self.score, self.later_only = inner, name, score, later_only
        self.name = "boxes-what-holds-it"
        self.first: bytes | None = None

    def detect(self, frame: Frame, queries: list[str]) -> list[Detection]:
        found = self.inner.detect(frame, queries)  # type: ignore[attr-defined]
        key = frame.rgb.tobytes()
        self.first = key if self.first is None else self.first
        if self.meant not in queries or (self.later_only and key == self.first):
            return found
        holders = [
            d.model_copy(
                update={"box": grown_box(d.box, 3.0, frame.width, frame.height), "score": self.score}
            )
            for d in found
            if d.label == self.meant
        ]
        return holders + found  # listed first: taken first where both are as near the image's centre


def _with_detector(monkeypatch: pytest.MonkeyPatch, score: float, later_only: bool) -> None:
    wrap_detector(monkeypatch, lambda inner: _BoxesWhatHoldsIt(inner, "book", score, later_only))


WEIGH_EVERY_BOOK = """
def execute_command(image, robot):
    books = image.find("book")
    weights = []
    for patch in books:
        robot.go_to_object(patch)
        robot.pick_up(patch)
        weights.append(robot.measure_weight(patch))
        robot.put_down()
    return len(weights)
"""


def test_the_furniture_boxed_from_nearer_is_not_the_object_come_to(monkeypatch):
    """From nearer the detector boxes the table under the book as a book, listed first: the robot does not
    take the table for the book it came to grasp (its arm would reach under the table top), it grasps the
    book and weighs it."""
    _with_detector(monkeypatch, score=0.9, later_only=True)
    program = WEIGH_EVERY_BOOK.replace('image.find("book")', 'image.find("book")[:1]')
    scene = Scene(BOOK_ON_TABLE, sensors=["camera", "force"])
    answer = run_program(program, scene, Settings(checks="none"))
    assert answer.error is None, answer.answer
    assert answer.value == 1, answer.answer


def _estimate(support: float, top: float, radius: float) -> ObjectEstimate:
    return ObjectEstimate(
        centre=(1.0, 0.0, (support + top) / 2), support_z=support, top_z=top, radius=radius, points=50
    )


@pytest.mark.parametrize(
    "new, is_beneath",
    [
        (_estimate(0.0, 0.48, 0.34), True),  # the table and the book on it, from the floor up
        (_estimate(0.45, 0.48, 0.10), False),  # the book again
        (_estimate(0.0, 0.48, 0.12), False),  # lower, as wide: a foot the first image did not see
        (_estimate(0.40, 0.48, 0.40), False),  # wider, standing where it did: the book with its neighbour
    ],
)
def test_what_stands_far_lower_and_far_wider_is_the_furniture_beneath(new, is_beneath):
    book = _estimate(0.45, 0.48, 0.10)
    assert beneath(new, book) is is_beneath
