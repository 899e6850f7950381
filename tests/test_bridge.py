"""The robot bridge: protocol, safety (token, version, limits, watchdog), the mujoco driver end to end."""

from __future__ import annotations

import ast
import json
import logging
import math
import os
import signal
import socket
import struct
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from attribot.bridge.driver import CameraFrame, Driver
from attribot.bridge.protocol import PROTOCOL_VERSION, recv_message, send_message
from attribot.bridge.server import Limits, RobotServer, serve_in_thread
from attribot.config import SceneConfig
from attribot.embodiments.base import Capability
from attribot.embodiments.bridge import BridgeError, BridgeWorld, EmbodimentDriver
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import UnsupportedAction
from conftest import EMPTY_SETTINGS, wait_listening

BRIDGE_DIR = Path(__file__).resolve().parents[1] / "src" / "attribot" / "bridge"
TOKEN = "correct horse"
LAYOUT, SEED = "household", 7


# --- Python 3.8 and the robot's imports ------------------------------------------------------------

_ROBOT_IMPORTS = {"numpy", "robomaster", "cv2", "attribot"}  # cv2: installed by the RoboMaster SDK itself


def test_every_bridge_module_parses_as_python_38_and_imports_only_stdlib_numpy_and_the_sdk():
    files = sorted(BRIDGE_DIR.glob("*.py"))
    assert {f.name for f in files} >= {"__init__.py", "protocol.py", "server.py"}
    for path in files:
        tree = ast.parse(path.read_text(), filename=str(path), feature_version=(3, 8))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                roots = [a.name.split(".")[0] for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                roots = [(node.module or "").split(".")[0]] if node.level == 0 else []
                if roots == ["attribot"]:
                    assert (node.module or "").startswith("attribot.bridge"), f"{path.name}: {node.module}"
            else:
                # keyword arguments that Python 3.8 does not know (zip(strict=) is 3.10)
                if isinstance(node, ast.Call) and any(k.arg == "strict" for k in node.keywords):
                    pytest.fail(f"{path.name}:{node.lineno}: zip(strict=...) needs Python 3.10")
                continue
            for root in roots:
                if root == "__future__":
                    continue
                assert root in sys.stdlib_module_names or root in _ROBOT_IMPORTS, (
                    f"{path.name} imports {root}"
                )


def test_a_walrus_free_38_grammar_check_really_rejects_newer_syntax():
    # the check above must be able to fail: a match statement does not parse with 3.8's grammar
    src = "match x:\n    case 1:\n        pass\n"
    with pytest.raises(SyntaxError):
        ast.parse(src, feature_version=(3, 8))


_ROBOT_38 = textwrap.dedent(
    """
    import sys
    from attribot.bridge.driver import Driver
    from attribot.bridge.server import Limits, RobotServer

    class Wheels(Driver):
        name = "wheels"

        def capabilities(self):
            return ["base"]

        def drive(self, vx, vy, wz):
            print("drive", vx, vy, wz, flush=True)

    limits = Limits(max_accel=100.0, max_turn_accel=100.0, watchdog_s=5.0, simulated=True)
    server = RobotServer(Wheels(), sys.argv[1], limits=limits)
    print("port", server.address[1], sys.version_info[0], sys.version_info[1], flush=True)
    server.serve_forever()
    """
)


def _python38() -> str | None:
    """A Python 3.8 interpreter on this machine (the RoboMaster SDK's), if there is one."""
    import glob
    import shutil

    candidates = [
        shutil.which("python3.8"),
        *sorted(glob.glob(os.path.expanduser("~/.pyenv/versions/3.8*/bin/python3.8"))),
    ]
    for exe in candidates:
        if exe and subprocess.run([exe, "-c", "import sys; assert sys.version_info[:2] == (3, 8)"],
                                  capture_output=True).returncode == 0:  # fmt: skip
            return exe
    return None


def test_the_robot_side_serves_on_python_38_as_the_robots_computer_runs_it():
    """Not only its grammar: the server itself on a real Python 3.8 (where `socket.timeout` is not yet a
    `TimeoutError`, so that catching the latter ended accepting after the first idle 0.2 s)."""
    exe = _python38()
    if exe is None:
        pytest.skip("no Python 3.8 interpreter on this machine")
    src = str(BRIDGE_DIR.parents[1])
    robot = subprocess.Popen(
        [exe, "-c", _ROBOT_38, TOKEN], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONPATH": src},
    )  # fmt: skip
    try:
        assert robot.stdout is not None
        _, port, major, minor = robot.stdout.readline().split()
        assert (major, minor) == ("3", "8")
        time.sleep(1.0)  # idle for longer than the accept time-out
        with BridgeWorld(url=f"tcp://127.0.0.1:{port}", token=TOKEN, timeout_s=10) as world:
            world.command_base(0.1, 0.0, 0.0)
            with pytest.raises(BridgeError, match="needs vx as a finite number"):
                world.command_base(float("nan"), 0.0, 0.0)
        with socket.create_connection(("127.0.0.1", int(port)), timeout=10) as sock:
            assert _hello(sock)["ok"] is True
            _raw(sock, b'{"op":"base","vx":' + b"[" * 20_000 + b"]" * 20_000 + b',"vy":0,"wz":0}')
            assert recv_message(sock)[0]["code"] == "message"
            _raw(sock, b'{"op":"base","vx":1' + b"0" * 4000 + b',"vy":0,"wz":0}')
            assert recv_message(sock)[0]["code"] == "value"
    finally:
        robot.terminate()
        out, err = robot.communicate(timeout=30)
    assert "drive 0.1 0.0 0.0" in out and "drive 0.0 0.0 0.0" in out
    assert "Traceback" not in err, err


# --- a recording driver for the safety tests ---------------------------------------------------------


class RecordingDriver(Driver):
    """A robot that records every base velocity it is given (wall clock, like a real one)."""

    name = "recorder"
    realtime = True

    def __init__(self) -> None:
        self.drives: list[tuple[float, tuple[float, float, float]]] = []
        self.arm: list[tuple[float, float]] = []
        self.stopped_at: list[float] = []

    def capabilities(self) -> list[str]:
        return ["base", "arm", "camera"]

    def camera(self) -> dict[str, float]:
        return {"width": 4, "height": 2, "fx": 3.0, "fy": 3.0, "cx": 2.0, "cy": 1.0}

    def frame(self) -> CameraFrame:
        import cv2

        ok, buf = cv2.imencode(".jpg", np.full((2, 4, 3), 200, np.uint8))
        return CameraFrame(bytes(buf.tobytes()), timestamp=123.5)

    def drive(self, vx: float, vy: float, wz: float) -> None:
        self.drives.append((time.monotonic(), (vx, vy, wz)))

    def set_arm(self, lift: float, extension: float) -> None:
        self.arm.append((lift, extension))

    def stop(self) -> None:
        self.stopped_at.append(time.monotonic())
        self.drive(0.0, 0.0, 0.0)

    @property
    def velocity(self) -> tuple[float, float, float]:
        return self.drives[-1][1] if self.drives else (0.0, 0.0, 0.0)


@contextmanager
def serving(
    make_driver: Callable[[], Driver], limits: Limits | None = None
) -> Iterator[tuple[RobotServer, Any]]:
    """A server on a free loopback port, serving in a thread that also builds and closes the driver
    (the MuJoCo renderer must be used and closed in the thread that made it current)."""
    server, driver, thread = serve_in_thread(make_driver, TOKEN, limits=limits)
    try:
        yield server, driver
    finally:
        server.close()
        thread.join(timeout=30)
        assert not thread.is_alive()


def url(server: RobotServer) -> str:
    return f"tcp://127.0.0.1:{server.address[1]}"


def test_hello_gives_capabilities_camera_and_limits_and_frames_carry_intrinsics_and_time():
    with serving(RecordingDriver) as (server, _), BridgeWorld(url=url(server), token=TOKEN) as world:
        assert world.capabilities() == {Capability.BASE, Capability.ARM, Capability.CAMERA}
        assert world.camera_info().fx == 3.0 and world.limits["watchdog_s"] == 0.5
        frame = world.observe()
        assert frame.rgb.shape == (2, 4, 3) and abs(int(frame.rgb[0, 0, 0]) - 200) <= 2
        assert frame.camera == world.camera_info() and world.last_timestamp == 123.5
        with pytest.raises(UnsupportedAction, match="recorder cannot measure distance.*no distance"):
            world.read_distance()


def test_a_wrong_token_is_refused_and_logged_and_nothing_moves(caplog):
    with serving(RecordingDriver) as (server, driver):
        with caplog.at_level(logging.WARNING, logger="attribot.bridge"):
            with pytest.raises(BridgeError, match="refused the bridge token") as info:
                BridgeWorld(url=url(server), token="wrong")
        assert "ATTRIBOT_BRIDGE_TOKEN" in (info.value.fix or "")
        assert any("wrong token" in r.getMessage() for r in caplog.records)
        # a raw client that skips hello and commands the base is refused too
        with socket.create_connection(server.address) as sock:
            send_message(sock, {"op": "base", "vx": 0.3, "vy": 0.0, "wz": 0.0})
            reply, _ = recv_message(sock)
        assert reply["ok"] is False and reply["code"] == "hello"
        assert all(v == (0.0, 0.0, 0.0) for _, v in driver.drives)


def test_a_protocol_version_mismatch_names_both_versions():
    with serving(RecordingDriver) as (server, _), socket.create_connection(server.address) as sock:
        send_message(sock, {"op": "hello", "version": PROTOCOL_VERSION + 1, "token": TOKEN})
        reply, _ = recv_message(sock)
    assert reply["ok"] is False and reply["code"] == "version"
    assert f"client speaks version {PROTOCOL_VERSION + 1}" in reply["error"]
    assert f"robot speaks version {PROTOCOL_VERSION}" in reply["error"]


def test_base_velocity_is_clipped_and_ramped_at_the_acceleration_limit():
    limits = Limits(max_speed=0.4, max_turn=1.0, max_accel=1.0, max_turn_accel=4.0, watchdog_s=2.0)
    with (
        serving(RecordingDriver, limits) as (server, driver),
        BridgeWorld(url=url(server), token=TOKEN) as world,
    ):
        world.command_base(5.0, -5.0, 9.0)
        first = driver.velocity
        assert first[0] <= 1.0 * 0.02 + 1e-9  # one ramp tick: a = 1 m/s^2 for 20 ms
        world.step(0.8)
        v = driver.velocity
        assert v == pytest.approx((0.4, -0.4, 1.0))  # clipped to the speed limits, reached by ramping
        times = [t for t, vel in driver.drives if 0 < vel[0] < 0.4]
        assert times and times[-1] - driver.drives[0][0] >= 0.3  # 0.4 m/s at 1 m/s^2 takes 0.4 s
        world.stop()
        assert driver.velocity == (0.0, 0.0, 0.0)


def test_the_watchdog_stops_the_robot_when_commands_stop_arriving():
    limits = Limits(watchdog_s=0.3)
    with (
        serving(RecordingDriver, limits) as (server, driver),
        BridgeWorld(url=url(server), token=TOKEN) as world,
    ):
        sent = time.monotonic()  # before the command: the server cannot have received it earlier
        world.command_base(0.2, 0.0, 0.0)
        time.sleep(0.1)
        assert driver.velocity[0] > 0
        deadline = sent + 2.0
        while not driver.stopped_at and time.monotonic() < deadline:
            time.sleep(0.01)
        assert driver.stopped_at, "the watchdog never stopped the robot"
        since_command = driver.stopped_at[0] - sent
        assert 0.3 <= since_command < 0.3 + 0.4  # 50 Hz watchdog; slack for a loaded machine
        assert driver.velocity == (0.0, 0.0, 0.0)
        assert any("watchdog" in why for _, why in server.stops)


def _hello(sock: socket.socket) -> dict[str, Any]:
    send_message(sock, {"op": "hello", "version": PROTOCOL_VERSION, "token": TOKEN})
    return recv_message(sock)[0]


@pytest.mark.parametrize(
    "request_",
    [
        {"op": "base", "vx": float("nan"), "vy": 0.0, "wz": 0.0},
        {"op": "base", "vx": 0.1, "vy": float("inf"), "wz": 0.0},
        {"op": "base", "vx": 0.1, "vy": 0.0, "wz": float("-inf")},
        {"op": "base", "vx": "0.3", "vy": 0.0, "wz": 0.0},
        {"op": "base", "vx": True, "vy": 0.0, "wz": 0.0},
        {"op": "base", "vy": 0.0, "wz": 0.0},
        {"op": "arm", "lift": float("nan"), "extension": 0.1},
        {"op": "step", "seconds": float("inf")},
    ],
    ids=["nan", "inf", "-inf", "text", "bool", "missing", "arm-nan", "step-inf"],
)
def test_non_finite_numbers_are_refused_robot_side_and_nothing_moves(request_):
    # issue 22 item 19: clipping a NaN gives the limit, so {"vx": NaN} drove the base at full speed
    with serving(RecordingDriver) as (server, driver), socket.create_connection(server.address) as sock:
        assert _hello(sock)["ok"] is True
        send_message(sock, request_)  # Python's json writes NaN and Infinity, as a hostile client may
        reply, _ = recv_message(sock)
        assert reply["ok"] is False and reply["code"] == "value", reply
        key = next(k for k in ("vx", "vy", "wz", "lift", "seconds") if k in reply["error"])
        assert f"needs {key} as a finite number" in reply["error"]
        send_message(sock, {"op": "base", "vx": 0.1, "vy": 0.0, "wz": 0.0})  # the session goes on
        assert recv_message(sock)[0]["ok"] is True
    assert all(math.isfinite(x) and abs(x) <= 0.1 + 1e-9 for _, v in driver.drives for x in v)
    assert driver.arm == []


def test_an_idle_connection_holds_nothing_and_is_dropped_after_the_hello_deadline():
    # issue 22 item 20: one connection that sent nothing blocked the robot for every client
    with serving(RecordingDriver) as (server, _), socket.create_connection(server.address) as idle:
        with BridgeWorld(url=url(server), token=TOKEN) as world:  # served at once, idle or not
            assert world.observe().rgb.shape == (2, 4, 3)
        idle.settimeout(30)
        assert idle.recv(1) == b""  # the robot closed it: no hello within the deadline


def test_a_hello_trickled_a_byte_at_a_time_is_cut_at_the_deadline():
    import select
    import struct

    with serving(RecordingDriver) as (server, _), socket.create_connection(server.address) as slow:
        slow.sendall(struct.pack(">4sII", b"ATB1", 1000, 0))  # a header of 1000 bytes is announced
        closed = False
        for _ in range(60):  # then sent a byte every 0.25 s: it would take 250 s
            try:
                slow.sendall(b" ")
            except OSError:
                closed = True
                break
            readable, _, _ = select.select([slow], [], [], 0.25)
            if readable:
                try:
                    closed = slow.recv(1) == b""
                except OSError:
                    closed = True
                break
        assert closed  # the robot hung up long before the hello was whole


def test_one_address_cannot_take_every_hello_slot():
    import select

    from attribot.bridge.server import MAX_GREETING_PER_ADDRESS

    with serving(RecordingDriver) as (server, _):
        idle = [socket.create_connection(server.address) for _ in range(MAX_GREETING_PER_ADDRESS + 2)]
        try:
            closed: list[socket.socket] = []
            deadline = time.monotonic() + 1.5  # within the hello deadline: only those past the cap close
            while len(closed) < 2 and time.monotonic() < deadline:
                open_ = [s for s in idle if s not in closed]
                readable, _, _ = select.select(open_, [], [], 0.1)
                closed += [s for s in readable if s.recv(1) == b""]
            assert len(closed) == 2
            assert select.select([s for s in idle if s not in closed], [], [], 0)[0] == []
        finally:
            for s in idle:
                s.close()
        deadline = time.monotonic() + 2.0
        while server._greeting and time.monotonic() < deadline:  # its threads see the connections close
            time.sleep(0.01)
        with BridgeWorld(url=url(server), token=TOKEN) as world:  # and once they are gone, a client is served
            assert world.observe().rgb.shape == (2, 4, 3)


def test_a_second_client_is_told_the_robot_is_busy():
    with serving(RecordingDriver) as (server, _):
        with BridgeWorld(url=url(server), token=TOKEN) as first:
            with pytest.raises(BridgeError, match="robot busy") as info:
                BridgeWorld(url=url(server), token=TOKEN, timeout_s=30)
            assert "wait until that client has finished" in (info.value.fix or "")
            assert first.observe().rgb.shape == (2, 4, 3)  # the first is still served
        for _ in range(2):  # once it has gone, the next client is served
            with BridgeWorld(url=url(server), token=TOKEN) as again:
                assert again.observe().rgb.shape == (2, 4, 3)


def test_a_client_with_a_wrong_token_is_refused_even_while_the_robot_is_busy():
    with serving(RecordingDriver) as (server, _), BridgeWorld(url=url(server), token=TOKEN):
        with pytest.raises(BridgeError, match="refused the bridge token"):
            BridgeWorld(url=url(server), token="wrong")


_CLIENT = textwrap.dedent(
    """
    import sys, time
    from attribot.embodiments.bridge import BridgeWorld
    world = BridgeWorld(url=sys.argv[1], token=sys.argv[2])
    while True:  # a planner servoing: a command every 50 ms
        world.command_base(0.3, 0.0, 0.5)
        print("sent", flush=True)
        time.sleep(0.05)
    """
)


def test_killing_the_client_mid_session_stops_the_base_within_the_watchdog_time():
    limits = Limits(watchdog_s=0.5)
    with serving(RecordingDriver, limits) as (server, driver):
        client = subprocess.Popen(
            [sys.executable, "-c", _CLIENT, url(server), TOKEN], stdout=subprocess.PIPE, text=True
        )
        try:
            for _ in range(5):  # it is driving
                assert client.stdout is not None and client.stdout.readline() == "sent\n"
            assert driver.velocity[0] > 0
            killed = time.monotonic()
            client.send_signal(signal.SIGKILL)
            client.wait(timeout=10)
            while driver.velocity != (0.0, 0.0, 0.0) and time.monotonic() < killed + 3:
                time.sleep(0.005)
            stopped = next(t for t, v in driver.drives if t >= killed and v == (0.0, 0.0, 0.0))
        finally:
            if client.poll() is None:
                client.kill()
        assert stopped - killed < limits.watchdog_s
        assert driver.velocity == (0.0, 0.0, 0.0)


# --- hostile clients: the robot stops on anything it refuses, and no message ends the server ----------


def _raw(sock: socket.socket, head: bytes, payload: bytes = b"") -> None:
    """Send a message whose header bytes are given as they are (json.dumps cannot write most of these)."""
    sock.sendall(struct.pack(">4sII", b"ATB1", len(head), len(payload)) + head + payload)


@contextmanager
def _session(
    limits: Limits | None = None, make: Callable[[], Driver] = RecordingDriver
) -> Iterator[tuple[RobotServer, Any, socket.socket]]:
    """A served driver and a raw client that has said hello."""
    with serving(make, limits) as (server, driver), socket.create_connection(server.address) as sock:
        sock.settimeout(30)
        assert _hello(sock)["ok"] is True
        yield server, driver, sock


def _still_served(server: RobotServer) -> None:
    """The server lives on: a new client is served and can drive."""
    with BridgeWorld(url=url(server), token=TOKEN, timeout_s=30) as world:
        world.command_base(0.05, 0.0, 0.0)
        world.stop()


def _until(condition: Callable[[], bool], timeout: float = 3.0) -> bool:
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.005)
    return condition()


