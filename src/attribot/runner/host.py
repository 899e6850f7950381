"""The host side of the sandbox: `ProgramRunner` keeps a worker process started ahead of need, sends it a
checked and compiled program, serves its API calls against the real objects, and turns whatever happens
into a `RunResult`. A worker runs one program and is then discarded, so no state passes between programs.
"""

from __future__ import annotations

import binascii
import inspect
import marshal
import math
import signal
import sys
import threading
import time
import weakref
from collections.abc import Callable, Sequence
from typing import Any

from attribot.errors import ConfigError, InputError
from attribot.runner import protocol as proto
from attribot.runner.calls import RunState, takes_one
from attribot.runner.policy import prepare_program
from attribot.runner.process import STARTUP_S, CallTimeout, Cutter, Gone, Overflow, Worker, kill_worker
from attribot.runner.protocol import KIND, Key, Kind
from attribot.runner.records import Limits, RunError, RunResult, TraceRecord

__all__ = ["ProgramRunner"]


class _Attempt:
    """One worker's go at serving a run: what the worker sends is answered here, message by message, until
    the run has a result. Until the worker has the program (`ready`) the deadline is the start-up allowance;
    from then on, the run's wall-clock limit and a grace."""

    def __init__(
        self, worker: Worker, state: RunState, request: dict[str, Any], t0: float, limits: Limits
    ) -> None:
        self.worker = worker
        self.state = state
        self.request = request
        self.t0 = t0
        self.limits = limits
        # the child times itself out at wall_s and reports the line; this deadline is the backstop for a
        # child stuck inside one long C call. It counts from the moment the worker has the program, so
        # that a slow start on a loaded machine is not charged to the program.
        self.grace = min(1.0, 0.2 + 0.1 * limits.wall_s)
        self.deadline = time.monotonic() + STARTUP_S
        self.ready = False
        self.max_bytes = limits.max_message_bytes + 4096

    def finish(
        self, ok: bool, value: Any = None, value_object: Any = None, error: RunError | None = None
    ) -> RunResult:
        """The run's result, with its output, trace and time so far."""
        return RunResult(
            ok=ok,
            value=value,
            value_object=value_object,
            output="".join(self.state.output),
            error=error,
            trace=self.state.trace,
            wall_ms=(time.perf_counter() - self.t0) * 1000,
        )

    def answer(self, msg: dict[str, Any] | None) -> RunResult | None:
        """Act on the worker's next message (None: the deadline passed first); the run's result once it
        has one. `Overflow` for a message that is not one the worker may send."""
        if msg is None:
            if not self.ready:
                self.worker.kill()
                raise ConfigError(
                    f"the sandbox worker did not start within {STARTUP_S} s",
                    f"check that `{sys.executable} -I -S` runs on this machine",
                )
            return self._timed_out()
        kind = msg.get(KIND)
        if kind == Kind.CALL:
            return self._serve_call(msg)
        if kind == Kind.OUT:
            self.state.add_output(msg.get(Key.TEXT))
            return None
        if kind == Kind.DONE:
            return self._done(msg)
        if kind == Kind.FAILED:
            line = msg.get(Key.LINE)
            category, message = str(msg.get(Key.CATEGORY)), str(msg.get(Key.MESSAGE))
            error = self.state.error(category, message, line if type(line) is int else None)
            return self.finish(False, error=error)
        if kind == Kind.GO and not self.ready:  # the worker has the program and starts its clocks
            self.ready = True
            self.deadline = time.monotonic() + self.limits.wall_s + self.grace
            self.state.cutter.arm(self.deadline)
            return None
        if kind == Kind.READY:
            return None
        raise Overflow("the program sent a message that is not valid")

    def _serve_call(self, msg: dict[str, Any]) -> RunResult | None:
        """Serve one API call and send the worker its reply; a result only when the run's time ran out."""
        try:
            reply = self.state.call(msg, self.deadline if self.ready else math.inf)
        except CallTimeout:
            reply = None
        if reply is None or time.monotonic() > self.deadline:
            return self._timed_out()
        self.worker.send(reply)
        return None

    def _done(self, msg: dict[str, Any]) -> RunResult:
        """The result of a program that returned (unless the host already decided to stop it)."""
        state = self.state
        if state.stop is not None:
            return self.finish(False, error=state.error(*state.stop))
        try:
            obj = state.decode(msg.get(Key.VALUE))
        except (ValueError, TypeError, RecursionError):
            message = f"{self.request[Key.ENTRY]} returned a value that cannot be read"
            return self.finish(False, error=state.error("runtime", message, None))
        return self.finish(True, value=state.summary(obj), value_object=obj)

    def _timed_out(self) -> RunResult:
        """Kill the worker, and the result of a run that went past its wall-clock limit."""
        self.worker.kill()
        state = self.state
        err = state.error("timeout", f"the program ran longer than {self.limits.wall_s} s", state.last_line)
        return self.finish(False, error=err)


