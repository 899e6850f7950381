"""`remote:URL` backends: the detector, VQA and language roles served by `attribot serve models`.

Spec: `remote:http://127.0.0.1:8500` (the scheme may be left out), optionally with options after `?`:
`image=jpeg|png` (how frames are sent; default jpeg, png is lossless) and `tries=N` (attempts per request,
default 3). The token comes from `settings.remote_token` (`ATTRIBOT_REMOTE_TOKEN`), the time-out for one
answer from `settings.remote_timeout_s`.

Only `frame.rgb` crosses the wire: depth, segmentation and ground truth stay on this side, and boxes come
back in the pixels of the frame sent. Connection failures, 429 and 5xx answers are retried with
exponential back-off (honouring `Retry-After`); a read time-out is not (the server is busy, and asking
again would add to its queue). What still fails becomes a `BackendError` that says what happened and what
to do: server down (start it, open the tunnel), token missing or wrong, model error (its message).
"""

from __future__ import annotations

import concurrent.futures
import time
import urllib.parse
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, TypeVar

from pydantic import BaseModel, ValidationError

from attribot.config import revealed
from attribot.deps import require
from attribot.errors import AttribotError, BackendError, ConfigError, InputError
from attribot.frame import Frame
from attribot.models.base import DETECTORS, LANGUAGE_MODELS, VQAS, Detection, off_own_body
from attribot.models.wire import (
    IMAGE_FORMATS,
    PATHS,
    AnswerRequest,
    AnswerResponse,
    CompleteRequest,
    CompleteResponse,
    DetectRequest,
    DetectResponse,
    ErrorBody,
    HealthResponse,
    ImageTooLarge,
    MetricsResponse,
    encode_image,
)

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = [
    "RemoteClient",
    "RemoteDetector",
    "RemoteVisualQA",
    "RemoteLanguageModel",
    "parse_remote_url",
    "probe_remote",
    "build_remote_detector",
    "build_remote_vqa",
    "build_remote_language",
]

M = TypeVar("M", bound=BaseModel)

_TUNNEL_FIX = (
    "start it on the GPU machine with `attribot serve models`, and if it runs elsewhere open the tunnel "
    "first: ssh -N -L 8500:127.0.0.1:8500 USER@GPU_HOST"
)
_RETRY_STATUS = {429, 500, 502, 503, 504}


def parse_remote_url(arg: str | None) -> tuple[str, dict[str, str]]:
    """`"http://h:8500?image=png"` -> `("http://h:8500", {"image": "png"})`; a bad URL is a ConfigError."""
    if not arg:
        raise ConfigError(
            "the remote backend needs the server's URL", "write e.g. remote:http://127.0.0.1:8500"
        )
    text = arg.strip()
    if "://" not in text:
        text = "http://" + text
    parts = urllib.parse.urlsplit(text)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise ConfigError(
            f"remote backend URL {arg!r} is not an http(s) URL with a host",
            "write e.g. remote:http://127.0.0.1:8500",
        )
    try:
        _ = parts.port
    except ValueError as exc:
        raise ConfigError(f"remote backend URL {arg!r} has a bad port ({exc})", "use e.g. :8500") from None
    options = dict(urllib.parse.parse_qsl(parts.query, keep_blank_values=True))
    unknown = set(options) - {"image", "tries"}
    if unknown:
        raise ConfigError(
            f"remote backend URL {arg!r} has unknown options: {', '.join(sorted(unknown))}",
            "the options are image=jpeg|png and tries=N",
        )
    base = urllib.parse.urlunsplit((parts.scheme, parts.netloc, parts.path.rstrip("/"), "", ""))
    return base, options


