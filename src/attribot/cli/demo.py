"""`attribot demo`: the live demo page."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from attribot.cli.flags import BACKEND_FLAGS, PLANNER_FLAGS, settings_of, with_flags
from attribot.cli.output import err_console, fail, prefetch_rendering, writable_folder


@with_flags(BACKEND_FLAGS, PLANNER_FLAGS)
def demo(
    host: str = typer.Option("127.0.0.1", "--host", help="Address to listen on (another one needs --token)."),
    port: int = typer.Option(8600, "--port", help="TCP port."),
    token: str | None = typer.Option(
        None, "--token", envvar="ATTRIBOT_DEMO_TOKEN", help="Token visitors must give (?token=... once)."
    ),
    runs_dir: Path | None = typer.Option(
        None,
        "--runs-dir",
        help="Keep each query's saved run here (default: a temporary folder, removed at exit).",
    ),
    allow_host: list[str] | None = typer.Option(
        None,
        "--allow-host",
        metavar="NAME",
        help="Another name visitors reach the demo by (e.g. lab-pc.local); IP addresses and localhost "
        "always work, other names are refused (DNS rebinding).",
    ),
    given: Any = None,
) -> None:
    """Serve the live demo page: choose a scene, ask, watch the robot, get the answer and its video."""
    import tempfile

    from attribot.demo import DemoConfig, serve_demo

    if not 0 < port < 65536:
        raise fail(f"--port must lie in 1..65535, got {port}", "use e.g. --port 8600")
    settings = settings_of(given)
    if runs_dir is not None:
        writable_folder(runs_dir, "--runs-dir")

    def announce(url: str) -> None:
        kept = f"runs saved in {runs_dir}" if runs_dir else "runs kept until it stops"
        err_console.print(f"attribot demo: open {url} ({kept}; Ctrl-C stops)", highlight=False)

    with tempfile.TemporaryDirectory(prefix="attribot-demo-") as scratch:
        config = DemoConfig(
            settings=settings,
            runs_dir=runs_dir or Path(scratch),
            token=token,
            hosts=tuple(allow_host or ()),
            keep_runs=runs_dir is not None,
        )
        prefetch_rendering()
        serve_demo(config, host=host, port=port, announce=announce)
