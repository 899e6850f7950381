"""OpenAI-compatible backends: vision chat as VQA, chat as the language model (spec `openai:MODEL`).

Any server that speaks the chat-completions API works by base URL: OpenAI (GPT-4o), vLLM, Ollama,
llama.cpp. The image goes in the message as a base64 PNG data URL. The endpoint and key are the ones the
LLM planner uses (`llm_base_url`, `llm_api_key`), through the one shared client (`openai_client.py`).
"""

from __future__ import annotations

import base64
import io
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING, Any

import numpy as np

from attribot.config import revealed
from attribot.errors import ConfigError, InputError
from attribot.frame import Frame, check_rgb
from attribot.models.base import LANGUAGE_MODELS, UNKNOWN, VQAS
from attribot.models.openai_client import chat_text, make_client

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = [
    "VQA_SYSTEM_PROMPT",
    "LANGUAGE_SYSTEM_PROMPT",
    "image_data_url",
    "clean_answer",
    "OpenAIVisualQA",
    "OpenAILanguageModel",
    "probe_endpoint",
    "build_openai_vqa",
    "build_openai_language",
]

VQA_SYSTEM_PROMPT = (
    "You answer questions about the image you are shown. Reply with a short answer only: a word, a "
    "number or a short phrase, no explanation. If the image does not show enough to answer, reply "
    f"exactly: {UNKNOWN}"
)
LANGUAGE_SYSTEM_PROMPT = (
    "You answer questions about everyday objects from common knowledge. Reply with a short answer only: a "
    f"word, a number or a short phrase, no explanation. If you cannot tell, reply exactly: {UNKNOWN}"
)


def image_data_url(rgb: np.ndarray) -> str:
    """`data:image/png;base64,...` of a uint8 (H, W, 3) RGB array (lossless, as the model sees the frame)."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(check_rgb(rgb), mode="RGB").save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def clean_answer(text: str) -> str:
    """The first line of a reply, without quotes or a final full stop; `UNKNOWN` when nothing is left."""
    lines = [line.strip() for line in text.strip().splitlines() if line.strip()]
    answer = lines[0].strip("\"'` ") if lines else ""
    if answer.endswith(".") and not answer.endswith(".."):
        answer = answer[:-1].rstrip()
    if not answer or answer.lower() == UNKNOWN:
        return UNKNOWN
    return answer


def _question(question: str) -> str:
    if not isinstance(question, str) or not question.strip():
        raise InputError(f"question {question!r} is empty or not a string", "ask a question in words")
    return question.strip()


class _ChatBackend:
    """What both chat backends share: one client, one model, the sampling settings."""

    def __init__(
        self,
        model: str,
        *,
        base_url: str | None = None,
        api_key: str | None = None,
        timeout_s: float = 60.0,
        temperature: float = 0.0,
        max_retries: int = 2,
        max_workers: int = 8,
    ) -> None:
        if not model or not model.strip():
            raise ConfigError(
                "the openai backend needs a model name", "write openai:MODEL, e.g. openai:gpt-4o"
            )
        self.model = model.strip()
        self.name = f"openai:{self.model}"
        self.temperature = float(temperature)
        self.max_workers = max(1, int(max_workers))
        self.retries = max(0, int(max_retries))
        self.client = make_client(base_url, api_key, timeout_s)

    def _chat(self, messages: list[dict[str, Any]]) -> str:
        return clean_answer(
            chat_text(self.client, self.model, messages, self.retries, temperature=self.temperature)
        )

    def _map(self, fn: Any, items: Sequence[Any]) -> list[str]:
        """Calls in parallel threads (the server batches many at once); order kept, first error raised."""
        if len(items) <= 1:
            return [fn(it) for it in items]
        with ThreadPoolExecutor(max_workers=min(self.max_workers, len(items))) as pool:
            return list(pool.map(fn, items))


class OpenAIVisualQA(_ChatBackend):
    """Visual question answering by a vision chat model; the frame travels as a PNG data URL."""

    def messages(self, frame: Frame, question: str) -> list[dict[str, Any]]:
        """The chat messages sent for one question (exposed for tests and for logging)."""
        return [
            {"role": "system", "content": VQA_SYSTEM_PROMPT},
            {
                "role": "user",
                "content": [
                    {"type": "text", "text": _question(question)},
                    {"type": "image_url", "image_url": {"url": image_data_url(frame.rgb)}},
                ],
            },
        ]

    def answer(self, frame: Frame, question: str) -> str:
        """A short answer to `question` about `frame`, `UNKNOWN` when the model cannot tell."""
        return self._chat(self.messages(frame, question))

    def answer_batch(self, frames: Sequence[Frame], questions: Sequence[str]) -> list[str]:
        """One answer per (frame, question) pair, requested concurrently."""
        if len(frames) != len(questions):
            raise InputError(
                f"answer_batch got {len(frames)} frames and {len(questions)} questions",
                "pass one question per frame",
            )
        msgs = [
            self.messages(f, q) for f, q in zip(frames, questions, strict=True)
        ]  # input errors before any call
        return self._map(self._chat, msgs)


class OpenAILanguageModel(_ChatBackend):
    """Text questions answered by a chat model (the `language_query` role)."""

    def messages(self, question: str) -> list[dict[str, Any]]:
        """The chat messages sent for one question."""
        return [
            {"role": "system", "content": LANGUAGE_SYSTEM_PROMPT},
            {"role": "user", "content": _question(question)},
        ]

    def complete(self, question: str) -> str:
        """A short answer to `question`, `UNKNOWN` when the model cannot tell."""
        return self._chat(self.messages(question))


def _client_args(settings: Settings) -> dict[str, Any]:
    return {
        "base_url": settings.llm_base_url,
        "api_key": revealed(settings.llm_api_key),
        "timeout_s": settings.llm_timeout_s,
        "temperature": settings.llm_temperature,
        "max_retries": settings.llm_retries,
    }


def _model_of(arg: str | None, settings: Settings) -> str:
    # `openai` alone means the planner's model: one endpoint, one model is the common local setup
    return arg or settings.llm_model


def build_openai_vqa(arg: str | None, settings: Settings) -> OpenAIVisualQA:
    """`openai:MODEL` VQA on the settings' endpoint (`openai` alone uses `llm_model`)."""
    return OpenAIVisualQA(_model_of(arg, settings), **_client_args(settings))


