"""The live demo: a page over `attribot ask`, served on this machine.

A visitor chooses a scene (layout, seed, objects, layout options) or uploads an image, types a query and
watches it run: the robot camera and the room camera as the episode is filmed, the program, each API call
with its result as it ends, then the answer with its box drawn and its values, and links to the episode
video and the saved run (a zip of what `attribot ask --save` writes). Queries run one after another on one
worker thread (a world renders and steps on the CPU; two at once would only halve each), a visitor (a
cookie) has at most one query waiting or running, and at most `MAX_WAITING` wait in all (`runs.py`).

Routes: `GET /` the page; `GET /static/...` its script and style; `GET /api/options` the layouts and the
backends; `POST /api/runs` start a query (JSON: query, layout, seed, objects, options, or image as
{name, data (base64)}); `GET /api/runs/{id}/events` its progress as server-sent events (status, program,
call, frame, answer, error, done); `GET /api/runs/{id}/answer.png | episode.mp4 | run.zip` what it saved.

Who may do what:
- Every request must name this demo as its `Host`: `localhost`, an IP address, or a name given with
  `--allow-host`. A site whose DNS name is rebound to this machine's address is refused (DNS rebinding).
- Starting a query, the one request that changes anything, needs the page's secret in `X-Attribot-Secret`
  (the server writes it into the page, one per visitor), a JSON body, and no `Origin` of another site:
  a form or `text/plain` post from another site (CSRF) cannot start one.
- With a token (`attribot demo --token`), every route needs it: `/?token=TOKEN` once (the page then keeps a
  cookie derived from it, and the address is cleaned of it), or `Authorization: Bearer TOKEN`.
"""

# no `from __future__ import annotations`: FastAPI reads the endpoints' annotations at run time, and
# `Request` is imported inside the functions that add the routes (the server extra is optional)
import asyncio
import hashlib
import hmac
import ipaddress
import logging
import re
import secrets
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from attribot.bridge.guard import WrongTokens
from attribot.config import MAX_QUERY_CHARS, Settings
from attribot.demo.runs import KEPT_RUNS, MAX_WAITING, Busy, Crowded, NoSpace, Run, Runs
from attribot.deps import require
from attribot.errors import AttribotError, ConfigError, InputError

__all__ = ["DemoConfig", "create_app", "MAX_IMAGE_BYTES", "MAX_IMAGE_PIXELS", "KEPT_RUNS", "MAX_WAITING"]

log = logging.getLogger("attribot.demo")

MAX_IMAGE_BYTES = 10 * 1024 * 1024
"""The largest image file a visitor may upload."""
MAX_IMAGE_PIXELS = 25_000_000
"""The most pixels an uploaded image may have (read from its header before it is decoded)."""
MAX_UPLOADS_IN_FLIGHT = 4
"""Queries whose request body is read and decoded at once: each holds up to a few times `MAX_IMAGE_BYTES`
(the base64 text, its bytes, the decoded pixels); the others wait for a slot unread, so that many uploads
at once cannot grow the process without bound."""
UPLOAD_WAIT_S = 15.0
"""How long a query waits for an upload slot before it is told to try again (HTTP 503)."""
BODY_TIMEOUT_S = 60.0
"""How long a query's request body may take to arrive (a client trickling it must not hold a task)."""
SECRET_HEADER = "X-Attribot-Secret"

_VISITOR = "attribot_demo_visitor"
_TOKEN = "attribot_demo_token"
_VISITOR_FORMAT = re.compile(r"[0-9a-f]{32}")
_LABEL = r"[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}[A-Za-z0-9])?"
_HOST_NAME = re.compile(rf"(?=.{{1,253}}\Z){_LABEL}(?:\.{_LABEL})*\.?")
_SECURITY_HEADERS = [
    ("x-content-type-options", "nosniff"),
    ("x-frame-options", "DENY"),
    ("referrer-policy", "no-referrer"),
    (
        "content-security-policy",
        "default-src 'self'; img-src 'self' data:; object-src 'none'; frame-ancestors 'none'; "
        "base-uri 'none'; form-action 'self'",
    ),
    ("cross-origin-opener-policy", "same-origin"),
    ("cross-origin-resource-policy", "same-origin"),
]