_REFUSED = {
    "nan-speed": (b'{"op":"base","vx":NaN,"vy":0,"wz":0}', "value"),
    "unknown-op": (b'{"op":"fly"}', "op"),
    "no-capability": (b'{"op":"grasp"}', "unsupported"),
    "arm-far-off": (b'{"op":"arm","lift":1e6,"extension":0}', "value"),
    "not-json": (b"{op: base}", "message"),
}


@pytest.mark.parametrize("name", list(_REFUSED))
def test_a_refused_request_stops_the_base_and_does_not_keep_it_driving(name):
    # issue 28: refused requests reset the watchdog, so a base kept driving at 0.4 m/s
    head, code = _REFUSED[name]
    limits = Limits(max_speed=0.4, max_accel=100.0, max_turn_accel=100.0, watchdog_s=0.3, simulated=True)
    with _session(limits) as (server, driver, sock):
        send_message(sock, {"op": "base", "vx": 0.4, "vy": 0.0, "wz": 0.0})
        assert recv_message(sock)[0]["ok"] is True
        assert _until(lambda: driver.velocity[0] == pytest.approx(0.4))
        for _ in range(8):  # refused requests keep coming, faster than the watchdog's time
            _raw(sock, head)
            reply = recv_message(sock)[0]
            assert reply["ok"] is False and reply["code"] == code, reply
            assert driver.velocity == (0.0, 0.0, 0.0)  # stopped before the refusal was sent
            time.sleep(0.1)
        assert driver.velocity == (0.0, 0.0, 0.0) and driver.arm == []
        assert any("refused" in why for _, why in server.stops)


