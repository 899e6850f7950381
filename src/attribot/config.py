"""Configuration: the backend settings of a run, and the scene a query runs in.

`Settings` come from defaults, overridden by a TOML file, overridden by `ATTRIBOT_*` environment variables.
The file is `./attribot.toml`, or the path in `ATTRIBOT_CONFIG`. Nothing is read at import time; call
`load_settings()` when a command starts. Every run saves the resolved settings beside its results.

`SceneConfig` is the one description of a simulated scene (layout, seed, objects, options, camera size,
render profile): the CLI builds it from its flags, datasets store it, and the MuJoCo world is built from it.
Every world has one typed config, tagged with the world's name in its `world` field and registered under
it in `WORLD_CONFIGS` (mujoco: `SceneConfig`, bridge: `BridgeConfig`, ai2thor: `Ai2ThorConfig`); the world
of the same name in `attribot.embodiments.base.EMBODIMENTS` is built from it. `WorldConfig` is their union,
told apart by the tag; `world_config(data)` reads any registered world's config from data the same way.

Errors name a field as the caller spells it: `create(..., naming=...)` takes a `FieldNaming` (the CLI's
names its flags, the Python API's its keywords), so that no flag name lives here.
"""

from __future__ import annotations

import contextvars
import os
import re
import types
import typing
import urllib.parse
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    PlainSerializer,
    SecretStr,
    Tag,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_settings import (
    BaseSettings,
    PydanticBaseSettingsSource,
    SettingsConfigDict,
    TomlConfigSettingsSource,
)

from attribot.errors import ConfigError, InputError, InvalidSetting, InvalidValue
from attribot.files import not_a_file, read_capped
from attribot.mechanisms import Mechanism, parse_checks
from attribot.noise import PerceptionNoise, WorldNoise
from attribot.priors import SCALE_RANGE as PRIORS_SCALE
from attribot.registry import Registry
from attribot.text import comma_names, one_of, plain_value, shown_url

__all__ = [
    "Settings",
    "load_settings",
    "config_path",
    "SceneConfig",
    "SCENE_CHECKS",
    "BridgeConfig",
    "Ai2ThorConfig",
    "WorldConfig",
    "WORLD_CONFIGS",
    "register_world_config",
    "world_config",
    "FieldNaming",
    "KEYWORDS",
    "MAX_OBJECTS",
    "MAX_QUERY_CHARS",
    "MAX_SEED",
    "MAX_TIME_S",
    "RENDER_PROFILES",
    "SECRETS",
    "MAX_SETTINGS_BYTES",
    "plain_input",
    "revealed",
    "PROMPTS",
    "CommandLine",
]

MAX_QUERY_CHARS = 500
"""Longer queries are refused: the paper's queries are under 80 characters, and a prompt is no place for
a pasted document. Defined here, below the API and the planners, so that reading a query imports neither."""
MAX_OBJECTS = 30
"""The most objects any layout places (each layout states its own, smaller range)."""
MAX_SEED = 2**32 - 1
MAX_TIME_S = 86_400.0
"""The longest time setting accepted (a day): longer ones overflow the clocks and sockets they reach."""
RENDER_PROFILES = ("fast", "pretty")
"""fast: no shadows or reflections; pretty: both (see `attribot.sim.render.PROFILES`)."""
PROMPTS = ("attribot", "paper")
"""The prompts the LLM planner can show (`attribot.api.prompt.PROMPTS`): attribot, generated from the API;
paper, the structure of the paper authors' released prompt, in the paper's dialect."""
OBJECT_LOOKS = ("detailed", "primitive")
"""detailed: objects that look like their category; primitive: their body primitives (see
`attribot.sim.looks`)."""
MAX_SETTINGS_BYTES = 1_000_000
"""The largest settings file read (attribot's settings fill a few hundred bytes)."""
MAX_SECRET_CHARS = 4096
MAX_TEXT_SETTING_CHARS = 4096
"""The longest text setting (a URL, a model name, a backend spec): longer ones are no such thing."""


