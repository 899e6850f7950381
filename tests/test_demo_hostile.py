"""The live demo against a hostile web (issue 28): DNS rebinding and other sites' posts, tokens and secrets,
bounded queues, uploads and streams, events encoded once, no server path shown, bad bodies, a clean stop.
Every server here is real (uvicorn on 127.0.0.1, or `attribot demo` in its own process)."""

from __future__ import annotations

import base64
import io
import json
import os
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path

import httpx
import pytest
from PIL import Image

from attribot.config import load_settings
from attribot.demo import DemoConfig, create_app, serve_demo
from attribot.demo.app import SECRET_HEADER
from attribot.errors import ConfigError
from attribot.server.run import ServerThread
from conftest import EMPTY_SETTINGS, alive, free_port, wait_for
from test_demo import _client, _events

QUERY = {"query": "Which object is the closest?", "seed": "0"}


def _app(tmp_path: Path, **fields: object) -> object:
    return create_app(DemoConfig(settings=load_settings(), runs_dir=tmp_path / "runs", **fields))  # type: ignore[arg-type]


@pytest.fixture
def demo(tmp_path):
    with ServerThread(_app(tmp_path)) as server:
        yield server


def _png(width: int, height: int) -> str:
    buf = io.BytesIO()
    Image.new("RGB", (width, height), (90, 120, 160)).save(buf, format="PNG")
    return base64.b64encode(buf.getvalue()).decode()


def _folders(tmp_path: Path) -> list[Path]:
    runs = tmp_path / "runs"
    return sorted(p for p in runs.iterdir()) if runs.is_dir() else []


# ---- DNS rebinding and other sites -------------------------------------------------------------------


@pytest.mark.parametrize("path", ["/", "/api/options", "/api/runs/0001-x/events", "/api/runs/0001-x/run.zip"])
def test_a_request_naming_another_host_is_refused_dns_rebinding(demo, path):
    # issue 28: no Host check: a site whose name was rebound to 127.0.0.1 could start a query, read its
    # events and download its zip
    client = _client(demo)
    reply = client.get(path, headers={"Host": f"attacker.example:{demo.port}"})
    assert reply.status_code == 400 and "does not answer to the host" in reply.json()["message"]
    assert "set-cookie" not in reply.headers
    started = client.post("/api/runs", json=QUERY, headers={"Host": "attacker.example"})
    assert started.status_code == 400
    for host in (f"127.0.0.1:{demo.port}", f"localhost:{demo.port}", "LOCALHOST", f"[::1]:{demo.port}"):
        assert client.get("/api/options", headers={"Host": host}).status_code == 200, host


def test_a_name_given_with_allow_host_is_answered(tmp_path):
    with ServerThread(_app(tmp_path, hosts=("lab-pc.local",))) as server:
        assert httpx.get(server.url + "/", headers={"Host": "lab-pc.local:8600"}).status_code == 200
        assert httpx.get(server.url + "/", headers={"Host": "other.local"}).status_code == 400


@pytest.mark.parametrize(
    "headers",
    [
        {"Origin": "http://attacker.example"},
        {"Origin": "null"},  # a sandboxed frame, a file: page
        {"Origin": "http://127.0.0.1:1"},  # another port of this machine is another site
        {"Sec-Fetch-Site": "cross-site"},
        {"Sec-Fetch-Site": "same-site"},
    ],
    ids=["other-site", "null", "other-port", "cross-site", "same-site"],
)
def test_a_post_from_another_site_starts_nothing_even_with_the_secret(demo, tmp_path, headers):
    client = _client(demo)
    reply = client.post("/api/runs", json=QUERY, headers=headers)
    assert reply.status_code == 403 and "another site" in reply.json()["message"]
    assert _folders(tmp_path) == []


def test_a_post_from_the_demos_own_page_starts_its_query(demo):
    client = _client(demo)
    same = client.post("/api/runs", json=QUERY, headers={"Origin": demo.url, "Sec-Fetch-Site": "same-origin"})
    assert same.status_code == 200, same.text


