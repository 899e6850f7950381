"""The paper's methods (its table's rows), each run on one dataset item with any planner and backends.

- `ovd`: the detector given the whole query; its highest-scoring box (the paper's OVD row).
- `vqa`: the VQA model asked the query; its answer grounded with the detector.
- `vqa+llm`: `visual_query("What are the items in this image?")`, then `language_query` to choose among
  them, then the detector for the box (the paper's VQA + GPT rows).
- `vlm`: an end-to-end vision-chat model shown the image and the query, answering with a box (the paper's
  GPT-4o row). It needs a real backend (`--vqa openai:MODEL`); without one it is recorded as not run.
- `attr-api`: a program over ImagePatch only (camera alone, no robot actions): the attribute API.
- `pa-api`: a program over the whole perception-action API with the item's sensors.

Each is a `Method` record registered in `attribot.eval.suite.METHODS` at the bottom of this module.
`run_method` returns one `Record`: the box and object chosen, whether it is right (box IoU >= 0.5 with the
true object, and the same object id where the world gives ids), the program and trace, measured values,
the error and its category (planner, runner, perception, action, uncertain: for a program, the kind of
the API call that failed as its trace records it), and wall seconds.
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel, FiniteFloat, field_validator, model_validator

from attribot.boxes import iou
from attribot.config import Settings
from attribot.errors import InputError
from attribot.eval.datasets import Box, Item, Name, TrueBox
from attribot.eval.suite import METHODS, TASKS, Method, register_method
from attribot.mechanisms import MECHANISMS, Mechanism
from attribot.noise import NOISE_PRESETS, PerceptionNoise, WorldNoise, world_noise
from attribot.priors import SCALE_RANGE as PRIORS_SCALE
from attribot.skills.safeguards import CheckEvent
from attribot.text import shown_url

__all__ = [
    "Record",
    "run_method",
    "Condition",
    "PROGRAM_METHODS",
    "ablations",
    "paper_methods",
]

NOISE_LEVELS = tuple(NOISE_PRESETS)
_WITHOUT = "-no-"
_PRIORS = "-priors"
_PRIORS_AT_END = re.compile(r"-priors([0-9]+(?:\.[0-9]+)?)$")


@dataclass(frozen=True)
class Condition:
    """A run condition: a noise preset (`attribot.noise.NOISE_PRESETS`) and, for an ablation, the one
    error-catching mechanism left off, or the mechanisms' perception priors scaled (`attribot.priors`:
    every size, height and span times `priors_scale`). Records and run folders name it `PRESET`,
    `PRESET-no-MECHANISM`, `PRESET-priorsFACTOR` or `PRESET-no-MECHANISM-priorsFACTOR` (`name`: records
    of a perturbed run are kept in files of their own, never mixed with the plain ones), read back with
    `parse`; `settings_for` and `world_noise` give an item's run its typed noise, mechanisms and priors."""

    preset: str
    without: Mechanism | None = None
    priors_scale: float = 1.0

    def __post_init__(self) -> None:
        low, high = PRIORS_SCALE
        if (
            self.preset not in NOISE_LEVELS
            or (self.without is not None and self.without not in MECHANISMS)
            or not (low <= self.priors_scale <= high)
        ):
            raise InputError(
                f"unknown noise level {self.name!r}",
                f"choose from: {', '.join(NOISE_LEVELS)}, or PRESET{_WITHOUT}MECHANISM for an ablation "
                f"(mechanisms: {', '.join(MECHANISMS)}), and/or PRESET{_PRIORS}FACTOR ({low} to {high}) for "
                "scaled perception priors",
            )
        if self.without is not None:  # a mechanism's name given as text is the mechanism
            object.__setattr__(self, "without", Mechanism(self.without))
        object.__setattr__(self, "priors_scale", float(self.priors_scale))

    @classmethod
    def parse(cls, name: str) -> Condition:
        """The condition a record or `--noise` names; an unknown one is an `InputError`."""
        scaled = _PRIORS_AT_END.search(name)
        rest = name[: scaled.start()] if scaled else name
        preset, _, mechanism = rest.partition(_WITHOUT)
        known = mechanism in MECHANISMS
        try:
            condition = cls(
                preset, Mechanism(mechanism) if known else None, float(scaled[1]) if scaled else 1.0
            )
        except InputError:
            condition = None
        if condition is None or condition.name != name:  # "realistic-no-": no mechanism; "-priors1.0"
            raise InputError(
                f"unknown noise level {name!r}",
                f"give PRESET, PRESET{_WITHOUT}MECHANISM (mechanisms: {', '.join(MECHANISMS)}), or either "
                f"with {_PRIORS}FACTOR after it ({PRIORS_SCALE[0]} to {PRIORS_SCALE[1]}, not 1), e.g. "
                f"clean{_PRIORS}0.7",
            )
        return condition

    @property
    def name(self) -> str:
        base = f"{self.preset}{_WITHOUT}{self.without}" if self.without else self.preset
        return f"{base}{_PRIORS}{self.priors_scale:g}" if self.priors_scale != 1.0 else base

    @property
    def mechanisms(self) -> tuple[Mechanism, ...]:
        """The mechanisms on under the condition: all, or all but the one left off."""
        return tuple(m for m in Mechanism if m != self.without)

    @property
    def ablation(self) -> bool:
        """Whether a mechanism is left off or the priors are scaled: the ablation table's columns."""
        return self.without is not None or self.priors_scale != 1.0

    def settings_for(self, settings: Settings, seed: int) -> Settings:
        """`settings` for one item under this condition: its preset's perception noise on the oracle
        backends, drawn from the item's `seed` (a clean preset adds none), its mechanisms (an ablation
        leaves one out) and its priors' scale (a scaled condition's, else the settings' own)."""
        update: dict[str, Any] = {"checks": self.mechanisms} if self.without is not None else {}
        if self.priors_scale != 1.0:
            update["priors_scale"] = self.priors_scale
        if self.preset != "clean":
            update["perception_noise"] = PerceptionNoise(preset=self.preset, seed=seed)
        return settings.model_copy(update=update) if update else settings

    def world_noise(self, seed: int) -> WorldNoise:
        """The world's imperfections of sensing and acting under this condition, drawn from `seed`."""
        return world_noise(self.preset, seed)


