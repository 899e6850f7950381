"""Seeded perception noise for the oracle backends: the errors a real detector and VQA model make.

The offline oracle sees perfectly, which hides the error propagation that the paper names as its main
limitation. These wrappers add it, as spec options of the `oracle` backends:

    oracle?miss=0.1&false_pos=0.05&jitter_px=4&confuse=0.05      (detector)
    oracle?miss_view=0.1&confuse_view=0.05&jitter_rel=0.04       (detector, errors that persist)
    oracle?wrong=0.1                                             (VQA)
    oracle?noise=realistic                                       (either: a preset of attribot.noise)

Per frame:
- miss: the chance that a true detection is dropped;
- false_pos: the chance, per query, of one spurious box somewhere in the image with the query's label;
- jitter_px: the standard deviation of Gaussian noise on each box edge, pixels;
- jitter_rel: the same, as a fraction of the box's width and height (a real detector's error scales);
- confuse: the chance that a detection is another visible object's box (a category confusion);
- wrong: the chance that a VQA answer is replaced by a plausible wrong one (another visible object's name,
  another colour, the other of yes/no).
From a viewpoint (the same in every frame taken from about the same place, looking about the same way):
- miss_view: the chance that an object is missed from a viewpoint, in every frame taken from it;
- confuse_view: the chance that, from a viewpoint, an object is taken for a given other one, every time.
A viewpoint is the object's cell in a 3x3 grid of the image and its distance in half-metre bands (from the
frame's depth): turning the head by a third of the view or moving by half a metre gives a new one.

Per-frame draws come from a generator seeded with the spec's `seed` (default 0) and a digest of the frame's
pixels and the query; viewpoint draws from the seed, the object and the viewpoint. The same scene, query
and seed give the same errors on every rerun, on any machine, and different scenes get independent
errors. The backend's name carries its options, so answers and records say which noise produced them.
"""

from __future__ import annotations

import hashlib
import urllib.parse
from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np

from attribot.errors import ConfigError
from attribot.frame import Frame
from attribot.lexicon import COLOR_WORDS
from attribot.models.base import Detection
from attribot.noise import PerceptionNoise, preset

__all__ = ["DetectorNoise", "VQANoise", "NoisyDetector", "NoisyVQA", "split_options"]


@dataclass(frozen=True)
class DetectorNoise:
    miss: float = 0.0
    false_pos: float = 0.0
    jitter_px: float = 0.0
    jitter_rel: float = 0.0
    confuse: float = 0.0
    miss_view: float = 0.0
    confuse_view: float = 0.0
    seed: int = 0

    @property
    def clean(self) -> bool:
        return not any(getattr(self, f.name) for f in fields(self) if f.name != "seed")


@dataclass(frozen=True)
class VQANoise:
    wrong: float = 0.0
    seed: int = 0

    @property
    def clean(self) -> bool:
        return not self.wrong


def split_options(arg: str | None) -> tuple[str | None, dict[str, str]]:
    """`"30?miss=0.1"` -> `("30", {"miss": "0.1"})`; `"?noise=realistic"` -> `(None, {...})`."""
    if arg is None or "?" not in arg:
        return arg, {}
    head, _, query = arg.partition("?")
    try:
        pairs = urllib.parse.parse_qsl(query, keep_blank_values=True, strict_parsing=True)
    except ValueError:
        raise ConfigError(
            f"backend options {query!r} are malformed", "write KEY=VALUE pairs joined by &, e.g. ?miss=0.1"
        ) from None
    return (head or None), dict(pairs)


