"""`attribot serve models`: the model server."""

from __future__ import annotations

from typing import Any

import typer

from attribot.cli.output import Command, Group, err_console, fail

serve_app = typer.Typer(
    cls=Group, help="Run servers: `attribot serve models` (the model server).", no_args_is_help=True
)


_SERVE_TOKEN = typer.Option(
    None,
    "--token",
    help="Bearer token clients must send (default: ATTRIBOT_REMOTE_TOKEN; none: no check).",
)
_SERVE_DETECTOR = typer.Option(None, "--detector", help="Detector spec to serve, e.g. hf:MODEL, or none.")
_SERVE_VQA = typer.Option(None, "--vqa", help="VQA spec to serve, e.g. hf:MODEL or openai:MODEL, or none.")
_SERVE_LANGUAGE = typer.Option(
    None, "--language", help="Language spec to serve (catalog, openai:MODEL, none)."
)
_SERVE_MODEL_PROCESS = typer.Option(
    True,
    "--model-process/--in-process",
    help="Run each hf: model (detector, VQA) in a process of its own, so that the server's HTTP work "
    "does not hold up the model (the default), or in the server's process.",
)


@serve_app.command("models", cls=Command)
def serve_models(
    host: str = typer.Option(
        "127.0.0.1", "--host", help="Address to listen on (127.0.0.1: reach it by SSH tunnel)."
    ),
    port: int = typer.Option(8500, "--port", help="TCP port."),
    token: str | None = _SERVE_TOKEN,
    detector: str | None = _SERVE_DETECTOR,
    vqa: str | None = _SERVE_VQA,
    language: str | None = _SERVE_LANGUAGE,
    max_batch: int = typer.Option(
        32, "--max-batch", help="Most requests of one role in one backend call (1 to 1024; 1: no batching)."
    ),
    batch_window_ms: float = typer.Option(
        2.0,
        "--batch-window-ms",
        help="Longest wait for a batch to fill, from its oldest request's arrival (0 to 10000).",
    ),
    max_image_mb: float = typer.Option(
        10.0, "--max-image-mb", help="Largest image file accepted, 0 to 200 MB (413 beyond)."
    ),
    max_queue: int = typer.Option(
        1024, "--max-queue", help="Most requests queued per role, 1 to 100000 (429 beyond)."
    ),
    log_level: str = typer.Option("info", "--log-level", help="uvicorn log level: warning, info, debug."),
    model_process: bool = _SERVE_MODEL_PROCESS,
) -> None:
    """Serve the configured detector, VQA and language backends over HTTP with dynamic batching."""
    from attribot.config import load_settings, revealed
    from attribot.server import build_served_backends, check_bind, listen_socket, served_specs
    from attribot.server import serve_models as run_server

    if not 0 < port < 65536:
        raise fail(f"--port must lie in 1..65535, got {port}", "use e.g. --port 8500")
    settings = load_settings()
    config = _server_config(
        token=token or revealed(settings.remote_token),
        max_batch=max_batch,
        batch_window_ms=batch_window_ms,
        max_image_mb=max_image_mb,
        max_queue=max_queue,
    )
    check_bind(host, config.token)
    given = {"detector": detector, "vqa": vqa, "language": language}
    _, notes = served_specs(settings, given)
    sock = listen_socket(host, port)  # a port in use is said before any model loads
    for note in notes:
        err_console.print(f"[yellow]note:[/] {note}", highlight=False)
    try:
        backends = build_served_backends(settings, given, model_process=model_process)
    except BaseException:
        sock.close()
        raise
    _print_served(backends, host, port, token_required=bool(config.token))
    run_server(backends, config, host=host, port=port, log_level=log_level, sock=sock)


def _server_config(
    token: str | None, max_batch: int, batch_window_ms: float, max_image_mb: float, max_queue: int
) -> Any:
    """The model server's config from the command's options; a value out of bounds fails naming its option."""
    from pydantic import ValidationError

    from attribot.server import ServerConfig

    try:
        return ServerConfig(
            token=token,
            max_batch=max_batch,
            batch_window_ms=batch_window_ms,
            max_image_mb=max_image_mb,
            max_queue=max_queue,
        )
    except ValidationError as exc:
        first = exc.errors()[0]
        option = "--" + str(first["loc"][0]).replace("_", "-") if first.get("loc") else "an option"
        raise fail(f"{option}: {first.get('msg')}", "see `attribot serve models --help`") from None


def _print_served(backends: dict[str, Any], host: str, port: int, *, token_required: bool) -> None:
    """Say on stderr what each role serves and where clients reach it."""
    for role, backend in backends.items():
        pid = getattr(backend, "pid", None)
        where = f" (model process {pid})" if pid is not None else ""
        err_console.print(
            f"serving {role}: {getattr(backend, 'name', '-') if backend else 'none'}{where}", highlight=False
        )
    err_console.print(
        f"listening on http://{host}:{port} (token {'required' if token_required else 'not required'}); "
        f"clients give remote:http://{host}:{port} as the backend spec of each served role",
        highlight=False,
    )
