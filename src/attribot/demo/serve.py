"""Serving the demo: the model server's rule for addresses (no token, no address beyond this machine)."""

from __future__ import annotations

from collections.abc import Callable

from attribot.demo.app import DemoConfig, create_app
from attribot.deps import require
from attribot.errors import ConfigError
from attribot.server.run import check_bind, listen_socket
from attribot.shutdown import termination_as_exit

__all__ = ["serve_demo"]


def serve_demo(
    config: DemoConfig,
    host: str = "127.0.0.1",
    port: int = 8600,
    log_level: str = "warning",
    announce: Callable[[str], None] | None = None,
) -> None:
    """Serve the demo on `host`:`port` until interrupted (Ctrl-C, SIGTERM). An address beyond this machine
    needs `config.token` (a `ConfigError` otherwise), and a port in use is said before anything starts;
    `announce` then gets the address to open (with the token)."""
    try:
        check_bind(host, config.token)
    except ConfigError as exc:  # the same rule as the model server's, with the demo's own fix
        raise ConfigError(
            exc.message.replace("the server", "the demo"),
            "set --token (or ATTRIBOT_DEMO_TOKEN), or listen on 127.0.0.1 and use an SSH tunnel",
        ) from None
    uvicorn = require("uvicorn", "the live demo")
    sock = listen_socket(host, port)
    app = create_app(config)
    if announce is not None:
        announce(f"http://{host}:{port}/" + (f"?token={config.token}" if config.token else ""))
    server = uvicorn.Server(uvicorn.Config(app, host=host, port=port, log_level=log_level, access_log=False))
    with termination_as_exit():
        try:
            server.run(sockets=[sock])
        finally:
            sock.close()