@dataclass(frozen=True)
class CommandLine:
    """How a described field shows on the command line. Every field of `Settings` and `SceneConfig` with a
    description is a flag of the commands that take it (`attribot.cli.flags.field_flags`): `--FIELD-NAME`,
    unset by default (the settings file's or the config's default then holds), its help the description.
    This marker, in the field's `Annotated` metadata, adds what the field itself cannot say: the placeholder
    of its value in --help (default: from its type), and for a setting its group, `run` or `planner`
    (`attribot exec` runs a given program and takes no planner flag)."""

    metavar: str | None = None
    group: str = "run"


def _read_checks(value: Any) -> Any:
    """The mechanisms `checks` names: text as `--checks` and the settings file write it ("all,-reset"),
    read here once, or mechanisms already chosen in code (a run condition's)."""
    if isinstance(value, tuple | frozenset | set) and all(isinstance(m, Mechanism) for m in value):
        return tuple(m for m in Mechanism if m in value)
    if not isinstance(value, str):
        raise ValueError("give the checks as text: all, none, or comma-separated names")
    if len(value) > MAX_TEXT_SETTING_CHARS:
        raise ValueError(f"it is {len(value)} characters long, more than {MAX_TEXT_SETTING_CHARS}")
    try:
        return parse_checks(value)
    except InputError as exc:
        raise ValueError(str(exc)) from None


def _checks_text(mechanisms: tuple[Mechanism, ...]) -> str:
    """The checks as a settings file and a saved run write them: all, none, or the names."""
    return "all" if set(mechanisms) == set(Mechanism) else ",".join(mechanisms) or "none"


Checks = Annotated[
    tuple[Mechanism, ...], BeforeValidator(_read_checks), PlainSerializer(_checks_text, return_type=str)
]
"""The error-catching mechanisms switched on, in their order: typed in a run, written as text."""


def _numeric(annotation: Any) -> bool:
    """Whether a field's type is a number (int, float, or one of them or None)."""
    if annotation in (int, float):
        return True
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        return any(a in (int, float) for a in typing.get_args(annotation))
    return False


def plain_input(model: type[BaseModel], name: str | None, value: Any) -> Any:
    """The one check of every config and settings field's input before its type's own (`plain_value`)."""
    if name is None:
        return value
    return plain_value(value, number=_numeric(model.model_fields[name].annotation))