CLEAN = Condition("clean")
"""No noise, every mechanism on, the priors as written."""


def ablations(preset: str = "realistic") -> tuple[Condition, ...]:
    """The conditions of the ablation table: `preset` with each mechanism off in turn."""
    return tuple(Condition(preset, m) for m in Mechanism)


class Record(BaseModel):
    """One method's result on one item (see the module docstring).

    status: right | wrong | failed | not run."""

    id: Name
    task: Name
    method: Name
    noise: Name
    query: str
    detector: str | None = None  # the run's detector spec (its noise aside); None in records made before
    prompt: str | None = None  # the prompt the planner showed a model (attribot, paper); None: no model
    form: str = "n/a"  # the item's form: superlative | absolute | comparative | n/a
    status: str
    right: bool
    iou: FiniteFloat | None = None
    box: Box | None = None
    box_from: str | None = None  # what the box is (`AnswerObject.box_from`); None: a record made before
    chosen_id: str | None = None
    true_id: str
    true_box: TrueBox
    answer: str = ""
    value: FiniteFloat | None = None
    unit: str | None = None
    program: str | None = None
    trace: list[dict[str, Any]] = []
    measured: list[dict[str, Any]] = []
    error: str | None = None
    error_category: str | None = None  # planner | runner | perception | action | uncertain (see `_category`)
    checks: list[dict[str, Any]] = []  # what the error-catching mechanisms did (caught, confirmed, unsettled)
    wall_s: FiniteFloat = 0.0
    sim_s: FiniteFloat | None = None  # simulated seconds of the robot's actions (pa-api in a simulator)
    perception: dict[str, int] = {}  # detector calls, those answered from memory, views through a network
    # what the chosen object rests on (`attribot.planning.answer.AnswerObject.evidence`): a sure or faint box,
    # seen nearer, elimination, a look-alike, a measurement
    evidence: list[str] = []
    guess: bool = False  # the answer said its object is a guess (an inference no detector confirmed)
    absent: bool = False  # the query names an object that is not there (the truth: not found)

    @property
    def refused(self) -> bool:
        """No object and no value: the method said it could not answer (not found, unsure, an error)."""
        return self.status == "failed"

    @property
    def confidently_wrong(self) -> bool:
        """Wrong, and not said to be a guess."""
        return self.status == "wrong" and not self.guess

    @property
    def right_refusing_guesses(self) -> bool:
        """Whether it would be right with guesses refused (`Settings.guesses`): a guess turns into no answer,
        which is right only where the object is not there."""
        return self.absent if self.guess else self.right

    @model_validator(mode="before")
    @classmethod
    def _absent_of_old_records(cls, data: Any) -> Any:
        # records written before `absent` was kept: only an absent object's item has no true object
        if isinstance(data, dict) and "absent" not in data and "true_id" in data:
            return {**data, "absent": not data["true_id"] and not data.get("true_box")}
        return data

    @field_validator("checks")
    @classmethod
    def _events(cls, checks: list[dict[str, Any]]) -> list[dict[str, Any]]:
        # each one a mechanism's event, so that the report's tables can read its fields
        return [CheckEvent.model_validate(c).model_dump() for c in checks]


