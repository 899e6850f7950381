"""The answer to one query: what `attribot ask --json` prints and `--save` writes."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, model_validator

from attribot.text import json_safe_data

__all__ = ["AnswerObject", "AnswerError", "Answer"]


class AnswerObject(BaseModel):
    """The chosen object: the world's id where there is one, its category, its box in pixels (y down)."""

    model_config = ConfigDict(frozen=True)

    id: str | None
    category: str | None
    box: tuple[float, float, float, float]


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
    program: str | None = None
    planner: str
    backends: dict[str, str]
    attempts: int
    trace: list[dict[str, Any]] = []
    error: AnswerError | None = None
    world: dict[str, Any] | None = None  # layout and seed, or the image file
    sim_s: float | None = None  # simulated seconds the robot spent on the query; None outside a simulator
    checks: list[dict[str, Any]] = []  # what the error-catching mechanisms did (attribot.api.safeguards)

    @model_validator(mode="before")
    @classmethod
    def _json_safe(cls, data: Any) -> Any:
        """Every text in an answer can be written as JSON: a lone surrogate (a program's own making, or
        undecodable bytes of a command line) becomes U+FFFD, so that --json and --save never fail."""
        return json_safe_data(data)

    @property
    def ok(self) -> bool:
        return self.error is None