class Settings(BaseSettings):
    """Resolved configuration of attribot. Backend specs: `oracle`, `catalog`, `hf:MODEL`,
    `openai:MODEL`, `remote:URL`."""

    model_config = SettingsConfigDict(
        env_prefix="ATTRIBOT_", extra="forbid", validate_default=True, hide_input_in_errors=True
    )

    # perception backends, one spec per role
    detector: Annotated[str, CommandLine("SPEC")] = Field(
        "oracle", description="Detector backend spec (oracle, coco, yolov5s, hf:MODEL, remote:URL)."
    )
    vqa: Annotated[str, CommandLine("SPEC")] = Field(
        "oracle", description="VQA backend spec (oracle, hf:MODEL, openai:MODEL, remote:URL)."
    )
    language: Annotated[str, CommandLine("SPEC")] = Field(
        "catalog", description="Language backend spec (catalog, openai:MODEL, remote:URL)."
    )

    # planner and the OpenAI-compatible endpoint it (and openai: backends) talk to
    planner: Annotated[str, CommandLine("NAME", "planner")] = Field(
        "rules", description="rules (offline, default) or llm."
    )
    llm_base_url: Annotated[str | None, CommandLine("URL", "planner")] = Field(
        None, description="OpenAI-compatible endpoint."
    )
    llm_model: Annotated[str, CommandLine("NAME", "planner")] = Field(
        "gpt-4o", description="Model name at that endpoint."
    )
    llm_api_key: SecretStr | None = Field(default=None, repr=False)  # see SECRETS
    llm_timeout_s: Annotated[float, CommandLine("SECONDS", "planner")] = Field(
        300.0,
        gt=0,
        le=MAX_TIME_S,
        allow_inf_nan=False,
        description="Seconds one request to the LLM endpoint may take (a local model's first request reads "
        "the whole prompt: minutes on a CPU); a request that times out is not sent again.",
    )
    llm_max_tokens: Annotated[int, CommandLine("TOKENS", "planner")] = Field(
        2048,
        ge=0,
        le=1_000_000,
        description="The longest reply asked of the LLM, in tokens (sent as max_tokens; 2048 holds a "
        "program with room to spare); 0 sends none, and the server decides.",
    )
    llm_retries: Annotated[int, CommandLine("N", "planner")] = Field(
        2,
        ge=0,
        le=10,
        description="Times a request to the LLM endpoint is sent again where the server did no work for it "
        "(no connection, 429, 5xx); never after a timeout. The client library's own retries are off.",
    )
    llm_max_tries: Annotated[int, CommandLine("N", "planner")] = Field(
        3,
        ge=1,
        le=100,
        description="Programs the llm planner may write for one query: the first, and each retry after a "
        "failed one with its error fed back.",
    )
    llm_temperature: float = Field(0.0, ge=0, le=2, allow_inf_nan=False)
    # the prompt the LLM planner shows (PROMPTS): recorded with every answer and evaluation record
    prompt: Annotated[str, CommandLine("NAME", "planner")] = Field(
        "attribot",
        description="The prompt the llm planner shows: attribot (default; generated from the API) or paper "
        "(the structure of the paper authors' released prompt).",
    )

    # transformers backends
    hf_device: str = "auto"
    hf_dtype: str = "auto"
    detector_threshold: float = Field(0.1, ge=0, le=1, allow_inf_nan=False)
    # the coco detector's files (`attribot fetch coco`); None: inside the Python environment
    coco_dir: Path | None = None
    # the yolov5s detector's files (`attribot fetch yolov5s`); None: inside the Python environment
    yolov5_dir: Path | None = None

    # remote model server
    remote_token: SecretStr | None = Field(default=None, repr=False)
    remote_timeout_s: float = Field(30.0, gt=0, le=MAX_TIME_S, allow_inf_nan=False)

    # the mechanisms that catch perception and action errors (attribot.skills.safeguards)
    checks: Annotated[Checks, CommandLine("NAMES")] = Field(
        "all",  # type: ignore[arg-type]  # text, read by `Checks` as every other source's
        description="Error-catching mechanisms: all (default), none, or names (look_again, verify_actions, "
        "remeasure, confidence, reset); all,-NAME leaves one out.",
    )
    strategies: Annotated[str, CommandLine("NAMES")] = Field(
        "",
        description="Registered strategies (attribot.skills.safeguards.STRATEGIES, from a plug-in) to use in "
        "place of their mechanisms' own, comma-separated names (default: none).",
    )
    # the perception noise an evaluation condition puts on the oracle backends for one item (its preset and
    # the item's seed); None: only what their specs ask for (`oracle?noise=realistic`)
    perception_noise: PerceptionNoise | None = None
    priors_scale: Annotated[float, CommandLine("FACTOR")] = Field(
        1.0,
        ge=PRIORS_SCALE[0],
        le=PRIORS_SCALE[1],
        allow_inf_nan=False,
        description="Scale every size, height and span of the mechanisms' perception priors "
        f"(attribot.priors) by this factor, {PRIORS_SCALE[0]} to {PRIORS_SCALE[1]} (default 1: the table as "
        "written), for an ablation on how much they lean on those numbers.",
    )
    guesses: Annotated[Literal["say", "refuse"], CommandLine("say|refuse")] = Field(
        "say",
        description="An answer whose object rests on a guess (a faint box, elimination, a look-alike that no "
        "nearer look confirmed, or an object chosen over one): say (default: the answer names it and says "
        "plainly that it is a guess) or refuse (no answer: nothing was found surely, for a robot that must "
        "not act on a guess).",
    )
    program_wall_s: Annotated[float, CommandLine("SECONDS")] = Field(
        60.0,
        gt=0,
        le=MAX_TIME_S,
        allow_inf_nan=False,
        description="Wall-clock seconds one program may run, API calls and robot actions included (default "
        "60; more on a real robot or with a real detector on a CPU).",
    )

    cache_dir: Path = Path(".attribot-cache")

    def __init__(self, **values: Any) -> None:
        """Settings from `values`, the ATTRIBOT_* variables and the settings file; a bad one raises
        `InvalidSetting` naming it and where it came from (`load_settings` is the usual way in)."""
        try:
            super().__init__(**values)
        except ValidationError as exc:
            error = _setting_error(exc, values, KEYWORDS)
            error.validation = exc  # type: ignore[attr-defined]  # load_settings names it its own way
            raise error from None

    @field_validator("*", mode="before")
    @classmethod
    def _plain(cls, value: Any, info: ValidationInfo) -> Any:
        return plain_input(cls, info.field_name, value)

    @field_validator(
        "detector", "vqa", "language", "planner", "llm_model", "hf_device", "hf_dtype", "strategies"
    )
    @classmethod
    def _short_text(cls, value: str) -> str:
        if len(value) > MAX_TEXT_SETTING_CHARS:
            raise ValueError(f"it is {len(value)} characters long, more than {MAX_TEXT_SETTING_CHARS}")
        return value

    @field_validator("strategies")
    @classmethod
    def _strategy_names(cls, value: str) -> str:
        bad = [n for n in comma_names(value) if not re.fullmatch(r"[\w.-]+", n)]
        if bad:
            raise ValueError(f"{bad[0]!r} is no strategy name (letters, digits, _ . -, comma-separated)")
        return value

    @property
    def mechanisms(self) -> frozenset[Mechanism]:
        """The error-catching mechanisms `checks` switches on."""
        return frozenset(self.checks)

    @field_validator("llm_base_url")
    @classmethod
    def _http_url(cls, value: str | None) -> str | None:
        if value is None:
            return None
        if len(value) > MAX_TEXT_SETTING_CHARS:
            raise ValueError(f"it is {len(value)} characters long, more than {MAX_TEXT_SETTING_CHARS}")
        if any(c.isspace() for c in value):
            raise ValueError("it holds a space, which no URL does")
        try:
            parts = urllib.parse.urlsplit(value)
            parts.port  # noqa: B018 (a port out of range raises here)
            host = parts.hostname or ""
            host.encode("idna")
        except (ValueError, UnicodeError):
            raise ValueError("it is not a URL (its host or port cannot be read)") from None
        if parts.scheme not in ("http", "https") or not host:
            raise ValueError("it is not an http(s) URL with a host, e.g. http://127.0.0.1:8000/v1")
        return value

    @field_validator("llm_api_key", "remote_token")
    @classmethod
    def _header_safe(cls, value: SecretStr | None) -> SecretStr | None:
        # it travels in an HTTP header: visible ASCII only (a space, a newline or an accent breaks the
        # request, or splits the header)
        if value is None or not value.get_secret_value():  # ATTRIBOT_LLM_API_KEY= (empty) sets none
            return None
        text = value.get_secret_value()
        if len(text) > MAX_SECRET_CHARS or not all("!" <= c <= "~" for c in text):
            raise ValueError(
                f"a key or token is 1 to {MAX_SECRET_CHARS} visible ASCII characters, with no space, "
                "accent or control character"
            )
        return value

    @classmethod
    def settings_customise_sources(
        cls,
        settings_cls: type[BaseSettings],
        init_settings: PydanticBaseSettingsSource,
        env_settings: PydanticBaseSettingsSource,
        dotenv_settings: PydanticBaseSettingsSource,
        file_secret_settings: PydanticBaseSettingsSource,
    ) -> tuple[PydanticBaseSettingsSource, ...]:
        path = config_path()
        sources: list[PydanticBaseSettingsSource] = [init_settings, env_settings]
        if path is not None:
            sources.append(TomlConfigSettingsSource(settings_cls, toml_file=path))
        return tuple(sources)

    @field_validator("prompt")
    @classmethod
    def _known_prompt(cls, value: str) -> str:
        return one_of(value, PROMPTS, "prompt")

    def public_dict(self) -> dict[str, Any]:
        """The settings as JSON-ready data, with secrets left out: what a run saves."""
        data = {k: shown_url(v) if isinstance(v, str) else v for k, v in self.model_dump(mode="json").items()}
        for secret in SECRETS:  # and a password in a URL (remote:http://user:pw@host) is left out too
            data[secret] = None if data.get(secret) is None else "***"
        return data


