"""The answer to one query (what `attribot ask --json` prints and `--save` writes), how a run's result
becomes one, and which results are no answer and go back to the planner for another try."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import Any

from pydantic import BaseModel, ConfigDict, model_validator

from attribot.models.base import GUESSED, INFERRED
from attribot.text import json_safe_data

__all__ = [
    "AnswerObject",
    "AnswerError",
    "Answer",
    "STATED_KEYS",
    "build_answer",
    "refusing_guess",
    "answer_patch",
    "with_chosen",
    "result_problem",
]


class AnswerObject(BaseModel):
    """The chosen object: the world's id where there is one, its category, its box in pixels (y down)."""

    model_config = ConfigDict(frozen=True)

    id: str | None
    category: str | None
    box: tuple[float, float, float, float]
    # what the choice rests on: the detection's evidence (`attribot.models.base.Evidence`), and "measurement"
    # where the robot measured it
    evidence: tuple[str, ...] = ()
    # what the box is: the detection in the image, or the mean of looks at it (ImagePatch.best_box)
    box_from: str | None = None
    # the objects it was measured against (the same quantity) that rest on a guess, each "name: how taken":
    # "the mug is closer than the toaster" is no surer than what was taken for the toaster
    rivals_guessed: tuple[str, ...] = ()

    @property
    def guess(self) -> bool:
        """Whether the object rests on an inference no detector confirmed (elimination, a likeness) or on a
        box the detector was not sure of (a faint box), or was chosen over an object that does."""
        return any(e in GUESSED for e in self.evidence) or bool(self.rivals_guessed)


class AnswerError(BaseModel):
    model_config = ConfigDict(frozen=True)

    category: str
    message: str
    line: int | None = None

    @model_validator(mode="before")
    @classmethod
    def _json_safe(cls, data: Any) -> Any:
        return json_safe_data(data)


class Answer(BaseModel):
    """One answered (or failed) query, with everything needed to check it: program, backends, trace."""

    query: str
    answer: str
    object: AnswerObject | None = None
    value: float | None = None
    unit: str | None = None
    boolean: bool | None = None  # the yes or no of a yes/no question ("is the kettle heavier than ...?")
    returned: Any = None  # what execute_command returned, JSON-ready (API objects as summaries)
    output: str = ""  # what the program printed (cut at the runner's output limit)
    program: str | None = None
    planner: str
    prompt: str | None = None  # the prompt the planner showed a model (attribot, paper); None: no prompt
    backends: dict[str, str]
    attempts: int
    trace: list[dict[str, Any]] = []
    error: AnswerError | None = None
    world: dict[str, Any] | None = None  # the world and its config, or the image file
    sim_s: float | None = None  # simulated seconds the robot spent on the query; None outside a simulator
    checks: list[dict[str, Any]] = []  # what the error-catching mechanisms did (attribot.skills.safeguards)
    perception: dict[str, int] = {}  # detector calls, those answered from memory, views through a network

    @model_validator(mode="before")
    @classmethod
    def _json_safe(cls, data: Any) -> Any:
        """Every text in an answer can be written as JSON: a lone surrogate (a program's own making, or
        undecodable bytes of a command line) becomes U+FFFD, so that --json and --save never fail."""
        return json_safe_data(data)

    @property
    def ok(self) -> bool:
        return self.error is None


STATED_KEYS = frozenset({"object", "value", "unit", "yes", "text"})
"""A program may return a dict with these keys (plain values, "object" an ImagePatch) to state its answer:
the chosen object, the value of the attribute asked and its unit (a size in metres, not the distance
measured to scale it), "yes" the answer to a yes/no question, and "text" the sentence that says why."""


# ---- which results are no answer -----------------------------------------------------------------------