def test_only_accepted_commands_feed_the_watchdog():
    limits = Limits(max_accel=100.0, max_turn_accel=100.0, watchdog_s=0.3, simulated=True)
    with _session(limits) as (server, driver, sock):
        send_message(sock, {"op": "base", "vx": 0.2, "vy": 0.0, "wz": 0.0})
        assert recv_message(sock)[0]["ok"] is True
        for _ in range(6):  # accepted requests, each within the watchdog's time: the base drives on
            time.sleep(0.1)
            send_message(sock, {"op": "observe"})
            assert recv_message(sock)[0]["ok"] is True
        assert driver.velocity[0] == pytest.approx(0.2) and not driver.stopped_at
        assert _until(lambda: bool(driver.stopped_at), 2.0)  # silence: the watchdog stops it
        assert any("watchdog" in why for _, why in server.stops)


def test_a_message_nested_200000_deep_is_refused_and_the_server_serves_on():
    # issue 28: one authenticated message nested 200,000 deep killed the server (RecursionError)
    with serving(RecordingDriver) as (server, driver):
        with socket.create_connection(server.address) as sock:
            sock.settimeout(30)
            assert _hello(sock)["ok"] is True
            _raw(sock, b'{"op":"base","vx":' + b"[" * 200_000 + b"]" * 200_000 + b',"vy":0,"wz":0}')
            reply = recv_message(sock)[0]
            assert reply["ok"] is False and reply["code"] == "message" and "too large" in reply["error"]
        with socket.create_connection(server.address) as sock:  # deep but small: refused for its depth
            sock.settimeout(30)
            assert _hello(sock)["ok"] is True
            _raw(sock, b'{"op":"base","vx":' + b"[" * 20_000 + b"]" * 20_000 + b',"vy":0,"wz":0}')
            reply = recv_message(sock)[0]
            assert reply["ok"] is False and reply["code"] == "message" and "16 deep" in reply["error"]
            send_message(sock, {"op": "base", "vx": 0.1, "vy": 0.0, "wz": 0.0})  # the session goes on
            assert recv_message(sock)[0]["ok"] is True
            send_message(sock, {"op": "bye"})
            recv_message(sock)
        _still_served(server)