@dataclass
class DemoConfig:
    """What the demo serves with: the backend settings of every query, the folder runs are saved in, the
    token every request must carry (None: no check, for 127.0.0.1 only), the host names it answers to
    beyond `localhost` and IP addresses, and whether it keeps every run's folder (else a run forgotten
    after `KEPT_RUNS` newer ones is removed), refusing new runs below `min_free_bytes` of free disk."""

    settings: Settings
    runs_dir: Path
    token: str | None = None
    hosts: tuple[str, ...] = ()
    keep_runs: bool = False
    min_free_bytes: int = 256 << 20
    max_streams_per_run: int = 4

    def __post_init__(self) -> None:
        for host in self.hosts:
            if not isinstance(host, str) or not (_HOST_NAME.fullmatch(host) or is_ip(host)):
                shown = repr(host) if len(repr(host)) <= 80 else repr(host)[:77] + "..."
                raise ConfigError(
                    f"--allow-host {shown} is not a host name",
                    "give a name visitors type, e.g. --allow-host lab-pc.local (letters, digits, '-' and "
                    "dots; no spaces, ports or schemes)",
                )


class _Upload(BaseModel):
    model_config = ConfigDict(extra="ignore")
    name: str = Field("upload.png", max_length=1000)
    data: str


class _RunRequest(BaseModel):
    """The page's form: a query, and a scene (layout, seed, objects, options) or an image."""

    model_config = ConfigDict(extra="ignore")
    query: str
    layout: str | None = Field(None, max_length=100)
    seed: int | str | None = Field(None, union_mode="left_to_right")
    objects: int | str | None = Field(None, union_mode="left_to_right")
    options: str | None = Field(None, max_length=4000)
    image: _Upload | None = None


def _host_name(value: str) -> str | None:
    """The host name of a `Host` (or `Origin` netloc) value, lower case and without its port."""
    try:
        return urlsplit("//" + value).hostname
    except ValueError:
        return None


def is_ip(name: str) -> bool:
    """Whether `name` is an IP address (v4 or v6) rather than a host name."""
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


def _visitor_of(cookies: dict[str, str]) -> str | None:
    value = cookies.get(_VISITOR, "")
    return value if _VISITOR_FORMAT.fullmatch(value) else None


def _problem(status: int, message: str, fix: str | None = None, headers: dict[str, str] | None = None) -> Any:
    from starlette.responses import JSONResponse

    return JSONResponse({"message": message, "fix": fix}, status_code=status, headers=headers)