def noise_options(
    options: dict[str, str],
    kind: type[DetectorNoise] | type[VQANoise],
    role: str,
    base: PerceptionNoise | None = None,
) -> dict:
    """The noise fields of `kind`: those of `base` (the settings' typed noise: a preset and its seed), then
    the spec's options (a preset first, then the explicit values)."""
    known = {f.name for f in fields(kind)}
    values: dict[str, float] = {} if base is None else dict(base.options(known))
    named = options.get("noise")
    if named is not None:
        values.update(preset(named, among=known))
    for key, raw in options.items():
        if key == "noise":
            continue
        if key not in known:
            raise ConfigError(
                f"the oracle {role} has no option {key!r}",
                f"its options are: noise, {', '.join(sorted(known))}",
            )
        try:
            values[key] = int(raw) if key == "seed" else float(raw)
        except ValueError:
            raise ConfigError(f"oracle option {key}={raw!r} is not a number", f"e.g. {key}=0.1") from None
    for key, value in values.items():
        bad = value < 0 or (key not in ("jitter_px", "seed") and value > 1) or value != value
        if bad:
            raise ConfigError(
                f"oracle option {key}={value} is out of range",
                "give a probability from 0 to 1 (jitter_px: pixels >= 0; seed: a whole number >= 0)",
            )
    return values


def _rng(noise_seed: int, frame: Frame, text: str) -> np.random.Generator:
    digest = hashlib.blake2b(digest_size=16)
    digest.update(np.ascontiguousarray(frame.rgb).data)
    digest.update(text.encode("utf-8", "surrogatepass"))
    return np.random.default_rng([noise_seed, *np.frombuffer(digest.digest(), np.uint32).tolist()])


def _spec_suffix(noise: DetectorNoise | VQANoise) -> str:
    parts = [f"{f.name}={getattr(noise, f.name):g}" for f in fields(noise) if getattr(noise, f.name)]
    return "?" + "&".join(parts) if parts else ""


class NoisyDetector:
    """A detector with seeded misses, false positives, jitter and confusions (see the module docstring)."""

    def __init__(self, inner: object, noise: DetectorNoise) -> None:
        self.inner = inner
        self.noise = noise
        self.name = f"{getattr(inner, 'name', 'detector')}{_spec_suffix(noise)}"

    def detect(self, frame: Frame, queries: Sequence[str]) -> list[Detection]:
        clean: list[Detection] = self.inner.detect(frame, queries)  # type: ignore[attr-defined]
        n = self.noise
        rng = _rng(n.seed, frame, "\x1f".join(queries if not isinstance(queries, str) else [queries]))
        everything: list[Detection] = []
        if n.confuse or n.confuse_view:
            everything = self.inner.detect(frame, ["object"])  # type: ignore[attr-defined]
        out: list[Detection] = []
        for det in clean:
            view = _viewpoint(det, frame) if (n.miss_view or n.confuse_view) else None
            if rng.random() < n.miss or (
                view is not None and _view_rng(n.seed, det, view, 1).random() < n.miss_view
            ):
                continue
            others = [d for d in everything if d.object_id != det.object_id]
            if others and view is not None and n.confuse_view:
                from_here = _view_rng(n.seed, det, view, 2)
                if from_here.random() < n.confuse_view:  # the same other object, every time from here
                    ranked = sorted(others, key=lambda d: str(d.object_id))
                    det = _as(det, ranked[int(from_here.integers(len(ranked)))])
            elif others and rng.random() < n.confuse:
                det = _as(det, others[int(rng.integers(len(others)))])
            out.append(self._jitter(det, frame, rng))
        phrases = [queries] if isinstance(queries, str) else list(queries)
        for query in phrases:
            if rng.random() < n.false_pos:
                out.append(self._spurious(query, frame, rng))
        return sorted(out, key=lambda d: -d.score)

    def _jitter(self, det: Detection, frame: Frame, rng: np.random.Generator) -> Detection:
        if not (self.noise.jitter_px or self.noise.jitter_rel):
            return det
        w, h = frame.width, frame.height
        bw, bh = det.box[2] - det.box[0], det.box[3] - det.box[1]
        scale = np.hypot(self.noise.jitter_px, self.noise.jitter_rel * np.array([bw, bh, bw, bh]))
        x0, y0, x1, y1 = (np.asarray(det.box) + rng.normal(0.0, 1.0, 4) * scale).tolist()
        x0, x1 = sorted((min(max(x0, 0.0), w - 1.0), min(max(x1, 0.0), w - 1.0)))
        y0, y1 = sorted((min(max(y0, 0.0), h - 1.0), min(max(y1, 0.0), h - 1.0)))
        box = (x0, y0, max(x1, x0 + 1.0), max(y1, y0 + 1.0))  # at least a pixel each way
        return Detection(box=box, score=det.score, label=det.label, object_id=det.object_id)

    @staticmethod
    def _spurious(query: str, frame: Frame, rng: np.random.Generator) -> Detection:
        w, h = frame.width, frame.height
        bw, bh = rng.uniform(0.05, 0.25) * w, rng.uniform(0.05, 0.25) * h
        x0, y0 = rng.uniform(0, w - bw), rng.uniform(0, h - bh)
        score = float(rng.uniform(0.1, 0.5))  # a real detector is often less sure of what is not there
        return Detection(box=(x0, y0, x0 + bw, y0 + bh), score=score, label=query.strip(), object_id=None)


