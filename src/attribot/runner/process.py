"""The sandbox's worker process as the host sees it: `Worker` starts one (`attribot.runner.worker`, isolated
Python), sends it messages and reads its replies within a deadline and a size, and kills it; `Cutter` cuts
a host-side API call still running at its run's deadline (`CallTimeout`).
"""

from __future__ import annotations

import json
import math
import os
import select
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from attribot.runner import worker

__all__ = [
    "CUT_SIGNAL",
    "STARTUP_S",
    "WORKER_PATH",
    "CallTimeout",
    "Cutter",
    "Gone",
    "Overflow",
    "Worker",
    "kill_worker",
]

WORKER_PATH = Path(worker.__file__).resolve()
STARTUP_S = 30.0  # a worker that is not ready by then is broken, not slow


class CallTimeout(BaseException):
    """Raised inside a host-side API call when the run's wall-clock deadline passes (a BaseException, so
    that a backend's `except Exception` cannot swallow it)."""


CUT_SIGNAL = signal.SIGRTMIN + 5 if hasattr(signal, "SIGRTMIN") else signal.SIGUSR2
"""The signal that cuts a host call: a real-time one that applications (and pytest-timeout's SIGALRM)
leave alone."""


class Cutter:
    """Cuts a host-side API call that is still running at its run's deadline.

    One watcher thread per runner, started with its first run, sleeps until the armed deadline and then
    signals the main thread if it is inside a call (`in_call`). `arm` (once per run, when the run is served
    from the main thread, where Python runs signal handlers, and the cutting signal is free) installs the
    handler and hands the watcher the deadline; `disarm` takes both back. The signal interrupts Python
    code and blocking system calls (a socket read from a stuck endpoint, a wait); a C call that never
    returns to Python (one model forward pass) ends first. A call itself only sets and clears `in_call`
    and reads the clock once, so the protection costs next to nothing per call. Elsewhere (another thread,
    the signal owned by the application) the deadline is checked when a call returns.
    """

    def __init__(self) -> None:
        self.in_call = False
        self._cond = threading.Condition()
        self._deadline: float | None = None  # armed: the deadline the watcher waits for
        self._target = 0
        self._thread: threading.Thread | None = None
        self._closed = False
        self._previous: Any = None
        self._armed = False

    def arm(self, deadline: float) -> None:
        """Watch `deadline` (time.monotonic) until `disarm`."""
        usable = threading.current_thread() is threading.main_thread() and signal.getsignal(CUT_SIGNAL) in (
            signal.SIG_DFL,
            signal.SIG_IGN,
            None,
        )
        if not usable or not math.isfinite(deadline) or self._armed:
            return
        self._previous = signal.signal(CUT_SIGNAL, self._expire)
        self._armed = True
        with self._cond:
            self._target = threading.get_ident()
            self._deadline = deadline
            if self._thread is None:
                self._thread = threading.Thread(target=self._watch, name="attribot-run-deadline", daemon=True)
                self._thread.start()
            self._cond.notify()

    def _watch(self) -> None:
        with self._cond:
            while not self._closed:
                if self._deadline is None:
                    self._cond.wait()
                    continue
                left = self._deadline - time.monotonic()
                if left > 0:
                    self._cond.wait(left)
                    continue
                # a call that starts after this check sees the deadline passed when it starts; the signal
                # is sent under the lock, so never after `disarm` has put the previous handler back
                if self.in_call:
                    signal.pthread_kill(self._target, CUT_SIGNAL)
                self._deadline = None

    def _expire(self, signum: int, frame: Any) -> None:
        if self.in_call:  # a signal that lands between calls is ignored
            self.in_call = False
            raise CallTimeout()

    def disarm(self) -> None:
        """Stop watching and put the previous handler back (the end of the run)."""
        self.in_call = False
        if not self._armed:
            return
        with self._cond:
            self._deadline = None
            self._cond.notify()
        signal.signal(CUT_SIGNAL, self._previous)
        self._armed = False

    def close(self) -> None:
        """End the watcher thread (the runner is closed)."""
        with self._cond:
            self._closed = True
            self._deadline = None
            self._cond.notify()


class Gone(Exception):
    """The worker closed its end of the pipe (it exited or was killed)."""


class Overflow(Exception):
    """The worker sent a message longer than the limit, or one that is not valid."""


class Worker:
    """One child process and the two pipes to it."""

    def __init__(self) -> None:
        to_child_r, to_child_w = os.pipe()
        from_child_r, from_child_w = os.pipe()
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-I", "-S", "-B", str(WORKER_PATH), str(to_child_r), str(from_child_w)],
                pass_fds=(to_child_r, from_child_w),
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                cwd="/",
                env={},
                start_new_session=True,  # a Ctrl-C at the terminal is the host's to handle
            )
        except BaseException:
            for fd in (to_child_r, to_child_w, from_child_r, from_child_w):
                os.close(fd)
            raise
        os.close(to_child_r)
        os.close(from_child_w)
        self.wfd = to_child_w
        self.rfd = from_child_r
        self.buf = bytearray()
        self.closed = False

    def alive(self) -> bool:
        return not self.closed and self.proc.poll() is None

    def send(self, msg: dict[str, Any]) -> None:
        data = (json.dumps(msg, separators=(",", ":")) + "\n").encode("ascii")
        view = memoryview(data)
        try:
            while view:
                n = os.write(self.wfd, view)
                view = view[n:]
        except (BrokenPipeError, OSError) as e:
            raise Gone() from e

    def recv(self, deadline: float, max_bytes: int) -> dict[str, Any] | None:
        """The next message, or None when `deadline` (time.monotonic) passes first."""
        while True:
            nl = self.buf.find(b"\n")
            if nl >= 0:
                line = bytes(self.buf[:nl])
                del self.buf[: nl + 1]
                try:
                    msg = json.loads(line)
                except (ValueError, RecursionError) as e:
                    raise Overflow("the program sent a message that is not valid") from e
                if not isinstance(msg, dict):
                    raise Overflow("the program sent a message that is not valid")
                return msg
            if len(self.buf) > max_bytes:
                raise Overflow(f"the program sent more than {max_bytes} bytes in one message")
            wait = deadline - time.monotonic()
            if wait <= 0:
                return None
            ready, _, _ = select.select([self.rfd], [], [], wait)
            if not ready:
                return None
            chunk = os.read(self.rfd, 1 << 16)
            if not chunk:
                raise Gone()
            self.buf += chunk

    def kill(self) -> int | None:
        """Stop the process (if it still runs) and close the pipes; returns its exit status."""
        if not self.closed:
            self.closed = True
            try:
                self.proc.kill()
            except OSError:
                pass
            for fd in (self.rfd, self.wfd):
                try:
                    os.close(fd)
                except OSError:
                    pass
        try:
            return self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            return None


def kill_worker(box: list[Worker | None]) -> None:
    worker = box[0]
    if worker is not None:
        worker.kill()
        box[0] = None
