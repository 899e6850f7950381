"""The perception bundle an `ImagePatch` uses: a detector, a VQA model and a language model."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from attribot.errors import ConfigError
from attribot.lexicon import surface_kind
from attribot.models.base import Detector, LanguageModel, VisualQA, build_backend
from attribot.models.cache import CachedDetector, cacheable
from attribot.text import shown_url

if TYPE_CHECKING:
    from attribot.config import Settings
    from attribot.frame import Frame

__all__ = ["Perception"]


@dataclass(frozen=True)
class Perception:
    """The three backends behind `find`/`exists`, `visual_query` and `language_query`.

    A detector whose answer depends on the pixels alone is kept behind a `CachedDetector`, so that every
    caller (find, looking again, the servo, the checks after a grasp) is answered from memory about a view
    the detector has already seen."""

    detector: Detector
    vqa: VisualQA
    language: LanguageModel

    def __post_init__(self) -> None:
        for role, proto, method in (
            ("detector", Detector, "detect"),
            ("vqa", VisualQA, "answer"),
            ("language", LanguageModel, "complete"),
        ):
            backend = getattr(self, role)
            if not isinstance(backend, proto):
                raise ConfigError(
                    f"the {role} backend {type(backend).__name__} does not follow the "
                    f"{proto.__name__} protocol",
                    f"give an object with a `name` and a `{method}` method (see attribot.models.base)",
                )
        if cacheable(self.detector) and not isinstance(self.detector, CachedDetector):
            object.__setattr__(self, "detector", CachedDetector(self.detector))

    @classmethod
    def from_settings(cls, settings: Settings) -> Perception:
        """Build each role from its spec in the settings (`detector`, `vqa`, `language`)."""
        return cls(
            detector=build_backend("detector", settings.detector, settings),
            vqa=build_backend("vqa", settings.vqa, settings),
            language=build_backend("language", settings.language, settings),
        )

    def counts(self) -> dict[str, int]:
        """What the detector did for this bundle: calls, those answered from memory, and the backend's own
        counts (views run through a network); empty for a detector that keeps none."""
        counts = getattr(self.detector, "counts", None)
        return dict(counts()) if callable(counts) else {}

    def names(self) -> dict[str, str]:
        """Backend name per role, as answers and traces report them."""
        names = {"detector": self.detector.name, "vqa": self.vqa.name, "language": self.language.name}
        return {role: shown_url(name) for role, name in names.items()}  # no password in a URL shown

    def findable(self, frame: Frame) -> str:
        """What `image.find` can find in `frame`, in words for the prompt: the detector's closed vocabulary
        (a `vocabulary` attribute) or any short name, and, for a detector that reads the simulator's
        segmentation (the oracle), the furniture and floor in view. A detector that reads pixels only is
        told nothing of the segmentation: a real robot's planner has no such list."""
        vocabulary = getattr(self.detector, "vocabulary", None)
        if vocabulary:
            things = f"only these {len(vocabulary)} names: {', '.join(vocabulary)}"
        else:
            things = 'objects by a short name ("cup", "ball", "apple")'
        if getattr(self.detector, "pixels_only", False):
            return things
        if frame.surfaces is not None and frame.surface_names:
            seen = {int(i) for i in np.unique(frame.surfaces)}
            kinds = sorted({surface_kind(n) for i, n in enumerate(frame.surface_names) if i in seen})
            if kinds:
                things += f"; the furniture and the floor in view: {', '.join(kinds)}"
        return things