def test_a_4001_digit_number_is_a_value_error_not_a_driver_failure():
    with _session() as (server, driver, sock):
        _raw(sock, b'{"op":"base","vx":1' + b"0" * 4000 + b',"vy":0,"wz":0}')
        reply = recv_message(sock)[0]
        assert reply["ok"] is False and reply["code"] == "value", reply
        assert "needs vx as a finite number" in reply["error"]
        _raw(sock, b'{"op":"step","seconds":' + b"9" * 5000 + b"}")  # past Python's own int limit too
        assert recv_message(sock)[0]["code"] == "value"
        assert all(math.isfinite(x) for _, v in driver.drives for x in v)


_HOSTILE = [
    ("not-json", b"not json at all", "message"),
    ("array", b"[1, 2, 3]", "message"),
    ("not-utf8", b'{"op":"\xff\xfe"}', "message"),
    ("truncated", b'{"op":"base","vx":0.1', "message"),
    ("object-speed", b'{"op":"base","vx":{"a":1},"vy":0,"wz":0}', "value"),
    ("list-speed", b'{"op":"base","vx":[0.1],"vy":0,"wz":0}', "value"),
    ("null-speed", b'{"op":"base","vx":null,"vy":0,"wz":0}', "value"),
    ("overflow-float", b'{"op":"base","vx":1e400,"vy":0,"wz":0}', "value"),
    ("duplicate-key", b'{"op":"base","vx":0.1,"vx":NaN,"vy":0,"wz":0}', "value"),
    ("null-op", b'{"op":null}', "op"),
    ("object-op", b'{"op":{"op":"base"}}', "op"),
    ("long-step", b'{"op":"step","seconds":1e6}', "value"),
    ("negative-step", b'{"op":"step","seconds":-1}', "value"),
    ("no-head", b'{"op":"head","pan":0,"tilt":0}', "unsupported"),
    ("sensor-list", b'{"op":"read","sensor":["temperature"]}', "unsupported"),
    ("second-hello", b'{"op":"hello","version":1,"token":"correct horse"}', "op"),
]


@pytest.mark.parametrize("head, code", [(h, c) for _, h, c in _HOSTILE], ids=[n for n, _, _ in _HOSTILE])
def test_a_malformed_request_is_refused_with_its_code_and_the_session_goes_on(head, code):
    with _session() as (server, driver, sock):
        _raw(sock, head)
        reply = recv_message(sock)[0]
        assert reply["ok"] is False and reply["code"] == code, reply
        assert reply["error"] and reply["fix"]
        send_message(sock, {"op": "base", "vx": 0.1, "vy": 0.0, "wz": 0.0})
        assert recv_message(sock)[0]["ok"] is True
    assert all(math.isfinite(x) and abs(x) <= 0.1 + 1e-9 for _, v in driver.drives for x in v)


