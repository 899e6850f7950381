"""What every planner shares: the request and plan records, the planner protocol and registry, and the
plan -> run -> feed the error back loop (`solve`).

A planner turns a query into a program (Python text defining `execute_command(image, robot)`); `solve`
runs it through a caller-given `execute` (the sandboxed runner in practice) and, when the run fails with a
structured error, asks the planner again with every earlier attempt and its error as feedback.
"""

from __future__ import annotations

import importlib
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, Protocol, runtime_checkable

from pydantic import BaseModel, ConfigDict

from attribot.api.prompt import ENTRY_POINT, MAX_QUERY_CHARS  # one definition of each, in the API layer
from attribot.errors import AttribotError, InputError
from attribot.planning.query import check_query, is_utf8_text
from attribot.registry import Registry

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = [
    "ENTRY_POINT",
    "MAX_QUERY_CHARS",
    "RunError",
    "PlanRequest",
    "Plan",
    "Attempt",
    "Planner",
    "PlannerBuilder",
    "PLANNERS",
    "build_planner",
    "NoProgram",
    "SolveResult",
    "solve",
    "check_query",
    "is_utf8_text",
    "describe_calls",
]


def _run_error_type() -> type[BaseModel]:
    """The runner's `RunError` when the runner is installed, else a record with the same fields.

    The runner is built alongside the planners; importing it here (a higher layer may import a lower one)
    keeps one error type across the project, and the fallback keeps planning usable on its own.
    """
    for module in ("attribot.runner", "attribot.runner.records"):
        try:
            return importlib.import_module(module).RunError
        except (ImportError, AttributeError):
            continue
    # neither is there: a record with the contract's fields

    class RunError(BaseModel):
        """A structured program error (the runner's contract): category, message, line, snippet, output."""

        model_config = ConfigDict(frozen=True)

        category: Literal["syntax", "policy", "runtime", "timeout", "limit", "api"]
        message: str
        line: int | None = None
        snippet: str | None = None
        output: str = ""

    return RunError


RunError = _run_error_type()


class PlanRequest(BaseModel):
    """What a planner is asked: the query (checked once, by whoever makes the request: planners take it as
    it is), the robot's sensors, whether robot actions are possible, what the detector can find in this
    world (empty: not known), and whether every try starts from the state the first one started from."""

    model_config = ConfigDict(frozen=True)

    query: str
    sensors: list[str] = ["camera"]
    embodied: bool = False
    findable: str = ""
    same_start: bool = False


class Plan(BaseModel):
    """A planner's answer: the program, the raw model reply it came from (llm), and whether it was cached."""

    model_config = ConfigDict(frozen=True)

    program: str
    reply: str | None = None
    cached: bool = False


class Attempt(BaseModel):
    """One try: the program that ran (empty when the reply had none) and its error, None when it worked.

    `reply` keeps the model's raw answer so that the conversation can be replayed to the model exactly.
    """

    model_config = ConfigDict(frozen=True)

    program: str
    error: RunError | None = None  # type: ignore[valid-type]
    reply: str | None = None
    did: list[str] = []  # the API calls the try made, in order, with their results or errors (short)


@runtime_checkable
class Planner(Protocol):
    """Turns a request (and the failed attempts so far) into a program."""

    name: str

    def plan(self, request: PlanRequest, feedback: Sequence[Attempt] = ()) -> Plan: ...


PlannerBuilder = Callable[["Settings"], Planner]

PLANNERS: Registry[PlannerBuilder] = Registry(
    "planner", homes={"rules": "attribot.planning.rules.planner", "llm": "attribot.planning.llm"}
)


def build_planner(name: str, settings: Settings) -> Planner:
    """The planner registered as `name` ("rules", "llm"), configured from `settings`."""
    return PLANNERS.get(name)(settings)


class NoProgram(AttribotError):
    """A planner's reply held no usable program. `error` is the structured message fed back to the model."""

    def __init__(self, message: str, fix: str | None = None, *, reply: str | None = None) -> None:
        super().__init__(message, fix)
        self.reply = reply
        self.error = RunError(category="syntax", message=message, line=None, snippet=None, output="")


