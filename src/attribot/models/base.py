"""What the API knows of perception: three small protocols, one result type, and the backend registries.

A backend spec is `KIND` or `KIND:ARG` (`oracle`, `catalog`, `hf:google/owlv2-base-patch16-ensemble`,
`openai:gpt-4o`, `remote:http://127.0.0.1:8500`). Each role has one registry of builders keyed by KIND;
a builder takes the ARG (or None) and the settings and returns the backend.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, Literal, Protocol, TypeVar, runtime_checkable

from pydantic import BaseModel, ConfigDict, ValidationError, field_validator

from attribot.errors import BackendError, ConfigError
from attribot.frame import Frame
from attribot.registry import Registry

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = [
    "Detection",
    "Detector",
    "VisualQA",
    "LanguageModel",
    "ROLES",
    "DETECTORS",
    "VQAS",
    "LANGUAGE_MODELS",
    "parse_spec",
    "build_backend",
    "UNKNOWN",
    "detect_many",
    "detect_in_views",
    "detect_confirming",
    "off_own_body",
    "OWN_BODY_SHARE",
    "OWN_BODY_MARGIN",
    "answer_many",
    "can_find",
    "findable_categories",
    "BackendStatus",
    "probe_backend",
    "reaches_out",
    "Evidence",
    "INFERRED",
    "GUESSED",
    "SURE_SCORE",
    "evidence_of",
    "NoVQA",
]

UNKNOWN = "unknown"
"""What a VQA or language backend answers when it cannot tell."""

Evidence = Literal["sure box", "faint box", "seen nearer", "elimination", "look-alike"]
"""What a detection rests on: the detector's own box (sure, or fainter than `SURE_SCORE`), the detector's sure
box seen from nearer by a robot that drove there (a faint one is a faint box), or an inference that names an
object the detector never named (by elimination, or for its likeness to one it did name)."""
INFERRED: frozenset[str] = frozenset({"elimination", "look-alike"})
"""The evidence of an inference: an answer resting on it unconfirmed is a guess."""
SURE_SCORE = 0.25
"""A detector's box at least this sure is a sure box; under it, a faint one."""
GUESSED: frozenset[str] = INFERRED | {"faint box"}
"""The evidence an answer calls a guess: an inference, or a box the detector itself was not sure of (in a
room of things it cannot name, a faint box is as often one of them as the object named)."""


