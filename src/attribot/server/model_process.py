"""A detector or VQA backend run in a child process of the server.

Why: in one process, the server's HTTP work (parsing, base64, JPEG decoding, JSON) and an eager PyTorch
model share one GIL: every op of a GPU forward releases the GIL and must take it back, waiting behind
whatever the event loop is doing at that moment. In a process of its own, the model's Python has a GIL
of its own, and a model that brings its process down (a CUDA fault, the out-of-memory killer) no longer
takes the server with it.

Only the RGB image of a frame crosses, as over HTTP. The images of a batch cross through one shared-memory
block (the parent writes each frame once, the child reads them in place), not through the pipe: pickling
a batch of 32 frames of 640x480 through a pipe costs about 45 ms here, the copy into shared memory about
1 ms. Queries, answers and errors cross the pipe.

The child builds the backend itself from a picklable factory (`functools.partial(build_backend, role,
spec, settings)`), so a CUDA model is created where it runs. It exits when the parent closes the pipe,
asks it to stop, or dies. An error raised in the child comes back as the same kind of AttribotError
(an InputError stays a 400); a child that dies mid-batch fails that batch with a BackendError and is
started again for the next one.
"""

from __future__ import annotations

import functools
import logging
import multiprocessing
import multiprocessing.connection
import signal
import threading
import traceback
import weakref
from collections.abc import Callable, Sequence
from multiprocessing import shared_memory
from typing import TYPE_CHECKING, Any

import numpy as np

from attribot import errors
from attribot.errors import AttribotError, BackendError
from attribot.frame import Frame
from attribot.models.base import Detection, answer_many, build_backend, detect_many
from attribot.shutdown import die_with_parent

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = ["ModelProcess", "ProcessDetector", "ProcessVisualQA", "start_model_process", "backend_factory"]

log = logging.getLogger("attribot.server")

_ROLES = ("detector", "vqa")
DEFAULT_BATCH_TIMEOUT_S = 300.0
"""Longest a model may take over one batch before its process is killed and started again."""
STOP_TIMEOUT_S = 3.0
"""How long a child is given to stop when asked, before it is killed."""


def backend_factory(role: str, spec: str, settings: Settings) -> Callable[[], Any]:
    """A picklable factory that builds the backend of `spec` (in the child process)."""
    return functools.partial(build_backend, role, spec, settings)


def _describe(exc: BaseException) -> tuple[str, str, str | None]:
    """(class name, message, fix) of an exception, to rebuild it on the other side of the pipe."""
    if isinstance(exc, AttribotError):
        return type(exc).__name__, exc.message, exc.fix
    return "", f"{type(exc).__name__}: {exc}", None


def _rebuild(kind: str, message: str, fix: str | None) -> AttribotError:
    """The error the child reported, as the same AttribotError subclass where it is one of ours."""
    from attribot.models.wire import ImageTooLarge

    known: dict[str, type[AttribotError]] = {
        name: cls
        for name, cls in vars(errors).items()
        if isinstance(cls, type) and issubclass(cls, AttribotError)
    }
    known["ImageTooLarge"] = ImageTooLarge
    cls = known.get(kind, BackendError)
    return cls(message, fix)


# ---- the child --------------------------------------------------------------------------------------


class _Attached:
    """The parent's shared-memory block, opened by name in the child without the resource tracker.

    `SharedMemory(name=...)` registers every attach with a tracker (before Python 3.13): the child's own
    tracker then "cleans up" the parent's block when the child exits and warns of a leak that is not one,
    and a tracker shared with the parent is cleared twice. The parent creates, owns and unlinks the block;
    the child only maps it."""

    def __init__(self, name: str) -> None:
        import _posixshmem  # the module SharedMemory itself uses
        import mmap
        import os

        fd = _posixshmem.shm_open("/" + name.lstrip("/"), os.O_RDWR, mode=0o600)
        try:
            self.buf: Any = mmap.mmap(fd, os.fstat(fd).st_size)
        finally:
            os.close(fd)
        self.name = name

    def close(self) -> None:
        self.buf.close()


def _child_main(conn: multiprocessing.connection.Connection, role: str, factory: Callable[[], Any]) -> None:
    """Build the backend, then serve batches until told to stop or the parent goes away."""
    # Ctrl-C in a terminal (or a service manager's SIGTERM) reaches the whole process group: the parent
    # alone stops the server, and then this process, in order (here it would only print a traceback)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # the same for a SIGTERM sent to the whole group
    die_with_parent()
    try:
        backend = factory()
    except BaseException as exc:  # noqa: BLE001 - reported to the parent, which raises it
        conn.send(("failed", *_describe(exc)))
        return
    conn.send(("ready", str(getattr(backend, "name", type(backend).__name__))))
    block: _Attached | None = None
    try:
        while True:
            try:
                message = conn.recv()
            except (EOFError, OSError):  # the parent is gone
                return
            if message[0] == "stop":
                return
            _, block_name, layout, payloads = message
            try:
                if block is None or block.name != block_name:
                    if block is not None:
                        block.close()
                    block = _Attached(block_name)
                frames = [
                    Frame(rgb=np.ndarray(shape, np.uint8, buffer=block.buf, offset=offset))
                    for offset, shape in layout
                ]
                if role == "detector":
                    result: list[Any] = detect_many(backend, frames, payloads)
                else:
                    result = answer_many(backend, frames, payloads)
                del frames  # views into the block: gone before the block can be closed
                conn.send(("ok", result))
            except BaseException as exc:  # noqa: BLE001 - every failure goes back to its batch
                if not isinstance(exc, AttribotError):
                    traceback.print_exc()  # the server's log keeps the child's traceback
                conn.send(("error", *_describe(exc)))
    finally:
        if block is not None:
            block.close()


