#!/usr/bin/env python3
"""The model server's cost per request and its batching gain, measured against references of the same run.

  PYTHONPATH=src python3 benchmarks/bench_server.py
      CPU. The backend is a stand-in whose cost is a fixed per-call overhead (sleeping --call-ms, like a
      GPU kernel launch and sync, plus --item-ms per image), so that batching has something to win.
  PYTHONPATH=src python3 benchmarks/bench_server.py --backend random:owlv2-b16 --device cuda --dtype float16
      GPU. A real-size transformers model with random weights (attribot.models.hf_random: owlv2-b16,
      owlv2-l14, grounding-dino-t, blip2-opt-2.7b; no download), served by the real `hf` backend code.
  PYTHONPATH=src python3 benchmarks/bench_server.py --backend hf:/path/to/model --device cuda
      GPU, a model from a local folder (or a hub id already in the cache).
  PYTHONPATH=src python3 benchmarks/bench_server.py --backend random:owlv2-tiny --quick
      The GPU path with a tiny model on the CPU: a check that it runs, not a measurement.

The server runs in a separate process (its own interpreter, so the load-generating client threads do
not share its GIL), with two listeners on the same backend: batching on (--max-batch, --window-ms) and
batching off (max batch 1). Frames are 640x480 and cross as JPEG (the client's default). Figures:

  overhead     a request through the remote client (JPEG encode, HTTP, decode, batcher) against the
               same backend called in-process in the server's process (the ratio's reference). The
               overhead is given paired (each round trip minus the server's own timing of that
               request's backend call, median) and by medians (round trip minus in-process); with
               batching off and on (a lone client skips the window). Also the JPEG encode and decode
               costs that are part of it. Target: <= 5 ms on loopback.
  batching     requests per second at concurrency 1, 8 and 32 with batching on against off; p50/p99
               latency. Target on a GPU: >= 4x at concurrency 32.

Every figure is one line: name, ratio to its reference, the absolute numbers.
On the GPU, install torchvision: without it the hf backends pre-process images with PIL on the CPU, one
image after another in the backend's thread, and that CPU time (not the GPU) bounds the batching gain.
Needs numpy, pillow, pydantic, fastapi, uvicorn, httpx (+ torch and transformers for --backend).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

SRC = Path(__file__).resolve().parent.parent / "src"
if str(SRC) not in sys.path:  # runnable without installing attribot
    sys.path.insert(0, str(SRC))

FRAME_HW = (480, 640)
LABELS = ["a cup", "a bowl", "an apple", "a book", "a remote control"]
QUESTION = "Question: which object is the heaviest? Answer:"
OVERHEAD_TARGET_MS = 5.0
GAIN_TARGET = 4.0


def scene_frame(seed: int = 0) -> Any:
    """A deterministic 640x480 image: a shaded floor and a few coloured boxes (compresses like a render)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    h, w = FRAME_HW
    y, x = np.mgrid[0:h, 0:w]
    rgb = np.stack([60 + x * 80 // w, 70 + y * 90 // h, np.full_like(x, 90)], -1).astype(np.uint8)
    for _ in range(6):
        x0, y0 = int(rng.integers(0, w - 120)), int(rng.integers(0, h - 100))
        rgb[y0 : y0 + int(rng.integers(30, 100)), x0 : x0 + int(rng.integers(30, 120))] = rng.integers(
            0, 256, 3
        )
    noise = rng.integers(-4, 5, rgb.shape)
    return np.clip(rgb.astype(int) + noise, 0, 255).astype(np.uint8)


# ---- backends ---------------------------------------------------------------------------------------


class FixedCostDetector:
    """Stand-in for a GPU model: each call costs `call_ms` (sleeping: the CPU is free, as while a GPU
    works) plus `item_ms` per image; answers with the box of the whole image."""

    def __init__(self, call_ms: float, item_ms: float) -> None:
        self.name = f"fixed-cost({call_ms:g} ms/call + {item_ms:g} ms/image)"
        self.call_s, self.item_s = call_ms / 1000.0, item_ms / 1000.0

    def detect(self, frame: Any, queries: Any) -> list:
        return self.detect_batch([frame], [queries])[0]

    def detect_batch(self, frames: Any, queries: Any) -> list:
        from attribot.models.base import Detection

        time.sleep(self.call_s + self.item_s * len(frames))
        return [
            [Detection(box=(0, 0, f.width, f.height), score=1.0, label=q[0])]
            for f, q in zip(frames, queries, strict=True)
        ]


def build_backend(args: argparse.Namespace) -> tuple[str, Any]:
    """(role, backend) for --backend."""
    if args.backend == "fixed":
        return "detector", FixedCostDetector(args.call_ms, args.item_ms)
    kind, _, arg = args.backend.partition(":")
    if kind == "random":
        from attribot.models.hf import HFDetector, HFVisualQA
        from attribot.models.hf_random import build_random

        dtype = {"auto": "float16" if args.device.startswith("cuda") else "float32"}.get(
            args.dtype, args.dtype
        )
        model, processor = build_random(arg, device=args.device, dtype=dtype)
        family = str(model.config.model_type)
        if family == "blip-2":
            return "vqa", HFVisualQA.from_loaded(
                model, processor, name=f"random:{arg}", max_batch=args.max_batch
            )
        return "detector", HFDetector.from_loaded(
            model, processor, name=f"random:{arg}", max_batch=args.max_batch
        )
    if kind == "hf":
        from attribot.models.hf import VQA_FAMILIES, HFDetector, HFVisualQA, model_family

        if model_family(arg) in VQA_FAMILIES:
            return "vqa", HFVisualQA(arg, device=args.device, dtype=args.dtype, max_batch=args.max_batch)
        return "detector", HFDetector(arg, device=args.device, dtype=args.dtype, max_batch=args.max_batch)
    raise SystemExit(f"error: --backend {args.backend!r}: write fixed, random:NAME or hf:MODEL")


def call(role: str, backend: Any, frame: Any) -> Any:
    return backend.detect(frame, LABELS) if role == "detector" else backend.answer(frame, QUESTION)


def sync(device: str) -> None:
    if device.startswith("cuda"):
        import torch

        torch.cuda.synchronize()


# ---- the server process -----------------------------------------------------------------------------


def serve(args: argparse.Namespace) -> None:
    """Build the backend, time it in-process, serve it on two ports (batching on and off), report, wait."""
    from attribot.frame import Frame
    from attribot.server import ServerConfig, ServerThread, create_app

    role, backend = build_backend(args)
    frame = Frame(rgb=scene_frame())
    for _ in range(args.warmup):
        call(role, backend, frame)
    times = []
    for _ in range(args.inproc_iters):
        t0 = time.perf_counter()
        call(role, backend, frame)
        sync(args.device)
        times.append((time.perf_counter() - t0) * 1000)
    servers = {}
    for mode, max_batch, window in (("on", args.max_batch, args.window_ms), ("off", 1, 0.0)):
        config = ServerConfig(max_batch=max_batch, batch_window_ms=window, max_queue=4096)
        servers[mode] = ServerThread(create_app(config=config, **{role: backend})).start()
    report = {
        "role": role,
        "backend": backend.name,
        "inproc_ms": statistics.median(times),
        "ports": {m: s.port for m, s in servers.items()},
    }
    print("READY " + json.dumps(report), flush=True)
    sys.stdin.read()  # until the parent closes our stdin
    for s in servers.values():
        s.stop()


# ---- the client side --------------------------------------------------------------------------------


def start_server(args: argparse.Namespace) -> tuple[subprocess.Popen, dict]:
    argv = [sys.executable, __file__, "--serve", *sys.argv[1:]]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith("READY "):
            return proc, json.loads(line[6:])
        print(line, end="", file=sys.stderr)
    raise SystemExit(f"error: the server process ended (exit code {proc.wait()}) before it was ready")


def load(client: Any, role: str, payload: Any, concurrency: int, total: int) -> tuple[float, list[float]]:
    """`total` requests from `concurrency` threads (each sends its next as soon as it has an answer):
    (requests per second, latencies in ms)."""
    from attribot.models.wire import PATHS, AnswerResponse, DetectResponse

    path, model = (
        (PATHS["detector"], DetectResponse) if role == "detector" else (PATHS["vqa"], AnswerResponse)
    )
    latencies: list[float] = []
    lock = threading.Lock()
    left = [total]
    start = threading.Barrier(concurrency + 1)
    errors: list[BaseException] = []

    def worker() -> None:
        start.wait()
        while True:
            with lock:
                if left[0] <= 0:
                    return
                left[0] -= 1
            t0 = time.perf_counter()
            try:
                client._request("POST", path, payload, model)
            except BaseException as exc:  # noqa: BLE001 - reported after the run
                errors.append(exc)
                return
            with lock:
                latencies.append((time.perf_counter() - t0) * 1000)

    threads = [threading.Thread(target=worker) for _ in range(concurrency)]
    for t in threads:
        t.start()
    start.wait()
    t0 = time.perf_counter()
    for t in threads:
        t.join()
    wall = time.perf_counter() - t0
    if errors:
        raise SystemExit(f"error: {len(errors)} requests failed, first: {errors[0]}")
    return len(latencies) / wall, latencies


def pct(values: list[float], q: float) -> float:
    import numpy as np

    return float(np.percentile(values, q))


def line(name: str, ratio: float, reference: str, detail: str) -> None:
    print(f"{name:<34} {ratio:8.2f}x  {reference:<28} {detail}", flush=True)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--backend", default="fixed", help="fixed (CPU stand-in), random:NAME or hf:MODEL")
    p.add_argument("--device", default="cpu", help="cpu or cuda (random:/hf: backends)")
    p.add_argument("--dtype", default="auto", help="auto (fp16 on cuda), float16, bfloat16, float32")
    p.add_argument("--call-ms", type=float, default=20.0, help="fixed backend: cost of one call")
    p.add_argument("--item-ms", type=float, default=0.5, help="fixed backend: extra cost per image")
    p.add_argument("--max-batch", type=int, default=32)
    p.add_argument("--window-ms", type=float, default=2.0, help="batching window of the 'on' listener")
    p.add_argument("--concurrency", default="1,8,32")
    p.add_argument("--requests", type=int, default=0, help="requests per load run (0: by concurrency)")
    p.add_argument("--quick", action="store_true", help="few iterations: check that it runs")
    p.add_argument("--warmup", type=int, default=0, help="in-process warm-up calls (0: 3 on CPU, 10 on GPU)")
    p.add_argument("--inproc-iters", type=int, default=0)
    p.add_argument("--serve", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args()
    if not args.inproc_iters:
        args.inproc_iters = 5 if args.quick else 30
    if not args.warmup:
        args.warmup = 10 if args.device.startswith("cuda") else 3
    if args.serve:
        serve(args)
        return

    import numpy as np  # noqa: F401 - fail early with a clear message if missing

    from attribot.models.remote import RemoteClient
    from attribot.models.wire import AnswerRequest, DetectRequest, decode_image, encode_image

    proc, info = start_server(args)
    role, inproc = info["role"], info["inproc_ms"]
    rgb = scene_frame()
    print(
        f"# backend {info['backend']} ({role}), device {args.device}, frame {FRAME_HW[1]}x{FRAME_HW[0]} "
        f"JPEG, max batch {args.max_batch}, window {args.window_ms:g} ms, server in its own process"
    )
    try:
        urls = {m: f"http://127.0.0.1:{port}" for m, port in info["ports"].items()}
        clients = {m: RemoteClient(u, timeout_s=600, max_connections=128) for m, u in urls.items()}
        iters = 5 if args.quick else 40

        # overhead: sequential requests, end to end through the client (encodes the frame every time)
        def remote_ms(mode: str) -> tuple[float, float]:
            """(median round trip, median of round trip minus the server's own backend time for the
            same request): the second pairs each request with its own backend cost, so the backend's
            jitter cancels out."""
            c = clients[mode]
            for _ in range(3):
                c.detect(rgb, LABELS) if role == "detector" else c.answer(rgb, QUESTION)
            t, paired = [], []
            for _ in range(iters):
                t0 = time.perf_counter()
                r = c.detect(rgb, LABELS) if role == "detector" else c.answer(rgb, QUESTION)
                ms = (time.perf_counter() - t0) * 1000
                t.append(ms)
                paired.append(ms - r.backend_ms)
            return statistics.median(t), statistics.median(paired)

        (off, over), (on, over_on) = remote_ms("off"), remote_ms("on")
        t0 = time.perf_counter()
        for _ in range(iters):
            data = encode_image(rgb, "jpeg")
        enc = (time.perf_counter() - t0) * 1000 / iters
        t0 = time.perf_counter()
        for _ in range(iters):
            decode_image(data)
        dec = (time.perf_counter() - t0) * 1000 / iters
        line(
            "overhead per request (batching off)",
            off / inproc,
            f"vs in-process {inproc:.2f} ms",
            f"remote {off:.2f} ms; overhead {over:.2f} ms paired, {off - inproc:.2f} ms by medians "
            f"(target <= {OVERHEAD_TARGET_MS:g}: {'met' if over <= OVERHEAD_TARGET_MS else 'NOT met'})",
        )
        line(
            "overhead per request (window on)",
            on / inproc,
            f"vs in-process {inproc:.2f} ms",
            f"remote {on:.2f} ms; overhead {over_on:.2f} ms paired, {on - inproc:.2f} ms by medians "
            f"({args.window_ms:g} ms window: a lone client skips it)",
        )
        if over > 0:
            line(
                "  of which JPEG encode + decode",
                (enc + dec) / over,
                "vs overhead (batching off)",
                f"{enc:.2f} + {dec:.2f} ms ({len(data) * 3 // 4 // 1024} kB)",
            )
        else:
            print(
                f"# the remote call was faster than the in-process reference: noise larger than the overhead "
                f"(JPEG encode + decode {enc:.2f} + {dec:.2f} ms)"
            )

        # batching gain: concurrent load, the frame encoded once (client-side encoding is not the server's)
        payload = (
            DetectRequest(image=data, queries=LABELS)
            if role == "detector"
            else AnswerRequest(image=data, question=QUESTION)
        )
        gains = {}
        for conc in [int(c) for c in args.concurrency.split(",")]:
            total = args.requests or (max(2 * conc, 8) if args.quick else max(12 * conc, 60))
            load(clients["off"], role, payload, conc, min(total, 2 * conc))  # warm connections
            rate_off, lat_off = load(clients["off"], role, payload, conc, total)
            load(clients["on"], role, payload, conc, min(total, 2 * conc))
            rate_on, lat_on = load(clients["on"], role, payload, conc, total)
            gains[conc] = rate_on / rate_off
            line(
                f"batching gain, concurrency {conc}",
                gains[conc],
                f"vs off {rate_off:.1f} req/s",
                f"on {rate_on:.1f} req/s; p50/p99 on {pct(lat_on, 50):.1f}/{pct(lat_on, 99):.1f} ms, "
                f"off {pct(lat_off, 50):.1f}/{pct(lat_off, 99):.1f} ms; {total} requests",
            )
        metrics = clients["on"].metrics().roles[role]
        print(
            f"# backend calls on the 'on' listener (all runs, the sequential ones included): "
            f"{metrics.batches}, "
            f"mean size {metrics.mean_batch_size:.1f}, sizes {metrics.batch_sizes}"
        )
        if 32 in gains and args.device.startswith("cuda"):
            print(
                f"# GPU target: gain >= {GAIN_TARGET:g}x at concurrency 32: "
                f"{'met' if gains[32] >= GAIN_TARGET else 'NOT met'} ({gains[32]:.2f}x)"
            )
    finally:
        assert proc.stdin is not None
        proc.stdin.close()
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:
            proc.kill()


if __name__ == "__main__":
    main()