@dataclass(frozen=True)
class SolveResult:
    """Every attempt in order, the plans behind them, and the final run (None when no program ever ran)."""

    attempts: list[Attempt]
    result: Any  # attribot.runner.RunResult | None
    plans: list[Plan] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.result is not None and bool(self.result.ok)

    @property
    def program(self) -> str | None:
        """The last program that was tried, or None when no reply held one."""
        for attempt in reversed(self.attempts):
            if attempt.program:
                return attempt.program
        return None

    @property
    def error(self) -> Any:
        """The error that ended the loop (RunError), None on success."""
        if self.ok:
            return None
        return self.attempts[-1].error if self.attempts else None


def solve(
    planner: Planner,
    request: PlanRequest,
    execute: Callable[[str], Any],
    max_tries: int,
    check: Callable[[Any], str | None] | None = None,
) -> SolveResult:
    """Plan, run, and on a structured error plan again with the error fed back, up to `max_tries` tries.

    `execute(program)` returns a RunResult (`ok`, `error`). `check(result)` says why a run that finished is
    still no answer (None returned, no object where the query asks which): such a run fails the try as a
    runtime error, with the program's output, and goes back to the planner like any other. A reply with
    no program (`NoProgram`) counts as a try whose error goes back to the planner. The loop also stops when
    the planner returns a program it has already tried: a deterministic planner (rules) ignores feedback,
    and running the same program on the same world again would only repeat the same error. Planner
    failures that are not about the program (an unreachable endpoint, an unsupported query) propagate as
    the `AttribotError` they are.
    """
    if max_tries < 1:
        raise InputError(f"max_tries must be at least 1, not {max_tries}")
    attempts: list[Attempt] = []
    plans: list[Plan] = []
    result: Any = None
    tried: set[str] = set()
    for _ in range(max_tries):
        try:
            plan = planner.plan(request, tuple(attempts))
        except NoProgram as exc:
            attempts.append(Attempt(program="", error=exc.error, reply=exc.reply))
            continue
        if plan.program in tried:
            break
        tried.add(plan.program)
        plans.append(plan)
        result = _checked(execute(plan.program), check)
        did = describe_calls(getattr(result, "trace", ()))  # a caller's own result may keep no trace
        attempts.append(Attempt(program=plan.program, error=result.error, reply=plan.reply, did=did))
        if result.ok:
            break
    return SolveResult(attempts=attempts, result=result, plans=plans)


def _checked(result: Any, check: Callable[[Any], str | None] | None) -> Any:
    """`result`, failed with `check`'s reason when it finished and is still no answer."""
    problem = check(result) if check is not None and result.ok else None
    if problem is None:
        return result
    error = RunError(category="runtime", message=problem, output=result.output)
    return result.model_copy(update={"ok": False, "error": error})


def describe_calls(trace: Sequence[Any], limit: int = 12) -> list[str]:
    """The API calls of a run as short lines ("Robot.pick_up(ball) -> failed: grasp failed ..."), the
    last `limit` of them: what a failed try did, for the feedback."""
    lines = []
    for record in trace:
        args = ", ".join(_short(a) for a in record.args)
        outcome = f"failed: {record.error}" if record.error else _short(record.result)
        lines.append(f"{record.call}({args}) -> {outcome}")
    if len(lines) > limit:
        lines = [f"... {len(lines) - limit} earlier calls", *lines[-limit:]]
    return lines


def _short(value: Any, size: int = 60) -> str:
    """A trace value in a few words: an API object by its label and id, the rest as JSON, cut."""
    if isinstance(value, dict) and "type" in value:
        name = value.get("label") or value.get("type")
        return f"{name} {value['object_id']}" if value.get("object_id") else str(name)
    if isinstance(value, list) and value and all(isinstance(v, dict) and "type" in v for v in value):
        return "[" + ", ".join(_short(v) for v in value[:4]) + (", ...]" if len(value) > 4 else "]")
    text = json.dumps(value, default=str)
    return text if len(text) <= size else text[: size - 3] + "..."
