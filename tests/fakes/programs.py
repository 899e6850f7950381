"""What the tests of LLM-written programs share: truths read from the world's own state, program text as
an LLM writes it, and `attribot ask --planner llm` run against a scripted endpoint."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import Any

from attribot.config import SceneConfig
from attribot.embodiments.mujoco import MujocoWorld

__all__ = ["Truth", "heaviest", "lightest", "closest", "truth_of", "program", "ask_llm_cli"]

Truth = Callable[[list[Any]], str]
"""The id of the right object, from the scene's objects."""


def heaviest(objects: list[Any]) -> str:
    return max(objects, key=lambda o: o.mass_kg).id


def lightest(objects: list[Any]) -> str:
    return min(objects, key=lambda o: o.mass_kg).id


def closest(objects: list[Any]) -> str:
    return min(objects, key=lambda o: o.distance_m).id


def truth_of(config: SceneConfig, truth: Truth) -> str:
    """The right object's id in the world `config` draws, from its own state (`scene_info()`)."""
    with MujocoWorld(config) as world:
        return truth(list(world.scene_info().objects))


def program(text: str) -> str:
    """A program's text as written in a test: dedented, one newline at its end."""
    return textwrap.dedent(text).strip("\n") + "\n"


def ask_llm_cli(
    query: str, args: tuple[str, ...], url: str, cache: str, config: Path, prompt: str | None = None
) -> subprocess.CompletedProcess[str]:
    """`attribot ask QUERY ARGS --planner llm --json` against the scripted endpoint at `url`, with the
    settings file `config`, the cache folder `cache` and, when given, the prompt dialect `prompt`."""
    env = {**os.environ, "ATTRIBOT_CONFIG": str(config), "ATTRIBOT_CACHE_DIR": cache}
    dialect = () if prompt is None else ("--prompt", prompt)
    return subprocess.run(
        [sys.executable, "-m", "attribot.cli", "ask", query, *args, "--planner", "llm", "--llm-base-url", url,
         "--llm-model", "scripted", *dialect, "--json"],
        capture_output=True, text=True, env=env, timeout=300,
    )  # fmt: skip
