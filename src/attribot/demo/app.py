"""The live demo: a page over `attribot ask`, served on this machine.

A visitor chooses a scene (layout, seed, objects, layout options) or uploads an image, types a query and
watches it run: the robot camera and the room camera as the episode is filmed, the program, each API call
with its result as it ends, then the answer with its box drawn and its values, and links to the episode
video and the saved run (a zip of what `attribot ask --save` writes). Queries run one after another on one
worker thread (a world renders and steps on the CPU; two at once would only halve each), and a visitor
(a cookie) has at most one query waiting or running.

Routes: `GET /` the page; `GET /static/...` its script and style; `GET /api/options` the layouts and the
backends; `POST /api/runs` start a query (JSON: query, layout, seed, objects, options, or image as
{name, data (base64)});
`GET /api/runs/{id}/events` its progress as server-sent events (status, program, call, frame, answer,
error, done); `GET /api/runs/{id}/answer.png | episode.mp4 | run.zip` what it saved.

With a token (`attribot demo --token`), every route needs it: `/?token=TOKEN` once (it is then kept in a
cookie), or `Authorization: Bearer TOKEN`.
"""

# no `from __future__ import annotations`: FastAPI reads the endpoints' annotations at run time, and
# `Request` is imported inside create_app (the server extra is optional)
import base64
import hmac
import io
import itertools
import json
import logging
import queue
import secrets
import threading
import time
import zipfile
from collections import OrderedDict
from collections.abc import AsyncIterator, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from attribot.config import MAX_QUERY_CHARS, Settings
from attribot.deps import require
from attribot.errors import AttribotError, InputError

__all__ = ["DemoConfig", "create_app", "MAX_IMAGE_BYTES"]

log = logging.getLogger("attribot.demo")

MAX_IMAGE_BYTES = 10 * 1024 * 1024
"""The largest image a visitor may upload."""
KEPT_RUNS = 32
"""Runs whose events and files stay reachable; older ones are forgotten (their folders stay on disk)."""
FRAME_INTERVAL_S = 0.1
"""The least time between two camera frames sent to one page (the sim may film faster than that)."""

_VISITOR = "attribot_demo_visitor"
_TOKEN = "attribot_demo_token"


@dataclass
class DemoConfig:
    """What the demo serves with: the backend settings of every query, the folder runs are saved in, and
    the token every request must carry (None: no check, for 127.0.0.1 only)."""

    settings: Settings
    runs_dir: Path
    token: str | None = None


@dataclass
class _Run:
    """One query: what the page asked, what happened so far, what it saved."""

    id: str
    visitor: str
    query: str
    config: Any
    image: Path | None
    folder: Path
    events: list[dict[str, Any]] = field(default_factory=list)
    frame: tuple[np.ndarray, np.ndarray] | None = None
    frames: int = 0  # frames taken so far; the page gets the latest one
    done: bool = False
    cond: threading.Condition = field(default_factory=threading.Condition)

    def emit(self, event_type: str, /, **data: Any) -> None:
        # positional-only: an event's data may hold its own "kind" (a trace record's call kind)
        with self.cond:
            self.events.append({**data, "type": event_type})
            self.cond.notify_all()

    def on_frame(self, robot: np.ndarray, room: np.ndarray) -> None:
        with self.cond:
            # copies: the recorder goes on writing its labels onto these arrays
            self.frame = (robot.copy(), room.copy())
            self.frames += 1
            self.cond.notify_all()


def _jpeg(rgb: np.ndarray, quality: int = 80) -> str:
    import cv2

    ok, data = cv2.imencode(
        ".jpg", np.ascontiguousarray(rgb[:, :, ::-1]), [cv2.IMWRITE_JPEG_QUALITY, quality]
    )
    if not ok:  # cannot happen for a uint8 RGB image; said plainly if it does
        raise RuntimeError("JPEG encoding failed")
    return "data:image/jpeg;base64," + base64.b64encode(data.tobytes()).decode("ascii")


class _Busy(InputError):
    """This visitor's earlier query has not finished (HTTP 409)."""


