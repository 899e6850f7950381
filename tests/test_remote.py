"""The `remote:URL` client: spec parsing, registry and probe, retries with back-off, clear errors.

Servers are real, on 127.0.0.1: the attribot server where the answer matters, pytest-httpserver where a
misbehaving server (5xx, 429, slow, garbage) is needed.
"""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
import pytest
from pytest_httpserver import HTTPServer
from werkzeug import Request, Response

from attribot.config import Settings
from attribot.errors import BackendError, ConfigError, InputError
from attribot.frame import Frame
from attribot.models.base import Detection, build_backend, probe_backend
from attribot.models.remote import (
    RemoteClient,
    RemoteDetector,
    RemoteLanguageModel,
    RemoteVisualQA,
    parse_remote_url,
)
from attribot.models.wire import DetectResponse, decode_image
from attribot.server import ServerConfig, ServerThread, create_app
from conftest import MeanColourVQA, WholeImageDetector, free_port

TOKEN = "remote-test-token"


@pytest.fixture(scope="module")
def server():
    app = create_app(
        detector=WholeImageDetector(),
        vqa=MeanColourVQA(),
        config=ServerConfig(token=TOKEN, batch_window_ms=0),
    )
    with ServerThread(app) as srv:
        yield srv


@pytest.fixture(scope="module")
def _http():
    srv = HTTPServer(host="127.0.0.1", port=0, threaded=True)
    srv.start()
    yield srv
    srv.stop()


@pytest.fixture
def http(_http):
    _http.clear()
    yield _http
    _http.clear()


def frame(h: int = 30, w: int = 40, colour=(200, 100, 50)) -> Frame:
    rgb = np.zeros((h, w, 3), np.uint8)
    rgb[:, :] = colour
    return Frame(rgb=rgb)


DETECT_OK = DetectResponse(
    detections=[Detection(box=(1, 2, 3, 4), score=0.5, label="cup")], backend="fake"
).model_dump(mode="json")


# ---- spec parsing -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("arg", "url", "options"),
    [
        ("http://127.0.0.1:8500", "http://127.0.0.1:8500", {}),
        ("127.0.0.1:8500", "http://127.0.0.1:8500", {}),
        ("https://gpu.example.org/attribot/", "https://gpu.example.org/attribot", {}),
        ("http://localhost:8500?image=png&tries=5", "http://localhost:8500", {"image": "png", "tries": "5"}),
    ],
)
def test_parse_remote_url(arg, url, options):
    assert parse_remote_url(arg) == (url, options)


@pytest.mark.parametrize(
    ("arg", "message"),
    [
        (None, "needs the server's URL"),
        ("", "needs the server's URL"),
        ("ftp://host:21", "not an http(s) URL"),
        ("http://:8500", "not an http(s) URL"),
        ("http://host:99999", "bad port"),
        ("http://host:8500?colour=red", "unknown options: colour"),
    ],
)
def test_parse_remote_url_errors(arg, message):
    with pytest.raises(ConfigError, match=message.replace("(", r"\(").replace(")", r"\)")):
        parse_remote_url(arg)


@pytest.mark.parametrize(
    ("query", "message"),
    [("image=gif", "format 'gif'"), ("tries=0", "at least 1"), ("tries=x", "not a number")],
)
def test_bad_client_options(query, message):
    with pytest.raises(ConfigError, match=message):
        RemoteClient(f"http://127.0.0.1:1?{query}")


# ---- through the registry, against the real server ----------------------------------------------------


