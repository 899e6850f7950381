"""Configuration: defaults, overridden by a TOML file, overridden by `ATTRIBOT_*` environment variables.

The file is `./attribot.toml`, or the path in `ATTRIBOT_CONFIG`. Nothing is read at import time; call
`load_settings()` when a command starts. Every run saves the resolved settings beside its results.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from pydantic import Field
from pydantic_settings import (
    BaseSettings,
    PydanticBaseSettingsSource,
    SettingsConfigDict,
    TomlConfigSettingsSource,
)

__all__ = ["Settings", "load_settings"]


class Settings(BaseSettings):
    """Resolved configuration of attribot. Backend specs: `oracle`, `catalog`, `hf:MODEL`,
    `openai:MODEL`, `remote:URL`."""

    model_config = SettingsConfigDict(env_prefix="ATTRIBOT_", extra="forbid", validate_default=True)

    # perception backends, one spec per role
    detector: str = "oracle"
    vqa: str = "oracle"
    language: str = "catalog"

    # planner and the OpenAI-compatible endpoint it (and openai: backends) talk to
    planner: str = "rules"
    llm_base_url: str | None = None
    llm_model: str = "gpt-4o"
    llm_api_key: str | None = Field(default=None, repr=False)
    llm_timeout_s: float = 60.0
    llm_max_tries: int = 3
    llm_temperature: float = 0.0

    # transformers backends
    hf_device: str = "auto"
    hf_dtype: str = "auto"
    detector_threshold: float = 0.1

    # remote model server
    remote_token: str | None = Field(default=None, repr=False)
    remote_timeout_s: float = 30.0

    cache_dir: Path = Path(".attribot-cache")

    @classmethod
    def settings_customise_sources(
        cls,
        settings_cls: type[BaseSettings],
        init_settings: PydanticBaseSettingsSource,
        env_settings: PydanticBaseSettingsSource,
        dotenv_settings: PydanticBaseSettingsSource,
        file_secret_settings: PydanticBaseSettingsSource,
    ) -> tuple[PydanticBaseSettingsSource, ...]:
        path = Path(os.environ.get("ATTRIBOT_CONFIG", "attribot.toml"))
        sources: list[PydanticBaseSettingsSource] = [init_settings, env_settings]
        if path.is_file():
            sources.append(TomlConfigSettingsSource(settings_cls, toml_file=path))
        return tuple(sources)

    def public_dict(self) -> dict[str, Any]:
        """The settings as JSON-ready data, with secrets left out: what a run saves."""
        data = self.model_dump(mode="json")
        for secret in ("llm_api_key", "remote_token"):
            data[secret] = None if data.get(secret) is None else "***"
        return data


def load_settings(**overrides: Any) -> Settings:
    """Settings from file and environment; keyword arguments (CLI flags) win over both."""
    return Settings(**{k: v for k, v in overrides.items() if v is not None})
