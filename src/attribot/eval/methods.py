"""The paper's methods (its table's rows), each run on one dataset item with any planner and backends.

- `ovd`: the detector given the whole query; its highest-scoring box (the paper's OVD row).
- `vqa`: the VQA model asked the query; its answer grounded with the detector.
- `vqa+llm`: `visual_query("What are the items in this image?")`, then `language_query` to choose among
  them, then the detector for the box (the paper's VQA + GPT rows).
- `vlm`: an end-to-end vision-chat model shown the image and the query, answering with a box (the paper's
  GPT-4o row). It needs a real backend (`--vqa openai:MODEL`); without one it is recorded as not run.
- `attr-api`: a program over ImagePatch only (camera alone, no robot actions): the attribute API.
- `pa-api`: a program over the whole perception-action API with the item's sensors.

`run_method` returns one `Record`: the box and object chosen, whether it is right (box IoU >= 0.5 with the
true object, and the same object id where the world gives ids), the program and trace, measured values,
the error and its category (planner, runner, perception, action), and wall seconds.
"""

from __future__ import annotations

import re
import time
from typing import Any

from pydantic import BaseModel

from attribot.api.safeguards import MECHANISMS
from attribot.boxes import iou
from attribot.config import Settings
from attribot.errors import InputError
from attribot.eval.datasets import Item
from attribot.noise import NOISE_PRESETS, world_noise

__all__ = [
    "METHODS",
    "PAPER_METHODS",
    "Record",
    "run_method",
    "noisy_settings",
    "check_condition",
    "PROGRAM_METHODS",
    "ablations",
]

METHODS = ("ovd", "vqa", "vqa+llm", "vlm", "attr-api", "pa-api")
PROGRAM_METHODS = ("attr-api", "pa-api")
"""The methods that run a program through the API: the ones with error-catching mechanisms to ablate."""
PAPER_METHODS = {
    "location": ("ovd", "attr-api", "vlm", "pa-api"),
    "size": ("ovd", "attr-api", "vlm", "pa-api"),
    "weight_image": ("ovd", "vqa", "vqa+llm", "attr-api", "vlm"),
    "distance_embodied": ("ovd", "vqa", "attr-api", "vlm", "pa-api"),
    "weight_embodied": ("ovd", "vqa", "attr-api", "vlm", "pa-api"),
}
"""Which methods the paper compares on each task (the default of `attribot eval`); pa-api is added on
location and size, where the robot can look again."""
NOISE_LEVELS = tuple(NOISE_PRESETS)
_WITHOUT = "-no-"


def check_condition(condition: str) -> tuple[str, str]:
    """A run condition, `PRESET` or `PRESET-no-MECHANISM` (an ablation): (preset, the checks spec)."""
    preset, _, mechanism = condition.partition(_WITHOUT)
    if preset not in NOISE_LEVELS or (mechanism and mechanism not in MECHANISMS):
        raise InputError(
            f"unknown noise level {condition!r}",
            f"choose from: {', '.join(NOISE_LEVELS)}, or PRESET{_WITHOUT}MECHANISM for an ablation "
            f"(mechanisms: {', '.join(MECHANISMS)})",
        )
    return preset, f"all,-{mechanism}" if mechanism else "all"


def ablations(preset: str = "realistic") -> tuple[str, ...]:
    """The conditions of the ablation table: `preset` with each mechanism off in turn."""
    return tuple(f"{preset}{_WITHOUT}{m}" for m in MECHANISMS)


class Record(BaseModel):
    """One method's result on one item (see the module docstring).

    status: right | wrong | failed | not run."""

    id: str
    task: str
    method: str
    noise: str
    query: str
    status: str
    right: bool
    iou: float | None = None
    box: list[float] | None = None
    chosen_id: str | None = None
    true_id: str
    true_box: list[float]
    answer: str = ""
    value: float | None = None
    unit: str | None = None
    program: str | None = None
    trace: list[dict[str, Any]] = []
    measured: list[dict[str, Any]] = []
    error: str | None = None
    error_category: str | None = None  # planner | runner | perception | action | uncertain
    checks: list[dict[str, Any]] = []  # what the error-catching mechanisms did (caught, confirmed, unsettled)
    wall_s: float = 0.0
    sim_s: float | None = None  # simulated seconds of the robot's actions (pa-api in a simulator)


def noisy_settings(settings: Settings, noise: str, seed: int) -> Settings:
    """The settings with the condition's noise preset on the oracle backends, drawn from the item's seed,
    and its mechanisms (an ablation leaves one out)."""
    preset, checks = check_condition(noise)
    update: dict[str, str] = {} if checks == "all" else {"checks": checks}
    if preset == "clean":
        return settings.model_copy(update=update) if update else settings
    for role in ("detector", "vqa"):
        spec = str(getattr(settings, role))
        if spec.split("?")[0] == "oracle":
            update[role] = f"oracle?noise={preset}&seed={seed}"
    return settings.model_copy(update=update)


