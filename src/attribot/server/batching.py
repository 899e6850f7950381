"""Dynamic batching: many concurrent requests of one role, one backend call.

A `Batcher` holds a queue of pending items. Its worker takes the oldest item and waits until either
`max_batch` items are queued or `window_s` has passed since that oldest item *arrived* (so time spent
queued behind a running batch counts towards the window), then calls the backend once on the batch in
its own thread and hands each result back to the request that sent it. While a batch runs, new requests
queue up and form the next batch, so under load batches grow without any window at all; the window lets
stragglers join (clients answered together send their next requests a little apart). A request that finds
the queue otherwise empty right after a batch of one is sent at once: a lone client never waits for the
window. `max_batch=1` turns batching off.

One thread per role calls the backend: a model is never entered twice at once (GPU models are not
thread-safe), and the event loop stays free to parse and decode the next requests meanwhile.

When a batched call raises, each item of the batch is run again on its own, so one bad input fails only
its own request and the others still get their answers; the error is reported for the item that raised.
"""

from __future__ import annotations

import asyncio
import collections
import concurrent.futures
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

import numpy as np

from attribot.errors import AttribotError

__all__ = ["Batcher", "Served", "Overloaded", "ShuttingDown", "RoleStats", "percentiles"]

I = TypeVar("I")  # noqa: E741 - item
R = TypeVar("R")  # result


class Overloaded(AttribotError):
    """More requests are queued for a role than the server accepts: HTTP 429, try again shortly."""


class ShuttingDown(AttribotError):
    """The server stopped before the request was served: HTTP 503."""


@dataclass
class Served(Generic[R]):
    """A result, with the size of the backend call it came from and where its time went."""

    result: R
    batch_size: int
    queue_ms: float
    backend_ms: float


def percentiles(values: Sequence[float]) -> dict[str, float]:
    """p50, p90, p99, max and mean of `values` (empty: {})."""
    if not values:
        return {}
    a = np.asarray(values, dtype=float)
    p50, p90, p99 = np.percentile(a, [50, 90, 99])
    return {
        "p50": round(float(p50), 3),
        "p90": round(float(p90), 3),
        "p99": round(float(p99), 3),
        "max": round(float(a.max()), 3),
        "mean": round(float(a.mean()), 3),
    }


@dataclass
class RoleStats:
    """Counters of one role. Updated only from the event loop thread, so no locks."""

    backend: str
    requests: int = 0
    ok: int = 0
    errors: collections.Counter[str] = field(default_factory=collections.Counter)
    batch_sizes: collections.Counter[int] = field(default_factory=collections.Counter)
    latency_ms: collections.deque[float] = field(default_factory=lambda: collections.deque(maxlen=10_000))
    backend_ms: collections.deque[float] = field(default_factory=lambda: collections.deque(maxlen=10_000))

    def summary(self, queued: int = 0) -> dict[str, Any]:
        batches = sum(self.batch_sizes.values())
        items = sum(size * n for size, n in self.batch_sizes.items())
        return {
            "backend": self.backend,
            "requests": self.requests,
            "ok": self.ok,
            "errors": dict(self.errors),
            "batches": batches,
            "batch_sizes": dict(sorted(self.batch_sizes.items())),
            "max_batch_size": max(self.batch_sizes, default=0),
            "mean_batch_size": round(items / batches, 3) if batches else 0.0,
            "queued": queued,
            "latency_ms": percentiles(list(self.latency_ms)),
            "backend_ms": percentiles(list(self.backend_ms)),
        }


@dataclass
class _Pending(Generic[I]):
    item: I
    future: asyncio.Future[Any]
    arrived: float


