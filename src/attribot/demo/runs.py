"""The demo's queries: one worker thread answers them in order, and each page follows one as events.

Every event is encoded once, as it happens, and the same text is sent to every page that follows the run
(a camera frame too: at most one every `FRAME_INTERVAL_S`, and only while some page watches). A page waits
on the server's event loop, not in a thread of its own, so that pages that follow runs never hold the
threads other requests need. What a visitor may start is bounded: one query of theirs at a time, at most
`MAX_WAITING` queries waiting in all, a run's folder only while disk space is left, and an uploaded image
only after it has been checked (and removed once its query has run). What the page is shown names no path
of the server's.
"""

from __future__ import annotations

import asyncio
import base64
import itertools
import json
import logging
import os
import queue
import secrets
import shutil
import sys
import tempfile
import threading
import time
import zipfile
from collections import OrderedDict
from collections.abc import AsyncIterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from attribot.errors import AttribotError, InputError

__all__ = [
    "Runs",
    "Run",
    "Busy",
    "Crowded",
    "NoSpace",
    "KEPT_RUNS",
    "MAX_WAITING",
    "FRAME_INTERVAL_S",
    "MAX_STREAMS",
]

log = logging.getLogger("attribot.demo")

KEPT_RUNS = 32
"""Runs whose events and files stay reachable; an older one is forgotten (and its folder removed unless the
demo keeps every run)."""
MAX_WAITING = 4
"""Queries waiting behind the running one; more are refused until one has run (HTTP 503)."""
FRAME_INTERVAL_S = 0.1
"""The least time between two camera frames sent to the pages (the sim may film faster than that)."""
KEEP_ALIVE_S = 15.0
"""A comment line on an idle event stream this often: lets the server notice a page that has gone."""
MAX_STREAMS = 64
"""Event streams open at once, in all."""
STOP_GRACE_S = 10.0
"""How long a stopping demo waits for the query that runs to notice and close its world."""


class Busy(InputError):
    """This visitor's earlier query has not finished (HTTP 409)."""


class Crowded(InputError):
    """Too many queries waiting, or too many pages following runs (HTTP 503)."""


class NoSpace(InputError):
    """The runs' folder has too little disk space left to save another run (HTTP 507)."""


class _Stopped(BaseException):
    """The demo is stopping: unwinds the query that runs in the worker from its next frame, call or try.
    Not an `Exception`, so that no `except Exception` on the way swallows it."""


def _jpeg(rgb: np.ndarray, quality: int = 80) -> str:
    import cv2

    ok, data = cv2.imencode(
        ".jpg", np.ascontiguousarray(rgb[:, :, ::-1]), [cv2.IMWRITE_JPEG_QUALITY, quality]
    )
    if not ok:  # cannot happen for a uint8 RGB image; said plainly if it does
        raise RuntimeError("JPEG encoding failed")
    return "data:image/jpeg;base64," + base64.b64encode(data.tobytes()).decode("ascii")


class PathScrubber:
    """Takes the server's own folders out of text the page is shown: a run's folder becomes nothing (its
    files keep their names), any other folder of the server's an ellipsis."""

    def __init__(self, runs_dir: Path) -> None:
        import attribot

        places = {runs_dir, runs_dir.resolve(), Path(tempfile.gettempdir()), Path.home(), Path.cwd()}
        places |= {Path(sys.prefix), Path(sys.base_prefix), Path(attribot.__file__).resolve().parents[1]}
        # the longest first: a folder inside another is replaced whole
        self.places = sorted({str(p) for p in places if len(str(p)) > 1}, key=len, reverse=True)

    def json_text(self, text: str, run_home: Path | None = None) -> str:
        """`text` (JSON, as `json.dumps` writes it) with the server's folders taken out of its strings."""
        pairs = [(str(run_home) + os.sep, "")] if run_home is not None else []
        pairs += [(place + os.sep, "\u2026/") for place in self.places]
        pairs += [(place, "\u2026") for place in self.places]
        for old, new in pairs:
            # a folder's name as JSON writes it (non-ASCII characters escaped)
            escaped_old, escaped_new = json.dumps(old)[1:-1], json.dumps(new)[1:-1]
            text = text.replace(escaped_old, escaped_new)
        return text

    def text(self, text: str) -> str:
        """Plain `text` with the server's folders taken out."""
        return json.loads(self.json_text(json.dumps(text)))


