"""Runner figures: the warm start of a program and the round trip of one API call, each against running the
same code in-process (measured in the same run, as ratios, because the machine is shared and noisy).

    .venv/bin/python benchmarks/bench_runner.py [--runs 30] [--calls 3000]

Targets (issue 3): a warm program starts in <= 15 ms; an API call costs <= 0.2 ms over the in-process call.
With --profile it also splits one call's cost into its parts (JSON, pipe round trip, host dispatch).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from typing import ClassVar

from attribot.runner import Limits, ProgramRunner


class Probe:
    """A host object with one cheap method, so the figures measure the runner, not the API."""

    API_ATTRIBUTES: ClassVar[tuple[str, ...]] = ("width",)
    API_METHODS: ClassVar[tuple[str, ...]] = ("ping",)

    def __init__(self) -> None:
        self.width = 640.0

    def ping(self, x: int) -> int:
        return x + 1


TRIVIAL = "def execute_command(probe):\n    return probe.width\n"
CALLS = (
    "def execute_command(probe, n):\n"
    "    s = 0\n"
    "    for i in range(n):\n"
    "        s = probe.ping(s)\n"
    "    return s\n"
)


def in_process(source: str, *args: object) -> object:
    """The reference: compile and run the same program here, on the real object, with no sandbox."""
    namespace: dict[str, object] = {}
    exec(compile(source, "<program>", "exec"), namespace)  # noqa: S102 (benchmark reference, our own code)
    return namespace["execute_command"](*args)  # type: ignore[operator]


def median_ms(samples: list[float]) -> float:
    return statistics.median(samples) * 1000


def bench_start(runner: ProgramRunner, runs: int) -> None:
    probe = Probe()
    ref, total, wall = [], [], []
    for _ in range(runs):
        t = time.perf_counter()
        in_process(TRIVIAL, probe)
        ref.append(time.perf_counter() - t)
    for _ in range(runs):
        time.sleep(0.05)  # let the pre-started worker finish starting: this measures a *warm* start
        t = time.perf_counter()
        res = runner.run(TRIVIAL, args=[probe])
        total.append(time.perf_counter() - t)
        assert res.ok and res.value == 640.0, res.error
        wall.append(res.wall_ms / 1000)
    r, w, tot = median_ms(ref), median_ms(wall), median_ms(total)
    print(
        f"warm start (check, send, run, result): {w:.2f} ms median over {runs} runs "
        f"(target <= 15 ms); in-process compile+run {r:.3f} ms; ratio {w / r:.0f}x"
    )
    print(f"warm start incl. pre-starting the next worker: {tot:.2f} ms median")


def bench_calls(runner: ProgramRunner, calls: int, repeats: int = 5) -> None:
    probe = Probe()
    ref, box = [], []
    for _ in range(repeats):
        t = time.perf_counter()
        in_process(CALLS, probe, calls)
        ref.append(time.perf_counter() - t)
        time.sleep(0.05)
        res = runner.run(CALLS, args=[probe, calls])
        assert res.ok and res.value == calls, res.error
        box.append(res.wall_ms / 1000)
    # one empty run gives the fixed part, so that the per-call figure is the calls' cost alone
    time.sleep(0.05)
    base = runner.run(CALLS, args=[probe, 0]).wall_ms / 1000
    per_ref = min(ref) / calls * 1000
    per_box = (min(box) - base) / calls * 1000
    print(
        f"API call round trip: {per_box * 1000:.1f} us per call in the sandbox vs {per_ref * 1000:.2f} us "
        f"in-process over {calls} calls; overhead {(per_box - per_ref) * 1000:.1f} us (target <= 200 us); "
        f"ratio {per_box / per_ref:.0f}x"
    )


def bench_parts(n: int = 3000) -> None:
    """Where one call's time goes: JSON both ways and a bare pipe ping-pong between two processes."""
    msg = {"t": "call", "h": 1, "m": "ping", "a": [123], "k": {}, "l": 4}
    reply = {"t": "ret", "v": 124}
    t = time.perf_counter()
    for _ in range(n):
        json.loads(json.dumps(msg, separators=(",", ":")))
        json.loads(json.dumps(reply, separators=(",", ":")))
    js = (time.perf_counter() - t) / n * 1e6
    import pickle

    t = time.perf_counter()
    for _ in range(n):
        pickle.loads(pickle.dumps(msg))
        pickle.loads(pickle.dumps(reply))
    pk = (time.perf_counter() - t) / n * 1e6
    a_r, a_w = os.pipe()
    b_r, b_w = os.pipe()
    pid = os.fork()
    if pid == 0:  # echo child
        os.close(a_w)
        os.close(b_r)
        while True:
            data = os.read(a_r, 64)
            if not data:
                os._exit(0)
            os.write(b_w, data)
    os.close(a_r)
    os.close(b_w)
    t = time.perf_counter()
    for _ in range(n):
        os.write(a_w, b"x" * 40)
        os.read(b_r, 64)
    pipe = (time.perf_counter() - t) / n * 1e6
    os.close(a_w)
    os.waitpid(pid, 0)
    os.close(b_r)
    print(
        f"parts of one call: JSON encode+decode both ways {js:.1f} us (pickle would be {pk:.1f} us); "
        f"bare pipe round trip between two processes {pipe:.1f} us"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--calls", type=int, default=3000)
    parser.add_argument("--profile", action="store_true")
    ns = parser.parse_args()
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cpus")
    limits = Limits(max_api_calls=max(ns.calls, 1000), wall_s=30)
    with ProgramRunner(classes=[Probe], limits=limits) as runner:
        time.sleep(0.2)
        bench_start(runner, ns.runs)
        bench_calls(runner, ns.calls)
    if ns.profile:
        bench_parts()


if __name__ == "__main__":
    main()
