"""The host side of the sandbox: `ProgramRunner` keeps a worker process started ahead of need, sends it a
checked and compiled program, serves its API calls against the real objects, and turns whatever happens
into a `RunResult`. A worker runs one program and is then discarded, so no state passes between programs.
"""

from __future__ import annotations

import binascii
import inspect
import json
import marshal
import math
import os
import re
import select
import signal
import subprocess
import sys
import threading
import time
import weakref
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from attribot.errors import AttribotError, ConfigError, InputError
from attribot.runner import protocol as proto
from attribot.runner import worker
from attribot.runner.policy import prepare_program, snippet_of
from attribot.runner.protocol import KIND, Key, Kind
from attribot.runner.records import Limits, RunError, RunResult, TraceRecord
from attribot.text import json_safe as _text

__all__ = ["ProgramRunner"]

WORKER_PATH = Path(worker.__file__).resolve()
_STARTUP_S = 30.0  # a worker that is not ready by then is broken, not slow
_CATEGORIES = {"syntax", "policy", "runtime", "timeout", "limit", "api"}  # a run's; "reply" is the planner's
# a file path; not the path part of a URL ("https://host/a/b" stays whole)
_PATHS = re.compile(r"(?<![\w:/.\\])(?:[A-Za-z]:)?(?:[\\/][\w.\-~]+){2,}[\\/]?")
TRACE_TEXT_CHARS = 1000
"""Longest text kept whole in a trace record; longer ones are cut and say how long they were."""
TRACE_ITEMS = 50
"""Most items of a list or dict kept in a trace record; the rest are counted."""
TRACE_DEPTH = 8
"""Deepest nesting kept in a trace record."""
TRACE_PART_CHARS = 8000
"""About the most characters the arguments, or the result, of one call keep in the trace."""
TRACE_RUN_CHARS = 2_000_000
"""About the most characters the trace of one run keeps: past them, a call's record keeps its name, line,
time and error, and says that its arguments and result were not kept."""


