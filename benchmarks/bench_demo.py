#!/usr/bin/env python3
"""The live demo (`attribot demo`) on a real local server, as ratios measured in the same run.

1. Fan-out: one query followed by N pages at once (its event stream opened N times). For each N: the
   query's wall time and the events (frames, calls, statuses...) each page receives per second, each
   against the same query followed by one page. Encoding every event once and fanning it out keeps both
   ratios near 1 as N grows; each page encoding its own frames made the query slower with every page.
2. The page and the API's round trip: `GET /`, `GET /api/options` and a `POST /api/runs` that is refused
   (an empty query: the whole guard and parse, no run), each against a bare endpoint served by the same
   uvicorn in the same process (what every request costs anyway).

    .venv/bin/python benchmarks/bench_demo.py [--viewers 1,10,30,60] [--requests 200]
"""

from __future__ import annotations

import argparse
import dataclasses
import re
import resource
import statistics
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import httpx

from attribot.config import load_settings
from attribot.demo import DemoConfig, create_app
from attribot.server.run import ServerThread

QUERY = {"query": "Which object is the closest?", "layout": "household", "seed": "7"}
SECRET_HEADER = "X-Attribot-Secret"


def _config(runs_dir: Path, viewers: int) -> DemoConfig:
    fields = {f.name for f in dataclasses.fields(DemoConfig)}
    extra = {"max_streams_per_run": viewers} if "max_streams_per_run" in fields else {}
    return DemoConfig(settings=load_settings(), runs_dir=runs_dir, **extra)  # type: ignore[arg-type]


def _client(url: str) -> httpx.Client:
    client = httpx.Client(base_url=url, timeout=600)
    page = client.get("/")
    secret = re.search(r'<meta name="attribot-secret" content="([0-9a-f]+)">', page.text)
    if secret is not None:
        client.headers[SECRET_HEADER] = secret.group(1)
    return client


def _follow(client: httpx.Client, url: str, out: list[tuple[int, int, float]], i: int) -> None:
    """Read the event stream to its end: (events, frames, seconds until its last event)."""
    t0 = time.perf_counter()
    events = frames = 0
    with client.stream("GET", url) as reply:
        for line in reply.iter_lines():
            if line.startswith("event: "):
                events += 1
                frames += line == "event: frame"
    out[i] = (events, frames, time.perf_counter() - t0)


def fan_out(viewers: list[int]) -> None:
    rows = []
    for n in [1, *viewers]:  # the first query pays the imports and the caches: measured, not shown
        with tempfile.TemporaryDirectory() as tmp, ServerThread(create_app(_config(Path(tmp), n))) as server:
            client = _client(server.url)
            rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
            t0 = time.perf_counter()
            started = client.post("/api/runs", json=QUERY)
            started.raise_for_status()
            results: list[Any] = [None] * n
            threads = [
                threading.Thread(target=_follow, args=(client, started.json()["events"], results, i))
                for i in range(n)
            ]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
            wall = time.perf_counter() - t0
            rss = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0) / 1024
            rate = statistics.mean(e / s for e, _, s in results)
            frames = statistics.mean(f for _, f, _ in results)
            rows.append((n, wall, rate, frames, rss))
    rows = rows[1:]
    _, wall1, rate1, _, _ = rows[0]
    for n, wall, rate, frames, rss in rows:
        print(
            f"{n:3d} pages: query {wall:5.1f} s (x{wall / wall1:.2f} of 1 page); "
            f"{rate:6.1f} events/s per page (x{rate / rate1:.2f}), {frames:.0f} frames per page; "
            f"peak memory +{rss:.0f} MB"
        )


def _median_ms(call: Any, n: int) -> float:
    times = []
    for _ in range(n):
        t = time.perf_counter()
        call()
        times.append(time.perf_counter() - t)
    return statistics.median(times) * 1000


def round_trips(requests: int) -> None:
    from starlette.applications import Starlette
    from starlette.responses import PlainTextResponse
    from starlette.routing import Route

    bare = Starlette(routes=[Route("/", lambda request: PlainTextResponse("ok"))])
    with tempfile.TemporaryDirectory() as tmp, ServerThread(create_app(_config(Path(tmp), 4))) as demo:
        with ServerThread(bare) as reference:
            ref_client = httpx.Client(base_url=reference.url)
            client = _client(demo.url)
            ref = _median_ms(lambda: ref_client.get("/"), requests)
            page = _median_ms(lambda: client.get("/"), requests)
            options = _median_ms(lambda: client.get("/api/options"), requests)
            refused = _median_ms(lambda: client.post("/api/runs", json={"query": " "}), requests)
    for what, ms in (("GET /", page), ("GET /api/options", options), ("POST /api/runs (refused)", refused)):
        print(
            f"{what}: {ms:.2f} ms median over {requests} (x{ms / ref:.2f} of a bare endpoint, {ref:.2f} ms)"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--viewers", default="1,10,30,60")
    parser.add_argument("--requests", type=int, default=200)
    args = parser.parse_args()
    round_trips(args.requests)
    fan_out([int(v) for v in args.viewers.split(",")])


if __name__ == "__main__":
    main()