def _sse(kind: str, text: str) -> str:
    return f"event: {kind}\ndata: {text}\n\n"


@dataclass
class Run:
    """One query: what the page asked, what happened so far (as event-stream text), what it saved."""

    id: str
    visitor: str
    query: str
    config: Any
    image: Path | None
    home: Path  # the run's own folder: the upload, and `folder` (what `attribot ask --save` writes)
    scrub: PathScrubber
    messages: list[str] = field(default_factory=list)  # every event so far, encoded once
    frame: str | None = None  # the latest camera frame, encoded once
    frame_seq: int = 0
    frame_at: float = -1e9
    viewers: int = 0  # pages following it now
    done: bool = False
    stopping: threading.Event = field(default_factory=threading.Event)
    lock: threading.Lock = field(default_factory=threading.Lock)
    loop: asyncio.AbstractEventLoop | None = None  # where the pages wait
    changed: asyncio.Event | None = None  # replaced by a fresh one at each change (set on the loop)
    _wake_pending: bool = False
    zip_lock: threading.Lock = field(default_factory=threading.Lock)

    @property
    def folder(self) -> Path:
        return self.home / "run"

    # ---- the worker's side (another thread) ---------------------------------------------------------
    def emit(self, event_type: str, /, **data: Any) -> None:
        # positional-only: an event's data may hold its own "kind" (a trace record's call kind)
        message = self._encode(event_type, data)
        with self.lock:
            self.messages.append(message)
        self._wake()

    def _encode(self, event_type: str, data: dict[str, Any]) -> str:
        """An event as event-stream text, once for every page, with no folder of the server's in it."""
        text = json.dumps({**data, "type": event_type}, allow_nan=False, default=str)
        return _sse(event_type, self.scrub.json_text(text, self.home))

    def on_frame(self, robot: np.ndarray, room: np.ndarray) -> None:
        """A frame of the episode (the worker's thread): encoded only when a page watches and the last one
        is `FRAME_INTERVAL_S` old, so that no page costs the query more than one encoding per interval."""
        self.check_stopping()
        now = time.monotonic()
        if self.viewers == 0 or now - self.frame_at < FRAME_INTERVAL_S:
            return
        message = _sse("frame", json.dumps({"type": "frame", "robot": _jpeg(robot), "room": _jpeg(room)}))
        with self.lock:
            self.frame, self.frame_seq, self.frame_at = message, self.frame_seq + 1, now
        self._wake()

    def finish(self, last: tuple[str, dict[str, Any]] | None = None) -> None:
        """The run is over: its `last` event (its answer), then "done", sent once it counts as finished
        (a page that reads the answer may fetch its files at once)."""
        message = None if last is None else self._encode(*last)
        with self.lock:
            self.done = True
            self.frame = None  # the page has the last one; a kept run need not hold it
            if message is not None:
                self.messages.append(message)
            self.messages.append(_sse("done", json.dumps({"type": "done"})))
        self._wake()

    def check_stopping(self) -> None:
        if self.stopping.is_set():
            raise _Stopped()

    def _wake(self) -> None:
        """Wake the pages waiting on the event loop (one call scheduled at a time)."""
        with self.lock:
            loop = self.loop
            if loop is None or self._wake_pending:
                return
            self._wake_pending = True
        try:
            loop.call_soon_threadsafe(self._woken)
        except RuntimeError:  # the loop has closed: no page waits any more
            pass

    def _woken(self) -> None:  # on the loop
        with self.lock:
            self._wake_pending = False
        changed, self.changed = self.changed, asyncio.Event()
        if changed is not None:
            changed.set()

    # ---- the pages' side (the event loop) -----------------------------------------------------------
    async def stream(self) -> AsyncIterator[str]:
        """The run's events from its start, then as they come; camera frames while it runs."""
        sent, frame_seq, last_frame = 0, 0, -1e9
        while True:
            changed = self.changed
            with self.lock:
                messages = self.messages[sent:]
                sent += len(messages)
                frame = None
                due = time.monotonic() - last_frame >= FRAME_INTERVAL_S
                if self.frame is not None and self.frame_seq != frame_seq and due:
                    frame, frame_seq = self.frame, self.frame_seq
                finished = self.done and sent == len(self.messages)
            if frame is not None:
                last_frame = time.monotonic()
                yield frame
            for message in messages:
                yield message
            if finished:
                return
            if messages or frame is not None:
                continue
            assert changed is not None
            try:
                await asyncio.wait_for(changed.wait(), KEEP_ALIVE_S)
            except TimeoutError:
                yield ": keep-alive\n\n"


