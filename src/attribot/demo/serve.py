"""Serving the demo: the model server's rule for addresses (no token, no address beyond this machine), a
deadline for each request's headers, and a clean stop on Ctrl-C or SIGTERM.

A stop waits a moment for the pages that follow runs, then unwinds the query that runs, whose world is
closed in its own thread before the process exits: a process that exits while a thread still renders with
MuJoCo's EGL context ends in a segmentation fault."""

from __future__ import annotations

import dataclasses
import logging
import os
import shutil
import sys
from collections.abc import Callable
from types import ModuleType
from typing import Any

from attribot.bridge.guard import MIN_TOKEN_CHARS as GUARD_MIN_TOKEN_CHARS
from attribot.demo.app import DemoConfig, create_app, is_ip
from attribot.demo.runs import STOP_GRACE_S
from attribot.deps import require
from attribot.errors import ConfigError
from attribot.server.run import check_bind, listen_socket
from attribot.shutdown import termination_as_exit

__all__ = ["serve_demo", "MIN_TOKEN_CHARS", "HEADER_TIMEOUT_S"]

log = logging.getLogger("attribot.demo")

MIN_TOKEN_CHARS = GUARD_MIN_TOKEN_CHARS
"""The shortest token the demo takes to listen beyond this machine (the rule of every server that can
spend a GPU or move a robot: `attribot.bridge.guard`)."""
HEADER_TIMEOUT_S = 5.0
"""How long a connection may take to send a request's headers (one trickling them, slowloris-style, would
otherwise hold a connection for ever)."""
STREAM_GRACE_S = 2.0
"""How long a stopping demo lets the pages that follow runs stay connected."""
_TOKEN_FIX = "set --token (or ATTRIBOT_DEMO_TOKEN) to a secret, e.g. $(openssl rand -hex 16)"


def _check_token(host: str, token: str | None) -> None:
    if token is not None and not token.strip():
        raise ConfigError("the demo's --token is blank", _TOKEN_FIX)
    try:
        check_bind(host, token)
    except ConfigError as exc:  # the same rule as the model server's, with the demo's own fix
        raise ConfigError(
            exc.message.replace("the server", "the demo"),
            "set --token (or ATTRIBOT_DEMO_TOKEN) to a strong secret, e.g. $(openssl rand -hex 16), or "
            "listen on 127.0.0.1 and use an SSH tunnel",
        ) from None


def _header_deadline(base: type[Any]) -> type[Any]:
    """uvicorn's HTTP protocol with a deadline on each request's headers: a connection that has not begun
    a request within `HEADER_TIMEOUT_S` of connecting, or of its last response, is closed. A request in
    progress (a page following a run for minutes) is never cut."""

    class HeaderDeadline(base):
        def connection_made(self, transport: Any) -> None:
            super().connection_made(transport)
            self._seen_cycle: Any = None
            self._deadline = self.loop.call_later(HEADER_TIMEOUT_S, self._check_headers)

        def _check_headers(self) -> None:
            cycle = getattr(self, "cycle", None)
            idle = cycle is None or getattr(cycle, "response_complete", False)
            if idle and cycle is self._seen_cycle:  # no new request began in a whole period
                self.transport.close()
                return
            self._seen_cycle = cycle
            self._deadline = self.loop.call_later(HEADER_TIMEOUT_S, self._check_headers)

        def connection_lost(self, exc: Exception | None) -> None:
            self._deadline.cancel()
            super().connection_lost(exc)

    return HeaderDeadline


def _answering_to(config: DemoConfig, host: str) -> DemoConfig:
    """`config` with `host` among the names the demo answers to, when it is a name (not an address)."""
    if host.lower() not in ("localhost", "0.0.0.0", "::") and not is_ip(host):
        return dataclasses.replace(config, hosts=(*config.hosts, host))
    return config


def _demo_server(uvicorn: ModuleType, app: Any, host: str, port: int, log_level: str) -> Any:
    """The uvicorn server of `app`: a deadline on each request's headers, and a signal that stops the
    demo's runs at once."""
    from uvicorn import Server as UvicornServer
    from uvicorn.protocols.http.auto import AutoHTTPProtocol

    runs = app.state.demo

    class Server(UvicornServer):
        def handle_exit(self, sig: int, frame: Any) -> None:
            # at the signal, not after the pages' grace: the running query unwinds now, so that the pages
            # that follow it get its last events before their connections close
            runs.stopping.set()
            super().handle_exit(sig, frame)

    return Server(
        uvicorn.Config(
            app,
            host=host,
            port=port,
            log_level=log_level,
            access_log=False,
            http=_header_deadline(AutoHTTPProtocol),
            timeout_keep_alive=5,
            timeout_graceful_shutdown=STREAM_GRACE_S,
        )
    )


def _stop_runs(runs: Any, config: DemoConfig, code: int | str | None) -> None:
    """Stop the demo's runs once the server has stopped; a query that does not stop in time ends the
    process at once with `code`."""
    grace = STOP_GRACE_S if not runs.stopping.is_set() else 0.5  # else stopped already, or not
    if runs.worker.is_alive() and not runs.stop(grace):
        # a query that did not notice the stop (a model call of minutes): exit without it, never through
        # the interpreter's teardown under a live rendering thread
        log.warning("the demo stops with a query still running")
        if not config.keep_runs:
            shutil.rmtree(config.runs_dir, ignore_errors=True)
        logging.shutdown()
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
        os._exit(code if isinstance(code, int) else 1)


def serve_demo(
    config: DemoConfig,
    host: str = "127.0.0.1",
    port: int = 8600,
    log_level: str = "warning",
    announce: Callable[[str], None] | None = None,
) -> None:
    """Serve the demo on `host`:`port` until interrupted (Ctrl-C, SIGTERM). An address beyond this machine
    needs a strong `config.token` (`attribot.bridge.guard.token_problem`; a `ConfigError` otherwise, as for a
    blank token),
    and a port in use is said before anything starts; `announce` then gets the address to open (with the
    token). The demo answers to `host` when it is a name, besides localhost and IP addresses."""
    _check_token(host, config.token)
    uvicorn = require("uvicorn", "the live demo")
    config = _answering_to(config, host)
    sock = listen_socket(host, port)
    app = create_app(config)
    runs = app.state.demo
    if announce is not None:
        announce(f"http://{host}:{port}/" + (f"?token={config.token}" if config.token else ""))
    server = _demo_server(uvicorn, app, host, port, log_level)
    code: int | str | None = 0
    with termination_as_exit():
        try:
            server.run(sockets=[sock])
        except KeyboardInterrupt:  # uvicorn raises Ctrl-C again once it has stopped
            code = 130
        except SystemExit as exc:  # SIGTERM or SIGHUP, raised again the same way
            code = exc.code
        finally:
            sock.close()
            _stop_runs(runs, config, code)
    if code:
        raise SystemExit(code)
