"""The package ships `py.typed`, so its types are checked (mypy, configured in pyproject.toml); and the
code stays lint-clean (ruff). Both are part of the `test` extra."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(
    "command",
    [
        [sys.executable, "-m", "mypy", "--no-incremental"],
        [sys.executable, "-m", "ruff", "check", "src", "tests", "benchmarks"],
    ],
    ids=["mypy", "ruff"],
)
def test_static_check_is_clean(command):
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]