def _as(det: Detection, other: Detection) -> Detection:
    """`det` confused with `other`: the other object's box under this detection's label and score."""
    return Detection(box=other.box, score=det.score, label=det.label, object_id=other.object_id)


def _viewpoint(det: Detection, frame: Frame) -> tuple[int, int, int]:
    """Where the object is seen from: its cell in a 3x3 grid of the image, and its distance in half-metre
    bands (the median depth in the box's middle; 0 without depth)."""
    x0, y0, x1, y1 = det.box
    cx, cy = (x0 + x1) / 2.0, (y0 + y1) / 2.0
    col = min(int(3 * cx / max(frame.width, 1)), 2)
    row = min(int(3 * cy / max(frame.height, 1)), 2)
    band = 0
    if frame.depth is not None:
        qx, qy = (x1 - x0) / 4.0, (y1 - y0) / 4.0
        patch = frame.depth[int(y0 + qy) : int(y1 - qy) + 1, int(x0 + qx) : int(x1 - qx) + 1]
        finite = patch[np.isfinite(patch)] if patch.size else patch
        if finite.size:
            band = int(float(np.median(finite)) / 0.5)
    return row, col, band


def _view_rng(seed: int, det: Detection, view: tuple[int, int, int], stream: int) -> np.random.Generator:
    """A generator for one object seen from one viewpoint: the same draws every time it is seen from there."""
    key = (det.object_id or f"{det.box[0]:.0f},{det.box[1]:.0f}").encode("utf-8", "surrogatepass")
    digest = np.frombuffer(hashlib.blake2b(key, digest_size=8).digest(), np.uint32).tolist()
    return np.random.default_rng([seed, stream, *view, *digest])


class NoisyVQA:
    """A VQA model whose answers are wrong with a seeded chance (see the module docstring)."""

    def __init__(self, inner: object, noise: VQANoise) -> None:
        self.inner = inner
        self.noise = noise
        self.name = f"{getattr(inner, 'name', 'vqa')}{_spec_suffix(noise)}"

    def answer(self, frame: Frame, question: str) -> str:
        truth: str = self.inner.answer(frame, question)  # type: ignore[attr-defined]
        rng = _rng(self.noise.seed, frame, question)
        if rng.random() >= self.noise.wrong:
            return truth
        return self._wrong(truth, frame, rng)

    def _wrong(self, truth: str, frame: Frame, rng: np.random.Generator) -> str:
        text = truth.strip().lower()
        if text in ("yes", "no"):
            return "no" if text == "yes" else "yes"
        if text in COLOR_WORDS:
            return str(rng.choice(sorted(COLOR_WORDS - {text})))
        names = sorted({o.category for o in frame.objects.values()} - {text})
        if names:
            return str(rng.choice(names))
        return "unknown"
