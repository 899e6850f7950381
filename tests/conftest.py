"""Helpers and fixtures shared by several test files, in sections. Import the helpers by name
(`from conftest import wait_for`); pytest finds the fixtures by itself. Add new shared fakes to the
section they belong to (or a new one), not to a test file."""

from __future__ import annotations

import socket
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from attribot.frame import Frame

ARTIFACTS = Path(__file__).parent / "artifacts"
EMPTY_SETTINGS = ARTIFACTS / "empty-settings.toml"
"""A settings file with no settings: point ATTRIBOT_CONFIG here so that no ./attribot.toml is read."""


# ---- settings -----------------------------------------------------------------------------------------


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


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on (just now)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# ---- frames ---------------------------------------------------------------------------------------------


def random_frame(h: int, w: int, seed: int = 0) -> Frame:
    """A frame of uniform random pixels."""
    return Frame(rgb=np.random.default_rng(seed).integers(0, 256, (h, w, 3), dtype=np.uint8))


def frame_with_box(h: int, w: int, box: tuple[int, int, int, int]) -> Frame:
    """A black frame with one bright rectangle (x0, y0, x1, y1): what `bright_box` finds again."""
    rgb = np.zeros((h, w, 3), np.uint8)
    x0, y0, x1, y1 = box
    rgb[y0:y1, x0:x1] = 200
    return Frame(rgb=rgb)


def bright_box(rgb: np.ndarray) -> tuple[float, float, float, float]:
    """The box of the bright pixels: stand-in detectors answer with it, so a frame that crossed a pipe or
    a wire can be checked against the one that was sent."""
    ys, xs = np.nonzero(rgb.max(axis=2) > 40)
    return float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1)