def result_problem(result: Any, wants_object: bool) -> str | None:
    """Why a run that finished is still no answer (the planner tries again with this message), or None.

    None returned; a number that is not finite; with `wants_object` (the query asks which object), a
    return that chooses none."""
    if result is None or result.error is not None:
        return None
    raw = result.value_object
    printed = " (it printed its answer: return it instead of printing it)" if result.output.strip() else ""
    if raw is None:
        return f"execute_command returned None{printed}; return the chosen ImagePatch or a value"
    if isinstance(raw, float) and not math.isfinite(raw):
        return f"execute_command returned {raw}, which is no answer; return a finite number or an object"
    if wants_object and answer_patch(raw) is None and _stated(raw) is None and not _patches(raw):
        shown = json.dumps(result.value, default=str)
        shown = shown if len(shown) <= 120 else shown[:117] + "..."
        return (
            f"the query asks which object, and execute_command returned {shown}, which chooses none; "
            "return the ImagePatch of the chosen object (from image.find)"
        )
    return None


# ---- a run's result as an answer -------------------------------------------------------------------


def build_answer(
    *,
    query: str,
    planner: str,
    prompt: str | None = None,
    program: str | None,
    result: Any,
    attempts: int,
    backends: dict[str, str],
    measurements: Sequence[Any],
    world: dict[str, Any],
    frame: Any,
    error: Any = None,
    doubt: str | None = None,
    named: str | None = None,
) -> Answer:
    """Turn a run result into an `Answer`: the chosen object, its measured value, a sentence for a person.
    `error` is the planner's own error when no program ever ran (a reply with no code); `doubt` says that
    the measurements behind the program's choice cannot tell it from another (no object is chosen); `named`
    says why the chosen object is not the one the program returned (`with_chosen`), and ends the answer."""
    common: dict[str, Any] = dict(
        query=query,
        program=program,
        planner=planner,
        prompt=prompt,
        backends=backends,
        attempts=attempts,
        trace=[t.model_dump(mode="json") for t in (result.trace if result is not None else [])],
        world=world,
        output=result.output if result is not None else "",
    )
    if result is None or result.error is not None:
        err = result.error if result is not None else error
        message = err.message if err is not None else "no program was produced"
        failed = AnswerError(
            category=err.category if err is not None else "planner",
            message=message,
            line=getattr(err, "line", None),
        )
        return Answer(answer=f"no answer: {message}", error=failed, **common)
    common["returned"] = result.value
    if doubt is not None:
        failed = AnswerError(category="uncertain", message=doubt)
        return Answer(answer=f"no answer: {doubt}", error=failed, **common)
    problem = result_problem(result, wants_object=False)
    if problem is not None:
        failed = AnswerError(category="runtime", message=problem)
        return Answer(answer=f"no answer: {problem}", error=failed, **common)
    stated = _stated(result.value_object)
    if stated is not None:
        return _stated_answer(stated, frame, measurements, common)
    chosen = answer_patch(result.value_object)
    if chosen is not None:
        answer = _chosen_answer(chosen, result.value_object, frame, measurements, common)
        return answer if named is None else answer.model_copy(update={"answer": f"{answer.answer} ({named})"})
    value = result.value
    number = float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None
    text = value if isinstance(value, str) else json.dumps(value, default=str)
    return Answer(answer=str(text), value=number, **common)


def refusing_guess(answer: Answer) -> Answer:
    """`answer` as a robot that must not act on a guess gives it (`Settings.guesses` = refuse): where its
    object rests on a guess, no answer, whose message keeps what the guess was (a person reading the
    refusal sees what was not trusted); any other answer as it is."""
    if answer.object is None or not answer.object.guess:
        return answer
    message = f"it would rest on a guess, and guesses are refused (guesses = refuse): {answer.answer}"
    refused = {"object": None, "value": None, "unit": None, "boolean": None}
    error = AnswerError(category="uncertain", message=message)
    return answer.model_copy(update={**refused, "answer": f"no answer: {message}", "error": error})