class _Guard:
    """The checks every request meets before any route (an ASGI middleware): its `Host`, the token, the
    `Origin` of anything but a read; and the headers every response carries (no framing, no sniffing, no
    referrer, a content security policy)."""

    def __init__(self, app: Any, config: DemoConfig) -> None:
        self.app = app
        self.hosts = {"localhost", *(h.lower() for h in config.hosts)}
        self.token = None if config.token is None else config.token.encode()
        # the cookie holds a value derived from the token, never the token itself
        self.cookie = (
            None if self.token is None else hmac.new(self.token, b"cookie", hashlib.sha256).hexdigest()
        )
        self.wrong_tokens = WrongTokens(log=log, what="demo")

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        from starlette.datastructures import Headers, MutableHeaders

        headers = Headers(scope=scope)
        extra: list[tuple[str, str]] = []
        refusal = self._refusal(scope, headers)
        if refusal is None and self.token is not None:
            refusal, extra, wait_s = self._token(scope, headers)
            if wait_s > 0:  # a peer guessing tokens is answered more and more slowly
                await asyncio.sleep(wait_s)

        async def guarded(message: Any) -> None:
            if message["type"] == "http.response.start":
                out = MutableHeaders(scope=message)
                for name, value in _SECURITY_HEADERS + extra:
                    out.append(name, value)
            await send(message)

        if refusal is not None:
            await refusal(scope, receive, guarded)
            return
        await self.app(scope, receive, guarded)

    def _refusal(self, scope: Any, headers: Any) -> Any:
        name = _host_name(headers.get("host", ""))
        if name is None or not (name in self.hosts or is_ip(name)):
            return _problem(
                400,
                "this demo does not answer to the host this request names",
                "open it by its IP address or as localhost (or start it with --allow-host NAME)",
            )
        if scope["method"] in ("GET", "HEAD"):
            return None
        origin = headers.get("origin")
        if origin is not None:
            parts = urlsplit(origin) if origin != "null" else None
            if parts is None or parts.netloc.lower() != headers.get("host", "").lower():
                return _problem(403, "this request comes from another site", "ask from the demo's own page")
        elif headers.get("sec-fetch-site", "same-origin") not in ("same-origin", "none"):
            return _problem(403, "this request comes from another site", "ask from the demo's own page")
        return None

    def _token(self, scope: Any, headers: Any) -> tuple[Any, list[tuple[str, str]], float]:
        """A refusal (or the redirect that takes the token out of the address), the headers to add, and how
        long to hold the answer (wrong tokens from one address are slowed, then that address is blocked)."""
        from starlette.datastructures import QueryParams
        from starlette.requests import cookie_parser

        assert self.token is not None and self.cookie is not None
        client = scope.get("client")
        peer = str(client[0]) if client else "?"
        left = self.wrong_tokens.blocked(peer)
        if left > 0:
            return (
                _problem(
                    429,
                    f"too many wrong tokens from this address: refused for {left:.0f} s more",
                    "open the address the demo printed, with ?token=TOKEN, once the wait is over",
                    {"Retry-After": str(int(left) + 1)},
                ),
                [],
                self.wrong_tokens.BLOCKED_WAIT_S,
            )
        query = QueryParams(scope["query_string"])
        given = query.get("token")
        auth = headers.get("authorization", "")
        if given is None and auth.lower().startswith("bearer "):
            given = auth[7:].strip()
        if given is not None:
            ok = hmac.compare_digest(given.encode("utf-8", "surrogatepass"), self.token)
            guessed = True
        else:
            cookie = cookie_parser(headers.get("cookie", "")).get(_TOKEN, "")
            ok = hmac.compare_digest(cookie.encode("utf-8", "surrogatepass"), self.cookie.encode())
            guessed = bool(cookie)
        if not ok:
            return (
                _problem(
                    401,
                    "the token is wrong" if given else "this demo needs its token",
                    "open the address the demo printed, with ?token=TOKEN",
                ),
                [],
                self.wrong_tokens.wrong(peer) if guessed else 0.0,
            )
        if guessed:
            self.wrong_tokens.right(peer)
        if "token" not in query:
            return None, [], 0.0
        kept = [("set-cookie", f"{_TOKEN}={self.cookie}; HttpOnly; Path=/; SameSite=strict")]
        if scope["path"] == "/" and scope["method"] == "GET":
            # the token leaves the address bar (and the history) at once: the page is kept by the cookie
            from starlette.responses import RedirectResponse

            return RedirectResponse("/", status_code=303), kept, 0.0
        return None, kept, 0.0


def _upload(image: _Upload) -> tuple[str, bytes]:
    """The uploaded image's file suffix and bytes, once it is known to be a PNG or JPEG file whose size and
    pixels are within the limits (read from its header before any pixel is decoded)."""
    import base64

    from attribot.models.wire import ImageTooLarge, decode_image

    if len(image.data) * 3 // 4 > MAX_IMAGE_BYTES + 2:
        raise ImageTooLarge(f"the image is larger than {MAX_IMAGE_BYTES >> 20} MB", "upload a smaller one")
    decode_image(image.data, max_pixels=MAX_IMAGE_PIXELS)
    data = base64.b64decode(image.data)
    return (".png" if data.startswith(b"\x89PNG") else ".jpg"), data