def _cut(value: Any, room: list[int] | None = None, depth: int = 0) -> Any:
    """A trace value cut to fit: long texts, long lists and dicts, deep nesting, and the whole within `room`
    (characters, counted down; `TRACE_PART_CHARS` when not given). A program can pass a 300 KB string, or
    a list of 190,000 names, to every call: the trace keeps what shows what the call was."""
    if room is None:
        room = [TRACE_PART_CHARS]
    if isinstance(value, str):
        keep = max(0, min(TRACE_TEXT_CHARS, room[0]))
        text = value if len(value) <= keep else value[:keep] + f"... ({len(value)} characters)"
        room[0] -= len(text)
        return text
    if isinstance(value, list):
        if depth >= TRACE_DEPTH or room[0] <= 0:
            room[0] -= 3
            return "..."
        items: list[Any] = []
        for item in value:
            if len(items) >= TRACE_ITEMS or room[0] <= 0:
                items.append(f"... ({len(value)} items)")
                break
            room[0] -= 2
            items.append(_cut(item, room, depth + 1))
        return items
    if isinstance(value, dict):
        if depth >= TRACE_DEPTH or room[0] <= 0:
            room[0] -= 3
            return "..."
        entries: dict[Any, Any] = {}
        for key, item in value.items():
            if len(entries) >= TRACE_ITEMS or room[0] <= 0:
                entries["..."] = f"{len(value) - len(entries)} more entries"
                break
            room[0] -= 2
            entries[_cut(key, room, depth + 1)] = _cut(item, room, depth + 1)
        return entries
    # a number, true, false or None; a 4,000-digit int counts its digits
    room[0] -= 8 + (value.bit_length() // 3 if isinstance(value, int) else 0)
    return value


# a default repr, "<attribot.skills.robot_session.RobotSession object at 0x7f...>": its class name is enough
_HOST_REPR = re.compile(r"<(?:\w+\.)*_*(\w+) object at 0x[0-9a-fA-F]+>")


def _scrub(text: str, limit: int = 300) -> str:
    """A host exception's text without file paths or host object reprs, short."""
    text = _PATHS.sub("<path>", _HOST_REPR.sub(r"<\1>", text))
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _failure(name: str, error: Exception) -> str:
    """What a program is told of a host call that failed: the exception's type and scrubbed text."""
    text = _scrub(str(error))
    return f"{name} failed: {type(error).__name__}" + (f": {text}" if text else "")


def _params(signature: inspect.Signature) -> str:
    """A method's parameters as a program would write them (names and defaults, no annotations)."""
    out = []
    for p in signature.parameters.values():
        text = p.name if p.default is inspect.Parameter.empty else f"{p.name}={p.default!r}"
        if p.kind is inspect.Parameter.VAR_POSITIONAL:
            text = "*" + p.name
        elif p.kind is inspect.Parameter.VAR_KEYWORD:
            text = "**" + p.name
        out.append(text)
    return ", ".join(out)


def _takes_one(method: Any) -> bool:
    """Whether `method` (a function of a class) needs exactly one argument besides `self`."""
    try:
        parameters = list(inspect.signature(method).parameters.values())[1:]
    except (TypeError, ValueError):
        return False
    positional = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    return sum(p.kind in positional and p.default is inspect.Parameter.empty for p in parameters) == 1


class _CallTimeout(BaseException):
    """Raised inside a host-side API call when the run's wall-clock deadline passes (a BaseException, so
    that a backend's `except Exception` cannot swallow it)."""


_CUT_SIGNAL = signal.SIGRTMIN + 5 if hasattr(signal, "SIGRTMIN") else signal.SIGUSR2
"""The signal that cuts a host call: a real-time one that applications (and pytest-timeout's SIGALRM)
leave alone."""


class _Cutter:
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
        usable = threading.current_thread() is threading.main_thread() and signal.getsignal(_CUT_SIGNAL) in (
            signal.SIG_DFL,
            signal.SIG_IGN,
            None,
        )
        if not usable or not math.isfinite(deadline) or self._armed:
            return
        self._previous = signal.signal(_CUT_SIGNAL, self._expire)
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
                    signal.pthread_kill(self._target, _CUT_SIGNAL)
                self._deadline = None

    def _expire(self, signum: int, frame: Any) -> None:
        if self.in_call:  # a signal that lands between calls is ignored
            self.in_call = False
            raise _CallTimeout()

    def disarm(self) -> None:
        """Stop watching and put the previous handler back (the end of the run)."""
        self.in_call = False
        if not self._armed:
            return
        with self._cond:
            self._deadline = None
            self._cond.notify()
        signal.signal(_CUT_SIGNAL, self._previous)
        self._armed = False

    def close(self) -> None:
        """End the watcher thread (the runner is closed)."""
        with self._cond:
            self._closed = True
            self._deadline = None
            self._cond.notify()


class _Gone(Exception):
    """The worker closed its end of the pipe (it exited or was killed)."""


class _Overflow(Exception):
    """The worker sent a message longer than the limit, or one that is not valid."""


class _Worker:
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
            raise _Gone() from e

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
                    raise _Overflow("the program sent a message that is not valid") from e
                if not isinstance(msg, dict):
                    raise _Overflow("the program sent a message that is not valid")
                return msg
            if len(self.buf) > max_bytes:
                raise _Overflow(f"the program sent more than {max_bytes} bytes in one message")
            wait = deadline - time.monotonic()
            if wait <= 0:
                return None
            ready, _, _ = select.select([self.rfd], [], [], wait)
            if not ready:
                return None
            chunk = os.read(self.rfd, 1 << 16)
            if not chunk:
                raise _Gone()
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


def _kill_worker(box: list[_Worker | None]) -> None:
    worker = box[0]
    if worker is not None:
        worker.kill()
        box[0] = None


class _Run:
    """The state of one run on the host: handles, trace, output, the first stop the host decided."""

    def __init__(
        self, runner: ProgramRunner, source: str, on_call: Callable[[TraceRecord], None] | None = None
    ) -> None:
        self.runner = runner
        self.source = source
        self.on_call = on_call
        self.objects: dict[int, Any] = {}
        self.ids: dict[int, int] = {}
        self.trace: list[TraceRecord] = []
        self.output: list[str] = []
        self.out_len = 0
        self.calls = 0
        self.last_line: int | None = None
        self.stop: tuple[str, str, int | None] | None = None
        self.cutter = runner._cutter
        self.trace_room = [TRACE_RUN_CHARS]  # what the trace may still keep (see `_kept`)

    # ---- host objects <-> handles -------------------------------------------------------------------
    def handle(self, obj: Any) -> dict[str, Any]:
        key = id(obj)
        h = self.ids.get(key)
        if h is not None:
            return {proto.TAG_HANDLE: h}  # the child already holds its stub
        cls = self.runner._class_of(obj)
        h = len(self.objects) + 1
        self.objects[h] = obj
        self.ids[key] = h
        attrs = {name: self.encode(getattr(obj, name), depth=1) for name in cls.API_ATTRIBUTES}
        return {proto.TAG_HANDLE: h, Key.STUB_CLASS: cls.__name__, Key.STUB_ATTRS: attrs}

    def encode(self, value: Any, depth: int = 0) -> Any:
        """Host values to the wire: plain data as is, API objects as handles, numpy scalars as numbers."""
        if depth > 50:
            raise TypeError("a value nested more than 50 deep")
        if value is None or isinstance(value, bool | int | str):
            return value
        if isinstance(value, float):
            return float(value)
        if isinstance(value, list):
            return [self.encode(v, depth + 1) for v in value]
        if isinstance(value, tuple):
            return {proto.TAG_TUPLE: [self.encode(v, depth + 1) for v in value]}
        if isinstance(value, dict):
            return {
                proto.TAG_DICT: [
                    [self.encode(k, depth + 1), self.encode(v, depth + 1)] for k, v in value.items()
                ]
            }
        if isinstance(value, set | frozenset):
            return {proto.TAG_SET: [self.encode(v, depth + 1) for v in value]}
        if self.runner._class_of(value) is not None:
            return self.handle(value)
        item = getattr(value, "item", None)  # numpy scalars
        if callable(item) and getattr(value, "shape", None) == ():
            return self.encode(item(), depth)
        raise TypeError(f"a {type(value).__name__}")

    def decode(self, data: Any) -> Any:
        """Wire values from the child (untrusted) to host values; handles must be ones this run made."""
        if isinstance(data, list):
            return [self.decode(v) for v in data]
        if isinstance(data, dict):
            if len(data) == 1:
                ((tag, inner),) = data.items()
                if tag == proto.TAG_HANDLE:
                    if type(inner) is not int or inner not in self.objects:
                        raise ValueError("an object the program does not hold")
                    return self.objects[inner]
                if isinstance(inner, list):
                    if tag == proto.TAG_TUPLE:
                        return tuple(self.decode(v) for v in inner)
                    if tag == proto.TAG_SET:
                        return {self.decode(v) for v in inner}
                    if tag == proto.TAG_DICT:
                        out = {}
                        for pair in inner:
                            if not isinstance(pair, list) or len(pair) != 2:
                                raise ValueError("a malformed dict")
                            out[self.decode(pair[0])] = self.decode(pair[1])
                        return out
            raise ValueError("a malformed value")
        if data is None or isinstance(data, bool | int | float | str):
            return data
        raise ValueError("a malformed value")

    def summary(self, value: Any, depth: int = 0) -> Any:
        """JSON-ready form for traces and `RunResult.value`: host objects as summary dicts."""
        if isinstance(value, str):
            return _text(value)
        if value is None or isinstance(value, bool | int):
            return value
        if isinstance(value, float):
            return value if math.isfinite(value) else str(value)
        if depth > 50:
            return "..."
        if isinstance(value, list | tuple):
            return [self.summary(v, depth + 1) for v in value]
        if isinstance(value, set | frozenset):
            items = [self.summary(v, depth + 1) for v in value]
            try:
                return sorted(items)
            except TypeError:
                return items
        if isinstance(value, dict):
            return {_text(str(k)): self.summary(v, depth + 1) for k, v in value.items()}
        cls = self.runner._class_of(value)
        if cls is not None:
            return self.runner.summarise(value)
        item = getattr(value, "item", None)  # numpy scalars
        if callable(item) and getattr(value, "shape", None) == ():
            return self.summary(item(), depth + 1)
        return f"<{type(value).__name__}>"  # not its repr: that shows host modules and addresses

    # ---- one API call -------------------------------------------------------------------------------
    def call(self, msg: dict[str, Any], deadline: float = math.inf) -> dict[str, Any]:
        """Serve one API call; past `deadline` (time.monotonic) the call is cut and `_CallTimeout` raised."""
        line = msg.get(Key.LINE) if type(msg.get(Key.LINE)) is int else None
        self.last_line = line
        self.calls += 1
        method = msg.get(Key.METHOD)
        limit = self.runner.limits.max_api_calls
        if self.calls > limit:
            message = f"more than {limit} API calls: the program may make at most {limit}"
            self.stop = self.stop or ("limit", message, line)
            return {KIND: Kind.STOP, Key.CATEGORY: "limit", Key.MESSAGE: message}
        try:
            obj, args, kwargs, receiver = self._read_call(msg)
        except (ValueError, TypeError, RecursionError) as e:
            return self._refuse(f"?.{method}", f"the call could not be read: {_scrub(str(e))}", line, [])
        has_receiver = Key.RECEIVER in msg
        cls = self.runner._class_of(obj)
        constructor = isinstance(method, str) and method == getattr(cls, "PROGRAM_CONSTRUCTOR", None)
        name = cls.__name__ if constructor else f"{cls.__name__}.{method}"
        kind = getattr(cls, "API_KIND", None)
        shown = self._kept([self.summary(a) for a in args] + ([self.summary(kwargs)] if kwargs else []))
        if not isinstance(method, str) or not (constructor or method in cls.API_METHODS):
            methods = ", ".join(cls.API_METHODS)
            message = f"{cls.__name__} has no method {method!r}; its methods are: {methods}"
            return self._refuse(name, message, line, shown, kind=kind)
        fn = getattr(obj, method)
        signature = self.runner._signature(cls, method, fn)
        if signature is not None:
            try:
                signature.bind(*args, **kwargs)
            except TypeError as e:
                return self._refuse(name, f"{name}({_params(signature)}): {e}", line, shown, kind=kind)
        called_on = getattr(cls, "PROGRAM_CALLED_ON", None) if has_receiver else None
        t0 = time.perf_counter()
        try:
            result = self._call_host(obj, fn, args, kwargs, called_on, receiver, deadline)
        except _CallTimeout:
            ms = (time.perf_counter() - t0) * 1000
            cut = "cut at the run's time limit"
            self.record(
                TraceRecord(call=name, args=shown, result=None, ms=ms, line=line, error=cut, kind=kind)
            )
            raise
        except AttribotError as e:
            ms = (time.perf_counter() - t0) * 1000
            note = self._note_of(cls, obj)
            return self._refuse(
                name, str(e), line, shown, ms, recoverable=e.recoverable, kind=kind, note=note
            )
        except Exception as e:  # noqa: BLE001 (any host failure is reported, without paths)
            ms = (time.perf_counter() - t0) * 1000
            return self._refuse(
                name, _failure(name, e), line, shown, ms, kind=kind, note=self._note_of(cls, obj)
            )
        ms = (time.perf_counter() - t0) * 1000
        return self._returned(name, result, line, shown, ms, kind, self._note_of(cls, obj))

    @staticmethod
    def _note_of(cls: type, obj: Any) -> str | None:
        """What the call just made did beyond itself, as the class's `PROGRAM_NOTES` host method says (read
        after every call, failed ones too, so that a note never lands on a later call's record)."""
        notes = getattr(cls, "PROGRAM_NOTES", None)
        return getattr(obj, notes)() if notes is not None else None

    def _read_call(self, msg: dict[str, Any]) -> tuple[Any, list[Any], dict[str, Any], Any]:
        """The object, arguments and receiver (None when there is none) that a call names, as host values;
        `ValueError`, `TypeError` or `RecursionError` when the child sent what cannot be read."""
        obj = self.decode({proto.TAG_HANDLE: msg.get(Key.HANDLE)})
        raw_args, raw_kwargs = msg.get(Key.ARGS), msg.get(Key.KWARGS)
        if not isinstance(raw_args, list) or not isinstance(raw_kwargs, dict):
            raise ValueError("a malformed call")
        args = [self.decode(a) for a in raw_args]
        kwargs = {str(k): self.decode(v) for k, v in raw_kwargs.items()}
        receiver = self.decode({proto.TAG_HANDLE: msg[Key.RECEIVER]}) if Key.RECEIVER in msg else None
        return obj, args, kwargs, receiver

    def _call_host(
        self,
        obj: Any,
        fn: Any,
        args: list[Any],
        kwargs: dict[str, Any],
        called_on: str | None,
        receiver: Any,
        deadline: float,
    ) -> Any:
        """Call the host method `fn`, where the run's deadline can cut it (`_CallTimeout`)."""
        cutter = self.cutter
        cutter.in_call = True  # before the clock is read: see `_Cutter.arm`
        try:
            if time.monotonic() >= deadline:
                raise _CallTimeout()
            if called_on is not None:  # `patch.method(...)`: the owner hears which patch
                getattr(obj, called_on)(receiver)
            return fn(*args, **kwargs)
        finally:
            cutter.in_call = False

    def _returned(
        self,
        name: str,
        result: Any,
        line: int | None,
        shown: list[Any],
        ms: float,
        kind: str | None,
        note: str | None = None,
    ) -> dict[str, Any]:
        """The reply that hands a call's result to the program, and its trace record; a refusal when the
        result is not something a program can hold."""
        try:
            wire = self.encode(result)
        except (TypeError, RecursionError) as e:
            message = f"{name} returned {e}, which cannot be passed to a program"
            return self._refuse(name, message, line, shown, ms, kind=kind)
        kept = self._kept(self.summary(result))
        self.record(TraceRecord(call=name, args=shown, result=kept, ms=ms, line=line, kind=kind, note=note))
        return {KIND: Kind.RETURN, Key.VALUE: wire}

    def _kept(self, value: Any) -> Any:
        """What the trace keeps of one call's arguments or result: `_cut`, within what is left of the run's
        `TRACE_RUN_CHARS` (past them, a note that it was not kept)."""
        if self.trace_room[0] <= 0:
            note = "(not kept: the trace of this run is full)"
            return [note] if isinstance(value, list) else note
        room = [TRACE_PART_CHARS]
        kept = _cut(value, room)
        self.trace_room[0] -= TRACE_PART_CHARS - room[0]
        return kept

    def record(self, record: TraceRecord) -> None:
        """Keep one call in the trace, and show it to the run's observer (a live view) as it happens."""
        self.trace.append(record)
        if self.on_call is not None:
            self.on_call(record)

    def _refuse(
        self,
        name: str,
        message: str,
        line: int | None,
        shown: list[Any],
        ms: float = 0.0,
        recoverable: bool = False,
        kind: str | None = None,
        note: str | None = None,
    ) -> dict[str, Any]:
        """The reply to a failed call: a stop, or with `recoverable` (an action that failed in the world)
        the `ActionFailed` the program may catch. Either way the trace records the failed call."""
        # a host error may quote a program's text, lone surrogates and all, or a host object's repr
        message = _text(_HOST_REPR.sub(r"<\1>", message))
        self.record(
            TraceRecord(
                call=name, args=shown, result=None, ms=ms, line=line, error=message, kind=kind, note=note
            )
        )
        reply = Kind.ACTION_FAILED if recoverable else Kind.API_ERROR
        return {KIND: reply, Key.CATEGORY: "api", Key.MESSAGE: message}

    def add_output(self, text: Any) -> None:
        if not isinstance(text, str):
            return
        room = self.runner.limits.max_output_chars - self.out_len
        if room <= 0:
            return
        text = _text(text[:room])
        self.output.append(text)
        self.out_len += len(text)

    def error(self, category: str, message: str, line: int | None) -> RunError:
        if category not in _CATEGORIES:
            category = "runtime"
        if self.stop is not None:  # the host's own decision wins over what the child says
            category, message, line = self.stop[0], self.stop[1], self.stop[2] if self.stop[2] else line
        n_lines = self.source.count("\n") + 1
        if type(line) is not int or not 1 <= line <= n_lines:
            line = None
        message = _scrub(_text(message), 1000) if isinstance(message, str) else "the program failed"
        return RunError(
            category=category,
            message=message,
            line=line,
            snippet=snippet_of(self.source, line),
            output="".join(self.output),
        )


class _Attempt:
    """One worker's go at serving a run: what the worker sends is answered here, message by message, until
    the run has a result. Until the worker has the program (`ready`) the deadline is the start-up allowance;
    from then on, the run's wall-clock limit and a grace."""

    def __init__(
        self, worker: _Worker, state: _Run, request: dict[str, Any], t0: float, limits: Limits
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
        self.deadline = time.monotonic() + _STARTUP_S
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
        has one. `_Overflow` for a message that is not one the worker may send."""
        if msg is None:
            if not self.ready:
                self.worker.kill()
                raise ConfigError(
                    f"the sandbox worker did not start within {_STARTUP_S} s",
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
        raise _Overflow("the program sent a message that is not valid")

    def _serve_call(self, msg: dict[str, Any]) -> RunResult | None:
        """Serve one API call and send the worker its reply; a result only when the run's time ran out."""
        try:
            reply = self.state.call(msg, self.deadline if self.ready else math.inf)
        except _CallTimeout:
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
        self._box: list[_Worker | None] = [None]
        self._closed = False
        self._cutter = _Cutter()  # one watcher thread for every run of this runner
        self._finalizer = weakref.finalize(self, _kill_worker, self._box)
        weakref.finalize(self, self._cutter.close)
        self._box[0] = _Worker()

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
                Key.FN_METHODS: {m: _takes_one(getattr(cls, m)) for m in methods},
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
            state = _Run(self, source, on_call)
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

    def _serve(self, state: _Run, request: dict[str, Any], t0: float, retry: bool = True) -> RunResult:
        worker = self._live_worker()
        attempt = _Attempt(worker, state, request, t0, self.limits)
        try:
            worker.send(request)
            while True:
                result = attempt.answer(worker.recv(attempt.deadline, attempt.max_bytes))
                if result is not None:
                    return result
        except _Overflow as e:
            worker.kill()
            return attempt.finish(False, error=state.error("limit", str(e), state.last_line))
        except _Gone:
            status = worker.kill()
            if not attempt.ready:  # the worker died before the program reached it: not the program's doing
                if retry:
                    self._box[0] = _Worker()
                    return self._serve(state, request, t0, retry=False)
                raise ConfigError(
                    f"the sandbox worker could not start (exit status {status})",
                    f"check that `{sys.executable} -I -S` runs on this machine",
                ) from None
            return attempt.finish(False, error=state.error(*self._death(status), state.last_line))

    def _live_worker(self) -> _Worker:
        """The waiting worker, or a fresh one in place of one that is missing or has died."""
        worker = self._box[0]
        if worker is None or not worker.alive():
            if worker is not None:
                worker.kill()
            worker = self._box[0] = _Worker()
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
        self._box[0] = None if self._closed else _Worker()

    def close(self) -> None:
        """Stop the waiting worker. The runner cannot run programs afterwards."""
        self._closed = True
        with self._lock:
            _kill_worker(self._box)
            self._cutter.close()

    def __enter__(self) -> ProgramRunner:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
