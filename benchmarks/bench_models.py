#!/usr/bin/env python3
"""Speed of the transformers backends (OWLv2, Grounding DINO, BLIP-2), with random weights: no download.

Three modes:

  PYTHONPATH=src python3 benchmarks/bench_models.py
      CPU, tiny models loaded by path through the `hf:` backends: per-image cost of a batched call
      against one call per image, measured in the same run (the ratio is the figure).

  PYTHONPATH=src python3 benchmarks/bench_models.py --device cuda --real-size
      GPU, the real architectures (OWLv2-B/16, OWLv2-L/14, Grounding DINO-T, BLIP-2 OPT-2.7b) built
      from their configs on the GPU, at batch 1, 8 and 32 in float16 and bfloat16:
      - `forward`: the model alone on tensors of the processor's shapes (5 labels; BLIP-2: one prefill
        pass over 32 query tokens + a 10-token prompt), the figure the anchors below were measured on;
      - `backend`: `detect_batch` / `answer_batch` end to end on 640x480 frames (pre-processing on the
        CPU unless torchvision is installed, post-processing, NMS; BLIP-2 generates 5 tokens), with
        where its time goes: before the model runs, in the model, after (a separate, synchronised pass).
      Prints ms per batch, ms per image, images per second, the per-image cost against the H100
      anchor (fp16, batch 1) and against our own batch 1, and whether batch 32 meets the target
      (per-image cost at most a third of the anchor).

  PYTHONPATH=src python3 benchmarks/bench_models.py --tiny
      The GPU mode's code path with tiny models on the CPU (a check that it runs, not a measurement).

Needs torch and transformers (>= 4.50); the `backend` rows also need attribot's core dependencies
(numpy, pydantic, pillow); when those are missing the rows are skipped with the reason. A GPU machine
without pydantic and without network can get it from a folder made elsewhere and put on PYTHONPATH:
  pip install --target out/gpu-deps --python-version 3.12 --platform manylinux2014_x86_64 \
      --only-binary=:all: pydantic && rm -rf out/gpu-deps/typing_extensions*
  PYTHONPATH=src:out/gpu-deps python3 benchmarks/bench_models.py --device cuda --real-size
`--compile` runs the models through torch.compile (minutes of warm-up per model and batch size).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
import traceback
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # tests/fakes: the random models

# anchors: ms per image on an H100, fp16, batch 1, random weights (issue 4)
ANCHORS_MS = {"owlv2-b16": 21.0, "owlv2-l14": 45.0, "grounding-dino-t": 58.0, "blip2-opt-2.7b": 62.0}
TARGET_FRACTION = 1 / 3  # per-image cost at batch 32 against the batch-1 anchor
REAL = ["owlv2-b16", "owlv2-l14", "grounding-dino-t", "blip2-opt-2.7b"]
TINY = {
    "owlv2-b16": "owlv2-tiny",
    "owlv2-l14": "owlv2-tiny",
    "grounding-dino-t": "grounding-dino-tiny",
    "blip2-opt-2.7b": "blip2-tiny",
}
LABELS = ["a cup", "a bowl", "an apple", "a book", "a remote control"]
FRAME_HW = (480, 640)


def _fail(message: str) -> None:
    print(f"error: {message}", file=sys.stderr)
    raise SystemExit(2)


def _imports() -> tuple[Any, Any]:
    try:
        import torch
        import transformers
    except ImportError as exc:
        _fail(f"{exc.name} is not installed: pip install 'attribot[models]' (torch, transformers)")
    return torch, transformers


class Timer:
    """Median wall time of a call, synchronising the GPU around it."""

    def __init__(self, torch: Any, device: str, warmup: int, iters: int) -> None:
        self.torch, self.device, self.warmup, self.iters = torch, device, warmup, iters

    def _sync(self) -> None:
        if self.device.startswith("cuda"):
            self.torch.cuda.synchronize()

    def __call__(self, fn: Any) -> float:
        for _ in range(self.warmup):
            fn()
        self._sync()
        times = []
        for _ in range(self.iters):
            self._sync()
            t0 = time.perf_counter()
            fn()
            self._sync()
            times.append(time.perf_counter() - t0)
        return statistics.median(times)


class PhaseSplit:
    """Where one backend call's time goes: before the model first runs (tokenising, image pre-processing,
    copies to the GPU), inside the model (the outermost forwards of the model and of its direct children,
    so that BLIP-2's `generate`, which calls the parts and not the whole, is covered too), and the rest
    (post-processing, NMS, decoding, the glue between generation steps). The GPU is synchronised at every
    boundary, so this is a separate pass from the timed calls."""

    def __init__(self, torch: Any, model: Any, device: str) -> None:
        self.torch, self.model, self.device = torch, model, device

    def _sync(self) -> None:
        if self.device.startswith("cuda"):
            self.torch.cuda.synchronize()

    def __call__(self, fn: Any, iters: int = 3) -> dict[str, float]:
        depth = [0]
        marks: list[tuple[str, float]] = []

        def enter(*_: Any, **__: Any) -> None:
            if depth[0] == 0:
                self._sync()
                marks.append(("in", time.perf_counter()))
            depth[0] += 1

        def leave(*_: Any, **__: Any) -> None:
            depth[0] -= 1
            if depth[0] == 0:
                self._sync()
                marks.append(("out", time.perf_counter()))

        modules = [self.model, *self.model.children()]
        handles = [m.register_forward_pre_hook(enter) for m in modules]
        handles += [m.register_forward_hook(leave) for m in modules]
        splits = []
        try:
            for _ in range(iters):
                marks.clear()
                self._sync()
                t0 = time.perf_counter()
                fn()
                self._sync()
                total = time.perf_counter() - t0
                ins = [t for kind, t in marks if kind == "in"]
                outs = [t for kind, t in marks if kind == "out"]
                inside = sum(b - a for a, b in zip(ins, outs, strict=True))
                before = (ins[0] - t0) if ins else total
                splits.append((before, inside, total - before - inside))
        finally:
            for h in handles:
                h.remove()
        return {
            name: statistics.median(s[i] for s in splits) * 1000
            for i, name in enumerate(("before_ms", "model_ms", "after_ms"))
        }


# ---- inputs of the processors' shapes -------------------------------------------------------------------


def forward_inputs(torch: Any, model: Any, processor: Any, batch: int, device: str, dtype: Any) -> dict:
    """Model inputs for `batch` images, with the shapes the processor would give for a 640x480 frame."""
    gen = torch.Generator(device="cpu").manual_seed(0)
    family = model.config.model_type
    if family == "owlv2":
        side = model.config.vision_config.image_size
        enc = processor.tokenizer(LABELS * batch, padding="max_length", truncation=True, return_tensors="pt")
        return {
            "input_ids": enc["input_ids"].to(device),
            "attention_mask": enc["attention_mask"].to(device),
            "pixel_values": torch.randn(batch, 3, side, side, generator=gen).to(device, dtype),
        }
    if family == "grounding-dino":
        size = processor.image_processor.size
        short, long_ = _edge(size, "shortest_edge", 800), _edge(size, "longest_edge", 1333)
        h, w = FRAME_HW
        scale = min(short / min(h, w), long_ / max(h, w))
        ph, pw = int(round(h * scale)), int(round(w * scale))
        text = ". ".join(LABELS) + "."
        enc = processor.tokenizer([text] * batch, padding="longest", return_tensors="pt")
        out = {k: v.to(device) for k, v in enc.items()}
        out["pixel_values"] = torch.randn(batch, 3, ph, pw, generator=gen).to(device, dtype)
        out["pixel_mask"] = torch.ones(batch, ph, pw, dtype=torch.long, device=device)
        return out
    if family == "blip-2":
        import numpy as np

        side = model.config.vision_config.image_size
        # about as many tokens as "Question: what is this? Answer:" has in OPT's real BPE vocabulary
        enc = processor(
            images=[np.zeros((side, side, 3), np.uint8)], text=["what is it?"], return_tensors="pt"
        )
        return {
            "input_ids": enc["input_ids"].repeat(batch, 1).to(device),
            "attention_mask": enc["attention_mask"].repeat(batch, 1).to(device),
            "pixel_values": torch.randn(batch, 3, side, side, generator=gen).to(device, dtype),
        }
    raise ValueError(f"no inputs for {family}")


def _edge(size: Any, key: str, default: int) -> int:
    try:
        return int(size[key])
    except (KeyError, TypeError):
        return int(getattr(size, key, None) or default)


def _frames(n: int, seed: int = 0) -> list:
    import numpy as np

    from attribot.frame import Frame

    rng = np.random.default_rng(seed)
    return [Frame(rgb=rng.integers(0, 256, (*FRAME_HW, 3), dtype=np.uint8)) for _ in range(n)]


# ---- GPU mode (and its CPU check) -----------------------------------------------------------------------


def run_sizes(args: argparse.Namespace) -> list[dict]:
    torch, transformers = _imports()
    from fakes.hf_random import build_random

    device = args.device
    if device.startswith("cuda") and not torch.cuda.is_available():
        _fail("--device cuda but torch sees no CUDA GPU: install a CUDA build of torch, or use --tiny (CPU)")
    gpu = torch.cuda.get_device_name(0) if device.startswith("cuda") else "cpu"
    print(f"# torch {torch.__version__}, transformers {transformers.__version__}, device {device} ({gpu})")
    dtypes = args.dtypes or (["float16", "bfloat16"] if device.startswith("cuda") else ["float32"])
    timer = Timer(torch, device, args.warmup, args.iters)
    rows: list[dict] = []
    names = args.models or REAL
    for name in names:
        if name not in REAL:
            _fail(f"unknown model {name!r}: choose from {', '.join(REAL)}")
        build_name = TINY[name] if args.tiny else name
        for dtype_name in dtypes:
            dtype = getattr(torch, dtype_name)
            try:
                t0 = time.perf_counter()
                model, processor = build_random(build_name, device=device, dtype=dtype_name)
                n_params = sum(p.numel() for p in model.parameters())
                print(
                    f"{name} ({build_name}) {dtype_name}: built {n_params / 1e6:.0f} M parameters in "
                    f"{time.perf_counter() - t0:.1f} s"
                )
            except Exception as exc:  # noqa: BLE001 - one model that cannot be built must not stop the rest
                print(f"{name} {dtype_name}: skipped, cannot build: {exc.__class__.__name__}: {exc}")
                continue
            if args.compile:
                # the same module, compiled: graphs per batch shape are built during the warm-up calls
                model = torch.compile(model, dynamic=False)
            if not args.no_backend:
                print(
                    f"{name}: image processor {type(processor.image_processor).__name__}, "
                    f"on the GPU: {_gpu_preprocessing(processor, device)}"
                )
            base: dict[str, float] = {}
            for part in ("forward", "backend"):
                if part == "backend" and args.no_backend:
                    continue
                for batch in args.batches:
                    row = {
                        "model": name,
                        "built": build_name,
                        "dtype": dtype_name,
                        "part": part,
                        "batch": batch,
                        "compiled": bool(args.compile),
                    }
                    try:
                        sec, split = _measure(torch, timer, part, model, processor, batch, device, dtype)
                    except Exception as exc:  # noqa: BLE001 - report and go on (OOM, missing processor deps)
                        if device.startswith("cuda"):
                            torch.cuda.empty_cache()
                        reason = (
                            f"{exc.__class__.__name__}: {str(exc).splitlines()[0][:200] if str(exc) else ''}"
                        )
                        print(f"{name} {dtype_name} {part:8s} batch {batch:3d}: skipped ({reason})")
                        if args.verbose:
                            traceback.print_exc()
                        rows.append(row | {"skipped": reason})
                        continue
                    per_image = sec * 1000 / batch
                    if batch == min(args.batches):
                        base[part] = per_image  # the reference of this run: the smallest batch
                    row |= {
                        "ms_per_batch": sec * 1000,
                        "ms_per_image": per_image,
                        "images_per_s": batch / sec,
                        "vs_anchor": per_image / ANCHORS_MS[name],
                        "vs_own_batch1": per_image / base[part] if part in base else None,
                        "ref_batch": min(args.batches),
                        **split,
                    }
                    rows.append(row)
                    print(_line(row, args.tiny))
            del model, processor
            if device.startswith("cuda"):
                torch.cuda.empty_cache()
    return rows


def _gpu_preprocessing(processor: Any, device: str) -> str:
    if "Blip" in type(processor).__name__:
        return "no (CPU: the VQA backend calls the processor as a whole)"
    try:
        from attribot.models.hf import _device_preprocessing
    except ImportError as exc:
        return f"unknown ({exc})"
    return "yes" if _device_preprocessing(processor.image_processor, device) else "no (CPU)"


def _measure(
    torch: Any, timer: Timer, part: str, model: Any, processor: Any, batch: int, device: str, dtype: Any
) -> tuple[float, dict[str, float]]:
    """Median seconds of one call, and for the backend its split (PhaseSplit: ms per batch)."""
    if part == "forward":
        inputs = forward_inputs(torch, model, processor, batch, device, dtype)

        def forward() -> None:
            with torch.inference_mode():
                model(**inputs)

        return timer(forward), {}
    from attribot.models.hf import HFDetector, HFVisualQA  # needs attribot's core dependencies

    frames = _frames(batch)
    if model.config.model_type == "blip-2":
        vqa = HFVisualQA.from_loaded(model, processor, max_new_tokens=5, max_batch=batch)
        questions = ["what is this object?"] * batch

        def call() -> Any:
            return vqa.answer_batch(frames, questions)
    else:
        det = HFDetector.from_loaded(model, processor, threshold=0.1, max_batch=batch)
        queries = [LABELS] * batch

        def call() -> Any:
            return det.detect_batch(frames, queries)

    return timer(call), PhaseSplit(torch, model, device)(call)


def _line(row: dict, tiny: bool) -> str:
    text = (
        f"{row['model']}{' compiled' if row['compiled'] else ''} {row['dtype']} "
        f"{row['part']:8s} batch {row['batch']:3d}: "
        f"{row['ms_per_batch']:9.1f} ms/batch "
        f"{row['ms_per_image']:8.2f} ms/image {row['images_per_s']:8.1f} img/s"
    )
    if row["vs_own_batch1"] is not None:
        text += f"  vs own batch {row['ref_batch']} {row['vs_own_batch1']:.2f}"
    if "model_ms" in row:
        text += (
            f"  [before the model {row['before_ms']:.1f} + model {row['model_ms']:.1f} + after "
            f"{row['after_ms']:.1f} ms/batch]"
        )
    if not tiny:
        text += f"  vs anchor {ANCHORS_MS[row['model']]:.0f} ms {row['vs_anchor']:.2f}"
        if row["part"] == "forward" and row["batch"] >= 32:
            verdict = "met" if row["vs_anchor"] <= TARGET_FRACTION else "NOT met"
            text += f" (target <= {TARGET_FRACTION:.2f}: {verdict})"
    return text


# ---- CPU mode: batched against one-by-one through the backends ------------------------------------------


def run_cpu_batching(args: argparse.Namespace) -> list[dict]:
    torch, transformers = _imports()
    from attribot.models.hf import HFDetector, HFVisualQA
    from fakes.hf_random import save_random

    print(
        f"# torch {torch.__version__}, transformers {transformers.__version__}, cpu, "
        f"{torch.get_num_threads()} threads"
    )
    n = args.cpu_batch
    frames = _frames(n)
    rows: list[dict] = []
    timer = Timer(torch, "cpu", args.warmup, args.iters)
    with tempfile.TemporaryDirectory(prefix="attribot-bench-") as tmp:
        for name in ("owlv2-tiny", "grounding-dino-tiny", "blip2-tiny"):
            folder = save_random(name, Path(tmp) / name)
            one, many = _one_vs_batched(HFDetector, HFVisualQA, str(folder), frames, timer)
            row = {
                "model": name,
                "images": n,
                "one_by_one_ms_per_image": one * 1000 / n,
                "batched_ms_per_image": many * 1000 / n,
                "batched_vs_one_by_one": many / one,
            }
            rows.append(row)
            print(
                f"{name}: {n} frames 640x480, one by one {row['one_by_one_ms_per_image']:.2f} ms/image, "
                f"batched {row['batched_ms_per_image']:.2f} ms/image, "
                f"batched/one-by-one {row['batched_vs_one_by_one']:.2f}"
            )
    return rows


def _one_vs_batched(
    detector_cls: Any, vqa_cls: Any, folder: str, frames: list, timer: Timer
) -> tuple[float, float]:
    """Seconds for the frames one call each, and in one batched call, through the backend."""
    n = len(frames)
    if "blip2" in Path(folder).name:
        vqa = vqa_cls(folder, device="cpu", max_new_tokens=5, max_batch=n)
        questions = ["what is this object?"] * n
        one = timer(lambda: [vqa.answer(f, q) for f, q in zip(frames, questions, strict=True)])
        return one, timer(lambda: vqa.answer_batch(frames, questions))
    det = detector_cls(folder, device="cpu", max_batch=n)
    queries = [LABELS] * n
    one = timer(lambda: [det.detect(f, q) for f, q in zip(frames, queries, strict=True)])
    return one, timer(lambda: det.detect_batch(frames, queries))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: cuda when available)")
    parser.add_argument("--real-size", action="store_true", help="the real architectures (needs a GPU)")
    parser.add_argument(
        "--tiny", action="store_true", help="the --real-size code path with tiny models (CPU check)"
    )
    parser.add_argument(
        "--dtypes",
        type=lambda s: s.split(","),
        default=None,
        help="comma list, e.g. float16,bfloat16 (default: those on cuda, float32 on cpu)",
    )
    parser.add_argument("--batches", type=lambda s: [int(b) for b in s.split(",")], default=[1, 8, 32])
    parser.add_argument(
        "--models", type=lambda s: s.split(","), default=None, help=f"subset of {','.join(REAL)}"
    )
    parser.add_argument("--warmup", type=int, default=None)
    parser.add_argument("--iters", type=int, default=None)
    parser.add_argument("--cpu-batch", type=int, default=16, help="frames per batch in the CPU mode")
    parser.add_argument("--no-backend", action="store_true", help="only the model forward rows")
    parser.add_argument("--compile", action="store_true", help="torch.compile the models (slow warm-up)")
    parser.add_argument("--json", type=Path, default=None, help="also write the rows to this file")
    parser.add_argument("--verbose", action="store_true", help="print tracebacks of skipped rows")
    args = parser.parse_args(argv)
    torch, _ = _imports()
    args.device = args.device or ("cuda" if torch.cuda.is_available() else "cpu")
    if args.dtypes:
        for d in args.dtypes:
            if d not in ("float32", "float16", "bfloat16"):
                _fail(f"--dtypes: {d!r} is not float32, float16 or bfloat16")
    if args.real_size or args.tiny:
        if args.real_size and args.tiny:
            _fail("choose --real-size or --tiny, not both")
        if args.real_size and not args.device.startswith("cuda"):
            _fail(
                "--real-size needs --device cuda (real-size models on the CPU would take hours); "
                "use --tiny to check the code path"
            )
        args.warmup = 3 if args.warmup is None else args.warmup
        args.iters = (10 if args.real_size else 2) if args.iters is None else args.iters
        rows = run_sizes(args)
    else:
        args.warmup = 1 if args.warmup is None else args.warmup
        args.iters = 3 if args.iters is None else args.iters
        rows = run_cpu_batching(args)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))
        print(f"# rows written to {args.json}")


if __name__ == "__main__":
    main()
