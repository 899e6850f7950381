"""Running the model server: in the foreground (`attribot serve models`), or in a thread (tests, benches)."""

from __future__ import annotations

import logging
import os
import socket
import sys
import threading
import time
from typing import TYPE_CHECKING, Any

from attribot.bridge.guard import TOKEN_FIX, bind_problem
from attribot.deps import require
from attribot.errors import ConfigError
from attribot.models.base import build_backend, parse_spec
from attribot.server.app import ServerConfig, create_app
from attribot.server.model_process import backend_factory, start_model_process
from attribot.shutdown import termination_as_exit

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = [
    "ServerThread",
    "served_specs",
    "build_served_backends",
    "close_backends",
    "check_bind",
    "listen_socket",
    "serve_models",
    "NONE",
]

log = logging.getLogger("attribot.server")

SHUTDOWN_GRACE_S = 3.0
"""How long a stopping server waits for the requests in flight."""
STUCK_CALL_WAIT_S = 0.5
"""How long a stopped server then waits for a backend call still running in one of its threads, before it
exits without it (a thread cannot be stopped, and Python would wait for it at exit, for ever)."""

NONE = "none"
"""The spec that leaves a role unserved."""

# kinds that make no sense behind the server: the oracle needs simulator truth, which never crosses the
# wire (only RGB does), and a remote backend would make the server a proxy of another server
_NOT_SERVABLE = {
    "oracle": "the oracle needs simulator ground truth, and only the image crosses the wire",
    "remote": "the server would forward every request to another server",
}


def served_specs(settings: Settings, specs: dict[str, str | None]) -> tuple[dict[str, str | None], list[str]]:
    """role -> the spec to serve (None: not served), and notes on the roles left out.

    A spec given here (a command-line flag) must be servable: `oracle` and `remote` raise ConfigError.
    A role left at None takes the settings' spec, and is quietly not served when that spec is one of those
    (the offline defaults are `oracle`), so that `attribot serve models --detector hf:MODEL` just works.
    """
    out: dict[str, str | None] = {}
    notes: list[str] = []
    for role, given in specs.items():
        spec = given if given is not None else getattr(settings, role)
        if spec.strip().lower() == NONE:
            out[role] = None
            continue
        kind, _ = parse_spec(spec)
        if kind in _NOT_SERVABLE:
            if given is not None:
                raise ConfigError(
                    f"the server cannot serve the {role} backend {spec!r}: {_NOT_SERVABLE[kind]}",
                    f"serve a model: --{role} hf:MODEL (or openai:MODEL), or --{role} none",
                )
            notes.append(
                f"{role} not served: the configured {spec!r} cannot be ({_NOT_SERVABLE[kind]}); "
                f"give --{role} SPEC to serve one"
            )
            out[role] = None
            continue
        out[role] = spec
    if all(s is None for s in out.values()):
        raise ConfigError(
            "no role left to serve" + (f" ({'; '.join(notes)})" if notes else ""),
            "give at least one of --detector, --vqa, --language, "
            "e.g. --detector hf:google/owlv2-base-patch16-ensemble",
        )
    return out, notes


def build_served_backends(
    settings: Settings, specs: dict[str, str | None], *, model_process: bool = True
) -> dict[str, Any]:
    """role -> backend built from the spec (None: not served); see `served_specs` for which.

    With `model_process` (the default), each transformers model (an `hf:` detector or VQA) runs in a child
    process of its own (`attribot.server.model_process`: the HTTP work no longer slows the model down).
    Backends that only call an endpoint (`openai:`) or look up a table (`catalog`) stay in the server's
    process: they hold no model to protect.
    """
    chosen, _ = served_specs(settings, specs)
    out: dict[str, Any] = {}
    try:
        for role, spec in chosen.items():
            if spec is None:
                out[role] = None
            elif model_process and role in ("detector", "vqa") and parse_spec(spec)[0] == "hf":
                out[role] = start_model_process(role, backend_factory(role, spec, settings))
            else:
                out[role] = build_backend(role, spec, settings)
    except BaseException:
        close_backends(out)  # the model processes started before the failure
        raise
    return out


def close_backends(backends: dict[str, Any]) -> None:
    """Close the backends that hold resources (model processes, HTTP clients)."""
    for backend in backends.values():
        close = getattr(backend, "close", None)
        if callable(close):
            close()


def check_bind(host: str, token: str | None) -> None:
    """Refuse to listen beyond this machine without a strong token (`attribot.bridge.guard`: at least 16
    characters of more than one kind, no obvious word): anyone who can reach the port could use the GPU.
    Loopback needs none (reach it through an SSH tunnel); a token given is never blank."""
    problem = bind_problem(host, token)
    if problem is None:
        return
    if token is None:
        fix = "set --token (or ATTRIBOT_REMOTE_TOKEN), or listen on 127.0.0.1 and use an SSH tunnel"
    else:
        fix = f"set --token (or ATTRIBOT_REMOTE_TOKEN) to a strong secret ({TOKEN_FIX})"
    raise ConfigError(problem, fix)


