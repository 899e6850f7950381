"""Awkward and large images through the hf: detector: time and peak memory of one `detect`, with the
image brought to the model's working size first (what the backend does) against the processor seeing the
full image (what it did), in the same run, each in a fresh process.

    .venv/bin/python benchmarks/bench_image_sizes.py [--model owlv2-tiny|owlv2-b16] [--reference]

Without --reference only the current path runs (the reference takes minutes on a 1x10000 image: OWLv2's
processor pads it to a 10000x10000 square and blurs it on the CPU). The model is a random one built from
its config (no download); the processor, which is where the cost was, has the real working size for
owlv2-b16 (960) and 32 for owlv2-tiny.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # tests/fakes: the random models

SHAPES = ((1, 10000), (3000, 4000), (12000, 12000))


def one(model: str, h: int, w: int, reference: bool) -> dict[str, float]:
    import numpy as np

    from attribot.frame import Frame
    from attribot.models import hf
    from fakes.hf_random import build_random

    if reference:  # the processor sees the full image, as before the working-size step
        hf.to_working_size = lambda rgb, side: (rgb, 1.0)  # type: ignore[assignment]
    net, processor = build_random(model, seed=0)
    det = hf.HFDetector.from_loaded(net, processor, threshold=0.1)
    rgb = np.empty((h, w, 3), np.uint8)  # a gradient, built without a float copy
    rgb[..., 0] = np.linspace(0, 255, w).astype(np.uint8)[None, :]
    rgb[..., 1] = np.linspace(0, 255, h).astype(np.uint8)[:, None]
    rgb[..., 2] = 90
    frame = Frame(rgb=rgb)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    det.detect(frame, ["cup"])
    seconds = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return {"s": seconds, "peak_mb": peak / 1024, "added_mb": (peak - before) / 1024}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="owlv2-tiny")
    parser.add_argument("--reference", action="store_true", help="also run the full-image processor")
    parser.add_argument("--one", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        model, h, w, mode = args.one
        print(json.dumps(one(model, int(h), int(w), mode == "reference")))
        return
    for h, w in SHAPES:
        row = {}
        for mode in ("working-size",) + (("reference",) if args.reference else ()):
            out = subprocess.run(
                [sys.executable, __file__, "--one", args.model, str(h), str(w), mode],
                capture_output=True,
                text=True,
            )
            row[mode] = json.loads(out.stdout.strip().splitlines()[-1]) if out.returncode == 0 else None
        cur = row["working-size"]
        line = f"{args.model} {w}x{h}: detect {cur['s']:.2f} s, peak RSS {cur['peak_mb']:.0f} MB"
        line += f" (+{cur['added_mb']:.0f} MB in detect)"
        ref = row.get("reference")
        if ref:
            line += (
                f"; full-image processor {ref['s']:.2f} s, peak {ref['peak_mb']:.0f} MB "
                f"(x{ref['s'] / cur['s']:.0f} time, x{ref['peak_mb'] / cur['peak_mb']:.1f} memory)"
            )
        print(line, flush=True)


if __name__ == "__main__":
    main()