@pytest.mark.parametrize(
    "content_type, body",
    [
        ("text/plain", json.dumps(QUERY)),  # what a form or a no-cors fetch of another site can send
        ("application/x-www-form-urlencoded", "query=Which+object+is+the+closest%3F"),
        (
            "multipart/form-data; boundary=x",
            "--x\r\nContent-Disposition: form-data; name=query\r\n\r\nq\r\n--x--",
        ),
        ("application/json-patch+json", json.dumps(QUERY)),
        (None, json.dumps(QUERY)),
    ],
    ids=["text-plain", "form", "multipart", "json-lookalike", "untyped"],
)
def test_only_a_json_post_with_the_pages_secret_starts_a_query(demo, tmp_path, content_type, body):
    # issue 28: a text/plain or form POST from another origin started a query (CSRF)
    client = _client(demo)
    headers = {"Content-Type": content_type} if content_type else {}
    reply = client.post("/api/runs", content=body.encode(), headers=headers)
    assert reply.status_code == 415 and "not JSON" in reply.json()["message"]
    plain = httpx.Client(base_url=demo.url, cookies=client.cookies)  # the cookie alone, no secret
    reply = plain.post("/api/runs", json=QUERY)
    assert reply.status_code == 403 and "secret" in reply.json()["message"]
    assert _folders(tmp_path) == []


def test_a_secret_belongs_to_one_visitor_and_one_server(tmp_path):
    with ServerThread(_app(tmp_path)) as server:
        first, second = _client(server), _client(server)
        stolen = first.headers[SECRET_HEADER]
        reply = second.post("/api/runs", json=QUERY, headers={SECRET_HEADER: stolen})
        assert reply.status_code == 403  # another visitor's secret is no secret of this one
        cookies = dict(first.cookies)
    with ServerThread(_app(tmp_path)) as again:  # the demo started again: old secrets are void
        replayed = httpx.post(
            again.url + "/api/runs", json=QUERY, cookies=cookies, headers={SECRET_HEADER: stolen}
        )
        assert replayed.status_code == 403


@pytest.mark.parametrize("cookie", ["x" * 4000, "../../etc", "0" * 31, "G" * 32, "\u00e9" * 32])
def test_a_visitor_cookie_the_demo_did_not_give_is_no_visitor(demo, cookie):
    client = httpx.Client(base_url=demo.url)
    raw = {"Cookie": b"attribot_demo_visitor=" + cookie.encode(), SECRET_HEADER: "0" * 64}
    reply = client.post("/api/runs", json=QUERY, headers=raw)
    assert reply.status_code == 400 and "visitor cookie" in reply.json()["message"]
    page = client.get("/", headers={"Cookie": raw["Cookie"]})  # the page gives a fresh one
    assert page.status_code == 200 and "attribot_demo_visitor=" in page.headers.get("set-cookie", "")


def test_every_answer_forbids_framing_sniffing_and_referrers(demo):
    client = _client(demo)
    for path in ("/", "/api/options", "/static/app.js", "/api/runs/none/events"):
        headers = client.get(path).headers
        assert headers["x-frame-options"] == "DENY" and headers["x-content-type-options"] == "nosniff"
        assert "frame-ancestors 'none'" in headers["content-security-policy"]
        assert headers["referrer-policy"] == "no-referrer"


# ---- tokens ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("token", ["   ", "\t\n", " ", "short", "a", "password", "passwordpassword1"])
def test_a_blank_or_short_token_is_refused_beyond_this_machine(tmp_path, token):
    # issue 28: a whitespace-only --token was accepted for binding beyond 127.0.0.1
    config = DemoConfig(settings=load_settings(), runs_dir=tmp_path, token=token)
    with socket.socket() as taken:  # were the token taken, the port in use would end the call at once
        taken.bind(("0.0.0.0", 0))
        taken.listen()
        with pytest.raises(ConfigError, match="blank|at least 16|'password'") as refused:
            serve_demo(config, host="0.0.0.0", port=taken.getsockname()[1])
    assert "--token" in (refused.value.fix or "")