def revealed(secret: SecretStr | None) -> str | None:
    """The text of a secret setting, where it is sent (an HTTP header); None when it is not set."""
    return None if secret is None else secret.get_secret_value()


SECRETS = tuple(name for name, f in Settings.model_fields.items() if f.annotation == SecretStr | None)
"""The settings that hold secrets (typed `SecretStr`: masked wherever they are shown, read only with
`.get_secret_value()` where they are sent), never saved and never echoed in an error."""


def config_path() -> Path | None:
    """The settings file: `$ATTRIBOT_CONFIG` (which must name a file), else `./attribot.toml` if present."""
    named = os.environ.get("ATTRIBOT_CONFIG")
    if named is None:
        path = Path("attribot.toml")
        return path if path.is_file() else None
    path = Path(named).expanduser()
    what = not_a_file(path)  # a FIFO or /dev/zero is named as such, and never opened
    if what is not None:
        raise ConfigError(
            f"ATTRIBOT_CONFIG names {named!r}, which is {what}, not a settings file",
            "point ATTRIBOT_CONFIG at a TOML file, or unset it to use ./attribot.toml",
        )
    return path


def load_settings(naming: FieldNaming | None = None, **overrides: Any) -> Settings:
    """Settings from file and environment; keyword arguments (CLI flags) win over both.

    A file that is not UTF-8 TOML, an unknown key or a bad value is an `InvalidSetting` that names the
    setting and where it came from (the given value as `naming` spells it, the ATTRIBOT_* variable or the
    file); a secret's value is never shown."""
    given = {k: v for k, v in overrides.items() if v is not None}
    path = config_path()
    if path is not None:
        _check_toml(path)
    try:
        return Settings(**given)
    except InvalidSetting as exc:
        raise _setting_error(exc.validation, given, naming or KEYWORDS) from None  # type: ignore[attr-defined]