def listen_socket(host: str, port: int) -> socket.socket:
    """A socket bound to `host`:`port`, taken before any model is loaded; a port in use (or an address
    this machine does not have) is a `ConfigError` that names it."""
    try:
        family, kind, proto, _, address = socket.getaddrinfo(
            host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE
        )[0]
    except socket.gaierror as exc:
        raise ConfigError(f"--host {host!r} is not an address of this machine ({exc.strerror})") from None
    sock = socket.socket(family, kind, proto)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as uvicorn does: restarts are quick
        sock.bind(address)
    except OSError as exc:
        sock.close()
        if exc.errno == 98:  # EADDRINUSE
            raise ConfigError(
                f"port {port} on {host} is already in use",
                f"stop what listens on port {port}, or choose another with --port",
            ) from None
        raise ConfigError(
            f"cannot listen on {host}:{port} ({exc.strerror or exc})", "choose another --host or --port"
        ) from None
    sock.set_inheritable(True)
    return sock


def _leave_stuck_calls() -> None:
    """Once the server has stopped: if a backend call still runs in one of its threads (a model or a
    parser that takes minutes), wait a moment, then exit without it, the clean-up already done."""
    current = threading.current_thread()
    busy = [t for t in threading.enumerate() if t is not current and not t.daemon and t.is_alive()]
    deadline = time.monotonic() + STUCK_CALL_WAIT_S
    for t in busy:
        t.join(max(deadline - time.monotonic(), 0.0))
    stuck = [t.name for t in busy if t.is_alive()]
    if not stuck:
        return
    exc = sys.exc_info()[1]
    code = (
        exc.code
        if isinstance(exc, SystemExit) and isinstance(exc.code, int)
        else 130
        if isinstance(exc, KeyboardInterrupt)
        else 1
        if exc is not None
        else 0
    )
    log.warning("exiting with a backend call still running (%s)", ", ".join(stuck))
    logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(code)


def _uvicorn_config(app: Any, host: str, port: int, log_level: str) -> Any:
    uvicorn = require("uvicorn", "the model server")
    return uvicorn.Config(
        app,
        host=host,
        port=port,
        log_level=log_level,
        access_log=False,
        lifespan="on",
        timeout_keep_alive=30,
        # on SIGTERM / Ctrl-C, requests in flight get this long; then they are cancelled and the backends
        # closed (a model call stuck for minutes no longer holds the server up)
        timeout_graceful_shutdown=SHUTDOWN_GRACE_S,
    )


def serve_models(
    backends: dict[str, Any],
    config: ServerConfig,
    *,
    host: str = "127.0.0.1",
    port: int = 8500,
    log_level: str = "info",
    sock: socket.socket | None = None,
) -> None:
    """Serve `backends` until interrupted (Ctrl-C, SIGTERM), then close them, on `sock` when given (from
    `listen_socket`) or on a socket of `host`:`port`.

    A stop takes a few seconds whatever runs: requests in flight get `SHUTDOWN_GRACE_S`, model processes
    are stopped, and a backend call stuck in one of the server's threads is left behind (the process
    exits without waiting for it)."""
    check_bind(host, config.token)
    uvicorn = require("uvicorn", "the model server")
    app = create_app(config=config, **backends)
    sock = sock if sock is not None else listen_socket(host, port)
    # uvicorn raises SIGTERM again once it has stopped: as SystemExit, so that the backends are closed
    with termination_as_exit():
        try:
            uvicorn.Server(_uvicorn_config(app, host, port, log_level)).run(sockets=[sock])
        finally:
            sock.close()
            close_backends(backends)
            _leave_stuck_calls()


class ServerThread:
    """A server in a background thread: `with ServerThread(app) as srv: httpx.get(srv.url + "/health")`.

    `port=0` takes a free port (read it from `.port` / `.url` once started); leaving the block stops it.
    """

    def __init__(self, app: Any, host: str = "127.0.0.1", port: int = 0, log_level: str = "warning") -> None:
        uvicorn = require("uvicorn", "the model server")
        self.host = host
        self.port = port
        self._server = uvicorn.Server(_uvicorn_config(app, host, port, log_level))
        self._thread = threading.Thread(target=self._server.run, name="attribot-server", daemon=True)

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}"

    def start(self, timeout_s: float = 20.0) -> ServerThread:
        self._thread.start()
        deadline = time.monotonic() + timeout_s
        while not self._server.started:
            if not self._thread.is_alive() or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(f"the model server did not start on {self.host}:{self.port}")
            time.sleep(0.01)
        sockets = [s for server in self._server.servers for s in server.sockets]
        if sockets:
            self.port = int(sockets[0].getsockname()[1])
        return self

    def stop(self, timeout_s: float = 10.0) -> None:
        self._server.should_exit = True
        if self._thread.is_alive():
            self._thread.join(timeout_s)

    def __enter__(self) -> ServerThread:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
