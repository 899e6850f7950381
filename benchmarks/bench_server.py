#!/usr/bin/env python3
"""The model server's cost per request and its batching gain, measured against references of the same run.

  PYTHONPATH=src python3 benchmarks/bench_server.py
      CPU. The backend is a stand-in whose cost is a fixed per-call overhead (sleeping --call-ms, like a
      GPU kernel launch and sync, plus --item-ms per image), so that batching has something to win.
  PYTHONPATH=src python3 benchmarks/bench_server.py --launch-ops 1000 --item-ops 150 --call-ms 12 \
      --item-ms 3.7 [--model-process]
      CPU, a stand-in that also spends its time as an eager PyTorch forward on a GPU does: 1000 kernel
      launches per call and 150 per image, each 8 us of Python holding the GIL (--op-us) and a release;
      --model-process serves it from a child process of the server (`attribot serve models`' default).
  PYTHONPATH=src python3 benchmarks/bench_server.py --backend random:owlv2-b16 --device cuda --dtype float16
      GPU. A real-size transformers model with random weights (tests/fakes/hf_random.py: owlv2-b16,
      owlv2-l14, grounding-dino-t, blip2-opt-2.7b; no download), served by the real `hf` backend code.
      Add --model-process to serve it as `attribot serve models` does.
  PYTHONPATH=src python3 benchmarks/bench_server.py --backend hf:/path/to/model --device cuda
      GPU, a model from a local folder (or a hub id already in the cache).
  PYTHONPATH=src python3 benchmarks/bench_server.py --backend random:owlv2-tiny --quick
      The GPU path with a tiny model on the CPU: a check that it runs, not a measurement.

The server runs in a separate process with two listeners on the same backend: batching on (--max-batch,
--window-ms) and batching off (max batch 1). The load comes from --client-processes processes (default:
the cores, at most 8), each with its share of the client threads: one Python process with 32 client
threads spends its own GIL on HTTP and JSON and would measure itself, not the server. Frames are 640x480
and cross as JPEG (the client's default). Figures:

  ceiling      the backend alone, in the server's process: its per-image cost at batch --max-batch
               against batch 1. No server can gain more from batching than this.
  overhead     a request through the remote client (JPEG encode, HTTP, decode, batcher) against the
               same backend called in-process in the server's process (the ratio's reference). The
               overhead is given paired (each round trip minus the server's own timing of that
               request's backend call, median) and by medians (round trip minus in-process); with
               batching off and on (a lone client skips the window). Also the JPEG encode and decode
               costs that are part of it. Target: <= 5 ms on loopback.
  batching     requests per second at concurrency 1, 8 and 32 with batching on against off, and as a
               share of the backend's own batch rate; p50/p99 latency. Target on a GPU: >= 4x at
               concurrency 32.

Every figure is one line: name, ratio to its reference, the absolute numbers.
On the GPU, install torchvision: without it the hf backends pre-process images with PIL on the CPU, one
image after another in the backend's thread, and that CPU time (not the GPU) bounds the batching gain.
Needs numpy, pillow, pydantic, fastapi, uvicorn, httpx (+ torch and transformers for --backend).
"""

from __future__ import annotations

import argparse
import functools
import hashlib
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # tests/fakes: the random models

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


_GIL_RELEASING_BUFFER = bytes(4096)


class FixedCostDetector:
    """Stand-in for a GPU model: each call costs `call_ms` plus `item_ms` per image, answering with the box
    of the whole image. With `launch_ops` > 0, the first part of that time is spent like an eager PyTorch
    forward on a GPU spends it: `launch_ops` kernel launches, each `op_us` of Python holding the GIL and
    then a release (as a torch op releases it); the rest is a sleep, the GPU working while the CPU waits.
    Without it (the default), the whole cost is a sleep: the best case for the server."""

    def __init__(
        self, call_ms: float, item_ms: float, launch_ops: int = 0, op_us: float = 8.0, item_ops: int = 0
    ) -> None:
        launch = (
            f", {launch_ops} launches + {item_ops}/image x {op_us:g} us holding the GIL"
            if launch_ops or item_ops
            else ""
        )
        self.name = f"fixed-cost({call_ms:g} ms/call + {item_ms:g} ms/image{launch})"
        self.call_s, self.item_s = call_ms / 1000.0, item_ms / 1000.0
        self.launch_ops, self.item_ops, self.op_s = launch_ops, item_ops, op_us / 1e6

    def detect(self, frame: Any, queries: Any) -> list:
        return self.detect_batch([frame], [queries])[0]

    def detect_batch(self, frames: Any, queries: Any) -> list:
        from attribot.models.base import Detection

        t0 = time.perf_counter()
        for _ in range(self.launch_ops + self.item_ops * len(frames)):
            busy_until = time.perf_counter() + self.op_s
            while time.perf_counter() < busy_until:  # Python work: holds the GIL
                pass
            hashlib.sha1(_GIL_RELEASING_BUFFER)  # the op: hashing over 2 kB releases the GIL, ~2 us
        left = self.call_s + self.item_s * len(frames) - (time.perf_counter() - t0)
        if left > 0:
            time.sleep(left)
        return [
            [Detection(box=(0, 0, f.width, f.height), score=1.0, label=q[0])]
            for f, q in zip(frames, queries, strict=True)
        ]


