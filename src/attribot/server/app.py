"""The model server's FastAPI application: detector, VQA and language backends behind HTTP.

Endpoints (records in `attribot.models.wire`):

  POST /v1/detect    DetectRequest   -> DetectResponse     batched (detect_many)
  POST /v1/answer    AnswerRequest   -> AnswerResponse     batched (answer_many)
  POST /v1/complete  CompleteRequest -> CompleteResponse   passed through, a few at a time
  GET  /health       HealthResponse  (no token needed: a liveness probe)
  GET  /metrics      MetricsResponse (counts, batch-size histogram, latency percentiles, errors)

Every error is an `ErrorBody` (category, message, fix) with a status that says whose fault it is:
401 no token, 403 wrong token, 400 unreadable request or image, 413 too large, 404 role not served,
429 queue full, 500 the backend raised (the server keeps serving), 503 shutting down.
The token is compared in constant time. Request bodies are read with a size cap before any parsing.
"""

# no `from __future__ import annotations`: FastAPI reads the endpoints' annotations at run time, and
# `Request` is imported inside create_app (the server extra is optional)
import asyncio
import concurrent.futures
import contextlib
import hmac
import logging
import time
from collections import Counter
from collections.abc import AsyncIterator
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from attribot import __version__
from attribot.bridge.guard import WrongTokens
from attribot.deps import require
from attribot.errors import AttribotError, InputError
from attribot.frame import Frame
from attribot.models.base import Detection, answer_many, detect_many
from attribot.models.wire import (
    PATHS,
    AnswerRequest,
    AnswerResponse,
    CompleteRequest,
    CompleteResponse,
    DetectRequest,
    DetectResponse,
    ErrorBody,
    ErrorCategory,
    ErrorInfo,
    HealthResponse,
    ImageTooLarge,
    MetricsResponse,
    decode_image,
)
from attribot.server.batching import Batcher, Overloaded, RoleStats, ShuttingDown

__all__ = ["ServerConfig", "create_app"]

log = logging.getLogger("attribot.server")


class ServerConfig(BaseModel):
    """How the server batches, what it accepts, and the token clients must send (None: no check)."""

    model_config = ConfigDict(extra="forbid")

    token: str | None = Field(default=None, repr=False)
    max_batch: int = Field(default=32, ge=1, le=1024)
    batch_window_ms: float = Field(default=2.0, ge=0.0, le=10_000.0, allow_inf_nan=False)
    max_queue: int = Field(default=1024, ge=1, le=100_000)
    max_image_mb: float = Field(default=10.0, gt=0.0, le=200.0, allow_inf_nan=False)
    max_pixels: int = Field(default=25_000_000, ge=1, le=400_000_000)
    language_threads: int = Field(default=8, ge=1, le=256)
    max_text_chars: int = Field(default=4000, ge=1, le=1_000_000)
    max_queries: int = Field(default=64, ge=1, le=10_000)

    @property
    def max_image_bytes(self) -> int:
        return int(self.max_image_mb * 2**20)

    @property
    def max_body_bytes(self) -> int:
        # base64 grows the image by 4/3; the rest of the JSON is a few kilobytes of text
        return self.max_image_bytes * 4 // 3 + 4 + 64 * 1024

    @property
    def max_text_body_bytes(self) -> int:
        """The largest body of a text-only request: a question of `max_text_chars`, each character
        written as a JSON escape at worst."""
        return self.max_text_chars * 6 + 4096


class _Refused(Exception):
    """An error answered before any backend is involved (auth, body size, parsing)."""

    def __init__(
        self, status: int, category: ErrorCategory, message: str, fix: str | None = None, wait_s: float = 0.0
    ) -> None:
        super().__init__(message)
        self.status, self.category, self.message, self.fix = status, category, message, fix
        self.wait_s = wait_s  # how long to hold the answer (a peer guessing tokens is slowed)