class Detection(BaseModel):
    """One detected object: xyxy box in pixels of the frame given (origin top-left), score in [0, 1]."""

    model_config = ConfigDict(frozen=True)

    box: tuple[float, float, float, float]
    score: float
    label: str
    object_id: str | None = None  # the world's id, when the backend knows it (oracle)
    evidence: Evidence | None = None  # None: the detector's own box (`evidence_of` says sure or faint)

    @field_validator("box")
    @classmethod
    def _box_ordered(cls, box: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
        if not all(math.isfinite(v) for v in box) or box[2] < box[0] or box[3] < box[1]:
            raise ValueError(f"box must be finite (x0, y0, x1, y1) with x1 >= x0, y1 >= y0; got {box}")
        return box

    @field_validator("score")
    @classmethod
    def _score_range(cls, score: float) -> float:
        if not 0.0 <= score <= 1.0:
            raise ValueError(f"score must lie in [0, 1]; got {score}")
        return score


def evidence_of(det: Detection) -> str:
    """What `det` rests on (`Evidence`): its own, or the detector's box, sure or faint by its score."""
    if det.evidence is not None:
        return det.evidence
    return "sure box" if det.score >= SURE_SCORE else "faint box"


@runtime_checkable
class Detector(Protocol):
    """Open-vocabulary detection: boxes for the noun phrases in `queries`, best first.

    A closed-set detector says what it can find: `vocabulary` (its class names, for the prompt),
    `can_find(name) -> bool` (whether a name reaches one of its classes: a mug is a cup) and `class_of(name)
    -> str | None` (the one class a name reaches); `can_find` and `findable_categories` below ask any
    detector. One whose answer depends on nothing but the frame's RGB pixels and the queries says so with
    `pixels_only = True`, and is then asked once per view (`attribot.models.cache`)."""

    name: str

    def detect(self, frame: Frame, queries: Sequence[str]) -> list[Detection]: ...


@runtime_checkable
class VisualQA(Protocol):
    """Visual question answering about one frame: a short text answer, `UNKNOWN` when unsure."""

    name: str

    def answer(self, frame: Frame, question: str) -> str: ...


@runtime_checkable
class LanguageModel(Protocol):
    """A text question in, a short text answer out, `UNKNOWN` when unsure."""

    name: str

    def complete(self, question: str) -> str: ...


def detect_many(
    detector: Detector, frames: Sequence[Frame], queries: Sequence[Sequence[str]]
) -> list[list[Detection]]:
    """Batched detection: the backend's own `detect_batch` when it has one, else one call per frame."""
    batch = getattr(detector, "detect_batch", None)
    if batch is not None:
        return batch(frames, queries)
    return [detector.detect(f, q) for f, q in zip(frames, queries, strict=True)]


def detect_confirming(detector: Detector, frame: Frame, queries: Sequence[str]) -> list[Detection]:
    """Detections of `queries` in a frame taken to confirm what another view of the same place found: the
    backend's own `detect_confirming` when it has one (it looks closer only where this frame shows a trace
    of them: coco), else `detect`."""
    own = getattr(detector, "detect_confirming", None)
    return detector.detect(frame, queries) if own is None else own(frame, queries)


OWN_BODY_SHARE = 0.5
"""A box whose pixels are the robot's own body for at least this share is no object (a gripper's orange
fingertips at the image's foot look like a carrot); an object held in the gripper still shows itself."""
OWN_BODY_MARGIN = 0.2
"""The share of a box's width (and height) left out on each side when it is measured for the body."""


def off_own_body(detections: list[Detection], frame: Frame) -> list[Detection]:
    """`detections` less those on the robot's own body (`Frame.own_body`), where the frame shows it."""
    own = frame.own_body
    if own is None or not own.any():
        return detections
    kept = []
    for det in detections:
        # the box's middle: a detector's box runs a few pixels past what it frames
        x0, y0, x1, y1 = det.box
        dx, dy = (x1 - x0) * OWN_BODY_MARGIN, (y1 - y0) * OWN_BODY_MARGIN
        x0, y0, x1, y1 = (int(round(v)) for v in (x0 + dx, y0 + dy, x1 - dx, y1 - dy))
        inside = own[max(y0, 0) : max(y1, y0 + 1), max(x0, 0) : max(x1, x0 + 1)]
        if inside.size == 0 or float(inside.mean()) < OWN_BODY_SHARE:
            kept.append(det)
    return kept


def detect_in_views(
    detector: Detector,
    frame: Frame,
    queries: Sequence[str],
    views: Sequence[tuple[int, int, int, int]],
    threshold: float | None = None,
) -> list[Detection]:
    """Detections in the given views of a frame (xyxy pixel regions, each shown to the detector on its own,
    so a small object in a small view grows to the detector's input size), in the frame's pixels, best
    first: the backend's own `detect_views` when it has one (one network pass per view, no tiling of its
    own), else `detect` on each view's crop. `threshold` asks a backend with `detect_views` for boxes down
    to that score (as far as it keeps them); the others answer at their own threshold."""
    own = getattr(detector, "detect_views", None)
    if own is not None:
        return own(frame, queries, views) if threshold is None else own(frame, queries, views, threshold)
    found: list[Detection] = []
    for view in views:
        for det in detector.detect(frame.crop(view), queries):
            x0, y0, x1, y1 = det.box
            found.append(
                det.model_copy(update={"box": (x0 + view[0], y0 + view[1], x1 + view[0], y1 + view[1])})
            )
    found.sort(key=lambda d: -d.score)
    return found


def answer_many(vqa: VisualQA, frames: Sequence[Frame], questions: Sequence[str]) -> list[str]:
    """Batched VQA: the backend's own `answer_batch` when it has one, else one call per frame."""
    batch = getattr(vqa, "answer_batch", None)
    if batch is not None:
        return batch(frames, questions)
    return [vqa.answer(f, q) for f, q in zip(frames, questions, strict=True)]


def can_find(detector: Detector, name: str) -> bool:
    """Whether `detector` can find objects called `name`: a closed-set detector answers with its own
    `can_find`; an open-vocabulary one (no `can_find`) takes any name."""
    ask = getattr(detector, "can_find", None)
    return True if ask is None else bool(ask(name))


def findable_categories(detector: Detector) -> tuple[str, ...] | None:
    """The categories layouts draw (`attribot.sim.catalog`) that `detector` can find, in catalog order, for a
    scene whose objects it can all name (`SceneConfig.vocabulary`); None for an open-vocabulary detector,
    which finds any. Two categories that reach one class of the detector (a ball and a basketball are both
    a sports ball) could not be told apart by it, so only the first in catalog order is kept; a detector
    that says which class a name reaches (`class_of`) keeps only names that reach one."""
    if getattr(detector, "can_find", None) is None:
        return None
    from attribot.sim.catalog import categories

    class_of = getattr(detector, "class_of", None)
    classes: set[str] = set()
    found: list[str] = []
    for cat in categories():
        if not cat.drawn or not can_find(detector, cat.name):
            continue
        same = cat.name if class_of is None else class_of(cat.name)
        if same is None or same in classes:
            continue
        classes.add(same)
        found.append(cat.name)
    return tuple(found)


Builder = Callable[[str | None, "Settings"], Any]
B = TypeVar("B")

_BACKEND_MODULES = {
    "oracle": "attribot.models.oracle",
    "catalog": "attribot.models.catalog",
    "hf": "attribot.models.hf",
    "coco": "attribot.models.coco",
    "yolov5s": "attribot.models.yolov5",
    "openai": "attribot.models.openai_chat",
    "remote": "attribot.models.remote",
    "none": "attribot.models.base",  # `NoVQA`, below
}
"""The module of each built-in backend kind, whatever its roles: building one imports that module alone."""


DETECTORS: Registry[Builder] = Registry("detector backend", homes=_BACKEND_MODULES)
VQAS: Registry[Builder] = Registry("vqa backend", homes=_BACKEND_MODULES)
LANGUAGE_MODELS: Registry[Builder] = Registry("language backend", homes=_BACKEND_MODULES)

ROLES: dict[str, Registry[Builder]] = {"detector": DETECTORS, "vqa": VQAS, "language": LANGUAGE_MODELS}


def without_oracle_vqa(settings: Settings) -> Settings | None:
    """`settings` asking no oracle VQA (`vqa = "none"`, a backend that refuses every question and names a real
    one) where the detector reads pixels and the VQA is the oracle's; None where nothing changes. A real
    detector's answers rest on no simulator truth: the oracle VQA reads the simulator's object records, so
    with it a real detector's run would still answer colour and state questions from the simulator."""
    if parse_spec(str(settings.detector))[0] == "oracle" or parse_spec(str(settings.vqa))[0] != "oracle":
        return None
    return settings.model_copy(update={"vqa": "none"})


def parse_spec(spec: str) -> tuple[str, str | None]:
    """`"hf:owlv2"` -> `("hf", "owlv2")`; `"oracle"` -> `("oracle", None)`; `"oracle?miss=0.1"` ->
    `("oracle", "?miss=0.1")` (the builder reads its options). Empty parts are errors."""
    text = spec.strip()
    kind, sep, arg = text.partition(":")
    if not sep and "?" in kind:  # "oracle?miss=0.1": options with no argument go to the builder as "?..."
        kind, _, query = kind.partition("?")
        sep, arg = "?", "?" + query
    if not kind or (sep and not arg.strip()):
        raise ConfigError(f"backend spec {spec!r} is malformed", "write KIND or KIND:ARG, e.g. hf:MODEL_ID")
    return kind.strip(), (arg.strip() if sep else None)


def build_backend(role: str, spec: str, settings: Settings) -> Any:
    """The backend for `role` built from `spec`; unknown roles or kinds raise with the known ones."""
    if role not in ROLES:
        raise ConfigError(f"unknown backend role {role!r}", f"choose one of: {', '.join(ROLES)}")
    kind, arg = parse_spec(spec)
    builder = ROLES[role].get(kind)
    backend = builder(arg, settings)
    if role == "detector" and not str(getattr(builder, "__module__", "")).startswith("attribot."):
        return _CheckedDetector(backend, kind)  # a plug-in's: what it returns is checked as it returns
    return backend


class _CheckedDetector:
    """A plug-in's detector whose every detection is checked as it returns (a label that is not text, a box
    out of order): a `BackendError` naming the detector and the field, not a failure far downstream."""

    def __init__(self, inner: Any, kind: str) -> None:
        self._inner = inner
        self._kind = kind

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)

    def detect(self, frame: Any, queries: Sequence[str]) -> list[Detection]:
        out = self._inner.detect(frame, queries)
        if not isinstance(out, (list, tuple)):
            raise BackendError(
                f"the detector {self._kind!r} returned {type(out).__name__}, not a list of detections",
                "make its detect() return a list of attribot.models.base.Detection",
            )
        checked = []
        for det in out:
            fields = det.model_dump(warnings=False) if isinstance(det, BaseModel) else det
            try:
                checked.append(Detection.model_validate(fields))
            except ValidationError as exc:
                first = exc.errors()[0]
                where = ".".join(str(p) for p in first.get("loc", ())) or "detection"
                raise BackendError(
                    f"the detector {self._kind!r} returned a detection whose {where} is "
                    f"{repr(first.get('input'))[:60]}: {first.get('msg', 'invalid')}",
                    "make its detect() return Detection(box=(x0, y0, x1, y1), score, label: text)",
                ) from None
        return checked