def _setting_error(exc: ValidationError, given: dict[str, Any], naming: FieldNaming) -> InvalidSetting:
    """The first error of `exc` as an `InvalidSetting` naming the setting and its source, and the fix."""
    first = exc.errors()[0]
    name = ".".join(str(p) for p in first.get("loc", ())) or "settings"
    env = f"ATTRIBOT_{name.upper()}"
    path = config_path()
    if name in given:
        source = naming.name(name)
    elif any(k.upper() == env for k in os.environ):
        source = f"the environment variable {env}"
    else:
        source = f"the settings file {str(path)!r}" if path is not None else "the defaults"
    if first.get("type") == "extra_forbidden":
        known = ", ".join(Settings.model_fields)
        return InvalidSetting(
            f"{source} has an unknown setting {shown_url(name)[:100]!r}",
            f"remove it; the settings are: {known}",
        )
    value = first.get("input")
    if name in SECRETS:
        kind = (
            "a secret, not shown"
            if isinstance(value, str | SecretStr)
            else f"not text: {type(value).__name__}"
        )
        shown = f"({kind})"
    else:
        text = shown_url(repr(value))
        shown = text if len(text) <= 200 else text[:197] + "..."
    message = str(first.get("msg", "invalid")).removeprefix("Value error, ")
    return InvalidSetting(
        f"setting {name} = {shown} (from {source}) is not valid: {message}",
        f"fix {name} in {source}; `attribot backends` shows the resolved configuration",
    )


def _check_toml(path: Path) -> None:
    """A settings file that cannot be read as UTF-8 TOML is a `ConfigError` naming the file and the line."""
    import tomllib

    try:
        data = read_capped(
            path, "the settings file", MAX_SETTINGS_BYTES, "attribot's settings are a few lines"
        )
    except InputError as exc:
        raise ConfigError(exc.message, exc.fix) from None
    try:
        tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"the settings file {str(path)!r} is not UTF-8 text (byte {exc.start})", "save it as UTF-8"
        ) from None
    except RecursionError:
        raise ConfigError(
            f"the settings file {str(path)!r} nests arrays or tables too deeply to read",
            "attribot's settings are flat `key = value` lines; remove the nesting",
        ) from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(
            f"the settings file {str(path)!r} is not valid TOML: {exc}",
            'write one `key = value` per line, strings in quotes, e.g. planner = "rules"',
        ) from None


class FieldNaming:
    """How a caller spells a config field in messages: `name("seed")` is "seed=" for the Python API;
    the CLI passes one that gives its flags ("--seed"). `example(field, value)` is "seed=7" or "--seed 7"."""

    def __init__(self, name: Callable[[str], str], example: Callable[[str, str], str]) -> None:
        self.name = name
        self.example = example