def _error_response(status: int, category: ErrorCategory, message: str, fix: str | None = None) -> Any:
    from starlette.responses import Response

    body = ErrorBody(error=ErrorInfo(category=category, message=message, fix=fix)).model_dump_json()
    headers = {}
    if status == 401:
        headers["WWW-Authenticate"] = "Bearer"
    if status in (429, 503):
        headers["Retry-After"] = "1"
    return Response(body, status_code=status, media_type="application/json", headers=headers)


def _classify(exc: BaseException, role: str, backend: str) -> tuple[int, ErrorCategory, str, str | None]:
    """HTTP status, category, message and fix for an exception raised while serving `role`."""
    if isinstance(exc, _Refused):
        return exc.status, exc.category, exc.message, exc.fix
    if isinstance(exc, ImageTooLarge):
        return 413, "too_large", exc.message, exc.fix
    if isinstance(exc, InputError):
        return 400, "input", exc.message, exc.fix
    if isinstance(exc, Overloaded):
        return 429, "overloaded", exc.message, exc.fix
    if isinstance(exc, ShuttingDown):
        return 503, "internal", exc.message, exc.fix
    if isinstance(exc, AttribotError):
        return 500, "backend", f"the {role} backend {backend} failed: {exc.message}", exc.fix
    return (
        500,
        "backend",
        f"the {role} backend {backend} failed: {exc.__class__.__name__}: {exc}",
        "see the server's log for the traceback; the server goes on serving other requests",
    )


def _parse(model: type[BaseModel], body: bytes) -> Any:
    try:
        return model.model_validate_json(body)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first.get("loc", ())) or "body"
        raise _Refused(
            400,
            "input",
            f"the request is not a valid {model.__name__}: {where}: {first.get('msg', 'invalid')}",
            "send JSON with the fields of attribot.models.wire." + model.__name__,
        ) from None