class Runs:
    """The runs, the queue, and the worker thread that answers them in order."""

    def __init__(
        self,
        runs_dir: Path,
        settings: Any,
        *,
        keep_runs: bool = False,
        min_free_bytes: int = 256 << 20,
        max_streams_per_run: int = 4,
    ) -> None:
        runs_dir.mkdir(parents=True, exist_ok=True)
        self.runs_dir = runs_dir
        self.settings = settings
        self.keep_runs = keep_runs
        self.min_free_bytes = min_free_bytes
        self.max_streams_per_run = max_streams_per_run
        self.scrub = PathScrubber(runs_dir)
        self.runs: OrderedDict[str, Run] = OrderedDict()
        self.lock = threading.Lock()
        self.queue: queue.Queue[Run | None] = queue.Queue()
        self.counter = itertools.count(1)
        self.streams = 0
        self.stopping = threading.Event()
        self.worker = threading.Thread(target=self._work, name="attribot-demo-worker", daemon=True)
        self.worker.start()

    # ---- starting a run ----------------------------------------------------------------------------
    def admit(self, visitor: str) -> None:
        """Refuse a new query of `visitor` before its upload is even decoded: the demo is stopping, the
        visitor's earlier one has not finished, the queue is full, or the disk nearly is."""
        if self.stopping.is_set():
            raise Crowded("the demo is stopping", "try again once it has been started again")
        with self.lock:
            active = [r for r in self.runs.values() if not r.done]
        if any(r.visitor == visitor for r in active):
            raise Busy("your earlier query is still running", "wait for its answer, then ask the next one")
        if len(active) > MAX_WAITING:
            raise Crowded(
                f"the demo is busy: {len(active) - 1} queries are waiting already",
                "try again in a minute",
            )
        try:
            free = shutil.disk_usage(self.runs_dir).free
        except OSError:
            free = 0
        if free < self.min_free_bytes:
            raise NoSpace(
                "the demo's disk is nearly full: it cannot save another run",
                "ask the demo's host to free disk space (or to start it with another --runs-dir)",
            )

    def start(self, visitor: str, query: str, config: Any, image: tuple[str, bytes] | None, loop: Any) -> Run:
        """Queue a query (its upload, already checked, as (suffix, bytes)); the page then follows `loop`."""
        self.admit(visitor)
        with self.lock:
            run_id = f"{next(self.counter):04d}-{secrets.token_hex(4)}"
        home = self.runs_dir / run_id
        path = None
        try:
            home.mkdir(parents=True)
            if image is not None:
                suffix, data = image
                path = home / ("upload" + suffix)
                path.write_bytes(data)
        except OSError as exc:
            shutil.rmtree(home, ignore_errors=True)
            raise NoSpace(
                f"the demo cannot save the run ({exc.strerror or type(exc).__name__})",
                "ask the demo's host to check the disk of its runs' folder",
            ) from None
        run = Run(run_id, visitor, query, config, path, home, self.scrub, stopping=self.stopping)
        run.loop, run.changed = loop, asyncio.Event()
        with self.lock:
            self.runs[run_id] = run
            forgotten = []
            while len(self.runs) > KEPT_RUNS:
                oldest = next(iter(self.runs))
                if not self.runs[oldest].done:
                    break
                forgotten.append(self.runs.pop(oldest))
            ahead = sum(1 for r in self.runs.values() if not r.done) - 1
        for old in forgotten:
            self._forget(old)
        run.emit("status", text=f"waiting: {ahead} queries ahead" if ahead else "starting")
        self.queue.put(run)
        return run

    def _forget(self, run: Run) -> None:
        if not self.keep_runs:  # the demo's own folder: a forgotten run's files go with it
            shutil.rmtree(run.home, ignore_errors=True)

    def get(self, run_id: str, visitor: str) -> Run:
        with self.lock:
            run = self.runs.get(run_id)
        if run is None or run.visitor != visitor:
            raise KeyError(run_id)
        return run

    # ---- following a run (on the event loop) -------------------------------------------------------
    def reserve(self, run: Run) -> None:
        """Count a page that follows `run` (before its response starts: a page that has its headers is
        counted); `Crowded` past the bounds. `release` it when its stream ends, however it ends."""
        if self.streams >= MAX_STREAMS:
            raise Crowded(f"{MAX_STREAMS} pages follow queries already", "try again in a minute")
        if run.viewers >= self.max_streams_per_run:
            raise Crowded(
                f"this query is followed by {run.viewers} pages already",
                "close the other tabs that show it",
            )
        self.streams += 1
        run.viewers += 1

    def release(self, run: Run) -> None:
        self.streams -= 1
        run.viewers -= 1

    # ---- the saved run -----------------------------------------------------------------------------
    def zipped(self, run: Run) -> Path:
        """The run's folder as a zip file, written once (beside the folder); its JSON files name no folder
        of the server's (a visitor replays it with their own settings)."""
        target = run.home / "run.zip"
        with run.zip_lock:
            if not target.is_file():
                partial = target.with_suffix(".partial")
                try:
                    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as archive:
                        for path in sorted(run.folder.iterdir()):
                            name = f"{run.home.name}/{path.name}"
                            if not path.is_file() or path.is_symlink():
                                continue
                            if path.suffix == ".json":
                                text = path.read_text(encoding="utf-8")
                                archive.writestr(name, self.scrub.json_text(text, run.home))
                            else:
                                archive.write(path, name)
                    partial.replace(target)
                except OSError:  # a full disk: no half-written zip is left to serve
                    partial.unlink(missing_ok=True)
                    raise
        return target

    # ---- the worker --------------------------------------------------------------------------------
    def stop(self, timeout: float = STOP_GRACE_S) -> bool:
        """Stop answering: the running query is unwound at its next frame, call or try (closing its world
        in its own thread), the waiting ones are dropped; True once the worker has ended within `timeout`."""
        self.stopping.set()
        self.queue.put(None)
        self.worker.join(timeout)
        return not self.worker.is_alive()

    def _work(self) -> None:
        while True:
            run = self.queue.get()
            if run is None:
                break
            if self.stopping.is_set():
                run.emit("error", message="the demo stopped before this query ran", fix=None)
                run.finish()
                continue
            self._answer(run)
        while True:  # what still waits is told why it will not run
            try:
                run = self.queue.get_nowait()
            except queue.Empty:
                return
            if run is not None:
                run.emit("error", message="the demo stopped before this query ran", fix=None)
                run.finish()

    def _answer(self, run: Run) -> None:
        from attribot.demo.adapter import run_query

        run.emit("status", text="building the scene" if run.image is None else "reading the image")
        tries = 0
        last = None

        def on_program(text: str) -> None:
            nonlocal tries
            run.check_stopping()
            tries += 1
            run.emit("program", attempt=tries, text=text)
            run.emit("status", text="running the program" + (f" (try {tries})" if tries > 1 else ""))

        def on_call(record: Any) -> None:
            run.check_stopping()
            run.emit("call", **record.model_dump(mode="json"))

        try:
            answer = run_query(
                run.query,
                config=run.config,
                image=run.image,
                settings=self.settings,
                save_dir=run.folder,
                on_program=on_program,
                on_call=on_call,
                on_frame=run.on_frame,
            )
        except _Stopped:
            log.warning("demo query %s stopped: the demo is stopping", run.id)
            run.emit("error", message="the demo stopped while this query ran", fix=None)
        except AttribotError as exc:
            run.emit("error", message=exc.message, fix=exc.fix)
        except Exception as exc:  # noqa: BLE001 (the page says what failed; the server goes on serving)
            log.exception("demo query %s failed", run.id)
            run.emit("error", message=f"internal error: {type(exc).__name__}: {exc}", fix=None)
        else:
            saved = {name: (run.folder / name).is_file() for name in ("answer.png", "episode.mp4")}
            last = (
                "answer",
                {
                    "answer": json.loads(answer.model_dump_json()),
                    "image": f"/api/runs/{run.id}/answer.png" if saved["answer.png"] else None,
                    "video": f"/api/runs/{run.id}/episode.mp4" if saved["episode.mp4"] else None,
                    "saved_run": f"/api/runs/{run.id}/run.zip",
                },
            )
        finally:
            if run.image is not None:  # the saved run keeps its own copy (input.png)
                run.image.unlink(missing_ok=True)
            run.finish(last)