KEYWORDS = FieldNaming(lambda field: f"{field}=", lambda field, value: f"{field}={value}")
"""Fields named as Python keywords: what `attribot.ask(..., seed=7)` and the configs take."""

OptionValue = str | int | float | bool


_NAMING: contextvars.ContextVar[FieldNaming | None] = contextvars.ContextVar("naming", default=None)


class _WorldConfig(BaseModel):
    """What every world's config shares: a bad field, given to the constructor or to `create`, is an
    `InvalidValue` (an `InputError`, and a ValueError) that names it as the caller spells it, with its limits
    and the fix; true or false is no number, and text holds no undecodable byte or control character."""

    WHAT: ClassVar[str] = "world"
    REACHES_OUT: ClassVar[str | None] = None
    """What building this world does beyond this process (None: nothing): a saved folder naming such a
    world is replayed only with trust (`attribot.saved_runs.TRUST_SAVED`)."""

    def __init__(self, **fields: Any) -> None:
        try:
            super().__init__(**fields)
        except ValidationError as exc:
            raise _invalid(type(self), exc, _NAMING.get() or KEYWORDS) from None

    @classmethod
    def create(cls, naming: FieldNaming | None = None, **fields: Any) -> Any:
        """A validated config; a bad field raises `InvalidValue` naming it (as `naming` spells it), its
        limits and the fix."""
        given = _NAMING.set(naming)  # read by __init__, which pydantic also calls from model_validate
        try:
            return cls(**fields)
        finally:
            _NAMING.reset(given)

    @field_validator("*", mode="before")
    @classmethod
    def _plain(cls, value: Any, info: ValidationInfo) -> Any:
        return plain_input(cls, info.field_name, value)

    @classmethod
    def world_name(cls) -> str:
        """The world this config is for: its `world` tag, which tells the configs of a `WorldConfig` apart."""
        return str(cls.model_fields["world"].default)

    @classmethod
    def settable(cls) -> tuple[str, ...]:
        """The fields a caller sets: all but the `world` tag."""
        return tuple(name for name in cls.model_fields if name != "world")


class SceneConfig(_WorldConfig):
    """Where a query runs in the embedded world: the layout and seed, and what overrides the layout's choice.

    layout: "household" | "arrangement" | "triplet" (see `attribot.sim.scene`); seed: the same seed gives
    the same scene and pixels; objects / categories: override the layout's choice; vocabulary: the only
    categories the layout may draw objects from (None: any of the catalog's), the layout's own rules
    applied within them (a household scene in the categories a closed-set detector can find, see
    `attribot.models.base.findable_categories`); options: layout
    options (e.g. {"pattern": "grid", "odd": "size"}); width, height: camera pixels; profile: "fast" or
    "pretty"; looks: "detailed" or "primitive" (how objects are drawn; physics and sensing are the same);
    force_noise_std: Gaussian noise of the wrist force sensor, newtons per axis; noise: the
    world's seeded imperfections of sensing and acting (`attribot.noise.WorldNoise`, presets by name);
    robot: "mast" (the default) or "ep" (RoboMaster-EP-like: its scenes put the objects on the floor).
    A bad field is an `InvalidValue` naming it (`SceneConfig.create(naming=...)` names it as a caller
    spells it).
    """

    WHAT: ClassVar[str] = "scene"
    model_config = ConfigDict(frozen=True, extra="forbid")

    world: Literal["mujoco"] = "mujoco"
    layout: Annotated[str, CommandLine("NAME")] = Field(
        "household", description="Scene layout: household (default), arrangement or triplet."
    )
    seed: Annotated[int, CommandLine("INT")] = Field(
        0,
        ge=0,
        le=MAX_SEED,
        strict=True,
        description=f"Scene seed (0 to {MAX_SEED}, default 0): the same seed gives the same scene and "
        "pixels.",
    )
    # bounded here, before any work (a million objects hung the layouts); each layout's range is narrower
    objects: Annotated[int | None, CommandLine("INT")] = Field(
        None,
        ge=1,
        le=MAX_OBJECTS,
        strict=True,
        description=f"Number of objects, 1 to {MAX_OBJECTS} (default: the layout chooses).",
    )
    categories: tuple[str, ...] | None = None
    vocabulary: tuple[str, ...] | None = None
    options: dict[str, OptionValue] = Field(default_factory=dict)
    width: Annotated[int, CommandLine("PX")] = Field(
        640, ge=16, le=4096, strict=True, description="Image width in pixels (default 640)."
    )
    height: Annotated[int, CommandLine("PX")] = Field(
        480, ge=16, le=4096, strict=True, description="Image height in pixels (default 480)."
    )
    profile: Annotated[str, CommandLine("NAME")] = Field(
        "fast", description="Render profile: fast (no shadows, default) or pretty."
    )
    force_noise_std: float = Field(0.0, ge=0.0, allow_inf_nan=False)
    noise: WorldNoise = Field(default_factory=WorldNoise)
    looks: str = "detailed"
    robot: Annotated[str, CommandLine("NAME")] = Field(
        "mast",
        description="The simulated robot: mast (default; a pan-tilt head and a telescoping arm) or ep "
        "(RoboMaster-EP-like: its camera on its arm, objects on the floor); any body attribot.sim.bodies "
        "registers.",
    )

    @field_validator("looks")
    @classmethod
    def _known_looks(cls, value: str) -> str:
        return one_of(value, OBJECT_LOOKS, "object looks")

    @field_validator("profile")
    @classmethod
    def _known_profile(cls, value: str) -> str:
        return one_of(value, RENDER_PROFILES, "render profile")

    @model_validator(mode="after")
    def _drawable(self) -> SceneConfig:
        # the checks across fields (the layout's options, what the robot's body fits and holds, the
        # vocabulary) read the simulator's catalog and layouts, above this layer: they are registered there
        for _name, check in SCENE_CHECKS.items():
            check(self)
        return self

    def describe(self) -> dict[str, Any]:
        """The fields that differ from the defaults, always with layout and seed: what answers record."""
        data = self.model_dump(mode="json", exclude_defaults=True)
        return {"layout": self.layout, "seed": self.seed, **data}


