"""The worker's state, the stop no program can catch, and its pipe to the host (the child side).

Run inside the sandbox (`worker.py`), so standard library only. `STATE` is the one state of the worker
process; `stop` raises a `SandboxStop` and records the first one, so it is reported even if something
swallowed it; `exchange` sends a message to the host with the timers held off.
"""

from __future__ import annotations

import json
import os

__all__ = [
    "STATE",
    "ActionFailed",
    "Channel",
    "SandboxStop",
    "dumps",
    "exchange",
    "on_timer",
    "stop",
]


class ActionFailed(Exception):
    """An action or measurement that ran and failed in the world (a grasp that closed on nothing, a
    rangefinder that saw nothing in range): the one error a program may catch (`except ActionFailed as
    error:`) to go on with the next object. It holds the host's message only."""


class SandboxStop(BaseException):
    """A stop the program cannot catch: a limit, a time-out, a refused or failed API call."""

    def __init__(self, category, message):
        super().__init__(message)
        self.category = category
        self.message = message


class _State:
    def __init__(self):
        self.chan = None
        self.stopped = None  # the first SandboxStop raised, reported even if swallowed
        self.critical = False  # inside pipe I/O: timers must not raise here
        self.pending = None  # a timer that fired during pipe I/O
        self.out_len = 0
        self.max_out = 0
        self.max_bits = 0
        self.max_seq = 0
        self.max_msg = 0
        self.timed_out = False  # timers raise once at most, so the clean-up cannot be hit twice
        self.stubs = {}
        self.classes = {}
        self.stub_types = {}
        self.constructors = {}  # class name -> (the session's object that builds it, the host method)
        self.owners = {}  # class name -> {method: takes one object}: its methods that are bare functions too
        self.made = {}  # class name -> [(object, line)] the program's `ClassName(...)` made
        self.implicit = {}  # class name -> the object its bare functions act on when the program made none
        self.borrowers = set()  # the classes whose objects take bare functions as methods too
        self.looked_at = None  # the last object of those the program called a method of: what it looks at
        self.math = None
        self.typing = None
        self.future = None


STATE = _State()


def stop(category, message):
    err = SandboxStop(category, message)
    if STATE.stopped is None:
        STATE.stopped = err
    raise err


# ---- the pipe --------------------------------------------------------------------------------------


class Channel:
    def __init__(self, rfd, wfd):
        self.rfile = open(rfd, "rb", buffering=1 << 16)  # noqa: SIM115 (lives as long as the process)
        self.wfd = wfd

    def send(self, msg):
        self.send_raw(dumps(msg))

    def send_raw(self, data):
        view = memoryview(data)
        while view:
            n = os.write(self.wfd, view)
            view = view[n:]

    def recv(self):
        line = self.rfile.readline()
        if not line:
            os._exit(0)  # the host is gone
        return json.loads(line)


def dumps(msg):
    return (json.dumps(msg, separators=(",", ":")) + "\n").encode("ascii")


def exchange(data, reply=True):
    """Send a message (and wait for the answer) with timers held off, so no time-out lands mid-write."""
    STATE.critical = True
    try:
        STATE.chan.send_raw(data)
        answer = STATE.chan.recv() if reply else None
    finally:
        STATE.critical = False
    if STATE.pending is not None:
        category, message = STATE.pending
        STATE.pending = None
        stop(category, message)
    return answer


def on_timer(category, message):
    def handler(signum, frame):
        if STATE.timed_out:
            return
        STATE.timed_out = True
        if STATE.critical:
            STATE.pending = (category, message)
            return
        stop(category, message)

    return handler