def build_openai_language(arg: str | None, settings: Settings) -> OpenAILanguageModel:
    """`openai:MODEL` language model on the settings' endpoint (`openai` alone uses `llm_model`)."""
    return OpenAILanguageModel(_model_of(arg, settings), **_client_args(settings))


def probe_endpoint(arg: str | None, settings: Settings, timeout_s: float = 3.0) -> tuple[bool | None, str]:
    """Whether the endpoint answers `GET /models` within `timeout_s` (no retries), and lists the model."""
    import openai

    model = _model_of(arg, settings)
    client = make_client(settings.llm_base_url, revealed(settings.llm_api_key), timeout_s)
    where = str(client.base_url)
    try:
        ids = [m.id for m in client.models.list()]
    except openai.AuthenticationError:
        return False, f"{where} refused the API key (401): set ATTRIBOT_LLM_API_KEY"
    except openai.APITimeoutError:
        return False, f"{where} did not answer within {timeout_s:g} s"
    except openai.APIConnectionError:
        return False, f"cannot reach {where}: check ATTRIBOT_LLM_BASE_URL and that the server runs"
    except openai.APIStatusError as exc:
        return False, f"{where} answered HTTP {exc.status_code} to /models"
    except openai.APIError as exc:
        return False, f"{where} gave an unusable /models answer: {str(exc)[:120]}"
    finally:
        client.close()
    if model in ids:
        return True, f"{where} serves {model}"
    listed = ", ".join(ids[:5]) + (", ..." if len(ids) > 5 else "")
    return True, f"{where} answers, but does not list {model} (it lists: {listed or 'nothing'})"


build_openai_vqa.probe = probe_endpoint  # type: ignore[attr-defined]
build_openai_language.probe = probe_endpoint  # type: ignore[attr-defined]
VQAS.register("openai")(build_openai_vqa)
LANGUAGE_MODELS.register("openai")(build_openai_language)
