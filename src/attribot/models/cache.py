"""Detections kept per view: a detector is not asked again what it has already answered about these pixels.

A robot that has not moved sees the same pixels again: the servo looks once more after it centred, a
`find` of another name asks about the image the last one did, looking again asks about the views of the
survey for every name. A detector whose answer depends on nothing but the RGB pixels and the queries says
so (`pixels_only = True`: coco, transformers, the model server); `Perception` wraps it in a
`CachedDetector`, which answers a repeated question from its memory. The key is what the view is, the
pixels themselves (`attribot.frame.pixel_digest`), and the queries: a frame taken after any motion that
shows other pixels is a new view, so a kept answer is never stale, and it is the very answer the
detector gave (the cache is exact). A detector that reads more (the oracle reads the simulator's
segmentation) is asked every time.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence
from typing import Any

from attribot.frame import Frame, pixel_digest
from attribot.models.base import Detection, Detector, detect_many

__all__ = ["CachedDetector", "cacheable"]

_Key = tuple[bytes, tuple[str, ...]]


def cacheable(detector: Detector) -> bool:
    """Whether `detector` says its answer depends on the pixels and the queries alone."""
    return bool(getattr(detector, "pixels_only", False))


class CachedDetector:
    """`inner`'s answers kept per (pixels, queries), the `size` most recent ones (see the module docstring).

    Every other attribute is `inner`'s (its name, vocabulary, `can_find`). `counts()` says how many calls
    were answered from memory, with the inner detector's own counts where it keeps some."""

    def __init__(self, inner: Detector, size: int = 512) -> None:
        self.inner = inner
        self.size = size
        self.calls = 0
        self.hits = 0
        self._kept: OrderedDict[_Key, list[Detection]] = OrderedDict()

    @property
    def name(self) -> str:
        return self.inner.name

    def __getattr__(self, attr: str) -> Any:
        if attr == "inner":  # not set yet (a copy being made): no detector to ask
            raise AttributeError(attr)
        return getattr(self.inner, attr)

    def detect(self, frame: Frame, queries: Sequence[str]) -> list[Detection]:
        return self.detect_batch([frame], [queries])[0]

    def detect_batch(
        self, frames: Sequence[Frame], queries: Sequence[Sequence[str]]
    ) -> list[list[Detection]]:
        """Each frame's detections: the kept answer for its pixels and queries, else the inner detector's
        (the views not kept asked together, in one batch where it has one)."""
        keys = [_key(f, q) for f, q in zip(frames, queries, strict=False)]
        known = [k for k in keys if k is not None]
        if len(frames) != len(queries) or len(known) != len(keys):
            return detect_many(self.inner, frames, queries)  # the inner detector names the mistake
        self.calls += len(known)
        answers: dict[_Key, Any] = {}
        for key in known:
            if key in self._kept:
                self._kept.move_to_end(key)
                answers[key] = self._kept[key]
        new = [i for i, key in enumerate(known) if key not in answers and known.index(key) == i]
        if new:
            asked = detect_many(self.inner, [frames[i] for i in new], [queries[i] for i in new])
            for i, answer in zip(new, asked, strict=True):
                answers[known[i]] = answer
                if isinstance(answer, list):  # what breaks the protocol is passed on, for the caller to name
                    self._kept[known[i]] = list(answer)
            while len(self._kept) > self.size:
                self._kept.popitem(last=False)
        self.hits += len(known) - len(new)
        # a list of its own for each caller: one may sort or cut it
        return [list(a) if isinstance(a, list) else a for a in (answers[key] for key in known)]

    def counts(self) -> dict[str, int]:
        """Detector calls, those answered from memory, and the inner detector's own counts."""
        inner = getattr(self.inner, "counts", None)
        own = {"detector_calls": self.calls, "detector_calls_cached": self.hits}
        return {**own, **(inner() if callable(inner) else {})}


def _key(frame: Frame, queries: Sequence[str]) -> _Key | None:
    """(the pixels' digest, the queries), or None for what is not a frame with queries (the inner detector
    refuses it, uncached)."""
    if not isinstance(frame, Frame):
        return None
    if isinstance(queries, str):
        return pixel_digest(frame.rgb), (queries,)
    if not all(isinstance(q, str) for q in queries):
        return None
    return pixel_digest(frame.rgb), tuple(queries)
