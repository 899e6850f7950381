"""Helpers and fixtures shared by several test files. Import the helpers by name (`from conftest import
wait_for`); pytest finds the fixtures by itself. The shared fakes live in tests/fakes/ (one module per kind)
and are served from here too, so `from conftest import BallWorld` keeps working; add new ones there."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from fakes.backends import (
    BrightBoxDetector,
    EchoLanguage,
    FakeDetector,
    FakeLanguage,
    FakeVQA,
    MeanColourVQA,
    Thing,
    WholeImageDetector,
    mean_colour,
    perception_for,
    wrap_detector,
)
from fakes.balls import (
    BALLS,
    CAM,
    CAM_HEIGHT,
    Ball,
    BallController,
    BallWorld,
    WorldDetector,
    _rot_head_to_world,
    _rot_world_to_head,
    world_perception,
)
from fakes.chat import serve_chat_replies
from fakes.frames import bright_box, frame_with_box, grown_box, random_frame
from fakes.worlds import TruthBlindWorld

ARTIFACTS = Path(__file__).parent / "artifacts"
EMPTY_SETTINGS = ARTIFACTS / "empty-settings.toml"
"""A settings file with no settings: point ATTRIBOT_CONFIG here so that no ./attribot.toml is read."""


# ---- settings -----------------------------------------------------------------------------------------


def cli(*args: str, cwd: Path | None = None, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """`attribot ARGS...` in a fresh process with the empty settings file, its output captured."""
    env = {**os.environ, "ATTRIBOT_CONFIG": str(EMPTY_SETTINGS)}
    return subprocess.run(
        [sys.executable, "-m", "attribot.cli", *args],
        capture_output=True,
        text=True,
        env=env,
        cwd=cwd,
        timeout=timeout,
    )


@pytest.fixture
def empty_settings(monkeypatch: pytest.MonkeyPatch) -> Path:
    """The defaults, whatever ./attribot.toml or ATTRIBOT_CONFIG the machine has."""
    monkeypatch.setenv("ATTRIBOT_CONFIG", str(EMPTY_SETTINGS))
    return EMPTY_SETTINGS


# ---- processes, ports and waiting -----------------------------------------------------------------------


def alive(pid: int) -> bool:
    """Whether process `pid` runs (a zombie, exited but not yet reaped, counts as gone)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def wait_for(predicate: Callable[[], bool], timeout: float = 10.0) -> bool:
    """Poll `predicate` until it holds or `timeout` seconds pass; its last value."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.05)
    return predicate()


def wait_listening(port: int, proc: subprocess.Popen[str], what: str, timeout: float = 120.0) -> None:
    """Wait until the server process `proc` accepts connections on 127.0.0.1:`port`; fail, naming `what`,
    if it exits first or `timeout` seconds pass."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            return
        except OSError:
            assert proc.poll() is None and time.monotonic() < deadline, f"{what} did not start"
            time.sleep(0.2)


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on (just now)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


__all__ = [
    "wait_listening",
    "ARTIFACTS",
    "EMPTY_SETTINGS",
    "cli",
    "empty_settings",
    "alive",
    "wait_for",
    "free_port",
    "random_frame",
    "frame_with_box",
    "bright_box",
    "grown_box",
    "mean_colour",
    "MeanColourVQA",
    "WholeImageDetector",
    "EchoLanguage",
    "BrightBoxDetector",
    "Thing",
    "FakeDetector",
    "FakeVQA",
    "FakeLanguage",
    "perception_for",
    "wrap_detector",
    "Ball",
    "CAM",
    "CAM_HEIGHT",
    "BallWorld",
    "WorldDetector",
    "BallController",
    "BALLS",
    "world_perception",
    "_rot_head_to_world",
    "_rot_world_to_head",
    "serve_chat_replies",
    "TruthBlindWorld",
]
