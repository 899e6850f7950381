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
perception_module = pytest.importorskip("attribot.skills.perception")
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


# ---- through the sandboxed runner ---------------------------------------------------------------------

runner_module = pytest.importorskip("attribot.runner")


@pytest.fixture
def sandbox():
    from attribot.api.robot import Robot

    with runner_module.ProgramRunner(classes=[api.ImagePatch, Robot]) as runner:
        yield runner


def test_rules_plan_solved_through_the_runner(sandbox):
    from attribot.planning import PlanRequest, build_planner, solve

    objects = [
        ("mug", "white", (60 + c * 120, 40 + r * 140, 120 + c * 120, 110 + r * 140))
        for r in range(3)
        for c in range(4)
    ]
    image = api.ImagePatch(frame_with(objects), perception_module.Perception.from_settings(Settings()))
    request = PlanRequest(query="the second mug from the right in the second to last row", sensors=["camera"])
    outcome = solve(
        build_planner("rules", Settings()), request, lambda p: sandbox.run(p, args=[image, None]), 3
    )
    assert outcome.ok, outcome.error
    assert outcome.result.value_object.object_id == "mug-6"
    assert [t.call for t in outcome.result.trace] == ["ImagePatch.find"]


def test_a_rules_program_error_comes_back_structured(sandbox):
    from attribot.planning import PlanRequest, build_planner, solve

    image = api.ImagePatch(
        frame_with([("mug", "white", (10, 10, 50, 50))]),
        perception_module.Perception.from_settings(Settings()),
    )
    request = PlanRequest(query="the third mug from the left", sensors=["camera"])
    outcome = solve(
        build_planner("rules", Settings()), request, lambda p: sandbox.run(p, args=[image, None]), 3
    )
    assert not outcome.ok and len(outcome.attempts) == 1  # deterministic: not run again
    assert outcome.error.category == "runtime"
    assert "asked for the 3rd mug from the left, but only 1 were found" in outcome.error.message


def test_llm_plan_with_the_runners_real_error_fed_back(sandbox, httpserver, tmp_path):
    from attribot.planning import PlanRequest, solve
    from attribot.planning.llm import LLMPlanner

    wrong = "def execute_command(image, robot):\n    mugs = image.find('mug')\n    return mugs[5]\n"
    right = "def execute_command(image, robot):\n    mugs = image.find('mug')\n    return mugs[0]\n"
    for program in (wrong, right):
        reply = {
            "choices": [{"index": 0, "message": {"role": "assistant", "content": f"```python\n{program}```"}}]
        }
        httpserver.expect_ordered_request("/v1/chat/completions").respond_with_json(reply)
    settings = Settings(llm_base_url=httpserver.url_for("/v1"), cache_dir=tmp_path)
    planner = LLMPlanner(settings, prompt_builder=lambda query, sensors: f"write a program for {query}")
    image = api.ImagePatch(
        frame_with([("mug", "white", (10, 10, 50, 50))]),
        perception_module.Perception.from_settings(Settings()),
    )
    request = PlanRequest(query="a mug", sensors=["camera"])
    outcome = solve(planner, request, lambda p: sandbox.run(p, args=[image, None]), max_tries=3)
    assert outcome.ok and len(outcome.attempts) == 2
    first_error = outcome.attempts[0].error
    assert first_error.category == "runtime" and first_error.line == 3
    feedback = httpserver.log[1][0].get_json()["messages"][-1]["content"]
    assert first_error.message in feedback and "line 3" in feedback and "mugs[5]" in feedback