class RemoteClient:
    """HTTP client of the model server: bearer token, time-outs, retries with back-off, clear errors.

    Thread-safe (one connection pool shared by all threads); `close()` or use as a context manager.
    """

    def __init__(
        self,
        url: str,
        *,
        token: str | None = None,
        timeout_s: float = 30.0,
        max_tries: int = 3,
        backoff_s: float = 0.2,
        image_format: str = "jpeg",
        max_connections: int = 64,
    ) -> None:
        httpx = require("httpx", "the remote: backend")
        self._httpx = httpx
        self.url, options = parse_remote_url(url)
        self.image_format = options.get("image", image_format)
        if self.image_format not in IMAGE_FORMATS:
            raise ConfigError(
                f"remote backend image format {self.image_format!r} is unknown",
                f"choose one of: {', '.join(IMAGE_FORMATS)}",
            )
        try:
            self.max_tries = int(options.get("tries", max_tries))
        except ValueError:
            raise ConfigError(
                f"remote backend tries={options['tries']!r} is not a number", "use e.g. tries=3"
            ) from None
        if self.max_tries < 1:
            raise ConfigError(
                f"remote backend tries must be at least 1, got {self.max_tries}", "use e.g. tries=3"
            )
        if timeout_s <= 0:
            raise ConfigError(f"the remote time-out must be positive, got {timeout_s}", "use e.g. 30 seconds")
        self.timeout_s = float(timeout_s)
        self.backoff_s = float(backoff_s)
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self._client = httpx.Client(
            base_url=self.url,
            headers=headers,
            timeout=httpx.Timeout(self.timeout_s, connect=min(self.timeout_s, 5.0)),
            limits=httpx.Limits(max_connections=max_connections, max_keepalive_connections=max_connections),
            trust_env=False,  # a proxy configured for the internet must not capture the tunnel's loopback
        )

    def close(self) -> None:
        self._client.close()

    def __enter__(self) -> RemoteClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ---- requests ---------------------------------------------------------------------------------

    def health(self, timeout_s: float | None = None) -> HealthResponse:
        """The server's health record (no token needed)."""
        return self._request("GET", PATHS["health"], None, HealthResponse, timeout_s=timeout_s)

    def metrics(self, timeout_s: float | None = None) -> MetricsResponse:
        """The server's counters (needs the token)."""
        return self._request("GET", PATHS["metrics"], None, MetricsResponse, timeout_s=timeout_s)

    def detect(self, rgb: Any, queries: Sequence[str]) -> DetectResponse:
        payload = DetectRequest(image=encode_image(rgb, self.image_format), queries=list(queries))
        return self._request("POST", PATHS["detector"], payload, DetectResponse)

    def answer(self, rgb: Any, question: str) -> AnswerResponse:
        payload = AnswerRequest(image=encode_image(rgb, self.image_format), question=question)
        return self._request("POST", PATHS["vqa"], payload, AnswerResponse)

    def complete(self, question: str) -> CompleteResponse:
        return self._request("POST", PATHS["language"], CompleteRequest(question=question), CompleteResponse)

    def _request(
        self,
        method: str,
        path: str,
        payload: BaseModel | None,
        model: type[M],
        *,
        timeout_s: float | None = None,
    ) -> M:
        httpx = self._httpx
        content = None if payload is None else payload.model_dump_json().encode()
        headers = {} if content is None else {"Content-Type": "application/json"}
        where = f"the model server at {self.url}"
        extra: dict[str, Any] = {} if timeout_s is None else {"timeout": timeout_s}
        tries = 1 if timeout_s is not None else self.max_tries  # probes ask once
        last = ""
        for attempt in range(tries):
            wait = self.backoff_s * (2**attempt)
            try:
                response = self._client.request(method, path, content=content, headers=headers, **extra)
            except httpx.TimeoutException as exc:
                if isinstance(exc, httpx.ConnectTimeout | httpx.PoolTimeout):
                    last = f"no connection within the time-out ({exc.__class__.__name__})"
                else:
                    raise BackendError(
                        f"{where} gave no answer within {extra.get('timeout', self.timeout_s):g} s "
                        f"({method} {path})",
                        "the server may be overloaded or the model slow: raise ATTRIBOT_REMOTE_TIMEOUT_S, "
                        "or check the server's log and /metrics",
                    ) from exc
            except httpx.TransportError as exc:
                last = f"{exc.__class__.__name__}: {exc}" if str(exc) else exc.__class__.__name__
            else:
                if response.status_code < 300:
                    return self._decode(response, model, where, path)
                error = _error_of(response)
                if response.status_code not in _RETRY_STATUS:
                    raise _final_error(response.status_code, error, where, path)
                last = f"HTTP {response.status_code}: {error.message if error else response.text[:200]}"
                retry_after = response.headers.get("retry-after", "")
                if retry_after.replace(".", "", 1).isdigit():
                    wait = max(wait, min(float(retry_after), 5.0))
                if attempt == tries - 1:
                    raise _final_error(response.status_code, error, where, path, tries)
            if attempt < tries - 1:
                time.sleep(wait)
        raise BackendError(
            f"cannot reach {where} after {tries} tr{'ies' if tries > 1 else 'y'} ({last})", _TUNNEL_FIX
        )

    @staticmethod
    def _decode(response: Any, model: type[M], where: str, path: str) -> M:
        try:
            return model.model_validate_json(response.content)
        except ValidationError as exc:
            raise BackendError(
                f"{where} answered {path} with something that is not a {model.__name__} "
                f"({exc.error_count()} problems, first: {exc.errors()[0].get('msg')}); body starts "
                f"{response.text[:120]!r}",
                "check that the URL points at `attribot serve models` of the same attribot version",
            ) from None


