"""The LLM planner against a real OpenAI-compatible HTTP server on 127.0.0.1 (pytest-httpserver): code in
every shape, broken bodies, time-outs, 429 and 500 answers, replies with no code, error feedback, cache."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass

import pytest
from werkzeug import Response

from attribot.config import Settings
from attribot.errors import BackendError, ConfigError
from attribot.planning import NoProgram, PlanRequest, RunError, solve
from attribot.planning.llm import LLMPlanner, ReplyCache, cache_key

REQUEST = PlanRequest(query="the second cup from the left", sensors=["camera", "distance"], embodied=True)
PROGRAM = (
    "def execute_command(image, robot):\n"
    "    cups = sorted(image.find('cup'), key=lambda cup: cup.horizontal_center)\n"
    "    return cups[1]\n"
)
PATH = "/v1/chat/completions"


def completion(content: str) -> dict:
    return {
        "id": "chatcmpl-1",
        "object": "chat.completion",
        "created": 0,
        "model": "test-model",
        "choices": [
            {"index": 0, "message": {"role": "assistant", "content": content}, "finish_reason": "stop"}
        ],
        "usage": {"prompt_tokens": 1, "completion_tokens": 1, "total_tokens": 2},
    }


def prompt_builder(query, sensors):
    return f"PROMPT for {query!r} with sensors {', '.join(sensors)}"


def make_planner(httpserver, tmp_path, *, retries=0, timeout=5.0, **overrides) -> LLMPlanner:
    settings = Settings(
        llm_base_url=httpserver.url_for("/v1"),
        llm_model="test-model",
        llm_timeout_s=timeout,
        cache_dir=tmp_path / "cache",
        **overrides,
    )
    return LLMPlanner(settings, prompt_builder=prompt_builder, http_retries=retries)


def bodies(httpserver) -> list[dict]:
    return [json.loads(request.get_data()) for request, _ in httpserver.log]


@pytest.mark.parametrize(
    "reply",
    [
        f"```python\n{PROGRAM}```",
        f"Here is the program.\n\n```py\n{PROGRAM}```\nIt sorts the cups from the left.",
        f"Sure:\n{PROGRAM}\nThat returns the second cup.",
        f"```python\ndef execute_command(image, robot):\n    return None\n```\n"
        f"Fixed:\n```python\n{PROGRAM}```",
    ],
    ids=["fenced", "prose-around", "bare", "several-blocks"],
)
def test_the_program_is_extracted_and_the_request_is_what_was_configured(httpserver, tmp_path, reply):
    httpserver.expect_request(PATH, method="POST").respond_with_json(completion(reply))
    plan = make_planner(httpserver, tmp_path).plan(REQUEST)
    assert plan.program == PROGRAM and plan.reply == reply and not plan.cached
    (body,) = bodies(httpserver)
    assert body["model"] == "test-model" and body["temperature"] == 0.0
    assert body["messages"] == [
        {"role": "user", "content": "PROMPT for 'the second cup from the left' with sensors camera, distance"}
    ]


@pytest.mark.parametrize(
    ("body", "content_type", "match"),
    [
        ('{"choices": [', "application/json", "not JSON"),
        ("<html>Bad gateway</html>", "text/html", "no text content"),
        ('{"choices": []}', "application/json", "no text content"),
        (
            json.dumps({"choices": [{"index": 0, "message": {"role": "assistant", "content": None}}]}),
            "application/json",
            "no text content",
        ),
    ],
    ids=["truncated-json", "html", "no-choices", "null-content"],
)
def test_malformed_bodies_are_backend_errors(httpserver, tmp_path, body, content_type, match):
    httpserver.expect_request(PATH).respond_with_data(body, content_type=content_type)
    with pytest.raises(BackendError, match=match):
        make_planner(httpserver, tmp_path).plan(REQUEST)


def test_a_slow_server_times_out(httpserver, tmp_path):
    def slow(request):
        time.sleep(1.0)
        return Response(json.dumps(completion(PROGRAM)), content_type="application/json")

    httpserver.expect_request(PATH).respond_with_handler(slow)
    started = time.monotonic()
    with pytest.raises(BackendError, match="did not answer in 0.2 s") as info:
        make_planner(httpserver, tmp_path, timeout=0.2).plan(REQUEST)
    assert time.monotonic() - started < 0.9  # gave up at the time-out, did not wait for the reply
    assert "ATTRIBOT_LLM_TIMEOUT_S" in info.value.fix
    # let the server finish the abandoned request, so that it does not land in the next test's log
    deadline = time.monotonic() + 3
    while not httpserver.log and time.monotonic() < deadline:
        time.sleep(0.05)


def test_429_then_success(httpserver, tmp_path):
    httpserver.expect_ordered_request(PATH).respond_with_json(
        {"error": {"message": "slow down"}}, status=429, headers={"retry-after-ms": "10"}
    )
    httpserver.expect_ordered_request(PATH).respond_with_json(completion(f"```python\n{PROGRAM}```"))
    plan = make_planner(httpserver, tmp_path, retries=2).plan(REQUEST)
    assert plan.program == PROGRAM and len(httpserver.log) == 2


def test_429_for_good_is_a_rate_limit_error(httpserver, tmp_path):
    httpserver.expect_request(PATH).respond_with_json({"error": {"message": "quota"}}, status=429)
    with pytest.raises(BackendError, match="429"):
        make_planner(httpserver, tmp_path, retries=0).plan(REQUEST)


def test_500_is_retried_then_reported(httpserver, tmp_path):
    httpserver.expect_request(PATH).respond_with_json(
        {"error": {"message": "model crashed"}}, status=500, headers={"retry-after-ms": "10"}
    )
    with pytest.raises(BackendError, match="HTTP 500"):
        make_planner(httpserver, tmp_path, retries=1).plan(REQUEST)
    assert len(httpserver.log) == 2  # the first try and one retry


def test_a_reply_without_code_goes_back_to_the_model(httpserver, tmp_path):
    refusal = "I'm sorry, but I can't see any image.\nCould you describe it?"
    httpserver.expect_ordered_request(PATH).respond_with_json(completion(refusal))
    httpserver.expect_ordered_request(PATH).respond_with_json(completion(f"```python\n{PROGRAM}```"))
    planner = make_planner(httpserver, tmp_path)
    with pytest.raises(NoProgram, match="no code in the reply"):
        planner.plan(REQUEST)
    outcome = solve(planner, REQUEST, lambda program: Result(True), max_tries=3)
    assert outcome.ok and len(outcome.attempts) == 2  # the refusal came from the cache, then the fix
    messages = bodies(httpserver)[-1]["messages"]
    assert [m["role"] for m in messages] == ["user", "assistant", "user"]
    assert messages[1]["content"] == refusal
    assert (
        "no code in the reply" in messages[2]["content"]
        and "I'm sorry, but I can't see any image." in messages[2]["content"]
    )
    assert "```python" in messages[2]["content"]


@dataclass
class Result:
    ok: bool
    error: object = None


def test_runner_errors_are_fed_back_and_the_model_asked_again(httpserver, tmp_path):
    fixed = PROGRAM.replace("cups[1]", "cups[1] if len(cups) > 1 else cups[0]")
    httpserver.expect_ordered_request(PATH).respond_with_json(completion(f"```python\n{PROGRAM}```"))
    httpserver.expect_ordered_request(PATH).respond_with_json(completion(f"```python\n{fixed}```"))
    error = RunError(
        category="runtime",
        message="IndexError: list index out of range",
        line=3,
        snippet="    return cups[1]",
        output="looking for cups\n",
    )
    results = iter([Result(False, error), Result(True)])
    runs = []
    outcome = solve(make_planner(httpserver, tmp_path), REQUEST, lambda p: runs.append(p) or next(results), 3)
    assert outcome.ok and runs == [PROGRAM, fixed]
    second = bodies(httpserver)[1]["messages"]
    assert second[1] == {"role": "assistant", "content": f"```python\n{PROGRAM}```"}
    feedback = second[2]["content"]
    for part in (
        "IndexError: list index out of range",
        "runtime error, line 3",
        "return cups[1]",
        "looking for cups",
    ):
        assert part in feedback


def test_the_cache_makes_a_rerun_free_and_reproducible(httpserver, tmp_path):
    httpserver.expect_request(PATH).respond_with_json(completion(f"```python\n{PROGRAM}```"))
    first = make_planner(httpserver, tmp_path).plan(REQUEST)
    again = make_planner(httpserver, tmp_path).plan(REQUEST)  # a new process would do the same
    assert len(httpserver.log) == 1
    assert again.cached and not first.cached and again.program == first.program and again.reply == first.reply
    # a different parameter is a different question
    make_planner(httpserver, tmp_path, llm_temperature=0.7).plan(REQUEST)
    assert len(httpserver.log) == 2
    files = list((tmp_path / "cache" / "llm").rglob("*"))
    assert not [f for f in files if f.name.startswith(".tmp-")]  # atomic writes leave no debris


@pytest.mark.parametrize(
    "garbage", [b"", b"{not json", b'{"key": "other", "reply": "x"}', b"\xff\xfe", b"[1, 2]"]
)
def test_a_corrupt_cache_file_is_ignored_and_rewritten(httpserver, tmp_path, garbage):
    httpserver.expect_request(PATH).respond_with_json(completion(f"```python\n{PROGRAM}```"))
    planner = make_planner(httpserver, tmp_path)
    key = cache_key("test-model", planner.messages(REQUEST), planner.params)
    path = planner.cache.path(key)
    path.parent.mkdir(parents=True)
    path.write_bytes(garbage)
    plan = planner.plan(REQUEST)
    assert not plan.cached and plan.program == PROGRAM and len(httpserver.log) == 1
    assert ReplyCache(path.parent.parent).get(key) == plan.reply  # rewritten, readable


def test_no_endpoint_is_a_config_error_that_says_what_to_set(tmp_path):
    planner = LLMPlanner(Settings(cache_dir=tmp_path), prompt_builder=prompt_builder)
    with pytest.raises(ConfigError, match="no endpoint") as info:
        planner.plan(REQUEST)
    assert "ATTRIBOT_LLM_BASE_URL" in info.value.fix


def test_an_unreachable_endpoint_is_a_backend_error(tmp_path):
    settings = Settings(llm_base_url="http://127.0.0.1:9/v1", llm_timeout_s=2.0, cache_dir=tmp_path)
    with pytest.raises(BackendError, match="cannot reach"):
        LLMPlanner(settings, prompt_builder=prompt_builder, http_retries=0).plan(REQUEST)


def test_the_default_prompt_is_the_apis_own(tmp_path):
    api_prompt = pytest.importorskip("attribot.api.prompt")
    planner = LLMPlanner(Settings(cache_dir=tmp_path))
    (message,) = planner.messages(REQUEST)
    assert message["content"] == api_prompt.build_prompt(REQUEST.query, REQUEST.sensors, embodied=True)