class _Demo:
    """The runs and the worker thread that answers them in order."""

    def __init__(self, config: DemoConfig) -> None:
        self.config = config
        self.runs: OrderedDict[str, _Run] = OrderedDict()
        self.lock = threading.Lock()
        self.queue: queue.Queue[_Run | None] = queue.Queue()
        self.counter = itertools.count(1)
        self.worker = threading.Thread(target=self._work, name="attribot-demo-worker", daemon=True)
        self.worker.start()

    # ---- runs ---------------------------------------------------------------------------------------
    def start(self, visitor: str, query: str, config: Any, image: tuple[str, bytes] | None) -> _Run:
        with self.lock:
            busy = [r for r in self.runs.values() if r.visitor == visitor and not r.done]
            if busy:
                raise _Busy(
                    "your earlier query is still running", "wait for its answer, then ask the next one"
                )
            run_id = f"{next(self.counter):04d}-{secrets.token_hex(4)}"
            folder = self.config.runs_dir / run_id
            folder.mkdir(parents=True)
            path = None
            if image is not None:
                name, data = image
                suffix = Path(name).suffix.lower()  # the name is the visitor's: only its known suffixes
                path = folder / ("upload" + (suffix if suffix in (".png", ".jpg", ".jpeg") else ".png"))
                path.write_bytes(data)
            run = _Run(run_id, visitor, query, config, path, folder / "run")
            self.runs[run_id] = run
            while len(self.runs) > KEPT_RUNS:
                oldest = next(iter(self.runs))
                if not self.runs[oldest].done:
                    break
                del self.runs[oldest]
            ahead = sum(1 for r in self.runs.values() if not r.done) - 1
        run.emit("status", text=f"waiting: {ahead} queries ahead" if ahead else "starting")
        self.queue.put(run)
        return run

    def get(self, run_id: str, visitor: str) -> _Run:
        with self.lock:
            run = self.runs.get(run_id)
        if run is None or run.visitor != visitor:
            raise KeyError(run_id)
        return run

    def close(self) -> None:
        self.queue.put(None)

    def _work(self) -> None:
        while True:
            run = self.queue.get()
            if run is None:
                return
            self._answer(run)

    def _answer(self, run: _Run) -> None:
        from attribot.demo.adapter import run_query

        run.emit("status", text="building the scene" if run.image is None else "reading the image")
        tries = 0

        def on_program(text: str) -> None:
            nonlocal tries
            tries += 1
            run.emit("program", attempt=tries, text=text)
            run.emit("status", text="running the program" + (f" (try {tries})" if tries > 1 else ""))

        def on_call(record: Any) -> None:
            run.emit("call", **record.model_dump(mode="json"))

        try:
            answer = run_query(
                run.query,
                config=run.config,
                image=run.image,
                settings=self.config.settings,
                save_dir=run.folder,
                on_program=on_program,
                on_call=on_call,
                on_frame=run.on_frame,
            )
        except AttribotError as exc:
            run.emit("error", message=exc.message, fix=exc.fix)
        except Exception as exc:  # noqa: BLE001 (the page says what failed; the server goes on serving)
            log.exception("demo query %s failed", run.id)
            run.emit("error", message=f"internal error: {type(exc).__name__}: {exc}", fix=None)
        else:
            saved = {name: (run.folder / name).is_file() for name in ("answer.png", "episode.mp4")}
            run.emit(
                "answer",
                answer=json.loads(answer.model_dump_json()),
                image=f"/api/runs/{run.id}/answer.png" if saved["answer.png"] else None,
                video=f"/api/runs/{run.id}/episode.mp4" if saved["episode.mp4"] else None,
                saved_run=f"/api/runs/{run.id}/run.zip",
            )
        finally:
            with run.cond:
                run.done = True
                run.frame = None  # the page has the last one; a kept run need not hold two images
                run.events.append({"type": "done"})
                run.cond.notify_all()

    # ---- the event stream ---------------------------------------------------------------------------
    def stream(self, run: _Run) -> Iterator[str]:
        sent, frames, last_frame = 0, 0, 0.0
        while True:
            with run.cond:
                if sent == len(run.events) and run.frames == frames and not run.done:
                    run.cond.wait(0.5)
                events = run.events[sent:]
                sent += len(events)
                frame = None
                if run.frames != frames and time.monotonic() - last_frame >= FRAME_INTERVAL_S:
                    frame, frames = run.frame, run.frames
                finished = run.done and sent == len(run.events)
            if frame is not None:
                last_frame = time.monotonic()
                yield _sse("frame", {"type": "frame", "robot": _jpeg(frame[0]), "room": _jpeg(frame[1])})
            for event in events:
                yield _sse(event["type"], event)
            if finished:
                return
            if not events and frame is None:
                yield ": keep-alive\n\n"  # a comment line: lets the server notice a page that has gone
                time.sleep(FRAME_INTERVAL_S / 2)