def _error_of(response: Any) -> Any:
    try:
        return ErrorBody.model_validate_json(response.content).error
    except ValidationError:
        return None


def _final_error(status: int, error: Any, where: str, path: str, tries: int = 1) -> Exception:
    """The exception for a non-2xx answer that will not be retried (again)."""
    message = error.message if error else f"HTTP {status}"
    fix = error.fix if error else None
    if status == 401:
        return BackendError(
            f"{where} refused the request: it needs a token and none was sent ({message})",
            "set ATTRIBOT_REMOTE_TOKEN (or remote_token in attribot.toml) to the server's token",
        )
    if status == 403:
        return BackendError(
            f"{where} refused the token ({message})",
            "set ATTRIBOT_REMOTE_TOKEN to the token the server was started with",
        )
    if status == 413:
        return ImageTooLarge(f"{where} refused the image as too large: {message}", fix)
    if status == 404 and error is not None and error.category == "not_served":
        return ConfigError(f"{where}: {message}", fix)
    if status == 404 or error is None:
        return BackendError(
            f"{where} answered {path} with HTTP {status} and no attribot error record",
            "check that the URL points at `attribot serve models` (GET /health should answer)",
        )
    if 400 <= status < 500 and status != 429:
        return InputError(f"{where} refused the request: {message}", fix)
    after = f" after {tries} tries" if tries > 1 else ""
    return BackendError(f"{where} failed{after}: {message}", fix)


def _rgb(frame: Frame) -> Any:
    if not isinstance(frame, Frame):
        raise InputError(
            f"a remote backend takes an attribot Frame; got {type(frame).__name__}", "pass a Frame"
        )
    return frame.rgb


def _concurrently(fn: Any, args: list[tuple[Any, ...]], limit: int = 16) -> list[Any]:
    """fn(*a) for each a, in parallel requests, so that the server can batch them; results in order."""
    if len(args) <= 1:
        return [fn(*a) for a in args]
    with concurrent.futures.ThreadPoolExecutor(min(limit, len(args))) as pool:
        return list(pool.map(lambda a: fn(*a), args))


class RemoteDetector:
    """Detector served by the model server: `detect` sends one frame, `detect_batch` sends many at once."""

    def __init__(self, client: RemoteClient) -> None:
        self.client = client
        self.name = f"remote:{client.url}"
        self.served_by: str | None = None  # the server's backend name, once a request has been answered
        self.pixels_only = True  # the server is sent the RGB pixels and the queries, nothing else

    def detect(self, frame: Frame, queries: Sequence[str]) -> list[Detection]:
        """Detections of `queries` in `frame` (boxes in its pixels), best first, as the server ranks them."""
        qs = [queries] if isinstance(queries, str) else list(queries)
        if not qs:
            raise InputError(
                "no query given to the detector", "pass one or more noun phrases, e.g. ['apple']"
            )
        response = self.client.detect(_rgb(frame), qs)
        self.served_by = response.backend
        return off_own_body(response.detections, frame)

    def detect_batch(
        self, frames: Sequence[Frame], queries: Sequence[Sequence[str]]
    ) -> list[list[Detection]]:
        if len(frames) != len(queries):
            raise InputError(
                f"{len(frames)} frames but {len(queries)} query lists", "give one list per frame"
            )
        return _concurrently(self.detect, list(zip(frames, queries, strict=True)))