class ProgramRunner:
    """Runs untrusted programs in a separate, killable process, against host objects of `classes`.

    Each class declares `API_METHODS` (the only methods a program may call) and `API_ATTRIBUTES` (plain
    values copied to the program when an object is handed to it). `run(source, args)` calls the entry
    function (`execute_command`) with `args`, which may be such objects or plain data.
    """

    def __init__(
        self, classes: Sequence[type], limits: Limits | None = None, entry: str = "execute_command"
    ) -> None:
        self.classes: tuple[Any, ...] = tuple(classes)  # classes that declare API_METHODS/API_ATTRIBUTES
        self.limits = limits or Limits()
        self.entry = entry
        if not entry.isidentifier() or entry.startswith("_"):
            raise ConfigError(
                f"entry point {entry!r} is not a public Python name", "use e.g. execute_command"
            )
        names: set[str] = set()
        for cls in self.classes:
            if not isinstance(cls, type):
                raise ConfigError(f"ProgramRunner classes must be classes, got {cls!r}")
            for attr in ("API_METHODS", "API_ATTRIBUTES"):
                value = getattr(cls, attr, None)
                if not isinstance(value, tuple) or not all(isinstance(v, str) for v in value):
                    raise ConfigError(
                        f"{cls.__name__} has no {attr} tuple of names",
                        f"declare {attr}: ClassVar[tuple[str, ...]] on the class",
                    )
                bad = [v for v in value if not v.isidentifier() or v.startswith("_")]
                if bad:
                    raise ConfigError(f"{cls.__name__}.{attr} holds names a program cannot use: {bad}")
            if cls.__name__ in names:
                raise ConfigError(f"two API classes are named {cls.__name__}")
            names.add(cls.__name__)
        self._wire_classes = {cls.__name__: list(cls.API_METHODS) for cls in self.classes}
        self._wire_functions = self._functions()
        self._class_cache: dict[type, type | None] = {}
        self._signatures: dict[tuple[type, str], inspect.Signature | None] = {}
        self._lock = threading.Lock()
        self._box: list[Worker | None] = [None]
        self._closed = False
        self._cutter = Cutter()  # one watcher thread for every run of this runner
        self._finalizer = weakref.finalize(self, kill_worker, self._box)
        weakref.finalize(self, self._cutter.close)
        self._box[0] = Worker()

    # ---- host-side helpers --------------------------------------------------------------------------
    def _functions(self) -> dict[str, Any]:
        """What the worker offers as bare functions: for each class that declares `PROGRAM_FUNCTIONS` (API
        method names), those methods and whether each takes one object (one required argument: a patch
        given to `patch.method()` with no arguments), and for each class named in its
        `PROGRAM_FUNCTIONS_ON` the ones its objects take too (all but the names it has of its own). Such a
        call tells the owner's host method named by `PROGRAM_CALLED_ON`, if any, which object it was on (and a
        call that names an object, which one the program looked at last)."""
        names = {cls.__name__: cls for cls in self.classes}
        out: dict[str, Any] = {}
        for cls in self.classes:
            methods = getattr(cls, "PROGRAM_FUNCTIONS", None)
            if methods is None:
                continue
            unknown = [m for m in methods if m not in cls.API_METHODS]
            if unknown:
                raise ConfigError(f"{cls.__name__}.PROGRAM_FUNCTIONS names no API method: {unknown}")
            on = tuple(getattr(cls, "PROGRAM_FUNCTIONS_ON", ()))
            strangers = [c for c in on if c not in names]
            if strangers:
                raise ConfigError(
                    f"{cls.__name__}.PROGRAM_FUNCTIONS_ON names no class of this runner: {strangers}"
                )
            out[cls.__name__] = {
                Key.FN_METHODS: {m: takes_one(getattr(cls, m)) for m in methods},
                Key.FN_ON: {
                    c: [m for m in methods if m not in (*names[c].API_METHODS, *names[c].API_ATTRIBUTES)]
                    for c in on
                },
            }
        return out

    def _class_of(self, obj: Any) -> Any:
        kind = type(obj)
        if kind not in self._class_cache:
            self._class_cache[kind] = next((c for c in self.classes if issubclass(kind, c)), None)
        return self._class_cache[kind]

    def _signature(self, cls: type, method: str, fn: Any) -> inspect.Signature | None:
        key = (cls, method)
        if key not in self._signatures:
            try:
                self._signatures[key] = inspect.signature(fn)
            except (TypeError, ValueError):
                self._signatures[key] = None
        return self._signatures[key]

    def _constructor_objects(self, args: Sequence[Any]) -> dict[type, tuple[Any, str]]:
        """For each class that declares `PROGRAM_CONSTRUCTOR` (a host method), the first argument of that
        class: `ClassName(...)` in a program calls that method on it. This is how programs in the paper's
        dialect (`ImagePatch(image)`, `Robot(sensors=[...])`) get the session's objects."""
        out: dict[type, tuple[Any, str]] = {}
        for cls in self.classes:
            method = getattr(cls, "PROGRAM_CONSTRUCTOR", None)
            if not isinstance(method, str) or not callable(getattr(cls, method, None)):
                continue
            found = next((a for a in args if self._class_of(a) is cls), None)
            if found is not None:
                out[cls] = (found, method)
        return out

    def summarise(self, obj: Any) -> dict[str, Any]:
        """The JSON-ready summary of a host object in traces and results: its class name, and its
        `summary()` when it has one, else its API attributes."""
        cls = self._class_of(obj)
        out: dict[str, Any] = {"type": cls.__name__}
        summary = getattr(obj, "summary", None)
        if callable(summary):
            out.update(summary())
        else:
            for name in cls.API_ATTRIBUTES:
                out[name] = getattr(obj, name)
        return out

    # ---- running ------------------------------------------------------------------------------------
    def run(
        self,
        source: str,
        args: Sequence[Any] = (),
        *,
        entry: str | None = None,
        on_call: Callable[[TraceRecord], None] | None = None,
    ) -> RunResult:
        """Check, then run `source` in a fresh worker: calls `entry(*args)` and returns what it gave.
        `on_call` sees each trace record as its call ends (on the host thread that serves the run)."""
        if self._closed:
            raise InputError("this ProgramRunner is closed", "make a new one")
        entry = entry or self.entry
        t0 = time.perf_counter()
        code, error = prepare_program(source, entry, self.limits)
        if error is not None:
            return RunResult(ok=False, error=error, wall_ms=(time.perf_counter() - t0) * 1000)
        with self._lock:
            state = RunState(self, source, on_call)
            try:
                wire_args = [state.encode(a) for a in args]
                constructors = {
                    cls.__name__: [state.encode(obj), method]
                    for cls, (obj, method) in self._constructor_objects(args).items()
                }
            except TypeError as e:
                raise InputError(
                    f"ProgramRunner.run: cannot pass {e} to a program",
                    "pass API objects of the runner's classes or plain data",
                ) from None
            request = {
                KIND: Kind.RUN,
                Key.CODE: binascii.b2a_base64(marshal.dumps(code), newline=False).decode("ascii"),
                Key.ENTRY: entry,
                Key.ARGS: wire_args,
                Key.LIMITS: proto.WireLimits(**self.limits.model_dump()).to_wire(),
                Key.CLASSES: self._wire_classes,
                Key.CONSTRUCTORS: constructors,
                Key.FUNCTIONS: self._wire_functions,
            }
            try:
                result = self._serve(state, request, t0)
            finally:
                state.cutter.disarm()
                self._respawn()
        return result

    def _serve(self, state: RunState, request: dict[str, Any], t0: float, retry: bool = True) -> RunResult:
        worker = self._live_worker()
        attempt = _Attempt(worker, state, request, t0, self.limits)
        try:
            worker.send(request)
            while True:
                result = attempt.answer(worker.recv(attempt.deadline, attempt.max_bytes))
                if result is not None:
                    return result
        except Overflow as e:
            worker.kill()
            return attempt.finish(False, error=state.error("limit", str(e), state.last_line))
        except Gone:
            status = worker.kill()
            if not attempt.ready:  # the worker died before the program reached it: not the program's doing
                if retry:
                    self._box[0] = Worker()
                    return self._serve(state, request, t0, retry=False)
                raise ConfigError(
                    f"the sandbox worker could not start (exit status {status})",
                    f"check that `{sys.executable} -I -S` runs on this machine",
                ) from None
            return attempt.finish(False, error=state.error(*self._death(status), state.last_line))

    def _live_worker(self) -> Worker:
        """The waiting worker, or a fresh one in place of one that is missing or has died."""
        worker = self._box[0]
        if worker is None or not worker.alive():
            if worker is not None:
                worker.kill()
            worker = self._box[0] = Worker()
        return worker

    @staticmethod
    def _death(status: int | None) -> tuple[str, str]:
        if status is not None and status < 0:
            sig = -status
            if sig in (signal.SIGXCPU, signal.SIGKILL):
                return "timeout", "the program used too much CPU time and was stopped"
            try:
                name = signal.Signals(sig).name
            except ValueError:
                name = str(sig)
            return "runtime", f"the program's process crashed ({name})"
        return "runtime", f"the program's process exited unexpectedly (status {status})"

    def _respawn(self) -> None:
        old = self._box[0]
        if old is not None:
            old.kill()
        self._box[0] = None if self._closed else Worker()

    def close(self) -> None:
        """Stop the waiting worker. The runner cannot run programs afterwards."""
        self._closed = True
        with self._lock:
            kill_worker(self._box)
            self._cutter.close()

    def __enter__(self) -> ProgramRunner:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
