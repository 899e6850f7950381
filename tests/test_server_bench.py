"""benchmarks/bench_server.py runs (CPU path, quick) and prints one figure per line with its reference."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize(
    "extra",
    [
        [],
        # the backend in a child process of the server, spending part of its time holding the GIL
        ["--model-process", "--launch-ops", "50", "--item-ops", "5", "--client-processes", "2"],
    ],
    ids=["in-process", "model-process"],
)
def test_bench_server_quick_cpu_run_prints_every_figure(extra):
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    out = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "bench_server.py"),
            "--quick",
            "--call-ms",
            "5",
            "--concurrency",
            "1,4",
            *extra,
        ],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
        check=False,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    figures = [ln for ln in out.stdout.splitlines() if not ln.startswith("#")]
    names = [re.split(r"\s{2,}", ln.strip())[0] for ln in figures]
    assert "overhead per request (batching off)" in names and "backend alone, batch 32 vs 1" in names
    assert "batching gain, concurrency 1" in names and "batching gain, concurrency 4" in names
    for ln in figures:
        assert re.search(r"\d+\.\d\dx\s+vs ", ln), ln  # a ratio, then its reference
    gain4 = next(ln for ln in figures if "concurrency 4" in ln)
    assert float(re.search(r"(\d+\.\d+)x", gain4).group(1)) > 0
    if "--model-process" in extra:
        assert "in a model process" in out.stdout and "clients in 2 process(es)" in out.stdout