def test_the_command_refuses_a_blank_token_with_error_and_fix():
    env = {**os.environ, "ATTRIBOT_CONFIG": str(EMPTY_SETTINGS)}
    done = subprocess.run(
        [sys.executable, "-m", "attribot.cli", "demo", "--host", "0.0.0.0", "--port", str(free_port()),
         "--token", "   "],
        capture_output=True, text=True, env=env, timeout=120,
    )  # fmt: skip
    assert done.returncode == 2 and "error: the demo's --token is blank" in done.stderr
    assert "fix:" in done.stderr


def test_wrong_tokens_from_one_address_are_slowed_then_blocked(tmp_path, monkeypatch):
    # issue 49: the demo answered about 1,300 wrong tokens a second without throttling
    import functools
    import time

    import attribot.demo.app as demo_app

    slowed = functools.partial(demo_app.WrongTokens, free=2, block_after=5, max_delay_s=0.05)
    monkeypatch.setattr(demo_app, "WrongTokens", slowed)
    token = "correct-horse-battery-9"
    with ServerThread(_app(tmp_path, token=token)) as server:
        plain = httpx.Client(base_url=server.url)
        statuses, waits = [], []
        for i in range(8):
            began = time.monotonic()
            statuses.append(plain.get(f"/api/options?token=guess{i}").status_code)
            waits.append(time.monotonic() - began)
        assert statuses == [401] * 5 + [429] * 3 and min(waits[2:5]) >= 0.04
        assert plain.get("/?token=" + token).status_code == 429  # blocked, even with the right one


def test_the_token_is_checked_on_every_route_and_never_kept_as_it_is(tmp_path):
    token = "correct-horse-battery"
    with ServerThread(_app(tmp_path, token=token)) as server:
        plain = httpx.Client(base_url=server.url)
        for path in ("/", "/api/options", "/static/app.js", "/api/runs/x/events"):
            assert plain.get(path).status_code == 401, path
        assert plain.get("/", headers={"Authorization": "Bearer wrong"}).status_code == 401
        assert plain.get("/?token=" + token.upper()).status_code == 401
        assert plain.get("/?token=%E9%00").status_code == 401  # not even text: refused, not a crash
        raw = httpx.Client(base_url=server.url, cookies={"attribot_demo_token": token})
        assert raw.get("/").status_code == 401  # the cookie holds a value derived from the token
        entered = plain.get("/?token=" + token)
        assert entered.status_code == 303 and token not in entered.headers["set-cookie"]
        assert (
            "HttpOnly" in entered.headers["set-cookie"]
            and "samesite=strict" in entered.headers["set-cookie"].lower()
        )
        assert plain.get("/").status_code == 200


# ---- bounds: queues, uploads, bodies, streams ------------------------------------------------------------


def test_queued_queries_are_bounded_whatever_the_number_of_cookies(demo, tmp_path):
    # issue 28: 40 cookies queued 40 runs
    from attribot.demo.runs import MAX_WAITING

    replies = [_client(demo).post("/api/runs", json=QUERY) for _ in range(12)]
    started = [r for r in replies if r.status_code == 200]
    refused = [r for r in replies if r.status_code == 503]
    assert len(started) == MAX_WAITING + 1 and len(refused) == 12 - len(started)
    assert all("queries are waiting" in r.json()["message"] and r.headers["retry-after"] for r in refused)
    assert len(_folders(tmp_path)) == len(started)  # a refused query wrote nothing