def test_registry_builds_all_three_roles_and_they_work(server):
    settings = Settings(remote_token=TOKEN, remote_timeout_s=5)
    spec = f"remote:{server.url}"
    det = build_backend("detector", spec, settings)
    vqa = build_backend("vqa", spec + "?image=png", settings)
    lang = build_backend("language", spec, settings)
    assert isinstance(det, RemoteDetector) and isinstance(vqa, RemoteVisualQA)
    assert isinstance(lang, RemoteLanguageModel) and det.name == f"remote:{server.url}"
    (d,) = det.detect(frame(30, 40), "cup")  # a single string is one query
    assert d.box == (0.0, 0.0, 40.0, 30.0) and d.label == "cup" and det.served_by == "test:whole-image"
    assert vqa.answer(frame(colour=(201, 99, 7)), "colour?") == "201,99,7"  # png: exact pixels
    # jpeg (the default) is lossy but close
    jpeg_vqa = build_backend("vqa", spec, settings)
    got = [int(v) for v in jpeg_vqa.answer(frame(colour=(201, 99, 7)), "colour?").split(",")]
    assert np.abs(np.array(got) - (201, 99, 7)).max() <= 3
    # the role this server does not serve: a ConfigError that says how to serve it
    with pytest.raises(ConfigError, match="serves no language"):
        lang.complete("which is heavier?")


def test_detect_batch_and_answer_batch_keep_order(server):
    client = RemoteClient(server.url, token=TOKEN, image_format="png")
    frames = [frame(10 + i, 20 + i, colour=(i, 2 * i, 3 * i)) for i in range(6)]
    boxes = RemoteDetector(client).detect_batch(frames, [[f"q{i}"] for i in range(6)])
    assert [b[0].box for b in boxes] == [(0, 0, 20 + i, 10 + i) for i in range(6)]
    answers = RemoteVisualQA(client).answer_batch(frames, ["c?"] * 6)
    assert answers == [f"{i},{2 * i},{3 * i}" for i in range(6)]
    with pytest.raises(InputError, match="6 frames but 5"):
        RemoteVisualQA(client).answer_batch(frames, ["c?"] * 5)


def test_client_input_checks(server):
    det = RemoteDetector(RemoteClient(server.url, token=TOKEN))
    with pytest.raises(InputError, match="no query"):
        det.detect(frame(), [])
    with pytest.raises(InputError, match="takes an attribot Frame"):
        det.detect(np.zeros((4, 4, 3), np.uint8), ["x"])
    with pytest.raises(InputError, match="question is empty"):
        RemoteVisualQA(det.client).answer(frame(), "  ")


def test_wrong_or_missing_token_is_a_clear_backend_error(server):
    with pytest.raises(BackendError, match="refused the token") as wrong:
        RemoteDetector(RemoteClient(server.url, token="nope")).detect(frame(), ["x"])
    assert "ATTRIBOT_REMOTE_TOKEN" in str(wrong.value)
    with pytest.raises(BackendError, match="needs a token and none was sent"):
        RemoteVisualQA(RemoteClient(server.url)).answer(frame(), "q")


def test_probe_reports_token_role_and_down_server(server):
    good = probe_backend("detector", f"remote:{server.url}", Settings(remote_token=TOKEN))
    assert good.available is True and "detector=test:whole-image" in good.detail
    bad_token = probe_backend("vqa", f"remote:{server.url}", Settings(remote_token="nope"))
    assert bad_token.available is False and "refused the token" in bad_token.detail
    not_served = probe_backend("language", f"remote:{server.url}", Settings(remote_token=TOKEN))
    assert not_served.available is False and "serves no language" in not_served.detail
    down = probe_backend("detector", f"remote:http://127.0.0.1:{free_port()}", Settings())
    assert down.available is False and "cannot reach" in down.detail and "after 1 try " in down.detail
    bad = probe_backend("detector", f"remote:{server.url}?tries=x", Settings(remote_token=TOKEN))
    assert bad.available is False and "not a number" in bad.detail


def test_importing_the_client_and_server_loads_no_extra():
    code = (
        "import sys, attribot.server, attribot.models.remote, attribot.models.wire;"
        "from attribot.models.base import DETECTORS; DETECTORS.names();"
        "loaded = {'fastapi', 'uvicorn', 'httpx', 'starlette', 'torch'} & set(sys.modules);"
        "assert not loaded, loaded"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)