def _chosen_answer(
    chosen: Any, returned: Any, frame: Any, measurements: Sequence[Any], common: dict[str, Any]
) -> Answer:
    """The answer naming the chosen object, with its last measurement or the number returned beside it."""
    obj = _answer_object(chosen, frame, measurements)
    text = _named(obj)
    measured = _last_measurement(chosen, measurements)
    if measured is not None:
        text += f", measured {measured.reading()}"
        return Answer(
            answer=text + _guessed(obj), object=obj, value=float(measured.value), unit=measured.unit, **common
        )
    beside = _number_beside(returned)
    if beside is not None:
        text += f", {beside:g}"
    return Answer(answer=text + _guessed(obj), object=obj, value=beside, **common)


def _named(obj: AnswerObject) -> str:
    """ "the mug (mug_1) at [x0, y0, x1, y1]": the object as an answer names it."""
    where = ", ".join(f"{v:.0f}" for v in obj.box)
    return f"the {obj.category or 'object'}" + (f" ({obj.id})" if obj.id else "") + f" at [{where}]"


_HOW_GUESSED = {
    "faint box": "named only faintly by the detector",
    "elimination": "taken by elimination",
    "look-alike": "taken for its likeness to one it saw",
}
"""How an object that rests on a guess was taken, as its answer says it (`GUESSED`)."""


def _guessed(obj: AnswerObject | None) -> str:
    """What an answer adds where its object is a guess: what it rests on, said plainly."""
    if obj is None or not obj.guess:
        return ""
    if not any(e in GUESSED for e in obj.evidence):
        rivals = " and ".join(_rival_named(r, obj.category) for r in obj.rivals_guessed)
        return f" (a guess: chosen over {rivals})"
    inferred = [e for e in obj.evidence if e in INFERRED]
    if not inferred:
        return " (a guess: the detector named it only faintly, under its sure score)"
    how = " and ".join(_HOW_GUESSED[e] for e in inferred)
    return f" (a guess: {how}; the detector never named it, and no nearer look confirmed it)"


def _rival_named(rival: str, chosen: str | None) -> str:
    """A guessed rival ("name: how") as an answer says it: "the toaster, named only faintly by the detector",
    or "another book, ..." where it bears the chosen object's own name (a second, faint box of "book")."""
    name, _, how = rival.partition(": ")
    return f"{'another' if name == chosen else 'the'} {name}, {how}"


def _stated(value_object: Any) -> dict[str, Any] | None:
    if not isinstance(value_object, dict) or not value_object or set(value_object) - STATED_KEYS:
        return None
    if not ({"object", "yes"} & set(value_object)):
        return None
    return value_object


def _stated_answer(
    stated: dict[str, Any], frame: Any, measurements: Sequence[Any], common: dict[str, Any]
) -> Answer:
    chosen = answer_patch(stated.get("object"))
    obj = _answer_object(chosen, frame, measurements) if chosen is not None else None
    parts = []
    yes = stated.get("yes")
    if isinstance(yes, bool):
        parts.append("yes" if yes else "no")
    raw = stated.get("value")
    value = float(raw) if isinstance(raw, int | float) and not isinstance(raw, bool) else None
    unit = stated.get("unit") if isinstance(stated.get("unit"), str) and value is not None else None
    text = stated.get("text")
    if isinstance(text, str) and text:
        parts.append(text)
    elif obj is not None:
        sentence = _named(obj)
        if value is not None:
            sentence += f", {value:.3f} {unit or ''}".rstrip()
        parts.append(sentence)
    return Answer(
        answer=(": ".join(parts) if len(parts) == 2 else (parts[0] if parts else "")) + _guessed(obj),
        object=obj,
        value=value,
        unit=unit,
        boolean=yes if isinstance(yes, bool) else None,
        **common,
    )


