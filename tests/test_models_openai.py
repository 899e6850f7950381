"""openai: backends (vision chat VQA, language) against a real HTTP server on 127.0.0.1."""

from __future__ import annotations

import base64
import io
import json
import time

import numpy as np
import pytest
from PIL import Image
from pytest_httpserver import HTTPServer
from werkzeug import Request, Response

from attribot.config import Settings
from attribot.errors import BackendError, ConfigError, InputError
from attribot.frame import Frame
from attribot.models.base import UNKNOWN, answer_many, build_backend, probe_backend
from attribot.models.openai_chat import (
    OpenAILanguageModel,
    OpenAIVisualQA,
    clean_answer,
    image_data_url,
)
from conftest import free_port


@pytest.fixture(scope="module")
def _running_server():
    srv = HTTPServer(host="127.0.0.1", port=0, threaded=True)
    srv.start()
    yield srv
    srv.stop()  # stopping takes half a second: once per module


@pytest.fixture
def server(_running_server):
    _running_server.clear()
    yield _running_server
    _running_server.clear()


def _completion(content, choices=True) -> dict:
    body = {"id": "c1", "object": "chat.completion", "created": 0, "model": "m"}
    body["choices"] = (
        [{"index": 0, "message": {"role": "assistant", "content": content}, "finish_reason": "stop"}]
        if choices
        else []
    )
    return body


def _settings(server: HTTPServer, **kw) -> Settings:
    return Settings(llm_base_url=server.url_for("/v1"), llm_api_key="sk-test", **kw)


def _frame(seed: int = 0) -> Frame:
    return Frame(rgb=np.random.default_rng(seed).integers(0, 256, (12, 17, 3), dtype=np.uint8))


def _decode_data_url(url: str) -> np.ndarray:
    head, _, data = url.partition(",")
    assert head == "data:image/png;base64"
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(data))).convert("RGB"))


def test_vqa_sends_question_and_png_data_url(server):
    server.expect_request("/v1/chat/completions", method="POST").respond_with_json(
        _completion(' "A red cup." ')
    )
    vqa = build_backend("vqa", "openai:vision-model", _settings(server))
    assert isinstance(vqa, OpenAIVisualQA) and vqa.name == "openai:vision-model"
    frame = _frame()
    assert vqa.answer(frame, "  What is on the table? ") == "A red cup"
    ((request, _),) = server.log
    assert request.headers["Authorization"] == "Bearer sk-test"
    body = json.loads(request.get_data())
    assert body["model"] == "vision-model" and body["temperature"] == 0.0
    user = body["messages"][-1]
    texts = [p["text"] for p in user["content"] if p["type"] == "text"]
    urls = [p["image_url"]["url"] for p in user["content"] if p["type"] == "image_url"]
    assert texts == ["What is on the table?"]
    assert np.array_equal(_decode_data_url(urls[0]), frame.rgb)  # lossless: the model sees our pixels


def test_vqa_batch_keeps_order_under_concurrency(server):
    def echo(request: Request) -> Response:
        body = json.loads(request.get_data())
        question = body["messages"][-1]["content"][0]["text"]
        time.sleep(0.05 if question.endswith("0") else 0.0)  # the first one finishes last
        return Response(json.dumps(_completion(question.upper())), content_type="application/json")

    server.expect_request("/v1/chat/completions").respond_with_handler(echo)
    vqa = build_backend("vqa", "openai:m", _settings(server))
    frames = [_frame(i) for i in range(5)]
    questions = [f"question {i}" for i in range(5)]
    assert answer_many(vqa, frames, questions) == [q.upper() for q in questions]
    assert len(server.log) == 5


def test_language_model_sends_text_only(server):
    server.expect_request("/v1/chat/completions").respond_with_json(_completion("0.3 kg.\nBecause..."))
    lm = build_backend("language", "openai:text-model", _settings(server))
    assert isinstance(lm, OpenAILanguageModel)
    assert lm.complete("How heavy is a mug?") == "0.3 kg"
    body = json.loads(server.log[0][0].get_data())
    assert body["messages"][-1] == {"role": "user", "content": "How heavy is a mug?"}
    assert body["model"] == "text-model"


