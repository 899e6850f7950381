"""The one place where the demo asks attribot a question (so that a change of entry point is one edit)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from attribot.config import SceneConfig, Settings
from attribot.planning.answer import Answer

__all__ = ["run_query"]


def run_query(
    query: str,
    *,
    config: SceneConfig | None,
    image: Path | None,
    settings: Settings,
    save_dir: Path,
    on_program: Callable[[str], None],
    on_call: Callable[[Any], None],
    on_frame: Callable[[Any, Any], None],
) -> Answer:
    """Answer `query` in the scene of `config` (or on the still `image`) as `attribot ask --save save_dir`
    does, calling `on_program` with each program as its try starts, `on_call` with each API call's
    TraceRecord as it ends and `on_frame` with each episode frame (robot camera, room camera RGB)."""
    from attribot.session import Scene, Watch, ask

    watch = Watch(program=on_program, call=on_call, frame=on_frame)
    scene = Scene(config=config, image=image)
    return ask(query, scene, settings, save_dir=save_dir, watch=watch)