SCENE_CHECKS: Registry[Callable[[SceneConfig], None]] = Registry(
    "scene check", modules=("attribot.sim.scene",)
)
"""The checks across a `SceneConfig`'s fields, each raising an `InputError` that names the fix; every
`SceneConfig` passes them as it is made."""


class BridgeConfig(_WorldConfig):
    """A robot behind `attribot bridge serve`: its address `url` (tcp://HOST:PORT) and the time-out of
    one request. The shared token is never part of a config (it comes from ATTRIBOT_BRIDGE_TOKEN), so a
    saved run holds no secret."""

    WHAT: ClassVar[str] = "bridge"
    REACHES_OUT: ClassVar[str | None] = "it acts on the robot at its address and sends ATTRIBOT_BRIDGE_TOKEN"
    model_config = ConfigDict(frozen=True, extra="forbid")

    world: Literal["bridge"] = "bridge"
    url: str = Field(pattern=r"^tcp://[^:/]+:\d+$")
    timeout_s: float = Field(10.0, gt=0, le=MAX_TIME_S, allow_inf_nan=False)

    def describe(self) -> dict[str, Any]:
        return {"url": self.url, **self.model_dump(mode="json", exclude_defaults=True, exclude={"url"})}


class Ai2ThorConfig(_WorldConfig):
    """An AI2-THOR scene: its name (FloorPlan1 to FloorPlan430), camera pixels and field of view."""

    WHAT: ClassVar[str] = "ai2thor"
    REACHES_OUT: ClassVar[str | None] = "its first run downloads a Unity build and executes it"
    model_config = ConfigDict(frozen=True, extra="forbid")

    world: Literal["ai2thor"] = "ai2thor"
    scene: str = "FloorPlan1"
    width: int = Field(640, ge=16, le=4096, strict=True)
    height: int = Field(480, ge=16, le=4096, strict=True)
    fov_deg: float = Field(90.0, gt=0, lt=180, allow_inf_nan=False)

    def describe(self) -> dict[str, Any]:
        return {"scene": self.scene, **self.model_dump(mode="json", exclude_defaults=True)}


def _world_tag(value: Any) -> str:
    """A world config's tag, given as data (none: mujoco's) or as a config."""
    if isinstance(value, dict):
        return str(value.get("world") or "mujoco")
    return str(getattr(value, "world", "mujoco"))