def _scene_config(form: _RunRequest) -> Any:
    """The SceneConfig of the page's scene fields; a bad field is an `InputError` that names it."""
    from attribot.config import SceneConfig
    from attribot.sim.scene_plan import LAYOUTS

    def number(name: str, value: int | str | None) -> int | None:
        if isinstance(value, int):
            return value
        text = str(value or "").strip()
        if not text:
            return None
        if not re.fullmatch(r"[+-]?[0-9]{1,18}", text):
            raise InputError(f"{name} {text[:40]!r} is not a whole number", f"give {name} as digits, e.g. 3")
        return int(text)

    options: dict[str, Any] = {}
    for item in str(form.options or "").replace(",", " ").split():
        key, sep, raw = item.partition("=")
        if not sep or not key:
            raise InputError(
                f"layout option {item[:60]!r} is not KEY=VALUE", "write e.g. pattern=grid odd=size"
            )
        value: Any = raw
        for cast in (int, float):
            try:
                value = cast(raw)
                break
            except ValueError:
                pass
        options[key] = value
    layout = str(form.layout or "household")
    if layout not in LAYOUTS:
        raise InputError(
            f"layout {layout[:60]!r} is not a layout here", f"choose one of: {', '.join(LAYOUTS.names())}"
        )
    fields: dict[str, Any] = {"layout": layout, "options": options}
    for name, given in (("seed", form.seed), ("objects", form.objects)):
        value = number(name, given)
        if value is not None:
            fields[name] = value
    return SceneConfig.create(**fields)


def _following(demo: Runs, run: Run) -> Any:
    """The response that streams `run`'s events to a page: counted against the bounds on streams from
    before its headers are sent until it ends (a refused page gets HTTP 503 instead)."""
    from starlette.responses import StreamingResponse

    class Following(StreamingResponse):
        async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
            try:
                demo.reserve(run)
            except Crowded as exc:
                await _problem(503, exc.message, exc.fix, {"Retry-After": "30"})(scope, receive, send)
                return
            try:
                await super().__call__(scope, receive, send)
            finally:
                demo.release(run)

    return Following(run.stream(), media_type="text/event-stream", headers={"Cache-Control": "no-store"})


@dataclass(frozen=True)
class _Shared:
    """What every route reads: the demo's config, its runs, the page's HTML, and the key the visitors'
    secrets are derived from (never sent, so it stays out of the repr too)."""

    config: DemoConfig
    runs: Runs
    page_html: str
    key: bytes = field(repr=False)
    uploads: asyncio.Semaphore = field(default_factory=lambda: asyncio.Semaphore(MAX_UPLOADS_IN_FLIGHT))

    def secret_of(self, visitor: str) -> str:
        return hmac.new(self.key, visitor.encode(), hashlib.sha256).hexdigest()

    def find(self, run_id: str, request: Any) -> Run | None:
        """The run `run_id` of the request's visitor, or None (another visitor's run is not found)."""
        try:
            return self.runs.get(run_id, _visitor_of(request.cookies) or "")
        except KeyError:
            return None


def _stopped_at_exit(runs: Runs) -> Any:
    """The app's lifespan: at the end, the running query is unwound and closes its world in its own thread
    before the process ends."""
    from contextlib import asynccontextmanager

    @asynccontextmanager
    async def lifespan(app: Any) -> Any:
        yield
        await asyncio.to_thread(runs.stop)

    return lifespan


def _add_page_routes(app: Any, shared: _Shared) -> None:
    """`GET /` (the page, with the visitor's secret in it), `/static/...` and `GET /api/options`."""
    from starlette import responses
    from starlette.requests import Request
    from starlette.staticfiles import StaticFiles

    from attribot.sim.scene_plan import LAYOUTS

    @app.get("/")
    def page(request: Request) -> Any:
        visitor = _visitor_of(request.cookies)
        fresh = visitor is None
        if visitor is None:
            visitor = secrets.token_hex(16)
        html = shared.page_html.replace(
            '<meta name="attribot-secret" content="">',
            f'<meta name="attribot-secret" content="{shared.secret_of(visitor)}">',
        )
        response = responses.HTMLResponse(html, headers={"Cache-Control": "no-store"})
        if fresh:
            response.set_cookie(_VISITOR, visitor, httponly=True, samesite="strict")
        return response

    app.mount("/static", StaticFiles(packages=[("attribot.demo", "static")]), name="static")

    @app.get("/api/options")
    def options() -> Any:
        settings = shared.config.settings
        return {
            "layouts": sorted(LAYOUTS.names()),
            "planner": settings.planner,
            "llm_model": settings.llm_model if settings.planner == "llm" else None,
            "prompt": settings.prompt if settings.planner == "llm" else None,
            "backends": {
                role: shared.runs.scrub.text(str(getattr(settings, role)))
                for role in ("detector", "vqa", "language")
            },
            "max_query_chars": MAX_QUERY_CHARS,
            "max_image_mb": MAX_IMAGE_BYTES // (1024 * 1024),
            "max_image_megapixels": MAX_IMAGE_PIXELS / 1e6,
        }