def test_a_huge_string_is_not_echoed_back():
    with _session() as (server, driver, sock):
        _raw(sock, json.dumps({"op": "x" * 60_000}).encode())
        reply = recv_message(sock)[0]
        assert reply["code"] == "op" and len(reply["error"]) < 200
        _raw(sock, json.dumps({"op": "base", "vx": "y" * 60_000, "vy": 0, "wz": 0}).encode())
        reply = recv_message(sock)[0]
        assert reply["code"] == "value" and len(reply["error"]) < 200


@pytest.mark.parametrize(
    "prefix",
    [
        struct.pack(">4sII", b"ATB1", 2 << 20, 0),  # a 2 MiB header announced
        struct.pack(">4sII", b"ATB1", 20, 1 << 20),  # a request with a payload (requests carry none)
        struct.pack(">4sII", b"HTTP", 0, 0),  # not a bridge message
    ],
    ids=["huge-header", "payload", "bad-magic"],
)
def test_a_message_over_the_limits_is_answered_then_the_connection_closed(prefix):
    limits = Limits(max_accel=100.0, max_turn_accel=100.0, watchdog_s=5.0, simulated=True)
    with serving(RecordingDriver, limits) as (server, driver):
        with socket.create_connection(server.address) as sock:
            sock.settimeout(30)
            assert _hello(sock)["ok"] is True
            send_message(sock, {"op": "base", "vx": 0.3, "vy": 0.0, "wz": 0.0})
            assert recv_message(sock)[0]["ok"] is True
            sock.sendall(prefix)  # nothing of the announced bytes is read: the reply comes at once
            reply = recv_message(sock)[0]
            assert reply["ok"] is False and reply["code"] == "message", reply
            assert sock.recv(1) == b""  # then closed
        assert _until(lambda: driver.velocity == (0.0, 0.0, 0.0))
        _still_served(server)


def test_a_request_trickled_after_the_hello_is_cut_and_frees_the_robot(monkeypatch):
    import attribot.bridge.server as bridge_server

    monkeypatch.setattr(bridge_server, "MESSAGE_TIMEOUT_S", 0.5)
    with serving(RecordingDriver) as (server, _), socket.create_connection(server.address) as slow:
        slow.settimeout(30)
        assert _hello(slow)["ok"] is True
        slow.sendall(struct.pack(">4sII", b"ATB1", 40, 0) + b'{"op":')  # and the rest never comes
        reply = recv_message(slow)[0]
        assert reply["code"] == "message" and "did not arrive in time" in reply["error"]
        assert slow.recv(1) == b""
        _still_served(server)  # not "robot busy": the trickling client no longer holds it


@pytest.mark.parametrize(
    "hello, code",
    [
        (b'{"op":"hello","version":1,"token":"\\ud800"}', "auth"),  # a lone surrogate
        (b'{"op":"hello","version":true,"token":"correct horse"}', "version"),
        (b'{"op":"hello","version":1.0e0,"token":"correct horse"}', "version"),
        (b'{"op":"hello","version":1,"token":["correct horse"]}', "auth"),
        (b'{"op":"hello","version":1,"token":"correct horse"', "hello"),  # cut short
        (b'{"op":' + b"[" * 20_000 + b"]" * 20_000 + b"}", "hello"),
        (b'{"op":' + b"[" * 200_000 + b"]" * 200_000 + b"}", "hello"),
        (b"\x00" * 100, "hello"),
    ],
    ids=["surrogate", "bool-version", "float-version", "list-token", "truncated", "deep", "huge", "nul"],
)
def test_a_strange_hello_is_refused_with_its_code_and_the_robot_serves_on(hello, code):
    with serving(RecordingDriver) as (server, driver):
        with socket.create_connection(server.address) as sock:
            sock.settimeout(30)
            _raw(sock, hello)
            reply = recv_message(sock)[0]
        assert reply["ok"] is False and reply["code"] == code, reply
        assert driver.drives == []
        _still_served(server)


class _BodiedDriver(RecordingDriver):
    """A recording robot that states the EP's body: its arm's travel is the body's lift and arm range."""

    def body(self) -> dict[str, Any]:
        from attribot.bridge.robomaster_body import EP_BODY

        return dict(EP_BODY)


def test_arm_targets_are_clipped_to_the_stated_travel_and_far_off_ones_refused():
    # issue 28: arm targets reached the SDK unclipped (lift=1e6 became moveto(x=-1e9, ...))
    with _session(make=_BodiedDriver) as (server, driver, sock):
        send_message(sock, {"op": "bye"})
        recv_message(sock)
    with serving(_BodiedDriver) as (server, driver):
        with socket.create_connection(server.address) as sock:
            hello = _hello(sock)
            assert hello["travel"]["lift"] == [0.03, 0.22] and hello["travel"]["extension"] == [0.0, 0.065]
            send_message(sock, {"op": "bye"})
            recv_message(sock)
        with BridgeWorld(url=url(server), token=TOKEN) as world:
            for lift, extension in ((1e6, 0.0), (0.1, -1e6), (-0.5, 0.0), (0.1, 0.2)):
                with pytest.raises(BridgeError, match="outside its travel"):
                    world.set_arm(lift, extension)
            assert driver.arm == []
            world.set_arm(0.23, 0.07)  # a hair beyond the travel: clipped into it
            world.set_arm(0.1, 0.03)  # within: as given
    assert driver.arm == [(0.22, 0.065), (0.1, 0.03)]


def test_the_watchdog_outlives_a_driver_that_fails_to_drive():
    class Failing(RecordingDriver):
        def drive(self, vx: float, vy: float, wz: float) -> None:
            if vx > 0.1:
                raise RuntimeError("the chassis stopped answering")
            super().drive(vx, vy, wz)

    limits = Limits(max_accel=1.0, watchdog_s=5.0)
    with _session(limits, Failing) as (server, driver, sock):
        send_message(sock, {"op": "base", "vx": 0.3, "vy": 0.0, "wz": 0.0})
        assert recv_message(sock)[0]["ok"] is True  # the ramp starts below 0.1 m/s
        # the watchdog thread's ramp meets the failure: it stops the robot, and lives on
        assert _until(lambda: any("failed to drive" in why for _, why in server.stops))
        assert driver.velocity == (0.0, 0.0, 0.0)
        send_message(sock, {"op": "base", "vx": 0.05, "vy": 0.0, "wz": 0.0})
        assert recv_message(sock)[0]["ok"] is True
        assert _until(lambda: driver.velocity[0] == pytest.approx(0.05))
        assert _until(lambda: bool(driver.stopped_at), 6.0)  # and still watches: silence stops it


