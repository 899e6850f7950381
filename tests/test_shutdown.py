"""SIGTERM and SIGHUP to `attribot ask` / `exec` stop them the way Ctrl-C does: no process of theirs is
left behind (the sandbox worker runs in a session of its own, so the default action would orphan it)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import alive, wait_for

LOOP = "def execute_command(image, robot):\n    n = 0\n    while True:\n        n += 1\n"


def _children(pid: int) -> set[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return set()
    return {int(p) for p in text.split()}


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_signal_to_exec_stops_the_sandbox_worker(tmp_path, sig):
    program = tmp_path / "loop.py"
    program.write_text(LOOP)
    proc = subprocess.Popen(
        [sys.executable, "-c", "from attribot.cli import main; main()", "exec", str(program)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=tmp_path,
        # the signal's default action, as in a terminal: under `nohup` the suite inherits SIGHUP ignored,
        # which attribot rightly leaves ignored
        preexec_fn=lambda: signal.signal(sig, signal.SIG_DFL),
    )
    seen: set[int] = set()
    try:
        # the program runs once a worker has been busy for a while (the runner starts one ahead of need)
        def running() -> bool:
            seen.update(_children(proc.pid))
            return any(_cpu_ticks(p) > 20 for p in seen)

        assert wait_for(running, 120), "the program never started"
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=30)
        # the command's own words when it ended otherwise
        assert proc.returncode == 128 + sig, (out + err).decode(errors="replace")[-3000:]
        assert wait_for(lambda: not any(alive(p) for p in seen), 3), "a worker outlived the command"
        assert b"Traceback" not in err
    finally:
        proc.kill()
        proc.wait()
        for p in seen:
            if alive(p):
                os.kill(p, signal.SIGKILL)


SWALLOWED = """
import signal, time, weakref
from attribot.shutdown import termination_as_exit

class Thing:
    pass

with termination_as_exit():
    thing = Thing()
    # the signal lands inside a weakref callback, where Python prints an exception and drops it (as in
    # importlib's module-lock clean-up, where a CI run once lost a SIGTERM)
    ref = weakref.ref(thing, lambda _: signal.raise_signal(signal.SIGTERM))
    del thing
    time.sleep(20)
    print("outlived the signal", flush=True)
"""


def test_a_signal_dropped_by_a_callback_still_ends_the_program():
    proc = subprocess.run([sys.executable, "-c", SWALLOWED], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 128 + signal.SIGTERM, proc.stdout + proc.stderr
    assert "outlived" not in proc.stdout
    assert "Traceback" not in proc.stderr, proc.stderr


def _cpu_ticks(pid: int) -> int:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0
    return int(fields[11]) + int(fields[12])  # utime + stime


SERVER = """
import sys
from attribot.server import ServerConfig, serve_models, start_model_process
from conftest import BrightBoxDetector
proc = start_model_process("detector", BrightBoxDetector)
print(proc.pid, flush=True)
serve_models({"detector": proc, "vqa": None, "language": None}, ServerConfig(), port=int(sys.argv[1]),
             log_level="warning")
"""


def test_sigterm_to_the_server_with_a_stuck_model_call_leaves_nothing(tmp_path):
    """A model call that never ends, and SIGTERM: the server stops within seconds, the model process is
    gone and its shared memory unlinked."""
    import socket
    import threading

    import httpx
    import numpy as np

    from attribot.models.wire import encode_image

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parent)}
    server = subprocess.Popen(
        [sys.executable, "-c", SERVER, str(port)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    child = int(server.stdout.readline())
    url = f"http://127.0.0.1:{port}"
    try:
        assert wait_for(lambda: _reachable(url), 30)
        image = encode_image(np.full((8, 8, 3), 200, np.uint8), "png")
        answers: list[int] = []

        def stuck() -> None:
            try:
                answers.append(
                    httpx.post(
                        url + "/v1/detect", json={"image": image, "queries": ["hang"]}, timeout=60
                    ).status_code
                )
            except httpx.HTTPError:
                answers.append(-1)

        caller = threading.Thread(target=stuck)
        caller.start()
        blocks: list[str] = []

        def mapped() -> bool:
            try:
                maps = Path(f"/proc/{child}/maps").read_text()
            except OSError:
                return False
            blocks.extend({line.split()[-1] for line in maps.splitlines() if "/dev/shm/" in line})
            return bool(blocks)

        assert wait_for(mapped, 20), "the model process never read the shared memory"
        server.send_signal(signal.SIGTERM)
        server.wait(timeout=20)
        caller.join(30)
        assert wait_for(lambda: not alive(child), 3), "the model process outlived the server"
        assert [b for b in blocks if Path(b).exists()] == [], "shared memory left in /dev/shm"
        err = server.stderr.read()
        assert "leaked shared_memory" not in err, err
    finally:
        server.kill()
        server.wait()
        if alive(child):
            os.kill(child, signal.SIGKILL)


def _reachable(url: str) -> bool:
    import httpx

    try:
        return httpx.get(url + "/health", timeout=1).status_code == 200
    except httpx.HTTPError:
        return False


STUCK_LANGUAGE_SERVER = """
import sys, threading, time
from attribot.server import ServerConfig, serve_models

class Stuck:
    name = "test:stuck"
    def complete(self, question):
        print("started", flush=True)
        n = 0
        end = time.monotonic() + 600
        while time.monotonic() < end:  # host CPU in Python, like a parser that takes minutes
            n += 1
        return "late"

print("up", flush=True)
serve_models({"detector": None, "vqa": None, "language": Stuck()}, ServerConfig(), port=int(sys.argv[1]),
             log_level="warning")
"""


def test_sigterm_stops_the_server_while_a_backend_call_runs_in_its_thread(tmp_path):
    # issue 22 item 22: idle it stopped in 4.6 s, with such a call it was still alive after 105 s
    import threading

    import httpx

    from conftest import free_port

    port = free_port()
    server = subprocess.Popen(
        [sys.executable, "-c", STUCK_LANGUAGE_SERVER, str(port)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    url = f"http://127.0.0.1:{port}"
    try:
        assert server.stdout.readline().strip() == "up"
        assert wait_for(lambda: _reachable(url), 30)

        def ask() -> None:
            try:
                httpx.post(url + "/v1/complete", json={"question": "which is heavier?"}, timeout=120)
            except httpx.HTTPError:
                pass

        threading.Thread(target=ask, daemon=True).start()
        assert server.stdout.readline().strip() == "started"
        server.send_signal(signal.SIGTERM)
        # the call would run 600 s: exiting at all (in seconds) is the behaviour under test
        assert server.wait(timeout=60) == 128 + signal.SIGTERM
        assert "still running" in server.stderr.read()
    finally:
        server.kill()
        server.wait()