async def _body_of(request: Any, limit: int) -> bytes | None:
    """The request's body, or None when it is over `limit` (what is still coming is read and dropped, up to
    a bound, so that the client sees the refusal and not a reset connection)."""
    declared = request.headers.get("content-length", "")
    over = declared.isdigit() and len(declared) <= 18 and int(declared) > limit
    body = bytearray()
    seen = 0
    async with asyncio.timeout(BODY_TIMEOUT_S):
        async for chunk in request.stream():
            seen += len(chunk)
            if over:
                if seen > 4 * limit:
                    break
                continue
            body.extend(chunk)
            over = len(body) > limit
    return None if over else bytes(body)


def _refusal_of_sender(request: Any, shared: _Shared) -> tuple[str | None, Any]:
    """The visitor who starts a query, or the refusal of a request that is not the page's own: no visitor
    cookie, not the page's secret, not JSON."""
    visitor = _visitor_of(request.cookies)
    if visitor is None:
        return None, _problem(400, "this browser has no visitor cookie", "load the demo page first, then ask")
    given = request.headers.get(SECRET_HEADER, "")
    if not hmac.compare_digest(given.encode("utf-8", "surrogatepass"), shared.secret_of(visitor).encode()):
        return None, _problem(
            403,
            "this request does not carry the demo page's secret",
            "reload the demo page and ask from it",
        )
    kind = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if kind != "application/json":
        return None, _problem(
            415, f"the request is {kind[:60] or 'untyped'}, not JSON", "send the page's form as JSON"
        )
    return visitor, None


async def _form_of(request: Any, limit: int, too_large: str) -> tuple[_RunRequest | None, Any]:
    """The page's form in the request's body, or the refusal of a body that is slow, too large or not the
    form."""
    from starlette.requests import ClientDisconnect

    try:
        body = await _body_of(request, limit)
    except TimeoutError:
        return None, _problem(408, f"the request took over {BODY_TIMEOUT_S:g} s to arrive", "send it again")
    except ClientDisconnect:  # the visitor left mid-upload: nobody reads an answer, and it is no error here
        from starlette.responses import Response

        return None, Response(status_code=499)
    if body is None:
        return None, _problem(413, too_large, "send a smaller image")
    try:
        return _RunRequest.model_validate_json(body), None
    except ValidationError as exc:
        first = exc.errors()[0]
        where = str(first.get("loc", ("body",))[0]) if first.get("loc") else "body"
        return None, _problem(
            400,
            f"the request is not the page's form: {where}: {first.get('msg', 'invalid')}",
            "send a JSON object: query, and layout, seed, objects, options, or image {name, data}",
        )


