"""Termination signals as exceptions: SIGTERM and SIGHUP unwind the program the way Ctrl-C does.

The default action of SIGTERM kills the process at once: no `finally` runs, so the sandbox worker (in a
session of its own), the model processes and their shared memory outlive it. Raising `SystemExit` instead
runs every clean-up on the way out. uvicorn captures SIGTERM while it serves and raises it again when it
has stopped, which then lands here too.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from collections.abc import Iterator
from typing import Any

__all__ = ["termination_as_exit", "die_with_parent"]


@contextlib.contextmanager
def termination_as_exit() -> Iterator[None]:
    """Inside the block, SIGTERM and SIGHUP raise `SystemExit(128 + signal)` (where they still have
    their default action, and on the main thread, the only one Python runs handlers on)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def terminate(signum: int, frame: Any) -> None:
        signal.signal(signum, signal.SIG_IGN)  # a second signal does not interrupt the clean-up
        raise SystemExit(128 + signum)

    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGTERM, signal.SIGHUP)}
    for sig, handler in previous.items():
        if handler in (signal.SIG_DFL, None):
            signal.signal(sig, terminate)
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler if handler is not None else signal.SIG_DFL)


def die_with_parent(parent: int | None = None) -> None:
    """Ask Linux to kill this (child) process when its parent dies, however it dies (SIGKILL, a crash): a
    child busy in a long call never reads its pipe, and would otherwise live on, re-parented, holding its
    memory (and a GPU). `parent`: the parent's pid, to catch a parent that died before this call.
    Elsewhere the pipe's end-of-file is what stops a child."""
    import ctypes

    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if parent is not None and os.getppid() != parent:  # the parent died before the request
        os._exit(1)