class _ModelServer:
    """The state of one server (backends, batchers, counters) and what each endpoint does with a request.

    `create_app` wires these methods to routes. Endpoint signatures live there: FastAPI reads their
    annotations at run time, and `Request` exists only with the server extra installed."""

    def __init__(self, detector: Any, vqa: Any, language: Any, cfg: ServerConfig) -> None:
        self.detector, self.vqa, self.language, self.cfg = detector, vqa, language, cfg
        self.names: dict[str, str | None] = {
            role: None if backend is None else str(getattr(backend, "name", type(backend).__name__))
            for role, backend in (("detector", detector), ("vqa", vqa), ("language", language))
        }
        self.stats = {role: RoleStats(backend=name) for role, name in self.names.items() if name is not None}
        self.rejected: Counter[str] = Counter()
        self.started = time.monotonic()
        self.token = None if cfg.token is None else cfg.token.encode()
        self.wrong_tokens = WrongTokens(log=log, what="model server")
        self.language_pool: list[concurrent.futures.ThreadPoolExecutor] = []
        self.batchers: dict[str, Batcher[Any, Any]] = {}
        batched = (("detector", detector, self._detect), ("vqa", vqa, self._answer))
        for role, backend, call in batched:
            if backend is not None:
                self.batchers[role] = Batcher(
                    role,
                    call,
                    max_batch=cfg.max_batch,
                    window_s=cfg.batch_window_ms / 1000.0,
                    max_queue=cfg.max_queue,
                    stats=self.stats[role],
                )

    # ---- backend calls (in a batcher's thread) ------------------------------------------------------

    def _detect(self, items: list[tuple[Frame, list[str]]]) -> list[list[Detection]]:
        return detect_many(self.detector, [f for f, _ in items], [q for _, q in items])

    def _answer(self, items: list[tuple[Frame, str]]) -> list[str]:
        return answer_many(self.vqa, [f for f, _ in items], [q for _, q in items])

    # ---- life cycle ---------------------------------------------------------------------------------

    @contextlib.asynccontextmanager
    async def lifespan(self, _app: Any) -> AsyncIterator[None]:
        for b in self.batchers.values():
            b.start()
        if self.language is not None:
            self.language_pool.append(
                concurrent.futures.ThreadPoolExecutor(
                    self.cfg.language_threads, thread_name_prefix="attribot-lang"
                )
            )
        try:
            yield
        finally:
            for b in self.batchers.values():
                await b.stop()
            for pool in self.language_pool:
                pool.shutdown(wait=False, cancel_futures=True)

    # ---- what every request goes through ------------------------------------------------------------

    def check_token(self, request: Any) -> None:
        """Refuse a request without the token (401), with a wrong one (403, answered more and more slowly
        past the first few from one address), or from an address blocked for guessing (429)."""
        if self.token is None:
            return
        peer = request.client.host if request.client else "?"
        left = self.wrong_tokens.blocked(peer)
        if left > 0:
            raise _Refused(
                429,
                "auth",
                f"too many wrong tokens from {peer}: refused for {left:.0f} s more",
                "set ATTRIBOT_REMOTE_TOKEN to the token the server was started with, then wait",
                wait_s=self.wrong_tokens.BLOCKED_WAIT_S,
            )
        header = request.headers.get("authorization", "")
        scheme, _, given = header.partition(" ")
        if not header or scheme.lower() != "bearer" or not given.strip():
            raise _Refused(
                401,
                "auth",
                "this server needs a bearer token and the request has none",
                "send `Authorization: Bearer TOKEN` (the client reads ATTRIBOT_REMOTE_TOKEN)",
            )
        if not hmac.compare_digest(given.strip().encode("utf-8", "surrogatepass"), self.token):
            raise _Refused(
                403,
                "auth",
                "the bearer token is wrong",
                "set ATTRIBOT_REMOTE_TOKEN to the token the server was started with",
                wait_s=self.wrong_tokens.wrong(peer),
            )
        self.wrong_tokens.right(peer)

    async def read_body(self, request: Any, role: str) -> bytes:
        cfg = self.cfg
        if role == "language":  # text only: a body far larger than the longest question is refused unread
            limit = cfg.max_text_body_bytes
            too_large = _Refused(
                413,
                "too_large",
                f"the request is over the server's limit of {limit} bytes for a text question "
                f"(questions up to {cfg.max_text_chars} characters)",
                "send a shorter question",
            )
        else:
            limit = cfg.max_body_bytes
            too_large = _Refused(
                413,
                "too_large",
                f"the request is over the server's limit of {limit / 2**20:.1f} MB "
                f"(images up to {cfg.max_image_mb:g} MB)",
                "send a smaller image (JPEG is ~10x smaller than PNG), or start the server with a larger "
                "--max-image-mb",
            )
        declared = request.headers.get("content-length")
        if declared is not None and declared.isdigit() and int(declared) > limit:
            # read and drop what the client is sending (up to a bound), so that it sees the 413 and not a
            # reset connection half-way through its upload
            seen = 0
            async for chunk in request.stream():
                seen += len(chunk)
                if seen > 8 * limit:
                    break
            raise too_large
        chunks: list[bytes] = []
        size = 0
        async for chunk in request.stream():
            size += len(chunk)
            if size > limit:
                raise too_large
            chunks.append(chunk)
        return b"".join(chunks)

    def check_text(self, texts: list[str], what: str) -> None:
        """Refuse (413) a question or query longer than the server takes: a backend's time and memory grow
        with its input (a 5 MB question doubled the VQA process's memory and ended in a 500)."""
        cfg = self.cfg
        if len(texts) > cfg.max_queries:
            what_s = "queries" if what == "query" else what + "s"
            raise _Refused(
                413,
                "too_large",
                f"the request has {len(texts)} {what_s}, over the server's limit of {cfg.max_queries}",
                f"send at most {cfg.max_queries} {what_s} per request",
            )
        longest = max((len(t) for t in texts), default=0)
        if longest > cfg.max_text_chars:
            raise _Refused(
                413,
                "too_large",
                f"the {what} is {longest} characters long, over the server's limit of {cfg.max_text_chars}",
                f"send a shorter {what} (attribot's API sends at most 2000 characters)",
            )

    def decode(self, data: str) -> Frame:
        cfg = self.cfg
        return Frame(rgb=decode_image(data, max_bytes=cfg.max_image_bytes, max_pixels=cfg.max_pixels))

    @staticmethod
    async def until_disconnected(request: Any, work: Any) -> Any:
        """The result of `work` (a coroutine), or None when the client disconnects first: then the work is
        cancelled, and a request still queued for a batch is left out of it."""
        task = asyncio.ensure_future(work)

        async def gone() -> None:
            while (await request.receive())["type"] != "http.disconnect":
                pass

        watcher = asyncio.ensure_future(gone())
        try:
            await asyncio.wait({task, watcher}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            if not task.done():
                task.cancel()
            watcher.cancel()
        if task.cancelled() or not task.done():
            return None
        return task.result()

    async def serve(self, role: str, request: Any, handle: Any) -> Any:
        """Common path: check the token, count, run `handle(body)`, turn any failure into an ErrorBody.
        Requests refused before they reach a role (token, role not served) count under `rejected`;
        the others count under their role (requests = ok + errors) with their latency."""
        from starlette.requests import ClientDisconnect
        from starlette.responses import Response

        t0 = time.perf_counter()
        name = self.names.get(role)
        role_stats = self.stats.get(role)
        admitted = False
        try:
            self.check_token(request)
            if name is None or role_stats is None:
                raise _Refused(
                    404,
                    "not_served",
                    f"this server serves no {role}",
                    f"start it with a {role} backend: attribot serve models --{role} SPEC",
                )
            role_stats.requests += 1
            admitted = True
            body = await self.read_body(request, role)
            record = await self.until_disconnected(request, handle(body))
            if record is None:  # the client went away: its work was dropped, nobody reads an answer
                role_stats.errors["disconnected"] += 1
                return Response(status_code=499)
            role_stats.ok += 1
            return Response(record.model_dump_json(), media_type="application/json")
        except ClientDisconnect:  # gone half-way through its body: not the backend's failure
            (role_stats.errors if admitted and role_stats is not None else self.rejected)["disconnected"] += 1
            return Response(status_code=499)
        except asyncio.CancelledError:  # the server stopped before this request was served
            if admitted and role_stats is not None:
                role_stats.errors["internal"] += 1
            return _error_response(503, "internal", "the server is shutting down", "send the request again")
        except Exception as exc:  # noqa: BLE001 - every failure becomes a structured answer
            if isinstance(exc, _Refused) and exc.wait_s > 0:
                await asyncio.sleep(exc.wait_s)
            status, category, message, fix = _classify(exc, role, name or "-")
            if status == 500:
                log.error("%s request failed: %s", role, message, exc_info=exc)
            (role_stats.errors if admitted and role_stats is not None else self.rejected)[category] += 1
            return _error_response(status, category, message, fix)
        finally:
            if admitted and role_stats is not None:
                role_stats.latency_ms.append((time.perf_counter() - t0) * 1000.0)

    # ---- the roles ----------------------------------------------------------------------------------

    async def detect(self, body: bytes) -> BaseModel:
        req: DetectRequest = _parse(DetectRequest, body)
        self.check_text(req.queries, "query")
        frame = await asyncio.to_thread(self.decode, req.image)
        served = await self.batchers["detector"].submit((frame, req.queries))
        return DetectResponse(
            detections=served.result,
            backend=self.names["detector"] or "",
            batch_size=served.batch_size,
            queue_ms=served.queue_ms,
            backend_ms=served.backend_ms,
        )

    async def answer(self, body: bytes) -> BaseModel:
        req: AnswerRequest = _parse(AnswerRequest, body)
        self.check_text([req.question], "question")
        frame = await asyncio.to_thread(self.decode, req.image)
        served = await self.batchers["vqa"].submit((frame, req.question))
        return AnswerResponse(
            answer=str(served.result),
            backend=self.names["vqa"] or "",
            batch_size=served.batch_size,
            queue_ms=served.queue_ms,
            backend_ms=served.backend_ms,
        )

    async def complete(self, body: bytes) -> BaseModel:
        req: CompleteRequest = _parse(CompleteRequest, body)
        self.check_text([req.question], "question")
        t0 = time.perf_counter()
        loop = asyncio.get_running_loop()
        text = await loop.run_in_executor(self.language_pool[0], self.language.complete, req.question)
        ms = (time.perf_counter() - t0) * 1000.0
        self.stats["language"].batch_sizes[1] += 1
        self.stats["language"].backend_ms.append(ms)
        return CompleteResponse(answer=str(text), backend=self.names["language"] or "", backend_ms=ms)

    # ---- service endpoints --------------------------------------------------------------------------

    def health(self) -> HealthResponse:
        return HealthResponse(version=__version__, roles=self.names, uptime_s=time.monotonic() - self.started)

    async def metrics(self, request: Any) -> Any:
        """The metrics record, or the error response of a refused token."""
        try:
            self.check_token(request)
        except _Refused as exc:
            self.rejected[exc.category] += 1
            if exc.wait_s > 0:
                await asyncio.sleep(exc.wait_s)
            return _error_response(exc.status, exc.category, exc.message, exc.fix)
        return MetricsResponse(
            uptime_s=time.monotonic() - self.started,
            max_batch=self.cfg.max_batch,
            batch_window_ms=self.cfg.batch_window_ms,
            requests=sum(s.requests for s in self.stats.values()),
            rejected=dict(self.rejected),
            roles={
                role: s.summary(self.batchers[role].queued if role in self.batchers else 0)
                for role, s in self.stats.items()
            },
        )


def create_app(
    *,
    detector: Any = None,
    vqa: Any = None,
    language: Any = None,
    config: ServerConfig | None = None,
) -> Any:
    """A FastAPI app serving the given backends (any of them None: that role answers 404).

    Backends follow the protocols of `attribot.models.base`; a detector or VQA with `detect_batch` /
    `answer_batch` gets whole batches, others are called once per item inside the batch.
    """
    fastapi = require("fastapi", "the model server")
    from starlette.exceptions import HTTPException as StarletteHTTPException
    from starlette.requests import Request
    from starlette.responses import Response

    server = _ModelServer(detector, vqa, language, config or ServerConfig())
    app = fastapi.FastAPI(
        title="attribot model server",
        version=__version__,
        lifespan=server.lifespan,
        docs_url=None,
        redoc_url=None,
        openapi_url=None,
    )

    @app.post(PATHS["detector"])
    async def detect(request: Request) -> Any:
        return await server.serve("detector", request, server.detect)

    @app.post(PATHS["vqa"])
    async def answer(request: Request) -> Any:
        return await server.serve("vqa", request, server.answer)

    @app.post(PATHS["language"])
    async def complete(request: Request) -> Any:
        return await server.serve("language", request, server.complete)

    @app.get(PATHS["health"])
    async def health() -> Any:
        return Response(server.health().model_dump_json(), media_type="application/json")

    @app.get(PATHS["metrics"])
    async def metrics(request: Request) -> Any:
        record = await server.metrics(request)
        if not isinstance(record, MetricsResponse):
            return record
        return Response(record.model_dump_json(), media_type="application/json")

    @app.exception_handler(StarletteHTTPException)
    async def http_error(_request: Request, exc: StarletteHTTPException) -> Any:
        # unknown paths and wrong methods: the same structured body as every other error
        known = ", ".join(f"{p}" for p in PATHS.values())
        return _error_response(
            exc.status_code, "input", f"{exc.detail} (HTTP {exc.status_code})", f"the endpoints are: {known}"
        )

    return app
