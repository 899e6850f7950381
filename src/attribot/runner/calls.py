"""A run's state on the host: the objects handed to the program (as handles), the API calls served against
them, the trace records kept of each (cut to fit), the program's output, and the errors a run ends with.
`attribot.runner.host.ProgramRunner` makes one `RunState` per run.
"""

from __future__ import annotations

import inspect
import math
import re
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from attribot.errors import AttribotError
from attribot.runner import protocol as proto
from attribot.runner.policy import snippet_of
from attribot.runner.process import CallTimeout
from attribot.runner.protocol import KIND, Key, Kind
from attribot.runner.records import RunError, TraceRecord
from attribot.text import json_safe as _text

if TYPE_CHECKING:
    from attribot.runner.host import ProgramRunner

__all__ = ["RunState", "TRACE_RUN_CHARS", "scrub", "takes_one"]

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


def cut_for_trace(value: Any, room: list[int] | None = None, depth: int = 0) -> Any:
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
            items.append(cut_for_trace(item, room, depth + 1))
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
            entries[cut_for_trace(key, room, depth + 1)] = cut_for_trace(item, room, depth + 1)
        return entries
    # a number, true, false or None; a 4,000-digit int counts its digits
    room[0] -= 8 + (value.bit_length() // 3 if isinstance(value, int) else 0)
    return value


# a default repr, "<attribot.skills.robot_session.RobotSession object at 0x7f...>": its class name is enough
_HOST_REPR = re.compile(r"<(?:\w+\.)*_*(\w+) object at 0x[0-9a-fA-F]+>")


def scrub(text: str, limit: int = 300) -> str:
    """A host exception's text without file paths or host object reprs, short."""
    text = _PATHS.sub("<path>", _HOST_REPR.sub(r"<\1>", text))
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _failure(name: str, error: Exception) -> str:
    """What a program is told of a host call that failed: the exception's type and scrubbed text."""
    text = scrub(str(error))
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


def takes_one(method: Any) -> bool:
    """Whether `method` (a function of a class) needs exactly one argument besides `self`."""
    try:
        parameters = list(inspect.signature(method).parameters.values())[1:]
    except (TypeError, ValueError):
        return False
    positional = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    return sum(p.kind in positional and p.default is inspect.Parameter.empty for p in parameters) == 1


class RunState:
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
        """Serve one API call; past `deadline` (time.monotonic) the call is cut and `CallTimeout` raised."""
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
            return self._refuse(f"?.{method}", f"the call could not be read: {scrub(str(e))}", line, [])
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
        except CallTimeout:
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
        """Call the host method `fn`, where the run's deadline can cut it (`CallTimeout`)."""
        cutter = self.cutter
        cutter.in_call = True  # before the clock is read: see `Cutter.arm`
        try:
            if time.monotonic() >= deadline:
                raise CallTimeout()
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
        """What the trace keeps of one call's arguments or result: `cut_for_trace`, within what is left of the
        run's `TRACE_RUN_CHARS` (past them, a note that it was not kept)."""
        if self.trace_room[0] <= 0:
            note = "(not kept: the trace of this run is full)"
            return [note] if isinstance(value, list) else note
        room = [TRACE_PART_CHARS]
        kept = cut_for_trace(value, room)
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
        message = scrub(_text(message), 1000) if isinstance(message, str) else "the program failed"
        return RunError(
            category=category,
            message=message,
            line=line,
            snippet=snippet_of(self.source, line),
            output="".join(self.output),
        )
