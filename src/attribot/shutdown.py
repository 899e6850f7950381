"""Termination signals as exceptions: SIGTERM and SIGHUP unwind the program the way Ctrl-C does.

The default action of SIGTERM kills the process at once: no `finally` runs, so the sandbox worker (in a
session of its own), the model processes and their shared memory outlive it. Raising `SystemExit` instead
runs every clean-up on the way out. uvicorn captures SIGTERM while it serves and raises it again when it
has stopped, which then lands here too.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from typing import Any

__all__ = ["termination_as_exit"]


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