def _record(item: Item, method: str, condition: Condition, **fields: Any) -> Record:
    box = fields.get("box")
    chosen = fields.get("chosen_id")
    overlap = iou(tuple(box), tuple(item.true_box)) if box and item.true_box else None
    right = overlap is not None and overlap >= 0.5 and (chosen is None or chosen == item.true_id)
    if item.absent:  # the truth is "not there": right only where no object was named
        right = not box and chosen is None and fields.get("status") != "not run"
        if right:
            fields.setdefault("status", "right")
    status = fields.pop("status", None) or (
        "right" if right else ("failed" if fields.get("error") else "wrong")
    )
    return Record(
        id=item.id,
        task=item.task,
        method=method,
        noise=condition.name,  # records keep the name the condition is written as
        query=item.query,
        form=item.form,
        status=status,
        right=right,
        iou=overlap,
        true_id=item.true_id,
        true_box=item.true_box,
        absent=bool(item.absent),
        **fields,
    )


_FRAMES: dict[str, Any] = {}
_FRAMES_KEPT = 4


def _world_frame(item: Item) -> Any:
    """The item's first camera frame; the last few are kept, since an item's methods and noise levels
    follow one another and each needs the same frame (building the world is most of their cost)."""
    key = item.model_dump_json()
    if key not in _FRAMES:
        from attribot.embodiments.mujoco import MujocoWorld

        with MujocoWorld(item.scene()) as world:
            _FRAMES[key] = world.observe()
        while len(_FRAMES) > _FRAMES_KEPT:
            _FRAMES.pop(next(iter(_FRAMES)))
    return _FRAMES[key]


def _vlm_configured(settings: Settings) -> bool:
    return str(settings.vqa).startswith("openai:")


def _best(detections: list[Any]) -> Any:
    return max(detections, key=lambda d: d.score) if detections else None


def _grounded(
    item: Item, method: str, condition: Condition, perception: Any, frame: Any, name: str, **extra: Any
) -> Record:
    """The detector's best box for `name` (a model's answer), as the record of `method`."""
    if not name or name.strip().lower() in ("unknown", "none", ""):
        return _record(
            item,
            method,
            condition,
            error=f"the model gave no object ({name!r})",
            error_category="perception",
            **extra,
        )
    best = _best(perception.detector.detect(frame, [name]))
    if best is None:
        return _record(
            item,
            method,
            condition,
            error=f"the detector found no {name!r}",
            error_category="perception",
            **extra,
        )
    return _record(
        item, method, condition, box=list(best.box), chosen_id=best.object_id, **{"answer": name, **extra}
    )


_ANSWER_NAME = re.compile(r"(?:the\s+)?([a-z][a-z ]*?)(?:[.!,]|$)")


def _first_name(text: str) -> str:
    match = _ANSWER_NAME.match(text.strip().lower())
    return match.group(1).strip() if match else ""


