"""SIGTERM and SIGHUP to `attribot ask` / `exec` stop them the way Ctrl-C does: no process of theirs is
left behind (the sandbox worker runs in a session of its own, so the default action would orphan it)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

LOOP = "def execute_command(image, robot):\n    n = 0\n    while True:\n        n += 1\n"


def _children(pid: int) -> set[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return set()
    return {int(p) for p in text.split()}


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def _wait_for(predicate, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.05)
    return predicate()


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_signal_to_exec_stops_the_sandbox_worker(tmp_path, sig):
    program = tmp_path / "loop.py"
    program.write_text(LOOP)
    proc = subprocess.Popen(
        [sys.executable, "-c", "from attribot.cli import main; main()", "exec", str(program)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=tmp_path,
    )
    seen: set[int] = set()
    try:
        # the program runs once a worker has been busy for a while (the runner starts one ahead of need)
        def running() -> bool:
            seen.update(_children(proc.pid))
            return any(_cpu_ticks(p) > 20 for p in seen)

        assert _wait_for(running, 120), "the program never started"
        proc.send_signal(sig)
        proc.wait(timeout=30)
        assert proc.returncode == 128 + sig
        assert _wait_for(lambda: not any(_alive(p) for p in seen), 3), "a worker outlived the command"
        assert b"Traceback" not in proc.stderr.read()
    finally:
        proc.kill()
        proc.wait()
        for p in seen:
            if _alive(p):
                os.kill(p, signal.SIGKILL)


def _cpu_ticks(pid: int) -> int:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0
    return int(fields[11]) + int(fields[12])  # utime + stime
