"""The runner's records: the limits a program runs under, and what comes back from a run."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, SerializerFunctionWrapHandler, model_serializer

__all__ = ["Limits", "RunError", "TraceRecord", "RunResult", "Category"]

Category = Literal["syntax", "policy", "runtime", "timeout", "limit", "api", "reply"]
"""What failed: the program's text (syntax, policy), its run (runtime, timeout, limit, api), or, before any
program, the model's reply, which held none to run (reply)."""


class Limits(BaseModel):
    """What one program may use. The defaults leave room for embodied programs (robot actions run on the
    host and count against `wall_s`, not against `cpu_s`, which is the program's own CPU time)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    wall_s: float = Field(
        60.0, gt=0, le=86_400, allow_inf_nan=False, description="wall-clock seconds, API calls included"
    )
    cpu_s: float = Field(
        10.0, gt=0, le=86_400, allow_inf_nan=False, description="CPU seconds of the program's own process"
    )
    memory_mb: int = Field(512, ge=64, le=1 << 20, description="address space of the program's process")
    max_output_chars: int = Field(
        20_000, ge=0, le=100_000_000, description="characters the program may print"
    )
    max_api_calls: int = Field(1_000, ge=0, le=10_000_000, description="API calls per run")
    max_recursion: int = Field(200, ge=10, le=100_000, description="nested Python calls")
    max_int_bits: int = Field(100_000, ge=64, description="bits of an integer made by **, * or <<")
    max_sequence: int = Field(10_000_000, ge=1, description="items of a sequence made by *")
    max_message_bytes: int = Field(2_000_000, ge=1_000, description="one API call or result on the pipe")
    max_source_chars: int = Field(100_000, ge=100, description="length of the program text")


class RunError(BaseModel):
    """A structured program error: what kind, where in the program, and the output printed before it.

    Messages never hold host paths or tracebacks: they are meant to go back to an LLM as they are.
    """

    model_config = ConfigDict(frozen=True)

    category: Category
    message: str
    line: int | None = None
    snippet: str | None = None
    output: str = ""


class TraceRecord(BaseModel):
    """One API call the program made: `call` like "ImagePatch.find", JSON-ready arguments and result
    (host objects appear as summary dicts), the host's time for it, and the kind of call its class declares
    (so that a failure is counted as perception or action by what failed, not by its name)."""

    model_config = ConfigDict(frozen=True)

    call: str
    args: list[Any]
    result: Any = None
    ms: float
    line: int | None = None  # the line of the program that made the call
    error: str | None = None  # the API error, when the call failed
    kind: str | None = None  # what the call does, as its class declares (`API_KIND`): perception | action
    # what the host did beyond the call itself, as its class's `PROGRAM_NOTES` method says ("put it back")
    note: str | None = None

    @model_serializer(mode="wrap")
    def _without_empty_note(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        """A record with no note is written as records were before notes: the field left out."""
        data: dict[str, Any] = handler(self)
        if data.get("note", "") is None:
            del data["note"]
        return data


class RunResult(BaseModel):
    """The outcome of one run. `value` is JSON-ready (a host object appears as a summary dict);
    `value_object` is the host object itself (e.g. the ImagePatch the program returned, or a list of
    them) and is never serialised."""

    model_config = ConfigDict(arbitrary_types_allowed=True)

    ok: bool
    value: Any = None
    value_object: Any = Field(default=None, exclude=True, repr=False)
    output: str = ""
    error: RunError | None = None
    trace: list[TraceRecord] = Field(default_factory=list)
    wall_ms: float = 0.0
