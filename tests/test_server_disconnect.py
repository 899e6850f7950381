"""A client that goes away is counted as gone (not as a backend error), and its queued work is dropped."""

from __future__ import annotations

import socket
import threading

import httpx
import numpy as np

from attribot.models.base import Detection
from attribot.models.wire import encode_image
from attribot.server import ServerConfig, ServerThread, create_app
from conftest import wait_for


class GatedDetector:
    """Answers only when `gate` is set; records the queries of every frame it was given."""

    name = "test:gated"

    def __init__(self) -> None:
        self.gate = threading.Event()
        self.seen: list[str] = []

    def detect(self, frame, queries):
        self.gate.wait(30)
        self.seen.append(queries[0])
        return [Detection(box=(0.0, 0.0, 1.0, 1.0), score=0.5, label=queries[0])]


def _metrics(url: str) -> dict:
    return httpx.get(url + "/metrics").json()["roles"]["detector"]


def test_disconnect_mid_body_is_counted_as_gone():
    detector = GatedDetector()
    detector.gate.set()
    with ServerThread(create_app(detector=detector, config=ServerConfig(max_batch=1))) as srv:
        with socket.create_connection(("127.0.0.1", srv.port)) as s:
            s.sendall(
                b"POST /v1/detect HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                b"Content-Length: 100000\r\n\r\n" + b'{"image": "' + b"A" * 1000
            )
        assert wait_for(lambda: _metrics(srv.url)["errors"].get("disconnected") == 1)
        assert "backend" not in _metrics(srv.url)["errors"]


def test_work_of_a_client_that_left_is_dropped():
    """Two requests wait behind a stuck batch; the client of one leaves: only the other is computed."""
    detector = GatedDetector()
    image = encode_image(np.zeros((8, 8, 3), np.uint8), "png")
    with ServerThread(create_app(detector=detector, config=ServerConfig(max_batch=1))) as srv:

        def post(query: str, timeout: float) -> None:
            try:
                httpx.post(srv.url + "/v1/detect", json={"image": image, "queries": [query]}, timeout=timeout)
            except httpx.HTTPError:
                pass

        first = threading.Thread(target=post, args=("first", 30))
        first.start()
        assert wait_for(lambda: _metrics(srv.url)["requests"] == 1)
        post("leaves", 0.5)  # queued behind "first", then its client times out and closes
        stays = threading.Thread(target=post, args=("stays", 30))
        stays.start()
        assert wait_for(lambda: _metrics(srv.url)["errors"].get("disconnected") == 1)
        detector.gate.set()
        first.join(30)
        stays.join(30)
        assert detector.seen == ["first", "stays"]
        assert _metrics(srv.url)["ok"] == 2
