"""The one OpenAI-compatible client of attribot, shared by the LLM planner and the `openai:` backends.

It covers OpenAI, vLLM, Ollama and llama.cpp servers by `base_url`. SDK errors become `BackendError`s
that say what went wrong and what to check.

The SDK's own retries are off (`max_retries=0`): they were silent, and each one sent the whole request
again, so a local server that took longer than the timeout computed the same reply three times. A request
is tried again here only where the server did no work for it (no connection, 429, a 5xx answer), as many
times as the caller's setting says; a timed-out request is never sent again, since the server may still
be computing it: its error names the timeout's setting instead.
"""

from __future__ import annotations

import time
from typing import Any

from attribot.errors import BackendError

__all__ = ["make_client", "chat_text"]


_BACKOFF_S = 0.5  # before the first retry; doubled before each next


def make_client(base_url: str | None, api_key: str | None, timeout_s: float) -> Any:
    """An `openai.OpenAI` client with no retries of its own (see the module docstring). Local servers need
    no key; a placeholder is sent where none is set."""
    import openai

    return openai.OpenAI(
        base_url=base_url,
        api_key=api_key or "not-needed",
        timeout=timeout_s,
        max_retries=0,
    )


def chat_text(
    client: Any, model: str, messages: list[dict[str, Any]], retries: int = 0, **params: Any
) -> str:
    """The text of the first choice of a chat completion, the request tried again up to `retries` times
    where the server did no work for it (see the module docstring); every failure is a `BackendError`."""
    for attempt in range(retries + 1):
        try:
            return _chat_once(client, model, messages, **params)
        except _Retriable as exc:
            if attempt == retries:
                raise exc.error from exc.__cause__
            time.sleep(_BACKOFF_S * 2**attempt)
    raise AssertionError("unreachable")  # pragma: no cover (the loop returns or raises)


class _Retriable(Exception):
    """A failure that cost the server nothing (no connection, 429, 5xx): its `BackendError` is `error`."""

    def __init__(self, error: BackendError) -> None:
        super().__init__(str(error))
        self.error = error


def _chat_once(client: Any, model: str, messages: list[dict[str, Any]], **params: Any) -> str:
    import openai

    where = str(getattr(client, "base_url", "the endpoint"))
    try:
        reply = client.chat.completions.create(model=model, messages=messages, **params)
    except openai.AuthenticationError as exc:
        raise BackendError(
            f"{where} refused the API key (401)", "set ATTRIBOT_LLM_API_KEY (or llm_api_key in attribot.toml)"
        ) from exc
    except openai.RateLimitError as exc:
        raise _Retriable(
            BackendError(f"{where} is rate limiting (429)", "wait, or lower the request rate")
        ) from exc
    except openai.APITimeoutError as exc:
        timeout = getattr(client, "timeout", None)
        waited = f" in {timeout:g} s" if isinstance(timeout, int | float) else " in time"
        raise BackendError(
            f"{where} did not answer{waited} (the request was sent once: the server may still be working "
            "on it; a local model's first request reads the whole prompt, which can take minutes)",
            "give it longer with --llm-timeout-s SECONDS (ATTRIBOT_LLM_TIMEOUT_S, llm_timeout_s in "
            "attribot.toml), or check the server",
        ) from exc
    except openai.APIConnectionError as exc:
        raise _Retriable(
            BackendError(f"cannot reach {where}", "check the base URL and that the server is running")
        ) from exc
    except openai.APIStatusError as exc:
        error = BackendError(f"{where} answered HTTP {exc.status_code}: {_short(exc.message)}")
        if exc.status_code >= 500:
            raise _Retriable(error) from exc
        raise error from exc
    except openai.APIError as exc:  # malformed bodies and other protocol errors
        raise BackendError(f"{where} gave an unusable answer: {_short(str(exc))}") from exc
    except ValueError as exc:  # a 200 whose body is not JSON: the SDK lets the decoder's error through
        raise BackendError(f"{where} answered with a body that is not JSON: {_short(str(exc))}") from exc
    choices = getattr(reply, "choices", None) or []
    content = choices[0].message.content if choices and choices[0].message is not None else None
    if not isinstance(content, str):
        raise BackendError(f"{where} answered with no text content", "check that the model is a chat model")
    return content


def _short(text: str, limit: int = 300) -> str:
    return text if len(text) <= limit else text[:limit] + "..."