def test_a_blank_token_is_refused_before_serving():
    for blank in ("", "   ", "\t\n"):
        with pytest.raises(ValueError, match="not blank"):
            RobotServer(RecordingDriver(), blank)
    served = subprocess.run(
        [sys.executable, "-m", "attribot.cli", "bridge", "serve", "--driver", "mujoco", "--token", "  "],
        capture_output=True, text=True, env=_env(), timeout=120,
    )  # fmt: skip
    assert served.returncode == 2 and "error: --token is blank" in served.stderr and "fix:" in served.stderr


def test_a_robot_that_answers_a_deep_message_is_a_bridge_error_on_the_host():
    """The host reads the robot's replies with the same bounds: a hostile robot cannot crash the planner."""
    import threading

    listener = socket.create_server(("127.0.0.1", 0))
    port = listener.getsockname()[1]

    def robot() -> None:
        conn, _ = listener.accept()
        with conn:
            recv_message(conn)
            _raw(conn, b'{"ok":true,"robot":' + b"[" * 100_000 + b"]" * 100_000 + b"}")
            conn.recv(1)

    thread = threading.Thread(target=robot, daemon=True)
    thread.start()
    try:
        with pytest.raises(BridgeError, match="stopped answering"):
            BridgeWorld(url=f"tcp://127.0.0.1:{port}", token=TOKEN, timeout_s=30)
    finally:
        listener.close()
        thread.join(timeout=10)


class PartsDriver(RecordingDriver):
    """A robot whose frames carry the per-pixel parts given, as it sends them (well formed or not)."""

    def __init__(self, **parts: Any) -> None:
        super().__init__()
        self.parts = parts

    def capabilities(self) -> list[str]:
        return ["camera"]

    def frame(self) -> CameraFrame:
        frame = super().frame()
        for name, value in self.parts.items():
            setattr(frame, name, value)
        return frame


@pytest.mark.parametrize(
    "parts, named",
    [
        ({"own_body": np.ones((3, 4), bool)}, "own_body part of shape"),  # not the frame's 2 x 4
        ({"depth": np.ones((2, 5), np.float32)}, "depth part of shape"),
        ({"segmentation": np.full((2, 4), -1, np.int32)}, None),  # well formed: kept
        ({"own_body": np.eye(2, 4, dtype=bool)}, None),
    ],
)
def test_a_frames_per_pixel_parts_must_be_the_frames_size(parts, named):
    """Depth, segmentation and the robot's own pixels come at the camera frame's size, or the frame is
    refused naming the part (a robot's reply is read within bounds, as a request is)."""
    with (
        serving(lambda: PartsDriver(**parts)) as (server, _),
        BridgeWorld(url=url(server), token=TOKEN) as bridge,
    ):
        if named is not None:
            with pytest.raises(BridgeError, match=named):
                bridge.observe()
            return
        frame = bridge.observe()
    if "own_body" in parts:
        assert np.array_equal(frame.own_body, parts["own_body"])
    else:
        assert np.array_equal(frame.segmentation, parts["segmentation"]) and frame.own_body is None


def test_a_compressed_part_is_never_inflated_past_the_frames_size(monkeypatch):
    """A segmentation that inflates to far more than a frame's worth (a zip bomb) is refused after
    reading one byte more than the frame's size."""
    import zlib

    from attribot.bridge import requests as robot_side

    real = robot_side._frame

    def bomb(driver, frame):
        header, payload = real(driver, frame)
        huge = zlib.compress(b"\0" * (64 << 20), 9)  # 64 MiB of zeros in about 64 kB
        header["parts"] = [["jpeg", header["parts"][0][1]], ["segmentation", len(huge)]]
        header["segmentation_shape"] = [2, 4]
        return header, payload[: header["parts"][0][1]] + huge

    monkeypatch.setattr(robot_side, "_frame", bomb)
    with serving(lambda: PartsDriver()) as (server, _), BridgeWorld(url=url(server), token=TOKEN) as bridge:
        with pytest.raises(BridgeError, match="segmentation part holds 33 bytes where 32 were due"):
            bridge.observe()


# --- the mujoco driver end to end ----------------------------------------------------------------


def _mujoco_driver() -> Driver:
    return EmbodimentDriver(MujocoWorld(SceneConfig(layout=LAYOUT, seed=SEED)))


@pytest.fixture(scope="module")
def mujoco_server() -> Iterator[RobotServer]:
    with serving(
        _mujoco_driver, Limits(max_accel=100.0, max_turn_accel=100.0, watchdog_s=5.0, simulated=True)
    ) as (
        server,
        _,
    ):
        yield server


def test_frames_and_sensors_over_the_bridge_match_the_direct_world(mujoco_server):
    with (
        BridgeWorld(url=url(mujoco_server), token=TOKEN) as bridge,
        MujocoWorld(layout=LAYOUT, seed=SEED) as direct,
    ):
        assert bridge.capabilities() == direct.capabilities()
        assert bridge.camera_info() == direct.camera_info()
        got, want = bridge.observe(), direct.observe()
        assert got.rgb.shape == want.rgb.shape
        assert np.abs(got.rgb.astype(int) - want.rgb).mean() < 2.0  # JPEG at quality 90
        assert np.array_equal(got.depth, want.depth)
        assert np.array_equal(got.segmentation, want.segmentation) and got.objects == want.objects
        assert bridge.read_distance() == direct.read_distance()
        assert bridge.joint_states() == direct.joint_states()
        # the robot's own pixels travel too (the head looking down at its gripper): detectors on the host
        # set aside a box on it
        joints = bridge.joint_states()
        for world in (bridge, direct):
            world.set_head(0.0, -1.0)
            world.step(1.0)
        got, want = bridge.observe(), direct.observe()
        bridge.set_head(
            joints["head_pan"], joints["head_tilt"]
        )  # the server's world as the next test expects
        bridge.step(1.0)
        assert want.own_body is not None and want.own_body.any()
        assert got.own_body is not None and np.array_equal(got.own_body, want.own_body)


class _PrivilegedThroughBridge:
    """The scripted pick-up's targets from the server's simulator, every command through the bridge:
    what #9's servo controller will do with vision instead of the simulator's truth."""

    def __init__(self, bridge: BridgeWorld, sim: Any) -> None:
        self._bridge = bridge
        self.sim = sim

    def __getattr__(self, name: str) -> Any:
        return getattr(self._bridge, name)


