"""The sandbox's wall-clock limit covers host-side API calls: a stuck call is cut at the deadline."""

from __future__ import annotations

import signal
import socket
import textwrap
import threading
from typing import ClassVar

from attribot.runner import Limits, ProgramRunner


class Stuck:
    """A host API whose calls hang: a wait that swallows ordinary exceptions, and a socket read from a
    peer that never answers (what a stuck model endpoint looks like)."""

    API_ATTRIBUTES: ClassVar[tuple[str, ...]] = ()
    API_METHODS: ClassVar[tuple[str, ...]] = ("wait", "read", "quick", "spin")

    def __init__(self) -> None:
        self.finished: list[str] = []

    def wait(self) -> str:
        try:
            threading.Event().wait(30)
        except Exception:  # noqa: BLE001 - a backend that swallows errors must still be cut
            pass
        self.finished.append("wait")
        return "late"

    def read(self) -> bytes:
        a, b = socket.socketpair()
        with a, b:
            data = a.recv(1)  # b never writes
        self.finished.append("read")
        return data

    def quick(self) -> int:
        return 7

    def spin(self) -> int:
        n = 0
        while n >= 0:  # host CPU, not the program's: what a backend's slow parsing looks like
            n += 1
        self.finished.append("spin")
        return n


def _run(method: str) -> tuple[object, Stuck]:
    stuck = Stuck()
    program = f"""
    def execute_command(api):
        first = api.quick()
        return api.{method}()
    """
    with ProgramRunner(classes=[Stuck], limits=Limits(wall_s=1.0, cpu_s=1.0)) as runner:
        result = runner.run(textwrap.dedent(program), args=[stuck])
    return result, stuck


def test_a_stuck_host_call_is_cut_at_the_wall_limit():
    result, stuck = _run("wait")
    assert not result.ok and result.error is not None
    assert result.error.category == "timeout" and result.error.line == 4
    assert stuck.finished == []  # cut, not waited out
    assert [t.call for t in result.trace] == ["Stuck.quick", "Stuck.wait"]
    assert result.trace[-1].error == "cut at the run's time limit"


def test_a_blocked_socket_read_is_cut_at_the_wall_limit():
    result, stuck = _run("read")
    assert result.error is not None and result.error.category == "timeout"
    assert stuck.finished == []


def test_host_cpu_spent_by_a_call_counts_against_the_wall_limit():
    # issue 22 item 1: a backend call burnt 45 s of host CPU for a program limited to 10 s
    result, stuck = _run("spin")
    assert result.error is not None and result.error.category == "timeout"
    assert stuck.finished == []
    assert result.trace[-1].call == "Stuck.spin" and result.trace[-1].error == "cut at the run's time limit"


def test_the_cutting_signal_is_put_back_after_a_run():
    from attribot.runner.process import CUT_SIGNAL as _CUT_SIGNAL

    before = signal.getsignal(_CUT_SIGNAL)
    result, _ = _run("quick")
    assert result.ok and result.value == 7
    assert signal.getsignal(_CUT_SIGNAL) is before


class Watched:
    """A host API that notes, at each call, the cutting signal's handler and the threads alive."""

    API_ATTRIBUTES: ClassVar[tuple[str, ...]] = ()
    API_METHODS: ClassVar[tuple[str, ...]] = ("ping",)

    def __init__(self) -> None:
        self.handlers: list[object] = []
        self.threads: set[int] = set()

    def ping(self) -> int:
        from attribot.runner.process import CUT_SIGNAL as _CUT_SIGNAL

        self.handlers.append(signal.getsignal(_CUT_SIGNAL))
        self.threads.update(t.ident or 0 for t in threading.enumerate() if t.name == "attribot-run-deadline")
        return 1


def test_the_protection_is_armed_once_per_run_not_once_per_call():
    # issue 22 item 23: a timer thread and a handler per call tripled the cost of every API call
    watched = Watched()
    program = "def execute_command(api):\n    return sum(api.ping() for _ in range(40))\n"
    with ProgramRunner(classes=[Watched], limits=Limits(wall_s=5.0)) as runner:
        result = runner.run(program, args=[watched])
    assert result.ok and result.value == 40
    assert len(watched.handlers) == 40
    assert all(h is watched.handlers[0] for h in watched.handlers)  # one handler, installed once
    assert callable(watched.handlers[0])  # and armed during the calls
    assert len(watched.threads) == 1  # one watcher thread for the whole run
