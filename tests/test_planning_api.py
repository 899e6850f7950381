"""Rules programs against the real API classes and the offline backends (oracle detector and VQA, catalog
language model) on a synthetic frame with a known segmentation: the phrasings the programs send are the
ones the backends read, and the right object comes back. Runs in-process; the sandbox is the runner's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from attribot.config import Settings
from attribot.frame import Frame, ObjectTruth

api = pytest.importorskip("attribot.api.patch")
perception_module = pytest.importorskip("attribot.api.perception")
from attribot.planning.rules import rules_program  # noqa: E402

H, W = 480, 640


def frame_with(objects: list[tuple[str, str, tuple[int, int, int, int]]]) -> Frame:
    """A frame whose segmentation paints each (category, colour, xyxy box, y down) object."""
    segmentation = np.full((H, W), -1, np.int32)
    truths = {}
    for key, (category, color, (x0, y0, x1, y1)) in enumerate(objects):
        segmentation[y0:y1, x0:x1] = key
        truths[key] = ObjectTruth(id=f"{category}-{key}", category=category, color=color)
    return Frame(rgb=np.zeros((H, W, 3), np.uint8), segmentation=segmentation, objects=truths)


def run(query: str, frame: Frame):
    perception = perception_module.Perception.from_settings(Settings())
    image = api.ImagePatch(frame, perception)
    namespace = {"math": math}
    exec(compile(rules_program(query), "<program>", "exec"), namespace)
    return namespace["execute_command"](image, None)


def test_second_mug_from_the_right_in_the_second_to_last_row():
    # three rows of four mugs (y down in pixels); the program must return mug-5 (middle row, 2nd from right)
    objects = [
        ("mug", "white", (60 + c * 120, 40 + r * 140, 120 + c * 120, 110 + r * 140))
        for r in range(3)
        for c in range(4)
    ]
    chosen = run("the second mug from the right in the second to last row", frame_with(objects))
    assert chosen.object_id == "mug-6"  # row 1 (0-based from the top), column 2 from the left


def test_smallest_red_apple_uses_the_oracle_colour_answers():
    objects = [
        ("apple", "red", (50, 200, 130, 280)),
        ("apple", "green", (200, 220, 240, 260)),  # smallest of all, but green
        ("apple", "red", (300, 210, 360, 270)),
        ("mug", "red", (450, 215, 480, 245)),  # red and small, but a mug
    ]
    assert run("the smallest red apple", frame_with(objects)).object_id == "apple-2"


def test_heaviest_item_through_vqa_and_the_catalog_language_model():
    objects = [
        ("apple", "red", (40, 200, 100, 260)),
        ("laptop", "gray", (200, 150, 400, 300)),
        ("pencil", "yellow", (450, 250, 600, 262)),
    ]
    chosen = run("the heaviest item", frame_with(objects))
    assert chosen.object_id == "laptop-1"
    lightest = run(
        "Out of the apple, the laptop and the pencil, which one is the most lightweight?", frame_with(objects)
    )
    assert lightest.object_id == "pencil-2"


def test_long_follows_orientation_with_real_patches():
    objects = [
        ("carrot", "orange", (50, 100, 70, 180)),  # upright, 80 long
        ("carrot", "orange", (200, 300, 320, 318)),
    ]  # lying, 120 long but only 18 tall
    assert run("the longest carrot", frame_with(objects)).object_id == "carrot-1"
    assert run("the tallest carrot", frame_with(objects)).object_id == "carrot-0"