def test_the_weight_path_over_the_bridge_reads_what_the_direct_world_reads():
    from attribot.sim import scripted

    def weigh(world: Any, object_id: str) -> float:
        scripted.approach_object(world, object_id)
        assert scripted.pick_object(world, object_id)
        world.step(0.5)
        force = world.read_force()
        scripted.place_back(world)
        return float(-force[2])

    limits = Limits(max_accel=1000.0, max_turn_accel=1000.0, watchdog_s=30.0, simulated=True)
    with serving(_mujoco_driver, limits) as (server, driver):
        sim = driver.world.sim  # type: ignore[attr-defined]
        pickable = [o.id for o in sim.objects.values() if o.category.pickable][:2]
        assert len(pickable) == 2
        with BridgeWorld(url=url(server), token=TOKEN) as bridge:
            over = {oid: weigh(_PrivilegedThroughBridge(bridge, sim), oid) for oid in pickable}
    with MujocoWorld(layout=LAYOUT, seed=SEED) as direct:
        here = {oid: weigh(direct, oid) for oid in pickable}
    for oid in pickable:
        assert over[oid] > 0.05
        assert over[oid] == pytest.approx(here[oid], rel=0.02, abs=0.01)


def test_the_servo_controller_weighs_over_the_bridge_as_in_the_direct_world():
    from attribot.api import Perception, Robot
    from attribot.config import load_settings

    perception = Perception.from_settings(load_settings(detector="oracle", vqa="oracle", language="catalog"))

    def weigh_all(world: Any) -> dict[str, float]:
        robot = Robot(sensors=["camera", "force"], world=world)
        assert robot.backend_name() == "servo"
        out = {}
        for patch in robot.look(perception).find("object")[:2]:
            robot.go_to_object(patch)
            robot.pick_up(patch)
            out[patch.object_id] = robot.measure_weight(patch)
            robot.put_down()
        return out

    limits = Limits(max_accel=1000.0, max_turn_accel=1000.0, watchdog_s=30.0, simulated=True)
    with serving(_mujoco_driver, limits) as (server, _), BridgeWorld(url=url(server), token=TOKEN) as bridge:
        with MujocoWorld(layout=LAYOUT, seed=SEED) as direct:
            assert bridge.body() == direct.body()
            here = weigh_all(direct)
        over = weigh_all(bridge)
    assert len(here) == 2 and over.keys() == here.keys()
    for oid in here:
        assert over[oid] == pytest.approx(here[oid], rel=0.01)


def test_a_robot_that_does_not_state_its_body_is_not_driven_by_perception():
    with serving(RecordingDriver) as (server, _), BridgeWorld(url=url(server), token=TOKEN) as world:
        with pytest.raises(UnsupportedAction, match="does not state its body geometry"):
            world.body()


def test_grasp_without_the_capability_is_refused_by_the_robot():
    with serving(RecordingDriver) as (server, _), BridgeWorld(url=url(server), token=TOKEN) as world:
        with pytest.raises(UnsupportedAction, match="no gripper capability"):
            world.grasp()


# --- the commands ------------------------------------------------------------------------------


def _env(**extra: str) -> dict[str, str]:
    return {**os.environ, "ATTRIBOT_CONFIG": str(EMPTY_SETTINGS), **extra}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def _served_process() -> Iterator[int]:
    """`attribot bridge serve --driver mujoco` in its own process on a free port, stopped with SIGINT."""
    port = _free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "attribot.cli", "bridge", "serve", "--driver", "mujoco", "--layout", LAYOUT,
         "--seed", str(SEED), "--port", str(port), "--token", TOKEN],
        stderr=subprocess.PIPE, text=True, env=_env(),
    )  # fmt: skip
    try:
        wait_listening(port, proc, "bridge serve")
        yield port
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()


@pytest.fixture(scope="module")
def served_cli() -> Iterator[int]:
    with _served_process() as port:
        yield port


def _ask(*args: str, **env: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "attribot.cli", "ask", *args], capture_output=True, text=True, env=_env(**env),
        timeout=300,
    )  # fmt: skip


def test_cli_ask_over_the_bridge_answers_as_the_direct_world(served_cli):
    query = "Which object is the closest to the robot?"
    over = _ask(query, "--world", "bridge", "--bridge-url", f"tcp://127.0.0.1:{served_cli}",
                "--sensors", "camera,distance", "--json", ATTRIBOT_BRIDGE_TOKEN=TOKEN)  # fmt: skip
    assert over.returncode == 0, over.stderr
    here = _ask(query, "--layout", LAYOUT, "--seed", str(SEED), "--sensors", "camera,distance", "--json")
    assert here.returncode == 0, here.stderr
    a, b = json.loads(over.stdout), json.loads(here.stdout)
    assert a["error"] is None and a["answer"] == b["answer"] and a["object"]["box"] == b["object"]["box"]
    assert [t["call"] for t in a["trace"]] == [t["call"] for t in b["trace"]]


def test_cli_wrong_token_exits_2_and_says_so(served_cli):
    bad = _ask("Which object is the closest to the robot?", "--world", "bridge", "--bridge-url",
               f"tcp://127.0.0.1:{served_cli}", ATTRIBOT_BRIDGE_TOKEN="nope")  # fmt: skip
    assert bad.returncode == 2
    assert "refused the bridge token" in bad.stderr and "ATTRIBOT_BRIDGE_TOKEN" in bad.stderr
    none = _ask("the closest item", "--world", "bridge", "--bridge-url", f"tcp://127.0.0.1:{served_cli}",
                ATTRIBOT_BRIDGE_TOKEN="")  # fmt: skip
    assert none.returncode == 2 and "ATTRIBOT_BRIDGE_TOKEN is not set" in none.stderr
    nourl = _ask("the closest item", "--world", "bridge")
    assert nourl.returncode == 2 and "--bridge-url" in nourl.stderr


def test_cli_embodied_weight_query_over_the_bridge_answers_as_the_direct_world():
    query = "Which object is the heaviest?"
    with _served_process() as port:  # a robot of its own: it starts where the direct world starts
        over = _ask(query, "--world", "bridge", "--bridge-url", f"tcp://127.0.0.1:{port}",
                    "--sensors", "camera,force", "--json", ATTRIBOT_BRIDGE_TOKEN=TOKEN)  # fmt: skip
    assert over.returncode == 0, over.stderr
    here = _ask(query, "--layout", LAYOUT, "--seed", str(SEED), "--sensors", "camera,force", "--json")
    assert here.returncode == 0, here.stderr
    a, b = json.loads(over.stdout), json.loads(here.stdout)
    assert a["error"] is None and a["backends"]["robot"] == b["backends"]["robot"] == "servo"
    assert a["answer"] == b["answer"] and a["value"] == pytest.approx(b["value"], rel=0.01)
    weighed = [t for t in a["trace"] if t["call"] == "Robot.measure_weight"]
    direct = [t for t in b["trace"] if t["call"] == "Robot.measure_weight"]
    assert len(weighed) == len(direct) >= 2
    for x, y in zip(weighed, direct, strict=True):
        assert x["args"][0]["object_id"] == y["args"][0]["object_id"]
        assert x["result"] == pytest.approx(y["result"], rel=0.01)