_UPLOADS = {
    "pixel-bomb": (
        lambda: {"name": "bomb.png", "data": _png(6000, 6000)},
        413,
        "megapixels",
    ),  # 36 MP, 100 kB
    "gif": (
        lambda: {"name": "a.png", "data": base64.b64encode(b"GIF89a" + b"\0" * 100).decode()},
        400,
        "PNG",
    ),
    "script": (
        lambda: {"name": "a.png", "data": base64.b64encode(b"#!/bin/sh\nrm -rf /\n").decode()},
        400,
        "PNG",
    ),
    "truncated": (lambda: {"name": "a.png", "data": _png(64, 48)[:120]}, 400, "corrupt"),
    "bad-name-and-data": (lambda: {"name": "../../etc/passwd", "data": "%%%"}, 400, "base64"),
    "no-data": (lambda: {"name": "a.png"}, 400, "image"),
    "text-chunk-bomb": (lambda: {"name": "a.png", "data": _text_bomb()}, 413, "inflates too far"),
    "number": (lambda: {"name": "a.png", "data": 12}, 400, "image"),
}


def _text_bomb() -> str:
    """A small PNG whose compressed text chunk inflates to 50 MB (issue 49: HTTP 500)."""
    import struct
    import zlib

    raw = base64.b64decode(_png(8, 8))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    bomb = chunk(b"zTXt", b"Comment\x00\x00" + zlib.compress(b"a" * (50 << 20), 9))
    return base64.b64encode(raw[:33] + bomb + raw[33:]).decode()


@pytest.mark.parametrize("kind", list(_UPLOADS))
def test_an_upload_is_checked_before_anything_is_written(demo, tmp_path, kind):
    # issue 28: uploads were written before any check
    make, status, words = _UPLOADS[kind]
    reply = _client(demo).post("/api/runs", json={"query": "Which object is red?", "image": make()})
    assert reply.status_code == status and words in reply.json()["message"], reply.text
    assert reply.json()["fix"]
    assert _folders(tmp_path) == []


def test_an_upload_is_removed_once_its_query_has_run_and_old_runs_are_forgotten(tmp_path, monkeypatch):
    import attribot.demo.runs as runs

    monkeypatch.setattr(runs, "KEPT_RUNS", 2)
    with ServerThread(_app(tmp_path)) as server:
        client = _client(server)
        ids = []
        for _ in range(3):  # an image without a real detector: answered at once with an error
            started = client.post("/api/runs", json={"query": "the red one", "image": {"data": _png(32, 24)}})
            assert started.status_code == 200, started.text
            events = _events(client, started.json()["events"])
            assert any(e["type"] == "error" for e in events)
            ids.append(started.json()["id"])
        left = [p.name for p in _folders(tmp_path)]
        assert ids[0] not in left and ids[1:] == left  # the forgotten run's folder is gone
        assert not list((tmp_path / "runs").rglob("upload*"))  # no upload outlives its query
        assert client.get(f"/api/runs/{ids[0]}/run.zip").status_code == 404


def test_a_nearly_full_disk_refuses_new_runs_and_serves_the_rest(tmp_path):
    # issue 28: a full disk broke every visitor
    with ServerThread(_app(tmp_path, min_free_bytes=1 << 62)) as server:
        client = _client(server)
        reply = client.post("/api/runs", json=QUERY)
        assert reply.status_code == 507 and "disk is nearly full" in reply.json()["message"]
        assert reply.json()["fix"] and client.get("/api/options").status_code == 200
        assert _folders(tmp_path) == []


@pytest.mark.parametrize(
    "body, words",
    [
        (b'{"query": "a", "seed": ' + b"[" * 100_000 + b"]" * 100_000 + b"}", "recursion"),
        (b'{"query": "a", "x": ' + b'{"a":' * 5000 + b"1" + b"}" * 5000 + b"}", "recursion"),
        (b'{"query": "Which is heaviest?", "seed": 1' + b"0" * 5000 + b"}", "number"),
        (b'{"query": 5}', "query"),
        (b'{"query": "a", "seed": [1]}', "seed"),
        (b'{"query": "a", "options": {"pattern": "grid"}}', "options"),
        (b"[1, 2]", "object"),
        (b"not json", "JSON"),
        (b'{"query": "\\ud800"}', "JSON"),
        (b'{"query": "Which object\\u001b[2J is red?"}', "control"),
        (b'{"query": "' + b"heavy " * 200 + b'"}', "characters long"),
        (b'{"query": "Which is heaviest?", "seed": "' + b"9" * 5000 + b'"}', "whole number"),
    ],
    ids=["deep-array", "deep-object", "huge-number", "number-query", "list-seed", "object-options",
         "array", "not-json", "surrogate", "escape-codes", "long-query", "long-seed"],
)  # fmt: skip
def test_a_malformed_body_is_a_400_that_names_the_field_never_a_500(demo, tmp_path, body, words):
    # issue 28: a deeply nested JSON body gave HTTP 500 with a traceback
    reply = _client(demo).post("/api/runs", content=body, headers={"Content-Type": "application/json"})
    assert reply.status_code == 400, reply.text
    assert words.lower() in reply.json()["message"].lower() and reply.json()["fix"]
    assert _folders(tmp_path) == []