class Batcher(Generic[I, R]):
    """Collects items for `call(items) -> results` (same length, same order) into batches.

    `await submit(item)` gives a `Served` result or raises what the backend raised for that item.
    Start with `start()` inside the running event loop; `stop()` fails whatever is still queued.
    """

    def __init__(
        self,
        name: str,
        call: Callable[[list[I]], list[R]],
        *,
        max_batch: int,
        window_s: float,
        max_queue: int,
        stats: RoleStats | None = None,
    ) -> None:
        if max_batch < 1:
            raise ValueError(f"max_batch must be at least 1, got {max_batch}")
        if window_s < 0:
            raise ValueError(f"the batching window must be >= 0 seconds, got {window_s}")
        self.name = name
        self._call = call
        self.max_batch = int(max_batch)
        self.window_s = float(window_s)
        self.max_queue = int(max_queue)
        self.stats = stats or RoleStats(backend=name)
        self._pending: collections.deque[_Pending[I]] = collections.deque()
        self._last_size = 1
        self._wake: asyncio.Event | None = None
        self._task: asyncio.Task[None] | None = None
        self._executor: concurrent.futures.ThreadPoolExecutor | None = None

    @property
    def queued(self) -> int:
        return len(self._pending)

    def start(self) -> None:
        """Start the worker; call from inside the event loop that will submit."""
        self._wake = asyncio.Event()
        self._executor = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix=f"attribot-{self.name}")
        self._task = asyncio.get_running_loop().create_task(self._work(), name=f"batcher-{self.name}")

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            try:
                await self._task
            except asyncio.CancelledError:
                pass
            self._task = None
        while self._pending:
            p = self._pending.popleft()
            if not p.future.done():
                p.future.set_exception(ShuttingDown("the server is shutting down", "send the request again"))
        if self._executor is not None:
            self._executor.shutdown(wait=False, cancel_futures=True)
            self._executor = None

    async def submit(self, item: I) -> Served[R]:
        if self._task is None or self._wake is None:
            raise ShuttingDown(f"the {self.name} batcher is not running", "send the request again")
        if len(self._pending) >= self.max_queue:
            raise Overloaded(
                f"{len(self._pending)} requests are already queued for the {self.name}",
                "retry after a short pause, or start the server with a larger --max-queue",
            )
        loop = asyncio.get_running_loop()
        future: asyncio.Future[Served[R]] = loop.create_future()
        self._pending.append(_Pending(item, future, loop.time()))
        self._wake.set()
        return await future

    # ---- the worker -----------------------------------------------------------------------------------

    async def _work(self) -> None:
        assert self._wake is not None
        loop = asyncio.get_running_loop()
        while True:
            while not self._pending:
                self._wake.clear()
                await self._wake.wait()
            deadline = self._pending[0].arrived + self.window_s
            # a lone request, after a lone request, goes at once: a single client (the usual robot) pays
            # no window; once requests overlap, the window lets stragglers join
            alone = len(self._pending) == 1 and self._last_size == 1
            while not alone and len(self._pending) < self.max_batch:
                remaining = deadline - loop.time()
                if remaining <= 0:
                    break
                self._wake.clear()
                try:
                    await asyncio.wait_for(self._wake.wait(), remaining)
                except TimeoutError:
                    break
            batch = [self._pending.popleft() for _ in range(min(self.max_batch, len(self._pending)))]
            # requests whose client went away are not worth a backend call
            batch = [p for p in batch if not p.future.done()]
            if not batch:
                continue
            self._last_size = len(batch)
            started = loop.time()
            try:
                outcomes, calls = await loop.run_in_executor(
                    self._executor, self._run, [p.item for p in batch]
                )
            except RuntimeError as exc:  # the executor was shut down under us: stop() is running
                for p in batch:
                    if not p.future.done():
                        p.future.set_exception(ShuttingDown(f"the server is shutting down ({exc})"))
                return
            for p, (result, error, size, ms) in zip(batch, outcomes, strict=True):
                if p.future.done():
                    continue
                if error is not None:
                    p.future.set_exception(error)
                else:
                    queue_ms = (started - p.arrived) * 1000.0
                    p.future.set_result(Served(result, size, queue_ms, ms))
            for size, ms in calls:
                self.stats.batch_sizes[size] += 1
                self.stats.backend_ms.append(ms)

    def _run(
        self, items: list[I]
    ) -> tuple[list[tuple[R | None, BaseException | None, int, float]], list[tuple[int, float]]]:
        """In the backend thread: one call for the batch; on failure, one call per item.
        Returns each item's (result, error, size of the call that served it, its ms) and every
        backend call made as (size, ms)."""
        t0 = time.perf_counter()
        try:
            results = self._checked(items)
            ms = (time.perf_counter() - t0) * 1000.0
            return [(r, None, len(items), ms) for r in results], [(len(items), ms)]
        except Exception as exc:  # noqa: BLE001 - reported per request below
            ms = (time.perf_counter() - t0) * 1000.0
            if len(items) == 1:
                return [(None, exc, 1, ms)], [(1, ms)]
        out: list[tuple[R | None, BaseException | None, int, float]] = []
        calls = [(len(items), ms)]
        for item in items:
            t1 = time.perf_counter()
            try:
                result: R | None = self._checked([item])[0]
                error: BaseException | None = None
            except Exception as exc:  # noqa: BLE001
                result, error = None, exc
            ms1 = (time.perf_counter() - t1) * 1000.0
            out.append((result, error, 1, ms1))
            calls.append((1, ms1))
        return out, calls

    def _checked(self, items: list[I]) -> list[R]:
        results = list(self._call(items))
        if len(results) != len(items):
            raise RuntimeError(
                f"the {self.name} backend returned {len(results)} results for {len(items)} inputs"
            )
        return results