# --- the bridge on a lab's network (issue 49) ----------------------------------------------------------

STRONG = "f3a9c1d27be84e06a5c4"


@pytest.mark.parametrize(
    ("token", "why"),
    [
        ("a", "1 character long"),
        ("password", "8 characters long"),
        ("aaaaaaaaaaaaaaaaaaaa", "one kind of character"),
        ("abcdefghijklmnopqrstu", "one kind of character"),
        ("ab12ab12ab12ab12ab12", "repeats 4 different characters"),
        ("MyPassword2024!!", "'password'"),
        ("\t", "blank"),
    ],
)
def test_off_loopback_a_weak_token_is_refused_before_anything_listens(token, why):
    from attribot.bridge.guard import bind_problem, token_problem

    assert why in (bind_problem("0.0.0.0", token) or "")
    with pytest.raises(ValueError, match="blank|token"):
        RobotServer(RecordingDriver(), token, host="0.0.0.0", port=1)  # refused before it binds
    assert bind_problem("127.0.0.1", "a") is None and token_problem(STRONG) is None


def test_python_m_bridge_binds_loopback_by_default_and_refuses_weak_tokens_beyond_it(monkeypatch, capsys):
    import attribot.bridge.__main__ as entry
    import attribot.bridge.robomaster as rm

    bound: list[Any] = []
    monkeypatch.setattr(rm.RoboMasterDriver, "connect", classmethod(lambda cls, **kw: RecordingDriver()))
    monkeypatch.setattr(RobotServer, "serve_forever", lambda self: bound.append(self.address))
    assert entry.main(["--token", "a", "--port", str(_free_port())]) == 0
    assert bound[0][0] == "127.0.0.1"
    for weak in ("a", "password", "\t"):
        with pytest.raises(SystemExit) as ended:
            entry.main(["--token", weak, "--host", "0.0.0.0"])
        assert ended.value.code == 2
    assert "at least 16" in capsys.readouterr().err


@pytest.mark.parametrize(
    "args",
    [
        ["-m", "attribot.bridge", "--token", "a"],
        ["-m", "attribot.cli", "bridge", "serve", "--driver", "robomaster", "--token", "a"],
    ],
)
def test_without_the_sdk_both_entry_points_end_in_one_line_naming_how_to_install_it(args):
    done = subprocess.run([sys.executable, *args], capture_output=True, text=True, env=_env(), timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "pip install robomaster" in lines[0], done.stderr


@pytest.mark.parametrize(
    ("flag", "value", "range_"),
    [
        ("--watchdog", "1e9", "0.05 to 5 s"),
        ("--max-speed", "1e6", "0.01 to 3.5 m/s"),
        ("--max-accel", "1e308", "0.01 to 10 m/s^2"),
        ("--max-turn", "nan", "0.01 to 10 rad/s"),
        ("--watchdog", "0", "0.05 to 5 s"),
    ],
)
def test_a_limit_outside_its_safe_range_is_refused_naming_the_range(flag, value, range_):
    import re

    from typer.testing import CliRunner

    import attribot.bridge.__main__ as entry
    from attribot.cli import app

    with pytest.raises(ValueError, match=re.escape(f"{flag} must lie in its safe range, {range_}")):
        Limits(**{{"--watchdog": "watchdog_s"}.get(flag, flag[2:].replace("-", "_")): float(value)})
    result = CliRunner().invoke(
        app, ["bridge", "serve", "--driver", "robomaster", "--token", "a", flag, value], env=_env()
    )
    assert result.exit_code == 2 and range_ in " ".join(result.output.split())
    with pytest.raises(SystemExit):
        entry.main(["--token", "a", flag, value])


def _hello_as(server: RobotServer, token: str) -> dict[str, Any]:
    with socket.create_connection(server.address, timeout=10) as sock:
        send_message(sock, {"op": "hello", "version": PROTOCOL_VERSION, "token": token})
        reply, _ = recv_message(sock)
        if reply.get("ok"):
            send_message(sock, {"op": "bye"})
            recv_message(sock)
    return reply


def test_wrong_tokens_are_slowed_then_blocked_per_peer_with_bounded_logging(caplog):
    from attribot.bridge.guard import WrongTokens

    with serving(RecordingDriver) as (server, driver):
        server.wrong_tokens = WrongTokens(free=2, block_after=6, max_delay_s=0.05, what="bridge")
        with caplog.at_level(logging.INFO):
            codes = []
            for _ in range(12):
                began = time.monotonic()
                codes.append((_hello_as(server, "wrong")["code"], time.monotonic() - began))
            right = _hello_as(server, TOKEN)
        assert [c for c, _ in codes] == ["auth"] * 6 + ["blocked"] * 6
        assert min(t for _, t in codes[3:6]) >= 0.04  # past the free ones, each answer waits
        assert right["ok"] is False and right["code"] == "blocked"  # a blocked address is refused outright
        lines = [r.getMessage() for r in caplog.records if "wrong token" in r.getMessage()]
        assert len(lines) <= 2, lines  # the first, and the block: not one a token
        assert not driver.drives


def test_the_throttle_forgets_a_peer_after_its_block_and_a_right_token_resets_the_count():
    from attribot.bridge.guard import WrongTokens

    now = [0.0]
    lines: list[str] = []

    class _Log:
        def warning(self, fmt: str, *args: Any) -> None:
            lines.append(fmt % args)

    throttle = WrongTokens(free=3, block_after=20, window_s=60, block_s=300, log=_Log(), clock=lambda: now[0])
    delays = [throttle.wrong("10.0.0.9") for _ in range(1500)]
    assert delays[:3] == [0.0] * 3 and delays[3] > 0 and max(delays) <= 2.0
    assert throttle.blocked("10.0.0.9") > 0 and throttle.blocked("10.0.0.8") == 0
    assert len(lines) == 2  # 1,500 wrong tokens: one line, then one for the block
    now[0] = 301.0
    assert throttle.blocked("10.0.0.9") == 0
    throttle.wrong("10.0.0.9")
    assert any("1500 wrong tokens from 10.0.0.9" in line for line in lines)  # the window's count, once
    throttle.right("10.0.0.9")
    assert throttle.counts() == {}
    for i in range(10_000):  # a scan of many addresses is bounded in memory
        throttle.wrong(f"10.1.{i // 256}.{i % 256}")
    assert len(throttle.counts()) <= throttle.max_peers