def answer_patch(value_object: Any) -> Any:
    """The object a program's return chose: the patch itself, a stated answer's "object", or the one patch
    of a returned list, tuple or dict (`(patch, kg)`, `{"cup": patch, "kg": 0.3}`); None otherwise."""
    from attribot.api.patch import ImagePatch

    stated = _stated(value_object)
    if stated is not None:
        value_object = stated.get("object")
    if isinstance(value_object, ImagePatch):
        return value_object
    items = value_object.values() if isinstance(value_object, dict) else value_object
    if isinstance(items, list | tuple) or isinstance(value_object, dict):
        patches = [v for v in items if isinstance(v, ImagePatch)]
        if len(patches) == 1:
            return patches[0]
    return None


def with_chosen(value_object: Any, chosen: Any, other: Any) -> Any | None:
    """A program's return with `other` where it chose `chosen` (`answer_patch`): the patch itself, or that
    patch in a returned list, tuple or dict; the rest as it was. None for a stated answer (`{"object": ...,
    "text": ...}`): its words are the program's own, and an object put under them would contradict them."""
    if value_object is chosen:
        return other
    if _stated(value_object) is not None:
        return None
    if isinstance(value_object, dict):
        return {k: other if v is chosen else v for k, v in value_object.items()}
    if isinstance(value_object, list | tuple):
        out = [other if v is chosen else v for v in value_object]
        return tuple(out) if isinstance(value_object, tuple) else out
    return value_object


def _patches(value_object: Any) -> bool:
    """Whether a return is a non-empty list or tuple of patches only (the objects of "which ones ...")."""
    from attribot.api.patch import ImagePatch

    items = value_object if isinstance(value_object, list | tuple) else ()
    return bool(items) and all(isinstance(v, ImagePatch) for v in items)


def _number_beside(returned: Any) -> float | None:
    """The one number returned beside the chosen patch (`(patch, 0.35)`), or None."""
    items = list(returned.values()) if isinstance(returned, dict) else returned
    if not isinstance(items, list | tuple):
        return None
    numbers = [v for v in items if isinstance(v, int | float) and not isinstance(v, bool)]
    if len(numbers) == 1 and math.isfinite(numbers[0]):
        return float(numbers[0])
    return None


def _answer_object(patch: Any, frame: Any, measurements: Sequence[Any] = ()) -> AnswerObject:
    category = patch.label or None
    if patch.object_id is not None:
        category = next((t.category for t in frame.objects.values() if t.id == patch.object_id), category)
    evidence = tuple(e for e in (getattr(patch, "evidence", None),) if e)
    mine = _last_measurement(patch, measurements)
    if mine is not None:
        evidence += ("measurement",)
    box, source = patch.best_box() if hasattr(patch, "best_box") else (patch.box, None)
    return AnswerObject(
        id=patch.object_id,
        category=category,
        box=tuple(round(v, 1) for v in box),
        box_from=source,
        evidence=evidence,
        rivals_guessed=() if mine is None else _rivals_guessed(mine, measurements),
    )


def _rivals_guessed(mine: Any, measurements: Sequence[Any]) -> tuple[str, ...]:
    """The other objects measured for the same quantity as `mine` (the chosen object's measurement) whose
    patches rest on a guess, each "name: how", once each."""
    out: list[str] = []
    for m in measurements:
        if m.kind != mine.kind or m.evidence not in GUESSED:
            continue
        if (m.object_id, m.label, m.box) == (mine.object_id, mine.label, mine.box):
            continue  # the chosen object itself, measured again
        line = f"{m.label}: {_HOW_GUESSED[m.evidence]}"
        if line not in out:
            out.append(line)
    return tuple(out)


def _last_measurement(patch: Any, measurements: Sequence[Any]) -> Any:
    """The last measurement the program took of the chosen object (the same world id, or where the detector
    gives none, the same name and box), or None."""
    if patch.object_id is not None:
        return next((m for m in reversed(measurements) if m.object_id == patch.object_id), None)
    box = tuple(patch.box)
    return next(
        (
            m
            for m in reversed(measurements)
            if m.object_id is None and m.label == patch.label and m.box == box
        ),
        None,
    )
