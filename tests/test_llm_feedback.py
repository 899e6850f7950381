"""What the LLM is told and asked, against real OpenAI-compatible servers on 127.0.0.1: feedback in the
words of the prompt it was shown (`--prompt paper` teaches `execute_command(image)`), a reply with no code
told so (not a syntax error) and no robot "put back" when nothing ran; a reply that copies the API's classes
around its function still yields the function; and the settings of the request itself: the timeout is
honoured with the request sent once (the client library's own retries are off), the reply length is sent."""

from __future__ import annotations

import json
import threading
import time
from textwrap import dedent

import pytest
from werkzeug import Response

from attribot.api import ImagePatch, Robot
from attribot.config import Settings
from attribot.errors import BackendError
from attribot.planning import Attempt, NoProgram, PlanRequest, RunError
from attribot.planning.extract import extract_program
from attribot.planning.llm import LLMPlanner, feedback_message
from attribot.runner import ProgramRunner
from conftest import BALLS, BallController, BallWorld, world_perception

PATH = "/v1/chat/completions"
REQUEST = PlanRequest(query="Which ball is the heaviest?", sensors=["camera", "force"], embodied=True)
REQUEST_SAME_START = REQUEST.model_copy(update={"same_start": True})


def completion(content: str) -> dict:
    return {
        "id": "c",
        "object": "chat.completion",
        "created": 0,
        "model": "m",
        "choices": [
            {"index": 0, "message": {"role": "assistant", "content": content}, "finish_reason": "stop"}
        ],
    }


def planner(httpserver, tmp_path, **settings) -> LLMPlanner:
    return LLMPlanner(
        Settings(llm_base_url=httpserver.url_for("/v1"), llm_model="m", cache_dir=tmp_path / "c", **settings)
    )


def test_feedback_to_the_paper_prompt_asks_for_its_own_entry_point(httpserver, tmp_path):
    code_without_entry = "```python\nimage_patch = ImagePatch(image)\nprint(image_patch.find('ball'))\n```"
    httpserver.expect_request(PATH).respond_with_json(completion(code_without_entry))
    paper = planner(httpserver, tmp_path, prompt="paper")
    with pytest.raises(NoProgram) as info:
        paper.plan(REQUEST)
    assert "does not define execute_command(image)" in info.value.message
    attempt = Attempt(program="", error=info.value.error, reply=info.value.reply)
    said = paper.messages(REQUEST, [attempt])[-1]["content"]
    assert "execute_command(image)" in said and "execute_command(image, robot)" not in said, said
    attribot = planner(httpserver, tmp_path, prompt="attribot")
    with pytest.raises(NoProgram, match=r"does not define execute_command\(image, robot\)"):
        attribot.plan(REQUEST)


def test_a_reply_with_no_code_is_not_a_syntax_error_and_nothing_ran_is_not_a_reset(httpserver, tmp_path):
    httpserver.expect_request(PATH).respond_with_json(completion("I cannot see the image, sorry."))
    llm = planner(httpserver, tmp_path)
    with pytest.raises(NoProgram) as info:
        llm.plan(REQUEST_SAME_START)
    assert info.value.error.category == "reply"
    said = llm.messages(REQUEST_SAME_START, [Attempt(program="", error=info.value.error)])[-1]["content"]
    assert "syntax error" not in said and "has no program" in said, said
    assert "back where it started" not in said and "Nothing ran" in said
    policy = RunError(category="policy", message="`import numpy` is not allowed", line=1)
    assert "back where it started" not in feedback_message(policy, same_start=True)
    ran = RunError(category="api", message="robot.pick_up(ball) needs an empty gripper")
    assert "back where it started" in feedback_message(ran, same_start=True)  # it ran, and was put back
    refused = feedback_message(ran, same_start=True, moved=False)  # it ran, and the robot never acted
    assert "back where it started" not in refused and "has not moved" in refused


COPIED = '''Here is the complete solution, with the API for reference:

```python
import math
from typing import List


class ImagePatch:
    """A part of the camera image."""

    def __init__(self, image, left: int = None, lower: int = None, right: int = None, upper: int = None):
        pass

    def find(self, object_name: str) -> List["ImagePatch"]:
        """Returns one ImagePatch for each object called `object_name`."""
        pass


class Robot:
    """The robot that carries the camera."""

    def __init__(self, sensors: List[str]):
        self.sensors = sensors

    def measure_weight(self, object_name: str) -> float:
        pass


def execute_command(image):
    robot = Robot(sensors=["camera", "force/torque sensor"])
    image_patch = ImagePatch(image)
    weights = []
    for ball_patch in image_patch.find("ball"):
        go_to_object(ball_patch)
        pick_up(ball_patch)
        weights.append((ball_patch.measure_weight("ball"), ball_patch))
    return max(weights, key=lambda pair: pair[0])[1]
```
'''


def test_a_reply_that_copies_the_api_classes_yields_its_function_and_runs():
    program = extract_program(COPIED, "execute_command(image)")
    assert "class ImagePatch" not in program and "class Robot" not in program
    assert program.startswith("import math") and "def execute_command(image):" in program
    world = BallWorld(BALLS)
    robot = Robot(sensors=("camera", "force"), world=world, controller=BallController(world))
    image = robot.look(world_perception())
    with ProgramRunner(classes=[ImagePatch, Robot]) as runner:
        result = runner.run(program, args=[image, robot])
    assert result.ok, result.error
    assert result.value["object_id"] == max(BALLS, key=lambda b: b.mass).id  # the world's heaviest ball


def test_a_slow_endpoint_gets_the_request_once_and_the_timeout_setting_is_honoured(httpserver, tmp_path):
    got: list[dict] = []
    done = threading.Event()

    def slow(request):
        got.append(json.loads(request.data))
        time.sleep(2.0)  # a local model reading the prompt
        done.set()
        return Response(
            json.dumps(completion("```python\ndef execute_command(image, robot):\n    return 1\n```"))
        )

    httpserver.expect_request(PATH).respond_with_handler(slow)
    short = planner(httpserver, tmp_path, llm_timeout_s=0.5, llm_retries=2, llm_max_tokens=700)
    started = time.monotonic()
    with pytest.raises(BackendError, match=r"did not answer in 0.5 s") as info:
        short.plan(REQUEST)
    assert time.monotonic() - started < 1.8  # gave up at the setting, not at the reply
    assert "--llm-timeout-s" in info.value.fix
    done.wait(5)
    assert len(got) == 1 and got[0]["max_tokens"] == 700  # sent once: no retry doubled the server's work
    got.clear()
    done.clear()
    patient = planner(httpserver, tmp_path, llm_timeout_s=10.0, llm_retries=2)
    assert patient.plan(REQUEST).program.startswith("def execute_command")
    assert len(got) == 1 and got[0]["max_tokens"] == 2048


def test_the_llm_request_settings_have_flags(tmp_path):
    import os
    import subprocess
    import sys

    shown = subprocess.run(
        [sys.executable, "-m", "attribot.cli", "ask", "--help"],
        capture_output=True, text=True, timeout=120, env={**os.environ, "COLUMNS": "200"},
    ).stdout  # fmt: skip
    for flag in ("--llm-timeout-s", "--llm-max-tokens", "--llm-retries", "--llm-max-tries"):
        assert flag in shown, shown


def test_the_copied_classes_are_stripped_only_when_they_are_the_apis():
    own = dedent("""
        class Pair:
            pass

        def execute_command(image, robot):
            return 1
    """)
    assert "class Pair" in extract_program(f"```python\n{own}```")  # the policy judges a class of its own