def run_method(item: Item, method: str, settings: Settings, condition: Condition = CLEAN) -> Record:
    """Run `method` on `item` with `settings` under `condition` (its noise on the oracle backends and the
    world, its mechanisms and priors); a crash of the method is that item's failure, recorded with its
    category."""
    started = time.perf_counter()
    runner = METHODS.get(method)
    try:
        record = runner.run(item, condition.settings_for(settings, item.seed), condition)
    except Exception as exc:  # noqa: BLE001 (a crash of one item is that item's failure, recorded)
        record = _record(
            item, method, condition, error=f"{type(exc).__name__}: {exc}", error_category="runner"
        )
    record.wall_s = time.perf_counter() - started
    record.detector = shown_url(str(settings.detector))  # a password in its URL is not recorded
    return record


def paper_methods(task: str) -> tuple[str, ...]:
    """The methods the paper compares on `task` (the default of `attribot eval`)."""
    return TASKS.get(task).methods


# ---- programs through the API (attr-api, pa-api) ---------------------------------------------------------


def _category(answer: Any) -> str | None:
    """What failed, from the answer's error and the trace: the planner (no program), a doubt the program
    stated, the kind of the API call that failed (its class says: perception or action), a perception call
    that came back empty just before the program gave up, else the runner."""
    if answer.error is None:
        return None
    if answer.error.category == "planner" or answer.program is None:
        return "planner"
    if answer.error.category == "uncertain":
        return "uncertain"
    failing = next((t for t in reversed(answer.trace) if t.get("error")), None)
    if failing is None:
        # a program that gave up right after a call that came back empty-handed (a find that found
        # nothing) failed for what that call did not perceive, not on its own
        last = answer.trace[-1] if answer.trace else None
        if last is not None and last.get("result") in ([], None) and last.get("kind") == "perception":
            return "perception"
        return "runner"
    return str(failing.get("kind") or "runner")