def reaches_out(role: str, spec: str) -> bool:
    """Whether the backend of `spec` for `role` reaches a place beyond this process's own data: an endpoint
    (remote:URL, openai: through llm_base_url), a model to load (hf:ID or PATH), a folder of files
    (coco:FOLDER). A builder says it with a `reaches_out(arg) -> bool` attribute; one that says nothing (a
    plug-in's kind) reaches out. What reaches out is chosen only by the user's own settings, never by a
    saved run (`attribot.session.replay`)."""
    if role not in ROLES:
        raise ConfigError(f"unknown backend role {role!r}", f"choose one of: {', '.join(ROLES)}")
    kind, arg = parse_spec(spec)
    says = getattr(ROLES[role].get(kind), "reaches_out", None)
    return True if says is None else bool(says(arg))


class BackendStatus(BaseModel):
    """Whether a configured backend can be used here: what `attribot backends` prints.

    `available` is None where the kind has no check (it runs in-process, or its module gives no probe).
    """

    role: str
    spec: str
    kind: str | None
    arg: str | None
    registered: bool
    available: bool | None
    detail: str


def probe_backend(role: str, spec: str, settings: Settings) -> BackendStatus:
    """Check `spec` for `role` without building it.

    A builder may carry a `probe` attribute, `probe(arg, settings) -> (available, detail)`, that checks
    cheaply (extra installed, model folder present, endpoint answering within a short time-out) and
    never raises; kinds without one are reported as registered with no check.
    """
    if role not in ROLES:
        raise ConfigError(f"unknown backend role {role!r}", f"choose one of: {', '.join(ROLES)}")
    try:
        kind, arg = parse_spec(spec)
    except ConfigError as exc:
        return BackendStatus(
            role=role, spec=spec, kind=None, arg=None, registered=False, available=False, detail=str(exc)
        )
    registry = ROLES[role]
    if kind not in registry:
        known = ", ".join(registry.names()) or "none"
        return BackendStatus(
            role=role,
            spec=spec,
            kind=kind,
            arg=arg,
            registered=False,
            available=False,
            detail=f"no {role} backend of kind {kind!r}; choose one of: {known}",
        )
    probe = getattr(registry.get(kind), "probe", None)
    if probe is None:
        return BackendStatus(
            role=role,
            spec=spec,
            kind=kind,
            arg=arg,
            registered=True,
            available=None,
            detail="registered; this kind defines no availability check",
        )
    try:
        available, detail = probe(arg, settings)
    except Exception as exc:  # noqa: BLE001 - a probe must not take the whole listing down
        available, detail = False, f"check failed: {exc.__class__.__name__}: {exc}"
    return BackendStatus(
        role=role, spec=spec, kind=kind, arg=arg, registered=True, available=available, detail=detail
    )


class NoVQA:
    """`--vqa none`: no visual question answering. A program that asks a question gets an error naming a
    real backend. An evaluation with a real detector uses it unless given another, so that no answer of a
    real-eyes run rests on the simulator's truth (the oracle VQA reads it)."""

    name = "none"

    def answer(self, frame: Frame, question: str) -> str:
        from attribot.errors import BackendError

        raise BackendError(
            f"no VQA backend to answer {question[:80]!r} (this run uses --vqa none)",
            "give a real one (--vqa hf:MODEL, openai:MODEL or remote:URL), or write the program without "
            "visual_query",
        )


VQAS.register("none")(lambda arg, settings: NoVQA())
