"""The LLM planner: any OpenAI-compatible chat endpoint writes the program.

The prompt is the one the settings name (`prompt`: `attribot`, generated from the API itself, or `paper`,
the structure of the paper authors' prompt; see `attribot.api.prompt`). Each failed attempt (an error
from the runner, or a reply with no usable code) goes back to the model as the assistant's earlier reply
followed by a user message with the structured error, and the model is asked again. Replies are cached on
disk under a hash of the model, the messages and the sampling parameters, so that a rerun is reproducible
and costs nothing.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from attribot.config import revealed
from attribot.errors import ConfigError
from attribot.files import write_whole
from attribot.planning.base import ENTRY_POINT, PLANNERS, Attempt, Plan, PlanRequest
from attribot.planning.extract import extract_program

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = ["LLMPlanner", "ReplyCache", "PromptBuilder", "feedback_message", "cache_key"]

PromptBuilder = Callable[..., "str | list[dict[str, str]]"]
"""`(query, sensors[, embodied=..., findable=...]) -> prompt`: the whole prompt as one user message, or a
list of chat messages. `embodied` and `findable` are passed when the builder accepts them."""

_OUTPUT_TAIL = 1500  # characters of program output sent back: enough to see what it printed last


_NOT_RUN = ("reply", "syntax", "policy")
"""Error categories of a try in which no program ran: the robot did nothing, so nothing was put back."""


def feedback_message(
    error: Any,
    did: Sequence[str] = (),
    same_start: bool = False,
    entry: str = f"{ENTRY_POINT}(image, robot)",
    moved: bool | None = None,
) -> str:
    """The follow-up user message for a failed attempt: the structured error, what the try did (its API
    calls, `did`), where the next try starts, and what to do (`entry`: the function the prompt asked for,
    in its own words). A reply with no program is told so (not a syntax error), and a try in which nothing
    ran, or in which the robot did not act (`moved` False), is not told that the robot was put back."""
    where = f", line {error.line}" if getattr(error, "line", None) else ""
    if error.category == "reply":
        lines = [f"Your reply has no program I can run: {error.message}"]
    else:
        lines = [f"Your program failed ({error.category} error{where}): {error.message}"]
    if getattr(error, "snippet", None):
        lines.append(f"The failing line: {error.snippet.strip()}")
    output = getattr(error, "output", "") or ""
    if output.strip():
        tail = output if len(output) <= _OUTPUT_TAIL else "..." + output[-_OUTPUT_TAIL:]
        lines.append(f"Its output so far:\n{tail}")
    if did:
        lines.append("What it did, call by call:\n" + "\n".join(f"- {line}" for line in did))
    if error.category in _NOT_RUN:
        lines.append("Nothing ran: the robot has not moved, and the next program starts from the same image.")
    elif moved is False:
        lines.append(
            "The robot has not moved: the next program starts from the same state and the same image."
        )
    elif same_start:
        lines.append(
            "The next program starts from the same state as this one: the robot back where it started, "
            "its gripper empty, and the same first image."
        )
    lines.append(
        f"Fix it and answer with the whole program again, as one ```python code block that defines {entry}."
    )
    return "\n".join(lines)


def cache_key(model: str, messages: Sequence[dict[str, Any]], params: dict[str, Any]) -> str:
    """The hash a reply is cached under: the model, the messages and the sampling parameters."""
    data = json.dumps(
        {"model": model, "messages": list(messages), "params": params}, sort_keys=True, ensure_ascii=False
    )
    return hashlib.sha256(data.encode("utf-8")).hexdigest()


class ReplyCache:
    """Model replies on disk, one JSON file per key. Writes are atomic (a temporary file renamed into
    place); a file that cannot be read or is not what was written is ignored and written anew."""

    def __init__(self, root: Path) -> None:
        self.root = Path(root)

    def path(self, key: str) -> Path:
        return self.root / key[:2] / f"{key}.json"

    def get(self, key: str) -> str | None:
        try:
            data = json.loads(self.path(key).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        if not isinstance(data, dict) or data.get("key") != key or not isinstance(data.get("reply"), str):
            return None
        return data["reply"]

    def put(self, key: str, reply: str, model: str) -> None:
        path = self.path(key)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            record = {"key": key, "model": model, "reply": reply}
            write_whole(path, json.dumps(record, ensure_ascii=False).encode("utf-8"))
        except OSError as exc:  # a read-only or full disk costs the cache, not the answer
            warnings.warn(
                f"could not cache the LLM reply in {path.parent}: {exc}", RuntimeWarning, stacklevel=2
            )


class LLMPlanner:
    """Plans with an OpenAI-compatible chat model; see the module docstring."""

    name = "llm"

    def __init__(
        self,
        settings: Settings,
        *,
        prompt_builder: PromptBuilder | None = None,
        use_cache: bool = True,
        http_retries: int | None = None,
    ) -> None:
        self.settings = settings
        self.model = settings.llm_model
        self.max_tries = settings.llm_max_tries
        self.params: dict[str, Any] = {"temperature": settings.llm_temperature}
        if settings.llm_max_tokens:
            self.params["max_tokens"] = settings.llm_max_tokens
        self.cache = ReplyCache(Path(settings.cache_dir) / "llm") if use_cache else None
        # requests sent again where the server did no work for them (`llm_retries`; see openai_client)
        self.http_retries = settings.llm_retries if http_retries is None else http_retries
        self._prompt_builder = prompt_builder
        # the prompt shown (named in every answer): the settings' choice, or "custom" for a given builder
        self.prompt = settings.prompt if prompt_builder is None else "custom"
        self._client: Any = None

    # -- the conversation ---------------------------------------------------------------------------

    def messages(self, request: PlanRequest, feedback: Sequence[Attempt] = ()) -> list[dict[str, str]]:
        """The chat messages for `request`: the prompt, then each failed attempt and its error."""
        builder = self._builder()
        extras = {"embodied": request.embodied, "findable": request.findable}
        prompt = builder(
            request.query, list(request.sensors), **{k: v for k, v in extras.items() if _accepts(builder, k)}
        )
        if isinstance(prompt, str):
            messages = [{"role": "user", "content": prompt}]
        else:
            messages = [{"role": str(m["role"]), "content": str(m["content"])} for m in prompt]
        for attempt in feedback:
            if attempt.error is None:
                continue
            said = attempt.reply if attempt.reply is not None else f"```python\n{attempt.program}```"
            messages.append({"role": "assistant", "content": said})
            feedback_text = feedback_message(
                attempt.error, attempt.did, request.same_start, self._entry(), attempt.moved
            )
            messages.append({"role": "user", "content": feedback_text})
        return messages

    def plan(self, request: PlanRequest, feedback: Sequence[Attempt] = ()) -> Plan:
        """Ask the model (or the cache); raises `NoProgram` when the reply holds no usable program."""
        messages = self.messages(request, feedback)
        reply, cached = self.complete(messages)
        return Plan(program=extract_program(reply, self._entry()), reply=reply, cached=cached)

    def complete(self, messages: list[dict[str, str]]) -> tuple[str, bool]:
        """The model's reply to `messages` and whether it came from the cache."""
        from attribot.models.openai_client import chat_text

        key = cache_key(self.model, messages, self.params)
        if self.cache is not None:
            hit = self.cache.get(key)
            if hit is not None:
                return hit, True
        reply = chat_text(self._get_client(), self.model, messages, self.http_retries, **self.params)
        if self.cache is not None:
            self.cache.put(key, reply, self.model)
        return reply, False

    # -- plumbing ----------------------------------------------------------------------------------

    def _builder(self) -> PromptBuilder:
        if self._prompt_builder is None:
            from attribot.api.prompt import prompt_style

            self._prompt_builder = prompt_style(self.prompt).build
        return self._prompt_builder

    def _entry(self) -> str:
        """The entry point as the prompt taught it: feedback asks for the same."""
        if self.prompt == "custom":
            return f"{ENTRY_POINT}(image, robot)"
        from attribot.api.prompt import prompt_style

        return prompt_style(self.prompt).entry

    def _get_client(self) -> Any:
        if self._client is None:
            if self.settings.llm_base_url is None and self.settings.llm_api_key is None:
                raise ConfigError(
                    "the llm planner has no endpoint: neither a base URL nor an API key is set",
                    "set ATTRIBOT_LLM_BASE_URL (e.g. http://127.0.0.1:8000/v1 for vLLM, "
                    "http://127.0.0.1:11434/v1 "
                    "for Ollama) or ATTRIBOT_LLM_API_KEY for OpenAI, or use --planner rules",
                )
            from attribot.models.openai_client import make_client

            self._client = make_client(
                self.settings.llm_base_url, revealed(self.settings.llm_api_key), self.settings.llm_timeout_s
            )
        return self._client


def _accepts(builder: Callable[..., Any], name: str) -> bool:
    """Whether the prompt builder accepts the keyword `name` (the API's takes `embodied=`: no robot actions
    on a still image, and `findable=`: what the detector can find here)."""
    try:
        parameters = inspect.signature(builder).parameters
    except (TypeError, ValueError):
        return False
    return name in parameters or any(p.kind is p.VAR_KEYWORD for p in parameters.values())


@PLANNERS.register("llm")
def _build_llm(settings: Settings) -> LLMPlanner:
    return LLMPlanner(settings)