def _record(item: Item, method: str, noise: str, **fields: Any) -> Record:
    box = fields.get("box")
    chosen = fields.get("chosen_id")
    overlap = iou(tuple(box), tuple(item.true_box)) if box and item.true_box else None
    right = overlap is not None and overlap >= 0.5 and (chosen is None or chosen == item.true_id)
    status = fields.pop("status", None) or (
        "right" if right else ("failed" if fields.get("error") else "wrong")
    )
    return Record(
        id=item.id,
        task=item.task,
        method=method,
        noise=noise,
        query=item.query,
        status=status,
        right=right,
        iou=overlap,
        true_id=item.true_id,
        true_box=item.true_box,
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
    item: Item, method: str, noise: str, perception: Any, frame: Any, name: str, **extra: Any
) -> Record:
    """The detector's best box for `name` (a model's answer), as the record of `method`."""
    if not name or name.strip().lower() in ("unknown", "none", ""):
        return _record(
            item,
            method,
            noise,
            error=f"the model gave no object ({name!r})",
            error_category="perception",
            **extra,
        )
    best = _best(perception.detector.detect(frame, [name]))
    if best is None:
        return _record(
            item, method, noise, error=f"the detector found no {name!r}", error_category="perception", **extra
        )
    return _record(
        item, method, noise, box=list(best.box), chosen_id=best.object_id, **{"answer": name, **extra}
    )


_ANSWER_NAME = re.compile(r"(?:the\s+)?([a-z][a-z ]*?)(?:[.!,]|$)")


def _first_name(text: str) -> str:
    match = _ANSWER_NAME.match(text.strip().lower())
    return match.group(1).strip() if match else ""


def run_method(item: Item, method: str, settings: Settings, noise: str = "clean") -> Record:
    """Run `method` on `item` with `settings` (and the noise level on the oracle backends)."""
    from attribot.api import Perception
    from attribot.session import Scene, ask

    started = time.perf_counter()
    settings = noisy_settings(settings, noise, item.seed)
    try:
        if method in PROGRAM_METHODS:
            sensors = item.sensors if method == "pa-api" else ["camera"]
            scene = item.scene().model_copy(
                update={"noise": world_noise(check_condition(noise)[0], item.seed)}
            )
            # attr-api: one image and no robot (looking again happens within that image)
            answer = ask(item.query, Scene(scene, sensors=sensors, still=method == "attr-api"), settings)
            trace = answer.trace
            failing = next((t["call"] for t in reversed(trace) if t.get("error")), "")
            category = None
            if answer.error is not None:
                if answer.error.category == "planner" or answer.program is None:
                    category = "planner"
                elif answer.error.category == "uncertain":
                    category = "uncertain"
                elif failing.startswith("Robot."):
                    category = "action"
                elif failing:
                    category = "perception"
                else:
                    category = "runner"
            measured = [
                {
                    "call": t["call"],
                    "object_id": (t["args"] or [{}])[0].get("object_id")
                    if t["args"] and isinstance(t["args"][0], dict)
                    else None,
                    "value": t["result"],
                }
                for t in trace
                if t["call"] in ("Robot.measure_weight", "Robot.measure_distance") and t.get("error") is None
            ]
            record = _record(
                item,
                method,
                noise,
                box=list(answer.object.box) if answer.object else None,
                chosen_id=answer.object.id if answer.object else None,
                answer=answer.answer,
                value=answer.value,
                unit=answer.unit,
                program=answer.program,
                trace=trace,
                measured=measured,
                error=answer.error.message if answer.error else None,
                error_category=category,
                sim_s=answer.sim_s,
                checks=answer.checks,
            )
        elif method == "vlm" and not _vlm_configured(settings):
            record = _vlm(item, noise, settings, None)  # not run: no world to build for it
        else:
            perception = Perception.from_settings(settings)
            frame = _world_frame(item)
            if method == "ovd":
                best = _best(perception.detector.detect(frame, [item.query]))
                record = (
                    _record(
                        item, method, noise, box=list(best.box), chosen_id=best.object_id, answer=best.label
                    )
                    if best is not None
                    else _record(
                        item, method, noise, error="the detector found nothing", error_category="perception"
                    )
                )
            elif method == "vqa":
                said = perception.vqa.answer(frame, item.query)
                record = _grounded(item, method, noise, perception, frame, _first_name(said), answer=said)
            elif method == "vqa+llm":
                items = perception.vqa.answer(frame, "What are the items in this image?")
                choice = perception.language.complete(
                    f"Out of these items: {items}; which one is {item.query}?"
                )
                record = _grounded(item, method, noise, perception, frame, _first_name(choice), answer=choice)
            elif method == "vlm":
                record = _vlm(item, noise, settings, frame)
            else:
                raise ValueError(f"unknown method {method!r}; choose from {', '.join(METHODS)}")
    except Exception as exc:  # noqa: BLE001 (a crash of one item is that item's failure, recorded)
        record = _record(item, method, noise, error=f"{type(exc).__name__}: {exc}", error_category="runner")
    record.wall_s = time.perf_counter() - started
    return record


def _vlm(item: Item, noise: str, settings: Settings, frame: Any) -> Record:
    """An end-to-end vision-chat model asked for the box; not run without one."""
    if not _vlm_configured(settings):
        return _record(
            item,
            "vlm",
            noise,
            status="not run",
            error="no vision-chat backend is configured (the vlm row needs one: --vqa openai:MODEL)",
        )
    from attribot.api import Perception

    vqa = Perception.from_settings(settings).vqa
    said = vqa.answer(
        frame,
        f"{item.query} Answer only with the bounding box of that object in pixels as x0,y0,x1,y1 "
        f"(image {frame.width}x{frame.height}, origin top-left).",
    )
    numbers = [float(n) for n in re.findall(r"-?\d+(?:\.\d+)?", said)[:4]]
    if len(numbers) != 4:
        return _record(
            item,
            "vlm",
            noise,
            answer=said,
            error="the model's reply holds no box",
            error_category="perception",
        )
    return _record(item, "vlm", noise, box=numbers, answer=said)