def _sse(kind: str, data: dict[str, Any]) -> str:
    return f"event: {kind}\ndata: {json.dumps(data, allow_nan=False, default=str)}\n\n"


def _zip_folder(folder: Path) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as archive:
        for path in sorted(folder.iterdir()):
            if path.is_file():
                archive.write(path, f"{folder.parent.name}/{path.name}")
    return buf.getvalue()


def _upload(image: Any) -> tuple[str, bytes] | None:
    """The uploaded image of the page's JSON ({"name": ..., "data": base64}), None when there is none."""
    if not image:
        return None
    if not isinstance(image, dict) or not isinstance(image.get("data"), str):
        raise InputError("the image is not {name, data (base64)}", "upload the image from the page")
    try:
        data = base64.b64decode(image["data"], validate=True)
    except ValueError:
        raise InputError("the image's data is not base64", "upload the image from the page") from None
    if len(data) > MAX_IMAGE_BYTES:
        raise InputError(
            f"the image is larger than {MAX_IMAGE_BYTES // (1024 * 1024)} MB", "send a smaller one"
        )
    return str(image.get("name") or "upload.png"), data


def _scene_config(form: dict[str, Any]) -> Any:
    """The SceneConfig of the page's scene fields; a bad field is an `InputError` that names it."""
    from attribot.config import SceneConfig

    def number(name: str) -> int | None:
        text = str(form.get(name) or "").strip()
        if not text:
            return None
        try:
            return int(text)
        except ValueError:
            raise InputError(
                f"{name} {text!r} is not a whole number", f"give {name} as digits, e.g. 3"
            ) from None

    options: dict[str, Any] = {}
    for item in str(form.get("options") or "").replace(",", " ").split():
        key, sep, raw = item.partition("=")
        if not sep or not key:
            raise InputError(f"layout option {item!r} is not KEY=VALUE", "write e.g. pattern=grid odd=size")
        value: Any = raw
        for cast in (int, float):
            try:
                value = cast(raw)
                break
            except ValueError:
                pass
        options[key] = value
    from attribot.sim.scene import LAYOUTS

    layout = str(form.get("layout") or "household")
    if layout not in LAYOUTS:
        raise InputError(
            f"layout {layout!r} is not a layout here", f"choose one of: {', '.join(LAYOUTS.names())}"
        )
    fields: dict[str, Any] = {"layout": layout, "options": options}
    for name in ("seed", "objects"):
        value = number(name)
        if value is not None:
            fields[name] = value
    return SceneConfig.create(**fields)