def _measured(trace: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The robot's measurements in a trace: the call, the object it was of, the value."""
    out = []
    for t in trace:
        if not str(t["call"]).startswith("Robot.measure_") or t.get("error") is not None:
            continue
        first = t["args"][0] if t["args"] else None
        out.append(
            {
                "call": t["call"],
                "object_id": first.get("object_id") if isinstance(first, dict) else None,
                "value": t["result"],
            }
        )
    return out


def _program(item: Item, method: str, settings: Settings, condition: Condition) -> Record:
    """A program over the API written by the planner; attr-api has one image and no robot (looking again
    happens within that image), pa-api the item's sensors and a robot that acts."""
    from attribot.session import Scene, ask

    sensors = item.sensors if method == "pa-api" else ["camera"]
    scene = item.scene().model_copy(update={"noise": condition.world_noise(item.seed)})
    try:
        answer = ask(item.query, Scene(scene, sensors=sensors, still=method == "attr-api"), settings)
    except InputError as exc:  # the planner refused it: what the camera alone cannot settle, say
        return _record(item, method, condition, error=str(exc), error_category="planner")
    return _record(
        item,
        method,
        condition,
        box=list(answer.object.box) if answer.object else None,
        box_from=answer.object.box_from if answer.object else None,
        chosen_id=answer.object.id if answer.object else None,
        answer=answer.answer,
        value=answer.value,
        unit=answer.unit,
        program=answer.program,
        prompt=answer.prompt,
        trace=answer.trace,
        measured=_measured(answer.trace),
        error=answer.error.message if answer.error else None,
        error_category=_category(answer),
        sim_s=answer.sim_s,
        checks=answer.checks,
        perception=answer.perception,
        evidence=list(answer.object.evidence) if answer.object else [],
        guess=answer.object.guess if answer.object else False,
    )


def _attr_api(item: Item, settings: Settings, condition: Condition) -> Record:
    return _program(item, "attr-api", settings, condition)


def _pa_api(item: Item, settings: Settings, condition: Condition) -> Record:
    return _program(item, "pa-api", settings, condition)


# ---- models asked directly (ovd, vqa, vqa+llm, vlm) -------------------------------------------------------


def _perception(settings: Settings) -> Any:
    from attribot.api import Perception

    return Perception.from_settings(settings)


def _ovd(item: Item, settings: Settings, condition: Condition) -> Record:
    frame, detector = _world_frame(item), _perception(settings).detector
    try:
        best = _best(detector.detect(frame, [item.query]))
    except InputError as exc:  # a closed-set detector that finds no class in the query refuses it
        return _record(item, "ovd", condition, error=f"the detector refused the query: {exc}",
                       error_category="perception")  # fmt: skip
    if best is None:
        return _record(
            item, "ovd", condition, error="the detector found nothing", error_category="perception"
        )
    return _record(item, "ovd", condition, box=list(best.box), chosen_id=best.object_id, answer=best.label)


def _vqa(item: Item, settings: Settings, condition: Condition) -> Record:
    perception, frame = _perception(settings), _world_frame(item)
    said = perception.vqa.answer(frame, item.query)
    return _grounded(item, "vqa", condition, perception, frame, _first_name(said), answer=said)


def _vqa_llm(item: Item, settings: Settings, condition: Condition) -> Record:
    perception, frame = _perception(settings), _world_frame(item)
    items = perception.vqa.answer(frame, "What are the items in this image?")
    choice = perception.language.complete(f"Out of these items: {items}; which one is {item.query}?")
    return _grounded(item, "vqa+llm", condition, perception, frame, _first_name(choice), answer=choice)


def _vlm(item: Item, settings: Settings, condition: Condition) -> Record:
    """An end-to-end vision-chat model asked for the box; not run without one (and no world built)."""
    if not _vlm_configured(settings):
        return _record(
            item,
            "vlm",
            condition,
            status="not run",
            error="no vision-chat backend is configured (the vlm row needs one: --vqa openai:MODEL)",
        )
    frame = _world_frame(item)
    said = _perception(settings).vqa.answer(
        frame,
        f"{item.query} Answer only with the bounding box of that object in pixels as x0,y0,x1,y1 "
        f"(image {frame.width}x{frame.height}, origin top-left).",
    )
    numbers = [float(n) for n in re.findall(r"-?\d+(?:\.\d+)?", said)[:4]]
    if len(numbers) != 4 or not all(math.isfinite(n) for n in numbers):  # "9" * 400 reads as inf
        return _record(
            item,
            "vlm",
            condition,
            answer=said,
            error="the model's reply holds no box",
            error_category="perception",
        )
    x0, y0, x1, y1 = numbers  # corners in another order still name a box
    box = [min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1)]
    return _record(item, "vlm", condition, box=box, answer=said)


# the paper's rows, in the order of its tables
register_method(
    Method(
        "ovd",
        _ovd,
        why="The offline oracle detector matches object names, not attributes: given a whole query it "
        "returns its best-scoring named object, so it is right only when that object happens to be the "
        "answer.",
    )
)
register_method(
    Method(
        "vqa",
        _vqa,
        why="The offline oracle VQA answers templated questions from the scene's metadata and says 'unknown' "
        "to weight and distance, so its row is near zero by design; a real VQA model guesses.",
    )
)
register_method(
    Method(
        "vqa+llm",
        _vqa_llm,
        why="The offline language model reads the catalog's masses: with the items named it compares them "
        "reliably, which a real LLM does from common sense.",
    )
)
register_method(
    Method(
        "vlm",
        _vlm,
        why="An end-to-end vision-chat model; not run without a configured backend (--vqa openai:MODEL).",
    )
)
register_method(
    Method(
        "attr-api",
        _attr_api,
        program=True,
        why="Programs over the camera alone: weight from the catalog by name, distance from visual "
        "proxies (the paper's attribute API hard-coded distance from the image centre, hence its 0.22).",
    )
)
register_method(
    Method(
        "pa-api",
        _pa_api,
        program=True,
        why="Programs that measure: the rangefinder after visual servoing, the wrist force sensor after "
        "driving, grasping and lifting by perception.",
    )
)

PROGRAM_METHODS = tuple(name for name, m in METHODS.items() if m.program)
"""The methods that run a program through the API: the ones with error-catching mechanisms to ablate."""