# ---- the parent -------------------------------------------------------------------------------------


class ModelProcess:
    """The parent's handle on a backend in a child process; one batch at a time (a lock guards the pipe).

    Use the role's subclass (`ProcessDetector`, `ProcessVisualQA`), or `start_model_process`.
    """

    role: str = ""

    def __init__(
        self,
        factory: Callable[[], Any],
        *,
        start_timeout_s: float = 900.0,
        batch_timeout_s: float = DEFAULT_BATCH_TIMEOUT_S,
    ) -> None:
        if self.role not in _ROLES:
            raise TypeError("use ProcessDetector or ProcessVisualQA")
        self._factory = factory
        self._start_timeout_s = float(start_timeout_s)
        self.batch_timeout_s = float(batch_timeout_s)
        self._context = multiprocessing.get_context("spawn")  # CUDA cannot be used in a forked child
        self._lock = threading.Lock()
        self._process: Any = None
        self._conn: multiprocessing.connection.Connection | None = None
        self._block: shared_memory.SharedMemory | None = None
        self.name = ""
        self.restarts = 0
        # what the finalizer needs, one dict refreshed by _sync_state (restarts and new blocks are seen)
        self._shared_state: dict[str, Any] = {}
        self._start()
        self._finalizer = weakref.finalize(self, ModelProcess._shutdown, self._shared_state)

    # -- life cycle

    def _sync_state(self) -> None:
        self._shared_state.update(process=self._process, conn=self._conn, block=self._block)

    def _start(self) -> None:
        parent_end, child_end = self._context.Pipe(duplex=True)
        process = self._context.Process(
            target=_child_main,
            args=(child_end, self.role, self._factory),
            name=f"attribot-{self.role}-model",
            daemon=True,  # multiprocessing stops it at the parent's exit, if nothing did before
        )
        process.start()
        child_end.close()
        try:
            reply = self._wait_for_start(parent_end, process)
        except BaseException:
            parent_end.close()
            process.join(5)
            if process.is_alive():
                process.kill()
            raise
        self._process, self._conn, self.name = process, parent_end, reply
        self._sync_state()

    def _wait_for_start(self, conn: multiprocessing.connection.Connection, process: Any) -> str:
        waited = 0.0
        while not conn.poll(0.1):
            waited += 0.1
            if not process.is_alive():
                raise BackendError(
                    f"the {self.role} model process exited (code {process.exitcode}) while loading its model",
                    "see the server's log above for the reason (out of memory, a missing CUDA library, ...)",
                )
            if waited > self._start_timeout_s:
                process.kill()
                raise BackendError(
                    f"the {self.role} model process did not finish loading in {self._start_timeout_s:g} s",
                    "check that the model is in the local cache and the GPU is free",
                )
        try:
            reply = conn.recv()
        except EOFError:
            process.join(5)
            raise BackendError(
                f"the {self.role} model process exited (code {process.exitcode}) while loading its model",
                "see the server's log above for the reason",
            ) from None
        if reply[0] == "failed":
            raise _rebuild(*reply[1:])
        return str(reply[1])

    @staticmethod
    def _shutdown(state: dict[str, Any]) -> None:
        conn, process, block = state.get("conn"), state.get("process"), state.get("block")
        if process is not None and state.get("busy"):
            process.kill()  # inside a batch: it would read "stop" only when the batch ends
        if conn is not None:
            try:
                conn.send(("stop",))
            except (OSError, ValueError):
                pass
            _close_quietly(conn)
        if process is not None:
            process.join(STOP_TIMEOUT_S)  # a child inside a model call reads "stop" only after it
            if process.is_alive():
                process.kill()
                process.join(5)
        if block is not None:
            block.close()
            try:
                block.unlink()
            except FileNotFoundError:
                pass
        state.clear()

    def close(self) -> None:
        """Stop the child and free the shared memory (also done when this object is collected).

        Does not wait for a batch in flight beyond a moment: a child stuck in a model call is killed, and
        the thread waiting for its answer gets a BackendError."""
        acquired = self._lock.acquire(timeout=0.5)
        try:
            self._shared_state["busy"] = not acquired
            self._finalizer()
            self._process = self._conn = self._block = None
        finally:
            if acquired:
                self._lock.release()

    @property
    def pid(self) -> int | None:
        """The child's process id (None once closed or lost)."""
        return None if self._process is None else int(self._process.pid)

    # -- one batch

    def _block_for(self, size: int) -> shared_memory.SharedMemory:
        """The shared-memory block, replaced by a larger one when a batch needs more room."""
        if self._block is None or self._block.size < size:
            if self._block is not None:
                self._block.close()
                self._block.unlink()  # the child's mapping stays valid until it moves to the new block
            # some headroom, so that a slowly growing batch does not replace the block every time
            self._block = shared_memory.SharedMemory(create=True, size=max(size * 5 // 4, 1 << 20))
            self._sync_state()
        return self._block

    def _run(self, frames: Sequence[Frame], payloads: Sequence[Any]) -> list[Any]:
        if len(frames) != len(payloads):
            raise ValueError(f"{len(frames)} frames but {len(payloads)} queries")
        if not frames:
            return []
        with self._lock:
            if self._conn is None:
                if not self._finalizer.alive:
                    raise BackendError(f"the {self.role} model process was closed", "start a new one")
                self.restarts += 1
                log.warning("starting the %s model process again (restart %d)", self.role, self.restarts)
                self._start()
            assert self._conn is not None
            layout: list[tuple[int, tuple[int, ...]]] = []
            offset = 0
            for frame in frames:
                layout.append((offset, tuple(frame.rgb.shape)))
                offset += frame.rgb.nbytes
            block = self._block_for(offset)
            for frame, (start, shape) in zip(frames, layout, strict=True):
                view = np.ndarray(shape, np.uint8, buffer=block.buf, offset=start)
                view[...] = frame.rgb
            del view
            try:
                self._conn.send(("run", block.name, layout, list(payloads)))
                if not self._conn.poll(self.batch_timeout_s):
                    self._lost(kill=True)
                    raise BackendError(
                        f"the {self.role} model took longer than {self.batch_timeout_s:g} s over a batch of "
                        f"{len(frames)}; its process was stopped",
                        "it is started again for the next request; send smaller images or fewer at once",
                    )
                reply = self._conn.recv()
            except (EOFError, OSError, TypeError, AttributeError):  # the last two: closed meanwhile
                code = self._lost()
                raise BackendError(
                    f"the {self.role} model process exited (code {code}) while serving a batch of "
                    f"{len(frames)}",
                    "see the server's log for the reason; it is started again for the next request",
                ) from None
        if reply[0] == "error":
            raise _rebuild(*reply[1:])
        result = list(reply[1])
        if len(result) != len(frames):
            raise BackendError(
                f"the {self.role} model process returned {len(result)} results for {len(frames)} inputs"
            )
        return result

    def _lost(self, kill: bool = False) -> int | None:
        """Forget a child that died (or, with `kill`, one past its deadline); the next batch starts a new
        one. Its exit code."""
        process, conn = self._process, self._conn
        self._process = self._conn = None
        self._sync_state()
        if conn is not None:
            _close_quietly(conn)
        if process is None:
            return None
        if kill:
            process.kill()
        process.join(5)
        if process.is_alive():
            process.kill()
            process.join(5)
        return process.exitcode


class ProcessDetector(ModelProcess):
    """A detector in a child process (see the module's docstring)."""

    role = "detector"

    def detect(self, frame: Frame, queries: Sequence[str]) -> list[Detection]:
        return self.detect_batch([frame], [queries])[0]

    def detect_batch(
        self, frames: Sequence[Frame], queries: Sequence[Sequence[str]]
    ) -> list[list[Detection]]:
        return self._run(frames, [list(q) for q in queries])


class ProcessVisualQA(ModelProcess):
    """A VQA backend in a child process (see the module's docstring)."""

    role = "vqa"

    def answer(self, frame: Frame, question: str) -> str:
        return self.answer_batch([frame], [question])[0]

    def answer_batch(self, frames: Sequence[Frame], questions: Sequence[str]) -> list[str]:
        return [str(a) for a in self._run(frames, list(questions))]


def start_model_process(
    role: str,
    factory: Callable[[], Any],
    *,
    start_timeout_s: float = 900.0,
    batch_timeout_s: float = DEFAULT_BATCH_TIMEOUT_S,
) -> ProcessDetector | ProcessVisualQA:
    """Start the backend `factory()` builds in a child process, as `role` (detector or vqa); returns
    once it is loaded (a failure to load raises here, with the child's message). A batch that takes
    longer than `batch_timeout_s` fails and the process is started again, as after a crash."""
    if role == "detector":
        return ProcessDetector(factory, start_timeout_s=start_timeout_s, batch_timeout_s=batch_timeout_s)
    if role == "vqa":
        return ProcessVisualQA(factory, start_timeout_s=start_timeout_s, batch_timeout_s=batch_timeout_s)
    raise errors.ConfigError(
        f"only the detector and VQA run in a model process, not the {role!r}",
        "serve the language role in the server's own process (it is a passthrough)",
    )


def _close_quietly(conn: Any) -> None:
    """Close a pipe end that another thread may be closing too: a request thread whose child was killed
    under it (`_lost`) races `close` (`_shutdown`), and the loser's EBADF must not stop the shutdown before
    it frees the shared memory."""
    try:
        conn.close()
    except OSError:
        pass