class RemoteVisualQA:
    """VQA served by the model server."""

    def __init__(self, client: RemoteClient) -> None:
        self.client = client
        self.name = f"remote:{client.url}"
        self.served_by: str | None = None

    def answer(self, frame: Frame, question: str) -> str:
        if not isinstance(question, str) or not question.strip():
            raise InputError("the question is empty", "ask e.g. 'What is this?'")
        response = self.client.answer(_rgb(frame), question)
        self.served_by = response.backend
        return response.answer

    def answer_batch(self, frames: Sequence[Frame], questions: Sequence[str]) -> list[str]:
        if len(frames) != len(questions):
            raise InputError(
                f"{len(frames)} frames but {len(questions)} questions", "give one question per frame"
            )
        return _concurrently(self.answer, list(zip(frames, questions, strict=True)))


class RemoteLanguageModel:
    """Language model served by the model server (a passthrough to the server's language backend)."""

    def __init__(self, client: RemoteClient) -> None:
        self.client = client
        self.name = f"remote:{client.url}"
        self.served_by: str | None = None

    def complete(self, question: str) -> str:
        if not isinstance(question, str) or not question.strip():
            raise InputError("the question is empty", "ask a question")
        response = self.client.complete(question)
        self.served_by = response.backend
        return response.answer


# ---- registration and probing ------------------------------------------------------------------------


def _client(arg: str | None, settings: Settings) -> RemoteClient:
    return RemoteClient(arg or "", token=revealed(settings.remote_token), timeout_s=settings.remote_timeout_s)


def build_remote_detector(arg: str | None, settings: Settings) -> RemoteDetector:
    return RemoteDetector(_client(arg, settings))


def build_remote_vqa(arg: str | None, settings: Settings) -> RemoteVisualQA:
    return RemoteVisualQA(_client(arg, settings))


def build_remote_language(arg: str | None, settings: Settings) -> RemoteLanguageModel:
    return RemoteLanguageModel(_client(arg, settings))


def probe_remote(
    role: str, arg: str | None, settings: Settings, timeout_s: float = 3.0
) -> tuple[bool | None, str]:
    """Whether the server at `arg` answers, serves `role`, and accepts our token; never raises."""
    token_note = "token accepted" if settings.remote_token else "no token set"
    try:
        with RemoteClient(arg or "", token=revealed(settings.remote_token), timeout_s=timeout_s) as client:
            url = client.url
            health = client.health(timeout_s=timeout_s)
            backend = health.roles.get(role)
            if backend is None:
                served = ", ".join(f"{r}={b}" for r, b in health.roles.items() if b) or "nothing"
                return False, f"the server at {url} serves no {role} (it serves {served})"
            client.metrics(timeout_s=timeout_s)  # the one cheap request that checks the token
    except AttribotError as exc:  # down, refused, not attribot, missing extra: all say why
        return False, str(exc)
    return True, f"server at {url} serves {role}={backend}; {token_note}"


def _probe_for(role: str) -> Any:
    def probe(arg: str | None, settings: Settings) -> tuple[bool | None, str]:
        return probe_remote(role, arg, settings)

    return probe


build_remote_detector.probe = _probe_for("detector")  # type: ignore[attr-defined]
build_remote_vqa.probe = _probe_for("vqa")  # type: ignore[attr-defined]
build_remote_language.probe = _probe_for("language")  # type: ignore[attr-defined]
DETECTORS.register("remote")(build_remote_detector)
VQAS.register("remote")(build_remote_vqa)
LANGUAGE_MODELS.register("remote")(build_remote_language)