def test_server_down_is_a_clear_error_after_retries():
    client = RemoteClient(f"http://127.0.0.1:{free_port()}", backoff_s=0.01, max_tries=3)
    t0 = time.perf_counter()
    with pytest.raises(BackendError, match=r"cannot reach the model server at .* after 3 tries") as exc:
        RemoteDetector(client).detect(frame(), ["x"])
    assert "ssh -N -L 8500:127.0.0.1:8500" in str(exc.value)
    assert time.perf_counter() - t0 < 5


# ---- retries against a misbehaving server -------------------------------------------------------------


def _sequence(*responses: Response):
    """A handler that answers with `responses` in turn (the last one repeats) and counts the calls."""
    calls: list[float] = []

    def handler(request: Request) -> Response:
        calls.append(time.perf_counter())
        return responses[min(len(calls), len(responses)) - 1]

    return handler, calls


def _json(status: int, body: dict, headers: dict | None = None) -> Response:
    import json

    return Response(json.dumps(body), status=status, content_type="application/json", headers=headers)


def test_retries_5xx_and_429_with_backoff_then_succeeds(http):
    overloaded = {"error": {"category": "overloaded", "message": "queue full"}}
    handler, calls = _sequence(
        _json(503, {"error": {"category": "internal", "message": "warming up"}}),
        _json(429, overloaded, {"Retry-After": "0"}),
        _json(200, DETECT_OK),
    )
    http.expect_request("/v1/detect", method="POST").respond_with_handler(handler)
    client = RemoteClient(http.url_for("/"), backoff_s=0.05, max_tries=3)
    (d,) = RemoteDetector(client).detect(frame(), ["cup"])
    assert d.label == "cup" and len(calls) == 3
    gaps = np.diff(calls)
    assert gaps[0] >= 0.05 and gaps[1] >= 0.1  # exponential back-off: 0.05 s, then 0.1 s
    body = http.log[0][0].get_json()
    assert set(body) == {"image", "queries"} and decode_image(body["image"]).shape == (30, 40, 3)


def test_persistent_5xx_gives_the_servers_message(http):
    handler, calls = _sequence(
        _json(500, {"error": {"category": "backend", "message": "model exploded", "fix": "see the log"}})
    )
    http.expect_request("/v1/answer", method="POST").respond_with_handler(handler)
    with pytest.raises(BackendError, match="failed after 2 tries: model exploded"):
        RemoteVisualQA(RemoteClient(http.url_for("/") + "?tries=2", backoff_s=0.01)).answer(frame(), "q")
    assert len(calls) == 2


def test_4xx_is_not_retried(http):
    handler, calls = _sequence(
        _json(400, {"error": {"category": "input", "message": "the image is corrupt"}})
    )
    http.expect_request("/v1/answer", method="POST").respond_with_handler(handler)
    with pytest.raises(InputError, match="refused the request: the image is corrupt"):
        RemoteVisualQA(RemoteClient(http.url_for("/"), backoff_s=0.01)).answer(frame(), "q")
    assert len(calls) == 1


def test_slow_server_times_out_without_retry(http):
    def slow(request: Request) -> Response:
        time.sleep(1.0)
        return _json(200, DETECT_OK)

    http.expect_request("/v1/detect", method="POST").respond_with_handler(slow)
    client = RemoteClient(http.url_for("/"), timeout_s=0.3)
    with pytest.raises(BackendError, match=r"no answer within 0.3 s") as exc:
        RemoteDetector(client).detect(frame(), ["x"])
    assert "ATTRIBOT_REMOTE_TIMEOUT_S" in str(exc.value)
    assert len(http.log) <= 1


@pytest.mark.parametrize(
    ("status", "body", "message"),
    [
        (200, {"detections": "many"}, "not a DetectResponse"),
        (404, {"detail": "Not Found"}, "no attribot error record"),
        (200, {"answer": "x"}, "not a DetectResponse"),
    ],
)
def test_garbage_answers_are_backend_errors(http, status, body, message):
    http.expect_request("/v1/detect", method="POST").respond_with_json(body, status=status)
    with pytest.raises(BackendError, match=message):
        RemoteDetector(RemoteClient(http.url_for("/"))).detect(frame(), ["x"])