def build_backend(args: argparse.Namespace) -> tuple[str, Any]:
    """(role, backend) for --backend."""
    if args.backend == "fixed":
        return "detector", FixedCostDetector(
            args.call_ms, args.item_ms, args.launch_ops, args.op_us, args.item_ops
        )
    kind, _, arg = args.backend.partition(":")
    if kind == "random":
        from attribot.models.hf import HFDetector, HFVisualQA
        from fakes.hf_random import build_random

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


def build_role_backend(args: argparse.Namespace, role: str) -> Any:
    """The backend of --backend alone (the factory a model process is started with)."""
    built_role, backend = build_backend(args)
    assert built_role == role
    return backend


def call(role: str, backend: Any, frame: Any) -> Any:
    return backend.detect(frame, LABELS) if role == "detector" else backend.answer(frame, QUESTION)


def call_batch(role: str, backend: Any, frames: list) -> Any:
    from attribot.models.base import answer_many, detect_many

    if role == "detector":
        return detect_many(backend, frames, [LABELS] * len(frames))
    return answer_many(backend, frames, [QUESTION] * len(frames))


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
    served = backend
    if args.model_process:
        from attribot.server import start_model_process

        served = start_model_process(role, functools.partial(build_role_backend, args, role))
    frame = Frame(rgb=scene_frame())
    for _ in range(args.warmup):
        call(role, backend, frame)
    times = []
    for _ in range(args.inproc_iters):
        t0 = time.perf_counter()
        call(role, backend, frame)
        sync(args.device)
        times.append((time.perf_counter() - t0) * 1000)
    # the backend's own batching gain: what the server's gain is bounded by
    frames = [Frame(rgb=scene_frame(i)) for i in range(args.max_batch)]
    call_batch(role, backend, frames)
    batch_times = []
    for _ in range(max(2, args.inproc_iters // 10)):
        t0 = time.perf_counter()
        call_batch(role, backend, frames)
        sync(args.device)
        batch_times.append((time.perf_counter() - t0) * 1000)
    servers = {}
    for mode, max_batch, window in (("on", args.max_batch, args.window_ms), ("off", 1, 0.0)):
        config = ServerConfig(max_batch=max_batch, batch_window_ms=window, max_queue=4096)
        servers[mode] = ServerThread(create_app(config=config, **{role: served})).start()
    report = {
        "role": role,
        "backend": backend.name + (" in a model process" if args.model_process else ""),
        "inproc_ms": statistics.median(times),
        "inproc_batch_ms": statistics.median(batch_times) / args.max_batch,
        "ports": {m: s.port for m, s in servers.items()},
    }
    print("READY " + json.dumps(report), flush=True)
    sys.stdin.read()  # until the parent closes our stdin
    for s in servers.values():
        s.stop()
    if served is not backend:
        served.close()


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


def load(
    client: Any, role: str, payload: Any, concurrency: int, left: Any, start_at: float
) -> tuple[float, float, list[float]]:
    """Requests from `concurrency` threads of this process (each sends its next as soon as it has an
    answer) while the counter `left` (a multiprocessing.Value shared with the other client processes) is
    above 0, starting at `start_at` (time.perf_counter: one clock for the processes of this machine):
    (start, end, latencies in ms)."""
    from attribot.models.wire import PATHS, AnswerResponse, DetectResponse

    path, model = (
        (PATHS["detector"], DetectResponse) if role == "detector" else (PATHS["vqa"], AnswerResponse)
    )
    latencies: list[float] = []
    lock = threading.Lock()
    start = threading.Barrier(concurrency + 1)
    errors: list[BaseException] = []

    def worker() -> None:
        start.wait()
        while True:
            with left.get_lock():
                if left.value <= 0:
                    return
                left.value -= 1
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
    while time.perf_counter() < start_at:
        time.sleep(min(0.001, max(0.0, start_at - time.perf_counter())))
    start.wait()
    t0 = time.perf_counter()
    for t in threads:
        t.join()
    if errors:
        raise RuntimeError(f"{len(errors)} requests failed, first: {errors[0]}")
    return t0, time.perf_counter(), latencies


def _client_process(conn: Any, left: Any) -> None:
    """A load-generating process: runs the `load` calls its parent sends, one client per server URL."""
    from attribot.models.remote import RemoteClient

    clients: dict[str, Any] = {}
    while True:
        try:
            task = conn.recv()
        except EOFError:
            return
        if task is None:
            return
        url, role, payload, concurrency, start_at = task
        if url not in clients:
            clients[url] = RemoteClient(url, timeout_s=600, max_connections=256)
        try:
            conn.send(("ok", load(clients[url], role, payload, concurrency, left, start_at)))
        except BaseException as exc:  # noqa: BLE001 - reported by the parent
            conn.send(("error", str(exc)))


class ClientProcesses:
    """Clients spread over several processes: one Python process with 32 client threads spends its
    own GIL on HTTP and JSON and becomes the bottleneck on a fast server (robots are separate machines)."""

    def __init__(self, processes: int) -> None:
        import multiprocessing

        ctx = multiprocessing.get_context("spawn")
        self.left = ctx.Value("q", 0)  # requests still to send, taken by all the processes
        self.conns, self.procs = [], []
        for _ in range(max(1, processes)):
            parent, child = ctx.Pipe()
            proc = ctx.Process(target=_client_process, args=(child, self.left), daemon=True)
            proc.start()
            child.close()
            self.conns.append(parent)
            self.procs.append(proc)

    def run(
        self, url: str, role: str, payload: Any, concurrency: int, total: int
    ) -> tuple[float, list[float]]:
        """(requests per second, latencies in ms) of `total` requests at `concurrency`, spread over the
        processes (at most one per concurrent client)."""
        n = min(len(self.conns), concurrency)
        start_at = time.perf_counter() + 0.2  # every process is waiting by then
        self.left.value = total
        for i in range(n):
            threads = concurrency // n + (i < concurrency % n)
            self.conns[i].send((url, role, payload, threads, start_at))
        starts, ends, latencies = [], [], []
        failures = []
        for conn in self.conns[:n]:
            status, result = conn.recv()
            if status != "ok":
                failures.append(result)
                continue
            starts.append(result[0])
            ends.append(result[1])
            latencies.extend(result[2])
        if failures:
            raise SystemExit(f"error: a client process failed: {failures[0]}")
        return len(latencies) / (max(ends) - min(starts)), latencies

    def close(self) -> None:
        for conn in self.conns:
            conn.send(None)
        for proc in self.procs:
            proc.join(10)


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
    p.add_argument(
        "--launch-ops", type=int, default=0, help="fixed backend: kernel launches per call holding the GIL"
    )
    p.add_argument(
        "--item-ops",
        type=int,
        default=0,
        help="fixed backend: launches per image",
    )
    p.add_argument("--op-us", type=float, default=8.0, help="fixed backend: Python time per launch")
    p.add_argument(
        "--model-process",
        action="store_true",
        help="serve the backend from a child process of the server (attribot serve models' default)",
    )
    p.add_argument(
        "--client-processes",
        type=int,
        default=min(8, os.cpu_count() or 1),
        help="processes the load-generating clients are spread over (default: cores, at most 8)",
    )
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
    role, inproc, per_image = info["role"], info["inproc_ms"], info["inproc_batch_ms"]
    ceiling = inproc / per_image
    rgb = scene_frame()
    print(
        f"# backend {info['backend']} ({role}), device {args.device}, frame {FRAME_HW[1]}x{FRAME_HW[0]} "
        f"JPEG, max batch {args.max_batch}, window {args.window_ms:g} ms, server in its own process, "
        f"clients in {args.client_processes} process(es)"
    )
    line(
        f"backend alone, batch {args.max_batch} vs 1",
        ceiling,
        f"vs batch 1 {inproc:.2f} ms",
        f"{per_image:.2f} ms per image: no server can gain more from batching",
    )
    loaders = ClientProcesses(args.client_processes)
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
        decode_image(encode_image(rgb, "jpeg"))  # first calls load the codecs
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
            loaders.run(urls["off"], role, payload, conc, min(total, 2 * conc))  # warm connections
            rate_off, lat_off = loaders.run(urls["off"], role, payload, conc, total)
            loaders.run(urls["on"], role, payload, conc, min(total, 2 * conc))
            rate_on, lat_on = loaders.run(urls["on"], role, payload, conc, total)
            gains[conc] = rate_on / rate_off
            line(
                f"batching gain, concurrency {conc}",
                gains[conc],
                f"vs off {rate_off:.1f} req/s",
                f"on {rate_on:.1f} req/s ({rate_on * per_image / 1000:.0%} of the backend's batch-"
                f"{args.max_batch} rate); p50/p99 on {pct(lat_on, 50):.1f}/{pct(lat_on, 99):.1f} ms, "
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
        loaders.close()
        assert proc.stdin is not None
        proc.stdin.close()
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:
            proc.kill()


if __name__ == "__main__":
    main()
