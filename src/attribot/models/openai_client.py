"""The one OpenAI-compatible client of attribot, shared by the LLM planner and the `openai:` backends.

It covers OpenAI, vLLM, Ollama and llama.cpp servers by `base_url`. SDK errors become `BackendError`s
that say what went wrong and what to check.
"""

from __future__ import annotations

from typing import Any

from attribot.errors import BackendError

__all__ = ["make_client", "chat_text"]


def make_client(base_url: str | None, api_key: str | None, timeout_s: float, max_retries: int = 2) -> Any:
    """An `openai.OpenAI` client. Local servers need no key; a placeholder is sent where none is set."""
    import openai

    return openai.OpenAI(
        base_url=base_url,
        api_key=api_key or "not-needed",
        timeout=timeout_s,
        max_retries=max_retries,
    )


def chat_text(client: Any, model: str, messages: list[dict[str, Any]], **params: Any) -> str:
    """The text of the first choice of a chat completion; every failure is a `BackendError`."""
    import openai

    where = str(getattr(client, "base_url", "the endpoint"))
    try:
        reply = client.chat.completions.create(model=model, messages=messages, **params)
    except openai.AuthenticationError as exc:
        raise BackendError(
            f"{where} refused the API key (401)", "set ATTRIBOT_LLM_API_KEY (or llm_api_key in attribot.toml)"
        ) from exc
    except openai.RateLimitError as exc:
        raise BackendError(
            f"{where} is rate limiting (429) after retries", "wait, or lower the request rate"
        ) from exc
    except openai.APITimeoutError as exc:
        raise BackendError(
            f"{where} did not answer in time", "raise ATTRIBOT_LLM_TIMEOUT_S or check the server"
        ) from exc
    except openai.APIConnectionError as exc:
        raise BackendError(
            f"cannot reach {where}", "check the base URL and that the server is running"
        ) from exc
    except openai.APIStatusError as exc:
        raise BackendError(f"{where} answered HTTP {exc.status_code}: {_short(exc.message)}") from exc
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
