#!/usr/bin/env python3
"""The robot bridge over loopback against the in-process world, in one process (ratios, not absolutes).

1. Frame round trip at 640x480: `BridgeWorld.observe()` (JPEG + depth + segmentation over TCP) against
   `MujocoWorld.observe()` in-process.
2. Control steps per second over the bridge: observe + command_base + step(1/30 s), as a servo loop does,
   against the same loop in-process (target: at least 30 per second over the bridge).
3. Time from the last command to the base stopping when the client process is killed (SIGKILL), with the
   watchdog at 0.5 s (target under 0.5 s; a dropped connection stops it at once).
4. The same embodied distance and weight queries (held-out seeds) over the bridge and directly, with the
   servo controller on both sides: answers compared, and the wall time of each side.
5. What the wrong-token throttle costs a right hello (connect, hello, reply, bye): the time of one with
   the throttle on (its table holding 1,000 other peers' wrong tokens) against one with it off, measured
   in alternating rounds in the same run; the ratio is the figure (target: within noise of 1.00).

    .venv/bin/python benchmarks/bench_bridge.py [--frames 30] [--steps 60] [--seeds 10,11,12,13,14]
    .venv/bin/python benchmarks/bench_bridge.py --throttle-only [--hellos 300 --rounds 7]
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import socket
import statistics
import subprocess
import sys
import textwrap
import threading
import time
from typing import Any

from attribot.bridge.driver import Driver
from attribot.bridge.protocol import PROTOCOL_VERSION, recv_message, send_message
from attribot.bridge.server import Limits, RobotServer, serve_in_thread
from attribot.config import BridgeConfig, SceneConfig, load_settings
from attribot.embodiments.bridge import BridgeWorld, EmbodimentDriver
from attribot.embodiments.mujoco import MujocoWorld
from attribot.session import Scene, ask

TOKEN = "bench"


class _TimedDriver(EmbodimentDriver):
    def __init__(self, world: MujocoWorld) -> None:
        super().__init__(world)
        self.drives: list[tuple[float, tuple[float, float, float]]] = []

    def drive(self, vx: float, vy: float, wz: float) -> None:
        self.drives.append((time.monotonic(), (vx, vy, wz)))
        super().drive(vx, vy, wz)


def serve(config: SceneConfig, limits: Limits) -> tuple[RobotServer, _TimedDriver, threading.Thread]:
    # the world is built, rendered and closed in the serving thread (EGL context)
    server, driver, thread = serve_in_thread(lambda: _TimedDriver(MujocoWorld(config)), TOKEN, limits=limits)
    assert isinstance(driver, _TimedDriver)
    return server, driver, thread


def timed(fn: Any, n: int) -> float:
    fn()
    start = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - start) / n


_CLIENT = textwrap.dedent(
    """
    import sys, time
    from attribot.embodiments.bridge import BridgeWorld
    world = BridgeWorld(url=sys.argv[1], token=sys.argv[2])
    world.command_base(0.2, 0.0, 0.3)
    world.step(0.05)  # a simulated robot moves in step
    print("sent", flush=True)
    time.sleep(60)
    """
)


class _Idle(Driver):
    name = "idle"

    def capabilities(self) -> list[str]:
        return ["base"]

    def drive(self, vx: float, vy: float, wz: float) -> None:
        pass


def _right_hello(address: tuple[str, int]) -> None:
    with socket.create_connection(address, timeout=10) as sock:
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        send_message(sock, {"op": "hello", "version": PROTOCOL_VERSION, "token": TOKEN})
        assert recv_message(sock)[0]["ok"] is True
        send_message(sock, {"op": "bye"})
        recv_message(sock)


def throttle_cost(hellos: int, rounds: int) -> None:
    """Right hellos to a server with the wrong-token throttle on, one with it off, and a second one with it
    off (the noise floor: two identical servers), each hello of a triple back to back in a rotating order.
    The figure is the median of the per-triple ratios on/off, beside the same for off/off."""
    logging.getLogger("attribot.bridge").setLevel(logging.ERROR)  # a line a hello would be the cost measured
    servers: dict[str, RobotServer] = {}
    threads = []
    for name, on in (("off", False), ("on", True), ("off2", False)):  # created in this order
        server, _, thread = serve_in_thread(_Idle, TOKEN, throttle=on)
        servers[name] = server
        threads.append(thread)
    throttle = servers["on"].wrong_tokens
    assert throttle is not None
    for i in range(1000):  # a table with other peers in it: the right hello still pays one lookup
        throttle.wrong(f"10.9.{i // 256}.{i % 256}")
    times: dict[str, list[float]] = {name: [] for name in servers}
    names = list(servers)
    try:
        for name in names:
            _right_hello(servers[name].address)  # warm
        for n in range(rounds * hellos):
            order = names[n % 3 :] + names[: n % 3]
            for name in order:
                t0 = time.perf_counter()
                _right_hello(servers[name].address)
                times[name].append(time.perf_counter() - t0)
    finally:
        for server in servers.values():
            server.close()
        for thread in threads:
            thread.join(timeout=30)
    on_off = statistics.median(a / b for a, b in zip(times["on"], times["off"], strict=True))
    floor = statistics.median(a / b for a, b in zip(times["off2"], times["off"], strict=True))
    print(
        f"right hello: throttle on {statistics.median(times['on']) * 1e3:.3f} ms, off "
        f"{statistics.median(times['off']) * 1e3:.3f} ms (medians of {len(times['on'])}); ratio on/off "
        f"{on_off:.3f} (median of back-to-back pairs), noise floor off/off {floor:.3f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=30)
    parser.add_argument("--steps", type=int, default=60)
    parser.add_argument("--seeds", default="10,11,12,13,14")
    parser.add_argument("--hellos", type=int, default=300)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--throttle-only", action="store_true", help="measure only the token throttle")
    args = parser.parse_args()
    throttle_cost(args.hellos, args.rounds)
    if args.throttle_only:
        return
    config = SceneConfig(layout="household", seed=3, width=640, height=480)
    limits = Limits(max_accel=100.0, max_turn_accel=100.0, watchdog_s=0.5, simulated=True)
    server, driver, thread = serve(config, limits)
    url = f"tcp://127.0.0.1:{server.address[1]}"
    try:
        with BridgeWorld(url=url, token=TOKEN) as bridge, MujocoWorld(config) as direct:
            t_bridge = timed(bridge.observe, args.frames)
            t_direct = timed(direct.observe, args.frames)
            print(f"frame 640x480: bridge {t_bridge * 1e3:.1f} ms, in-process {t_direct * 1e3:.1f} ms, "
                  f"ratio {t_bridge / t_direct:.2f}")  # fmt: skip

            def loop(world: Any) -> None:
                world.observe()
                world.command_base(0.05, 0.0, 0.1)
                world.step(1 / 30)

            s_bridge = 1 / timed(lambda: loop(bridge), args.steps)
            s_direct = 1 / timed(lambda: loop(direct), args.steps)
            print(f"control steps/s (observe+command+step): bridge {s_bridge:.1f}, "
                  f"in-process {s_direct:.1f}, ratio {s_bridge / s_direct:.2f}")  # fmt: skip
            bridge.stop()

        for how in (signal.SIGKILL, signal.SIGSTOP):  # killed: the connection drops; frozen: the watchdog
            client = subprocess.Popen(
                [sys.executable, "-c", _CLIENT, url, TOKEN], stdout=subprocess.PIPE, text=True
            )
            assert client.stdout is not None and client.stdout.readline() == "sent\n"
            time.sleep(0.1)
            last_command = max(t for t, v in driver.drives if v != (0.0, 0.0, 0.0))
            client.send_signal(how)
            signalled = time.monotonic()
            while driver.drives[-1][1] != (0.0, 0.0, 0.0):
                time.sleep(0.001)
            stop_at = driver.drives[-1][0]
            print(
                f"client {how.name}: base stopped {stop_at - last_command:.3f} s after the last command "
                f"({stop_at - signalled:.3f} s after the signal; watchdog {limits.watchdog_s} s)"
            )
            client.kill()
            client.wait()
            time.sleep(0.1)
    finally:
        server.close()
        thread.join(timeout=30)

    queries = [
        ("Which object is the closest to the robot?", "distance"),
        ("Which object is the farthest from the robot?", "distance"),
        ("Which object is the heaviest?", "force"),
        ("Which item is the lightest?", "force"),
    ]
    same = total = 0
    walls = {"bridge": 0.0, "direct": 0.0}
    settings = load_settings()
    os.environ["ATTRIBOT_BRIDGE_TOKEN"] = TOKEN
    for seed in [int(s) for s in args.seeds.split(",")]:
        cfg = SceneConfig(layout="household", seed=seed)
        for query, sensor in queries:  # a fresh robot per query, as the direct world is fresh per query
            sensors = ["camera", sensor]
            server, driver, thread = serve(cfg, Limits(watchdog_s=5.0))
            bridged = BridgeConfig(url=f"tcp://127.0.0.1:{server.address[1]}")
            try:
                t0 = time.perf_counter()
                over = ask(query, Scene(world="bridge", config=bridged, sensors=sensors), settings)
                walls["bridge"] += time.perf_counter() - t0
            finally:
                server.close()
                thread.join(timeout=30)
            t0 = time.perf_counter()
            here = ask(query, Scene(world="mujoco", config=cfg, sensors=sensors), settings)
            walls["direct"] += time.perf_counter() - t0
            total += 1
            same += over.answer == here.answer and over.error is None
            if over.answer != here.answer:
                print(f"  seed {seed} {query!r}: bridge {over.answer!r} / direct {here.answer!r}")
            if over.backends.get("robot") != "servo":
                print(
                    f"  seed {seed} {query!r}: the bridge answer names robot {over.backends.get('robot')!r}"
                )
    print(
        f"embodied distance and weight queries, seeds {args.seeds}: {same}/{total} answers identical over "
        f"the bridge; wall {walls['bridge']:.1f} s over the bridge vs {walls['direct']:.1f} s direct "
        f"(ratio {walls['bridge'] / max(walls['direct'], 1e-9):.2f})"
    )


if __name__ == "__main__":
    main()