def test_an_oversized_or_trickled_body_is_refused(demo, tmp_path, monkeypatch):
    import attribot.demo.app as app

    client = _client(demo)
    huge = b'{"query": "a", "x": "' + b"y" * (15 << 20) + b'"}'
    reply = client.post("/api/runs", content=huge, headers={"Content-Type": "application/json"})
    assert reply.status_code == 413
    monkeypatch.setattr(app, "BODY_TIMEOUT_S", 1.0)
    with socket.create_connection(("127.0.0.1", demo.port)) as slow:
        cookie = "; ".join(f"{k}={v}" for k, v in client.cookies.items())
        secret = client.headers[SECRET_HEADER]
        slow.sendall(
            (
                f"POST /api/runs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
                f"Content-Length: 1000\r\nCookie: {cookie}\r\n{SECRET_HEADER}: {secret}"
                "\r\n\r\n{"
            ).encode()
        )
        slow.settimeout(30)
        assert b" 408 " in slow.recv(4096).split(b"\r\n")[0]
    assert _folders(tmp_path) == []


def test_streams_of_one_query_are_bounded(demo):
    from contextlib import ExitStack

    client = _client(demo)
    started = client.post("/api/runs", json=QUERY).json()
    with ExitStack() as pages:
        for _ in range(4):
            page = pages.enter_context(client.stream("GET", started["events"], timeout=60))
            assert page.status_code == 200
        extra = client.get(started["events"])
        assert extra.status_code == 503 and "followed by 4 pages" in extra.json()["message"]
    assert _client(demo).get("/api/runs/none/events").status_code == 404


@pytest.mark.parametrize(
    "path",
    [
        "/api/runs/{id}/..%2f..%2f..%2fetc%2fpasswd",
        "/api/runs/{id}/program.py",
        "/api/runs/{id}/answer.json",
        "/api/runs/{id}/%2e%2e",
        "/api/runs/..%2f{id}/run.zip",
        "/api/runs/{id}/run.zip%00.png",
        "/static/..%2f..%2fapp.py",
        "/static/%2e%2e/%2e%2e/app.py",
    ],
)
def test_path_tricks_reach_no_file_beyond_the_three_served(tmp_path, path):
    with ServerThread(_app(tmp_path)) as server:
        client = _client(server)
        started = client.post(
            "/api/runs", json={"query": "the red one", "image": {"data": _png(32, 24)}}
        ).json()
        _events(client, started["events"])
        reply = client.get(path.format(id=started["id"]))
        assert reply.status_code in (404, 400, 405), reply.status_code
        assert b"def " not in reply.content and b"root:" not in reply.content


# ---- events: encoded once, no server paths -------------------------------------------------------------