def _add_start_route(app: Any, shared: _Shared) -> None:
    """`POST /api/runs`: start a query from the page's form, its scene or its uploaded image."""
    from starlette.concurrency import run_in_threadpool
    from starlette.requests import Request

    from attribot.models.wire import ImageTooLarge
    from attribot.planning.query import check_query

    limit = MAX_IMAGE_BYTES * 4 // 3 + 65536  # the image travels as base64 inside the JSON
    too_large = f"the upload is larger than {MAX_IMAGE_BYTES // (1024 * 1024)} MB"

    @app.post("/api/runs")
    async def start(request: Request) -> Any:
        visitor, refusal = _refusal_of_sender(request, shared)
        if visitor is None:
            return refusal
        try:  # its body is read only with a slot: uploads in flight are bounded, the others wait unread
            await asyncio.wait_for(shared.uploads.acquire(), UPLOAD_WAIT_S)
        except TimeoutError:
            return _problem(
                503,
                f"{MAX_UPLOADS_IN_FLIGHT} other queries are being uploaded",
                "send the query again in a moment",
                {"Retry-After": "10"},
            )
        try:
            return await _start(request, visitor)
        finally:
            shared.uploads.release()

    async def _start(request: Any, visitor: str) -> Any:
        form, refusal = await _form_of(request, limit, too_large)
        if form is None:
            return refusal
        try:
            query = check_query(form.query)
            shared.runs.admit(visitor)  # before the upload is decoded: a refused query costs nothing more
            image = None if form.image is None else await run_in_threadpool(_upload, form.image)
            scene = None if image is not None else _scene_config(form)
            run = shared.runs.start(visitor, query, scene, image, asyncio.get_running_loop())
        except AttribotError as exc:
            statuses: dict[type, int] = {Busy: 409, Crowded: 503, NoSpace: 507, ImageTooLarge: 413}
            status = statuses.get(type(exc), 400)
            headers = {"Retry-After": "30"} if status in (503, 507) else None
            return _problem(status, exc.message, exc.fix, headers)
        return {"id": run.id, "events": f"/api/runs/{run.id}/events"}


def _add_run_routes(app: Any, shared: _Shared) -> None:
    """`GET /api/runs/{id}/events` (the run's progress as server-sent events) and what a finished run saved:
    `answer.png`, `episode.mp4`, `run.zip`; each of the visitor's own runs only."""
    from starlette import responses
    from starlette.concurrency import run_in_threadpool
    from starlette.requests import Request

    @app.get("/api/runs/{run_id}/events")
    async def events(run_id: str, request: Request) -> Any:
        run = shared.find(run_id, request)
        if run is None:
            return _problem(404, f"no run {run_id[:40]!r} of this browser", "start a query from the page")
        return _following(shared.runs, run)

    media = {"answer.png": "image/png", "episode.mp4": "video/mp4"}

    @app.get("/api/runs/{run_id}/{name}")
    async def saved(run_id: str, name: str, request: Request) -> Any:
        run = shared.find(run_id, request)
        if run is None or not run.done:
            return _problem(404, f"no finished run {run_id[:40]!r} of this browser", "wait for the answer")
        if name == "run.zip":
            if not run.folder.is_dir():
                return _problem(404, "this run saved nothing", "its query failed before it ran")
            try:
                path = await run_in_threadpool(shared.runs.zipped, run)
            except OSError as exc:
                return _problem(507, f"the demo cannot write the zip ({exc.strerror})", "download it later")
            return responses.FileResponse(
                path, media_type="application/zip", filename=f"attribot-run-{run.id}.zip"
            )
        path = run.folder / name
        if name not in media or not path.is_file():
            return _problem(
                404, "this run has no such file", "answer.png, episode.mp4 and run.zip are served"
            )
        return responses.FileResponse(path, media_type=media[name], filename=f"{run.id}-{name}")


def create_app(config: DemoConfig) -> Any:
    """The demo's FastAPI app (start it with uvicorn, or `attribot demo`)."""
    fastapi = require("fastapi", "the live demo")
    runs = Runs(
        config.runs_dir,
        config.settings,
        keep_runs=config.keep_runs,
        min_free_bytes=config.min_free_bytes,
        max_streams_per_run=config.max_streams_per_run,
    )
    shared = _Shared(
        config,
        runs,
        key=secrets.token_bytes(32),  # the visitors' secrets; a restarted demo gives new ones
        page_html=(Path(__file__).parent / "static" / "index.html").read_text(encoding="utf-8"),
    )
    app = fastapi.FastAPI(
        title="attribot demo", docs_url=None, redoc_url=None, lifespan=_stopped_at_exit(runs)
    )
    app.add_middleware(_Guard, config=config)
    # in this order: a route is matched by the first path that fits (`events` before `{name}`)
    _add_page_routes(app, shared)
    _add_start_route(app, shared)
    _add_run_routes(app, shared)
    app.state.demo = runs
    return app