def test_bare_openai_spec_uses_the_planner_model(server):
    server.expect_request("/v1/chat/completions").respond_with_json(_completion("Unknown."))
    lm = build_backend("language", "openai", _settings(server, llm_model="local-llm"))
    assert lm.complete("Which is heavier?") == UNKNOWN
    assert json.loads(server.log[0][0].get_data())["model"] == "local-llm"


@pytest.mark.parametrize(
    ("status", "body", "match"),
    [
        (401, {"error": {"message": "invalid key"}}, "refused the API key"),
        (500, {"error": {"message": "model crashed"}}, "HTTP 500"),
        (200, _completion(None, choices=False), "no text content"),
        (200, _completion(None), "no text content"),
    ],
)
def test_endpoint_errors_become_backend_errors(server, status, body, match):
    server.expect_request("/v1/chat/completions").respond_with_json(body, status=status)
    vqa = OpenAIVisualQA("m", base_url=server.url_for("/v1"), api_key="k", max_retries=0)
    with pytest.raises(BackendError, match=match):
        vqa.answer(_frame(), "what is it?")
    lm = OpenAILanguageModel("m", base_url=server.url_for("/v1"), api_key="k", max_retries=0)
    with pytest.raises(BackendError, match=match):
        lm.complete("what is it?")


def test_timeout_is_a_backend_error(server):
    def slow(request: Request) -> Response:
        time.sleep(1.0)
        return Response(json.dumps(_completion("late")), content_type="application/json")

    server.expect_request("/v1/chat/completions").respond_with_handler(slow)
    lm = OpenAILanguageModel("m", base_url=server.url_for("/v1"), timeout_s=0.2, max_retries=0)
    start = time.monotonic()
    with pytest.raises(BackendError, match="did not answer in 0.2 s"):
        lm.complete("anyone there?")
    assert time.monotonic() - start < 0.9


def test_unreachable_endpoint_is_a_backend_error():
    lm = OpenAILanguageModel("m", base_url=f"http://127.0.0.1:{free_port()}/v1", max_retries=0, timeout_s=2)
    with pytest.raises(BackendError, match="cannot reach"):
        lm.complete("hello?")


def test_bad_questions_fail_before_any_request(server):
    vqa = OpenAIVisualQA("m", base_url=server.url_for("/v1"), max_retries=0)
    with pytest.raises(InputError, match="empty"):
        vqa.answer(_frame(), "  ")
    with pytest.raises(InputError, match="2 frames and 1"):
        vqa.answer_batch([_frame(), _frame()], ["a?"])
    with pytest.raises(ConfigError, match="model name"):
        OpenAIVisualQA(" ")
    assert server.log == []


def test_probe_lists_models_or_says_why_not(server):
    server.expect_request("/v1/models").respond_with_json(
        {
            "object": "list",
            "data": [{"id": "vision-model", "object": "model", "created": 0, "owned_by": "me"}],
        }
    )
    s = _settings(server)
    ok = probe_backend("vqa", "openai:vision-model", s)
    assert ok.available is True and "serves vision-model" in ok.detail
    other = probe_backend("language", "openai:gpt-x", s)
    assert other.available is True and "does not list gpt-x" in other.detail
    down = Settings(llm_base_url=f"http://127.0.0.1:{free_port()}/v1")
    bad = probe_backend("language", "openai:m", down)
    assert bad.available is False and "cannot reach" in bad.detail


def test_probe_reports_a_refused_key(server):
    server.expect_request("/v1/models").respond_with_json({"error": {"message": "no"}}, status=401)
    st = probe_backend("vqa", "openai:m", _settings(server))
    assert st.available is False and "401" in st.detail


@pytest.mark.parametrize(
    ("raw", "want"),
    [
        ("yes", "yes"),
        (" 'Blue.' ", "Blue"),
        ("", UNKNOWN),
        ("\n\n", UNKNOWN),
        ("UNKNOWN", UNKNOWN),
        ("two\nthree", "two"),
        ("Wait...", "Wait..."),
    ],
)
def test_clean_answer_table(raw, want):
    assert clean_answer(raw) == want


def test_image_data_url_rejects_non_images():
    with pytest.raises(ValueError, match="uint8"):
        image_data_url(np.zeros((4, 4), np.float32))