WorldConfig = Annotated[
    Annotated[SceneConfig, Tag("mujoco")] | Annotated[BridgeConfig, Tag("bridge")]
    | Annotated[Ai2ThorConfig, Tag("ai2thor")],
    Discriminator(_world_tag),
]  # fmt: skip
"""The built-in worlds' configs, told apart by their `world` tag (a plug-in world's too: `world_config`)."""
WORLD_CONFIGS: Registry[type[_WorldConfig]] = Registry("world")
"""The typed config of each world, under its `world` tag (the same names as `EMBODIMENTS`)."""


def register_world_config(kind: type[_WorldConfig], aliases: tuple[str, ...] = ()) -> type[_WorldConfig]:
    """Register a world's config under its `world` tag (a `Literal` field with that default)."""
    if "world" not in kind.model_fields or not isinstance(kind.model_fields["world"].default, str):
        raise ConfigError(
            f"{kind.__name__} has no world tag", 'give it a field world: Literal["NAME"] = "NAME"'
        )
    return WORLD_CONFIGS.register(kind.world_name(), aliases=aliases)(kind)


register_world_config(SceneConfig, aliases=("sim",))
register_world_config(BridgeConfig)
register_world_config(Ai2ThorConfig)


def world_config(data: dict[str, Any], naming: FieldNaming | None = None) -> Any:
    """The typed config `data` describes: its `world` tag (default mujoco) chooses the config, which
    checks the rest; an unknown world lists the known ones, a bad field is an `InvalidValue`."""
    fields = dict(data)
    kind = WORLD_CONFIGS.get(str(fields.pop("world", None) or "mujoco"))
    return kind.create(naming, **fields)


def _invalid(cls: Any, exc: ValidationError, naming: FieldNaming) -> InvalidValue:
    """The first error of `exc` as an `InvalidValue` naming the field as `naming` spells it, and the fix."""
    what = cls.WHAT
    first = exc.errors()[0]
    name = ".".join(str(p) for p in first.get("loc", ())) or what
    field = name.split(".")[0]
    value = shown_url(repr(first.get("input")))
    shown = naming.name(field) if field in cls.model_fields else name
    fix = _FIXES.get(field)
    message = str(first.get("msg", "invalid")).removeprefix("Value error, ")
    value = value if len(value) <= 200 else value[:197] + "..."
    return InvalidValue(
        f"{what} setting {name} ({shown}) = {value} is not valid: {message}",
        fix(naming) if fix else f"the {what} settings are: {', '.join(cls.settable())}",
    )


_FIXES: dict[str, Callable[[FieldNaming], str]] = {
    "seed": lambda n: f"give a whole number from 0 to {MAX_SEED}, e.g. {n.example('seed', '7')}",
    "objects": lambda n: (
        f"ask for 1 to {MAX_OBJECTS} objects (each layout has its own range within it), e.g. "
        + n.example("objects", "4")
    ),
    "width": lambda n: "give a width and height from 16 to 4096 pixels",
    "height": lambda n: "give a width and height from 16 to 4096 pixels",
    "profile": lambda n: f"choose one of: {', '.join(RENDER_PROFILES)}",
    "force_noise_std": lambda n: "give a finite standard deviation >= 0 N",
    "options": lambda n: f"write layout options as KEY=VALUE, e.g. {n.example('options', 'pattern=grid')}",
    "noise": lambda n: (
        f"give {n.name('noise')} a preset (clean, realistic, sensing, acting) or KEY=VALUE pairs"
    ),
    "categories": lambda n: (
        "name categories from `attribot scene info` or the catalog, e.g. "
        + n.example("categories", "mug,apple")
    ),
    "vocabulary": lambda n: (
        "give catalog category names, e.g. those a detector can find "
        "(attribot.models.base.findable_categories)"
    ),
    "url": lambda n: f"give the robot's address, e.g. {n.example('url', 'tcp://192.168.2.1:7777')}",
    "timeout_s": lambda n: "give a time-out in seconds, more than 0",
    "scene": lambda n: f"name an AI2-THOR scene, e.g. {n.example('scene', 'FloorPlan1')}",
    "fov_deg": lambda n: "give a field of view between 0 and 180 degrees",
}