def create_app(config: DemoConfig) -> Any:
    """The demo's FastAPI app (start it with uvicorn, or `attribot demo`)."""
    fastapi = require("fastapi", "the live demo")
    from contextlib import asynccontextmanager

    from starlette import responses
    from starlette.requests import Request
    from starlette.staticfiles import StaticFiles

    from attribot.sim.scene import LAYOUTS

    demo = _Demo(config)
    token = None if config.token is None else config.token.encode()

    @asynccontextmanager
    async def lifespan(app: Any) -> AsyncIterator[None]:
        yield
        demo.close()

    app = fastapi.FastAPI(title="attribot demo", docs_url=None, redoc_url=None, lifespan=lifespan)

    def problem(status: int, message: str, fix: str | None = None) -> Any:
        return responses.JSONResponse({"message": message, "fix": fix}, status_code=status)

    @app.middleware("http")
    async def check_token(request: Any, call_next: Any) -> Any:
        if token is None:
            return await call_next(request)
        given = request.query_params.get("token") or request.cookies.get(_TOKEN) or ""
        auth = request.headers.get("authorization", "")
        if auth.lower().startswith("bearer "):
            given = auth[7:].strip()
        if not hmac.compare_digest(given.encode(), token):
            return problem(
                401,
                "this demo needs its token" if not given else "the token is wrong",
                "open the address the demo printed, with ?token=TOKEN",
            )
        response = await call_next(request)
        if request.query_params.get("token"):
            response.set_cookie(_TOKEN, given, httponly=True, samesite="strict")
        return response

    @app.get("/")
    def page(request: Request) -> Any:
        html = (Path(__file__).parent / "static" / "index.html").read_text(encoding="utf-8")
        response = responses.HTMLResponse(html)
        if not request.cookies.get(_VISITOR):
            response.set_cookie(_VISITOR, secrets.token_hex(16), httponly=True, samesite="strict")
        return response

    app.mount("/static", StaticFiles(packages=[("attribot.demo", "static")]), name="static")

    @app.get("/api/options")
    def options() -> Any:
        settings = config.settings
        return {
            "layouts": sorted(LAYOUTS.names()),
            "planner": settings.planner,
            "llm_model": settings.llm_model if settings.planner == "llm" else None,
            "prompt": settings.prompt if settings.planner == "llm" else None,
            "backends": {"detector": settings.detector, "vqa": settings.vqa, "language": settings.language},
            "max_query_chars": MAX_QUERY_CHARS,
            "max_image_mb": MAX_IMAGE_BYTES // (1024 * 1024),
        }

    @app.post("/api/runs")
    async def start(request: Request) -> Any:
        visitor = request.cookies.get(_VISITOR)
        if not visitor:
            return problem(400, "this browser has no visitor cookie", "load the demo page first, then ask")
        limit = MAX_IMAGE_BYTES * 4 // 3 + 65536  # the image travels as base64 inside the JSON
        body = bytearray()
        async for chunk in request.stream():
            body.extend(chunk)
            if len(body) > limit:
                return problem(
                    413,
                    f"the upload is larger than {MAX_IMAGE_BYTES // (1024 * 1024)} MB",
                    "send a smaller image",
                )
        try:
            fields = json.loads(body)
            if not isinstance(fields, dict):
                raise ValueError("not an object")
        except ValueError:
            return problem(400, "the request is not a JSON object", "send the page's form as JSON")
        try:
            query = str(fields.get("query") or "").strip()
            if not query:
                raise InputError("the query is empty", "type a question, e.g. Which object is the heaviest?")
            image = _upload(fields.get("image"))
            scene = None if image is not None else _scene_config(fields)
            run = demo.start(visitor, query, scene, image)
        except AttribotError as exc:
            return problem(409 if isinstance(exc, _Busy) else 400, exc.message, exc.fix)
        return {"id": run.id, "events": f"/api/runs/{run.id}/events"}

    def find(run_id: str, request: Request) -> _Run | None:
        try:
            return demo.get(run_id, request.cookies.get(_VISITOR) or "")
        except KeyError:
            return None

    @app.get("/api/runs/{run_id}/events")
    def events(run_id: str, request: Request) -> Any:
        run = find(run_id, request)
        if run is None:
            return problem(404, f"no run {run_id!r} of this browser", "start a query from the page")
        return responses.StreamingResponse(
            demo.stream(run), media_type="text/event-stream", headers={"Cache-Control": "no-store"}
        )

    media = {"answer.png": "image/png", "episode.mp4": "video/mp4"}

    @app.get("/api/runs/{run_id}/{name}")
    def saved(run_id: str, name: str, request: Request) -> Any:
        run = find(run_id, request)
        if run is None or not run.done:
            return problem(404, f"no finished run {run_id!r} of this browser", "wait for the answer")
        if name == "run.zip":
            if not run.folder.is_dir():
                return problem(404, "this run saved nothing", "its query failed before it ran")
            return responses.Response(
                _zip_folder(run.folder),
                media_type="application/zip",
                headers={"Content-Disposition": f'attachment; filename="attribot-run-{run.id}.zip"'},
            )
        path = run.folder / name
        if name not in media or not path.is_file():
            return problem(404, f"this run has no {name}", "answer.png, episode.mp4 and run.zip are served")
        return responses.FileResponse(path, media_type=media[name], filename=f"{run.id}-{name}")

    app.state.demo = demo
    return app
