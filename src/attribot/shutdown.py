"""Termination signals as exceptions: SIGTERM and SIGHUP unwind the program the way Ctrl-C does.

The default action of SIGTERM kills the process at once: no `finally` runs, so the sandbox worker (in a
session of its own), the model processes and their shared memory outlive it. Raising `SystemExit` instead
runs every clean-up on the way out. uvicorn captures SIGTERM while it serves and raises it again when it
has stopped, which then lands here too.
"""

from __future__ import annotations

import _thread
import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

__all__ = ["termination_as_exit", "die_with_parent"]


class _Termination(SystemExit):
    """The exit a termination signal raised: told apart from others when Python drops it."""

    def __init__(self, signum: int) -> None:
        super().__init__(128 + signum)
        self.signum = signum


@contextlib.contextmanager
def termination_as_exit() -> Iterator[None]:
    """Inside the block, SIGTERM and SIGHUP raise `SystemExit(128 + signal)` (where they still have
    their default action, and on the main thread, the only one Python runs handlers on).

    Python drops an exception raised where it cannot propagate (a weakref callback, `__del__`, a GC
    callback) after printing it. A signal that lands there is sent to the main thread again, so that the
    exit happens at the next place it can."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def terminate(signum: int, frame: Any) -> None:
        signal.signal(signum, signal.SIG_IGN)  # a second signal does not interrupt the clean-up
        raise _Termination(signum)

    def dropped(unraisable: Any) -> None:
        if not isinstance(unraisable.exc_value, _Termination):
            previous_hook(unraisable)
            return
        signum = unraisable.exc_value.signum
        main = threading.main_thread().ident
        assert main is not None
        # sent from a thread a moment later, when the main thread has left the code that dropped the exit
        # (`threading.Thread.start` would wait here, where a signal is dropped again); pthread_kill rather
        # than a flag, so that a blocking call on the main thread is interrupted too
        _thread.start_new_thread(_send_later, (main, signum))
        signal.signal(signum, terminate)

    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGTERM, signal.SIGHUP)}
    previous_hook = sys.unraisablehook
    for sig, handler in previous.items():
        if handler in (signal.SIG_DFL, None):
            signal.signal(sig, terminate)
    sys.unraisablehook = dropped
    try:
        yield
    finally:
        sys.unraisablehook = previous_hook
        for sig, handler in previous.items():
            signal.signal(sig, handler if handler is not None else signal.SIG_DFL)


def _send_later(thread: int, signum: int) -> None:
    time.sleep(0.05)
    signal.pthread_kill(thread, signum)


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
