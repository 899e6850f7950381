#!/usr/bin/env python3
"""What an oracle question imports: attribot modules and wall time of a fresh process, for three stages.

- config: `import attribot` and make the default `SceneConfig` (its checks run as it is made);
- set-up: an oracle ask's set-up without the world's physics: the settings, the scene config, the rules
  planner, the three backends (`Perception.from_settings`) and the world's class;
- ask: a whole `attribot.ask` on a small triplet scene.

Each figure is the median of N fresh processes, printed as a ratio to `python -c "import numpy"` measured
in the same run (the machine is shared and noisy), with the number of attribot modules the process holds
at the end and those of the backends and worlds an oracle question never uses. `--src DIR` (repeatable)
measures other checkouts' `src` folders in the same run, e.g. the commit before a change:

    git archive BASE src | tar -x -C /tmp/before
    PYTHONPATH=src .venv/bin/python benchmarks/bench_imports.py --src /tmp/before/src --src src
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

UNUSED = (
    "attribot.models.hf",
    "attribot.models.coco",
    "attribot.models.remote",
    "attribot.models.openai_chat",
    "attribot.planning.llm",
    "attribot.embodiments.ai2thor",
    "attribot.embodiments.bridge",
    "attribot.bridge",
    "attribot.server",
)

STAGES = {
    "config": """
import attribot
attribot.SceneConfig()
""",
    "set-up": """
import attribot
from attribot.skills.perception import Perception
from attribot.embodiments.base import EMBODIMENTS
from attribot.planning import build_planner
settings = attribot.load_settings()
config = attribot.SceneConfig()
build_planner(settings.planner, settings)
Perception.from_settings(settings)
EMBODIMENTS.get("mujoco")
""",
    "ask": """
import attribot
attribot.ask("which object is the heaviest?", attribot.SceneConfig(layout="triplet", seed=1, width=160,
             height=120))
""",
}

REPORT = """
import json, sys
mods = [m for m in sys.modules if m.startswith("attribot")]
unused = [m for m in mods if any(m == u or m.startswith(u + ".") for u in {unused!r})]
print(json.dumps([len(mods), sorted(unused)]))
"""


def run(code: str, src: str, env: dict[str, str]) -> tuple[float, list]:
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env={**env, "PYTHONPATH": src}
    )
    took = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"failed ({done.returncode}) with {src}: {done.stderr.strip()[-2000:]}")
    return took, json.loads(done.stdout.strip().splitlines()[-1]) if done.stdout.strip() else []


def median_wall(code: str, src: str, env: dict[str, str], runs: int) -> tuple[float, list]:
    times, last = [], []
    for _ in range(runs):
        took, last = run(code, src, env)
        times.append(took)
    return statistics.median(times), last


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--src", action="append", help="a checkout's src folder (default: this one's)")
    args = parser.parse_args()
    sources = args.src or [str(Path(__file__).resolve().parents[1] / "src")]
    with tempfile.TemporaryDirectory() as tmp:
        empty = Path(tmp) / "attribot.toml"
        empty.write_text("")
        env = {k: v for k, v in os.environ.items() if k != "ATTRIBOT_PLUGINS"}
        env["ATTRIBOT_CONFIG"] = str(empty)
        reference, _ = median_wall("import numpy", sources[0], env, args.runs)
        print(f"reference `python -c 'import numpy'`: {reference * 1000:.0f} ms (median of {args.runs})")
        for stage, code in STAGES.items():
            for src in sources:
                wall, (count, unused) = median_wall(code + REPORT.format(unused=UNUSED), src, env, args.runs)
                print(
                    f"{stage:7s} {src}: {wall * 1000:.0f} ms = {wall / reference:.1f}x import numpy, "
                    f"{count} attribot modules, unused backends/worlds imported: {len(unused)}"
                    + (f" ({', '.join(unused)})" if unused else "")
                )


if __name__ == "__main__":
    main()
