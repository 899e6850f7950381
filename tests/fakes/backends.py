"""Stand-in perception backends following the protocols of attribot.models.base: answers that show
what they were given (a mean colour, a box of bright pixels, a frame's size), and scripted ones."""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from attribot.api import Perception
from attribot.errors import InputError
from attribot.frame import Frame
from attribot.models.base import UNKNOWN, Detection
from fakes.frames import bright_box

__all__ = [
    "mean_colour",
    "MeanColourVQA",
    "WholeImageDetector",
    "EchoLanguage",
    "BrightBoxDetector",
    "Thing",
    "FakeDetector",
    "FakeVQA",
    "FakeLanguage",
    "perception_for",
    "wrap_detector",
]


def mean_colour(rgb: np.ndarray) -> str:
    """The mean colour of an image as "r,g,b": what `MeanColourVQA` answers, so that an answer that
    crossed a wire can be checked against the image that was sent."""
    return ",".join(str(int(round(v))) for v in rgb.reshape(-1, 3).mean(axis=0))


class MeanColourVQA:
    """Answers with the mean colour of the image; the question "fail" raises a model error."""

    name = "test:mean-colour"

    def answer(self, frame: Frame, question: str) -> str:
        if question == "fail":
            raise ValueError("CUDA out of memory (simulated)")
        return mean_colour(frame.rgb)


class WholeImageDetector:
    """Finds every query as the whole image, score 0.5."""

    name = "test:whole-image"

    def detect(self, frame: Frame, queries: list[str]) -> list[Detection]:
        return [
            Detection(box=(0.0, 0.0, float(frame.width), float(frame.height)), score=0.5, label=q)
            for q in queries
        ]


class EchoLanguage:
    """Answers a question with the question in capitals."""

    name = "test:echo"

    def complete(self, question: str) -> str:
        return question.upper()


class BrightBoxDetector:
    """Box of the bright pixels, labelled with the first query and the child's process id. The first
    query can ask for trouble: "bad-input" raises an InputError, "crash" a RuntimeError, "exit" ends the
    process, as a CUDA fault or the out-of-memory killer would, "hang" never returns."""

    name = "test:bright-box"

    def detect(self, frame: Frame, queries):
        return self.detect_batch([frame], [queries])[0]

    def detect_batch(self, frames, queries):
        out = []
        for f, q in zip(frames, queries, strict=True):
            if q[0] == "bad-input":
                raise InputError("this image is not acceptable", "send another one")
            if q[0] == "crash":
                raise RuntimeError("the model crashed on purpose")
            if q[0] == "exit":
                os._exit(3)
            if q[0] == "hang":  # a model call that never ends
                time.sleep(3600)
            out.append([Detection(box=bright_box(f.rgb), score=0.9, label=f"{q[0]}@{os.getpid()}")])
        return out


@dataclass(frozen=True)
class Thing:
    """A labelled box in full-frame pixels (y down), for the 2D detector."""

    label: str
    box: tuple[float, float, float, float]
    score: float = 0.9
    object_id: str | None = None


class FakeDetector:
    """Returns the things whose label is queried and whose box overlaps the frame given, in its pixels."""

    name = "fake-detector"

    def __init__(self, things: Sequence[Thing] = ()) -> None:
        self.things = list(things)
        self.calls: list[tuple[tuple[int, int, int, int], list[str]]] = []

    def detect(self, frame: Frame, queries: Sequence[str]) -> list[Detection]:
        ox, oy = frame.origin
        self.calls.append(((ox, oy, frame.width, frame.height), list(queries)))
        out = []
        for t in self.things:
            if t.label not in queries:
                continue
            x0, y0, x1, y1 = t.box[0] - ox, t.box[1] - oy, t.box[2] - ox, t.box[3] - oy
            x0, y0 = max(x0, 0.0), max(y0, 0.0)
            x1, y1 = min(x1, frame.width), min(y1, frame.height)
            if x1 > x0 and y1 > y0:
                out.append(
                    Detection(box=(x0, y0, x1, y1), score=t.score, label=t.label, object_id=t.object_id)
                )
        return out


class FakeVQA:
    """Answers with the size and origin of the pixels it was given, so tests can see what it saw."""

    name = "fake-vqa"

    def __init__(self) -> None:
        self.questions: list[str] = []

    def answer(self, frame: Frame, question: str) -> str:
        self.questions.append(question)
        return f"{frame.width}x{frame.height}@{frame.origin[0]},{frame.origin[1]}"


class FakeLanguage:
    name = "fake-language"

    def __init__(self, answers: dict[str, str] | None = None) -> None:
        self.answers = answers or {}

    def complete(self, question: str) -> str:
        return self.answers.get(question, UNKNOWN)


def perception_for(things: Sequence[Thing] = (), answers: dict[str, str] | None = None) -> Perception:
    return Perception(FakeDetector(things), FakeVQA(), FakeLanguage(answers))


def wrap_detector(monkeypatch: Any, wrap: Callable[[Any], Any]) -> None:
    """Every `Perception` built from settings for the rest of the test has its detector wrapped by `wrap`
    (a detector that also boxes what it should not: a jug as a second vase, a table under a book)."""
    real = Perception.from_settings

    def wrapped(settings: Any) -> Perception:
        p = real(settings)
        return dataclasses.replace(p, detector=wrap(p.detector))

    monkeypatch.setattr(Perception, "from_settings", staticmethod(wrapped))