def test_each_frame_is_encoded_once_whatever_the_number_of_pages(demo, monkeypatch):
    # issue 28: each event stream encoded its own frames (60 streams took a 7 s query to 26 s)
    import attribot.demo.runs as runs

    encoded, produced = [], []
    real, real_sse = runs._jpeg, runs._sse
    monkeypatch.setattr(runs, "_jpeg", lambda rgb, quality=80: encoded.append(1) or real(rgb, quality))
    # the frames the run made, seen by a page or not: a page shown only the newest frame skips the others
    monkeypatch.setattr(
        runs, "_sse", lambda kind, text: (kind == "frame" and produced.append(text)) or real_sse(kind, text)
    )
    client = _client(demo)
    started = client.post("/api/runs", json=QUERY).json()
    results: list[list[dict]] = [[] for _ in range(4)]

    def follow(i: int) -> None:
        results[i] = _events(client, started["events"])

    threads = [threading.Thread(target=follow, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(300)
    frames = [[(e["robot"], e["room"]) for e in events if e["type"] == "frame"] for events in results]
    assert all(events[-1]["type"] == "done" for events in results)
    assert all(frames), "every page saw the cameras"
    assert {f for page in frames for f in page} <= {
        (e["robot"], e["room"]) for e in map(json.loads, produced)
    }
    assert len(encoded) <= 2 * len(set(produced)) + 2  # two views a frame, each encoded once for all pages
    # and the other events are the same text for every page
    assert all(
        [e for e in r if e["type"] != "frame"] == [e for e in results[0] if e["type"] != "frame"]
        for r in results
    )


def test_events_name_no_path_of_the_server(tmp_path):
    # issue 28: error events showed the server's absolute paths
    settings = load_settings(detector=f"hf:{tmp_path / 'models' / 'owl'}")
    app = create_app(DemoConfig(settings=settings, runs_dir=tmp_path / "runs"))
    with ServerThread(app) as server:
        client = _client(server)
        options = client.get("/api/options").text
        started = client.post("/api/runs", json={"query": "the red one", "image": {"data": _png(32, 24)}})
        text = json.dumps(_events(client, started.json()["events"]))
    error = next(e for e in json.loads(text) if e["type"] == "error")
    assert "owl" in error["message"]  # the error still says what is missing
    for secret in (str(tmp_path), str(tmp_path.resolve()), "/tmp/", str(Path.home()) + "/"):
        assert secret not in text and secret not in options, secret


# ---- a clean stop ----------------------------------------------------------------------------------------


def _children(pid: int) -> set[int]:
    try:
        return {int(p) for p in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()}
    except OSError:
        return set()


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_during_a_query_stops_the_demo_cleanly(tmp_path, sig):
    # issue 28: SIGTERM or SIGINT during a query often ended the process with SIGSEGV (a thread still
    # rendering with MuJoCo's EGL context while the interpreter tore down)
    port = free_port()
    env = {**os.environ, "ATTRIBOT_CONFIG": str(EMPTY_SETTINGS), "TMPDIR": str(tmp_path)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "attribot.cli", "demo", "--port", str(port)],
        stderr=subprocess.PIPE, text=True, env=env,
        preexec_fn=lambda: signal.signal(sig, signal.SIG_DFL),  # as in a terminal
    )  # fmt: skip
    seen: set[int] = set()
    try:
        url = f"http://127.0.0.1:{port}"
        assert wait_for(lambda: _reachable(url), 120), "the demo did not start"
        if sig == signal.SIGTERM:  # slowloris: connections that never finish their headers are cut
            slow = [socket.create_connection(("127.0.0.1", port)) for _ in range(3)]
            for s in slow:
                s.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-a: ")
                s.settimeout(30)
            assert all(s.recv(1) == b"" for s in slow)  # closed within the header deadline
        client = httpx.Client(base_url=url, timeout=60)
        secret = client.get("/").text.split('name="attribot-secret" content="')[1].split('"')[0]
        started = client.post("/api/runs", json=QUERY, headers={SECRET_HEADER: secret}).json()
        events: list[dict] = []
        with client.stream("GET", started["events"], timeout=120) as reply:
            for line in reply.iter_lines():
                seen.update(_children(proc.pid))
                if line.startswith("data: "):
                    events.append(json.loads(line[6:]))
                    if events[-1]["type"] == "frame" and not any(e["type"] == "signalled" for e in events):
                        proc.send_signal(sig)  # mid-query: the robot is moving
                        events.append({"type": "signalled"})
        assert proc.wait(timeout=60) == 128 + sig
        stderr = proc.stderr.read() if proc.stderr else ""
        assert "Traceback" not in stderr and "Segmentation" not in stderr, stderr[-3000:]
        error = next(e for e in events if e["type"] == "error")
        assert error["message"] == "the demo stopped while this query ran"
        assert events[-1]["type"] == "done"
        assert wait_for(lambda: not any(alive(p) for p in seen), 5), "a process outlived the demo"
        assert not list(tmp_path.glob("attribot-demo-*")), "the scratch folder outlived the demo"
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        for p in seen:
            if alive(p):
                os.kill(p, signal.SIGKILL)


def _reachable(url: str) -> bool:
    try:
        return httpx.get(url + "/api/options", timeout=2).status_code == 200
    except httpx.HTTPError:
        return False


def test_a_camera_jpeg_in_mpo_layout_is_taken_as_ask_image_takes_it(demo):
    # issue 49: a camera's JPEG with a second picture after the first (MPO) was refused
    buf = io.BytesIO()
    picture = Image.new("RGB", (64, 48), (200, 30, 30))
    picture.save(buf, format="MPO", save_all=True, append_images=[picture])
    image = {"name": "camera.jpg", "data": base64.b64encode(buf.getvalue()).decode()}
    reply = _client(demo).post("/api/runs", json={"query": "Which object is red?", "image": image})
    assert reply.status_code == 200, reply.text


def _partial_upload(server_url: str, client: httpx.Client) -> socket.socket:
    """A connection that starts a query's upload of 1 MB, sends 64 kB of it and waits."""
    from urllib.parse import urlsplit

    where = urlsplit(server_url)
    cookies = "; ".join(f"{k}={v}" for k, v in client.cookies.items())
    head = (
        f"POST /api/runs HTTP/1.1\r\nHost: {where.hostname}:{where.port}\r\n"
        f"Content-Type: application/json\r\nContent-Length: {1 << 20}\r\nCookie: {cookies}\r\n"
        f"{SECRET_HEADER}: {client.headers[SECRET_HEADER]}\r\n\r\n"
    )
    sock = socket.create_connection((where.hostname, where.port))
    sock.sendall(head.encode() + b'{"query": "Which object is red?", "image": {"data": "' + b"A" * 65536)
    return sock


def test_a_client_dropping_mid_upload_leaves_no_traceback(demo, caplog):
    # issue 49: each client that dropped mid-upload left a traceback in the log
    import logging
    import time

    client = _client(demo)
    with caplog.at_level(logging.INFO):
        for _ in range(3):
            _partial_upload(demo.url, client).close()
        time.sleep(1.0)
        assert client.get("/api/options").status_code == 200  # and the demo serves on
    said = [r for r in caplog.records if r.exc_info or "Exception in ASGI" in r.getMessage()]
    assert said == [], [r.getMessage() for r in said]


def test_uploads_in_flight_are_bounded_and_the_rest_wait_then_are_told(demo, monkeypatch):
    # issue 49: 16 uploads in flight grew the process by about 600 MB
    import attribot.demo.app as demo_app

    monkeypatch.setattr(demo_app, "UPLOAD_WAIT_S", 0.5)
    client = _client(demo)
    held = [_partial_upload(demo.url, client) for _ in range(demo_app.MAX_UPLOADS_IN_FLIGHT)]
    try:
        import time

        time.sleep(0.5)
        reply = _client(demo).post("/api/runs", json={"query": "Which object is red?", "seed": "x"})
        assert reply.status_code == 503 and "being uploaded" in reply.json()["message"]
        assert reply.headers["retry-after"]
    finally:
        for sock in held:
            sock.close()
    time.sleep(0.5)
    again = _client(demo).post("/api/runs", json={"query": "Which object is red?", "seed": "x"})
    assert again.status_code == 400 and "seed" in again.json()["message"]  # a slot again: read and answered
