"""Configuration: the backend settings of a run, and the scene a query runs in.

`Settings` come from defaults, overridden by a TOML file, overridden by `ATTRIBOT_*` environment variables.
The file is `./attribot.toml`, or the path in `ATTRIBOT_CONFIG`. Nothing is read at import time; call
`load_settings()` when a command starts. Every run saves the resolved settings beside its results.

`SceneConfig` is the one description of a simulated scene (layout, seed, objects, options, camera size,
render profile): the CLI builds it from its flags, datasets store it, and the MuJoCo world is built from it.
Every world has one typed config, registered in `WORLD_CONFIGS` under the world's name (mujoco:
`SceneConfig`, bridge: `BridgeConfig`, ai2thor: `Ai2ThorConfig`); the world of the same name in
`attribot.embodiments.base.EMBODIMENTS` is built from it.

Errors name a field as the caller spells it: `create(..., naming=...)` takes a `FieldNaming` (the CLI's
names its flags, the Python API's its keywords), so that no flag name lives here.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator
from pydantic_settings import (
    BaseSettings,
    PydanticBaseSettingsSource,
    SettingsConfigDict,
    TomlConfigSettingsSource,
)

from attribot.errors import ConfigError, InputError
from attribot.files import not_a_file
from attribot.noise import WorldNoise
from attribot.registry import Registry

__all__ = [
    "Settings",
    "load_settings",
    "config_path",
    "SceneConfig",
    "BridgeConfig",
    "Ai2ThorConfig",
    "WORLD_CONFIGS",
    "FieldNaming",
    "KEYWORDS",
    "MAX_OBJECTS",
    "MAX_QUERY_CHARS",
    "MAX_SEED",
    "MAX_TIME_S",
    "RENDER_PROFILES",
    "ROBOTS",
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
ROBOTS = ("mast", "ep")
"""mast: the default mobile manipulator (a pan-tilt head on a mast, a telescoping arm on a lift); ep: a
RoboMaster-EP-like robot (its camera on a two-link arm, a gripper that reaches the floor, no depth camera;
see `attribot.sim.robot_ep`)."""
OBJECT_LOOKS = ("detailed", "primitive")
"""detailed: objects that look like their category; primitive: their body primitives (see
`attribot.sim.looks`)."""


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
    llm_timeout_s: float = Field(60.0, gt=0, le=MAX_TIME_S, allow_inf_nan=False)
    llm_max_tries: int = Field(3, ge=1, le=100)
    llm_temperature: float = Field(0.0, ge=0, le=2, allow_inf_nan=False)

    # transformers backends
    hf_device: str = "auto"
    hf_dtype: str = "auto"
    detector_threshold: float = Field(0.1, ge=0, le=1, allow_inf_nan=False)
    # the coco detector's files (`attribot fetch coco`); None: inside the Python environment
    coco_dir: Path | None = None

    # remote model server
    remote_token: str | None = Field(default=None, repr=False)
    remote_timeout_s: float = Field(30.0, gt=0, le=MAX_TIME_S, allow_inf_nan=False)

    # the mechanisms that catch perception and action errors (attribot.api.safeguards): "all", "none",
    # names, or "all,-look_again" to leave one out
    checks: str = "all"
    # the wall-clock seconds one program may run, its API calls and the robot's actions included: a real
    # robot, or a real detector on a CPU, needs more than the simulator with the oracle
    program_wall_s: float = Field(60.0, gt=0, le=MAX_TIME_S, allow_inf_nan=False)

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
        path = config_path()
        sources: list[PydanticBaseSettingsSource] = [init_settings, env_settings]
        if path is not None:
            sources.append(TomlConfigSettingsSource(settings_cls, toml_file=path))
        return tuple(sources)

    def public_dict(self) -> dict[str, Any]:
        """The settings as JSON-ready data, with secrets left out: what a run saves."""
        data = self.model_dump(mode="json")
        for secret in ("llm_api_key", "remote_token"):
            data[secret] = None if data.get(secret) is None else "***"
        return data


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

    A file that is not UTF-8 TOML, an unknown key or a bad value is a `ConfigError` that names the
    setting and where it came from (the given value as `naming` spells it, the ATTRIBOT_* variable or the
    file)."""
    given = {k: v for k, v in overrides.items() if v is not None}
    path = config_path()
    if path is not None:
        _check_toml(path)
    try:
        return Settings(**given)
    except ValidationError as exc:
        first = exc.errors()[0]
        name = ".".join(str(p) for p in first.get("loc", ())) or "settings"
        env = f"ATTRIBOT_{name.upper()}"
        if name in given:
            source = (naming or KEYWORDS).name(name)
        elif any(k.upper() == env for k in os.environ):
            source = f"the environment variable {env}"
        else:
            source = f"the settings file {str(path)!r}" if path is not None else "the defaults"
        value = first.get("input")
        if first.get("type") == "extra_forbidden":
            known = ", ".join(Settings.model_fields)
            raise ConfigError(
                f"{source} has an unknown setting {name!r}", f"remove it; the settings are: {known}"
            ) from None
        raise ConfigError(
            f"setting {name} = {value!r} (from {source}) is not valid: {first.get('msg', 'invalid')}",
            f"fix {name} in {source}; `attribot backends` shows the resolved configuration",
        ) from None


def _check_toml(path: Path) -> None:
    """A settings file that cannot be read as UTF-8 TOML is a `ConfigError` naming the file and the line."""
    import tomllib

    try:
        tomllib.loads(path.read_bytes().decode("utf-8"))
    except OSError as exc:
        raise ConfigError(
            f"the settings file {str(path)!r} cannot be read ({exc.strerror or exc})", "check its permissions"
        ) from None
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


class SceneConfig(BaseModel):
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
    Build it with `SceneConfig.create(...)` to get an `InputError` that names the bad field.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    layout: str = "household"
    seed: int = Field(0, ge=0, le=MAX_SEED, strict=True)
    objects: int | None = Field(None, ge=1, strict=True)  # the upper bound is each layout's own
    categories: tuple[str, ...] | None = None
    vocabulary: tuple[str, ...] | None = None
    options: dict[str, OptionValue] = Field(default_factory=dict)
    width: int = Field(640, ge=16, le=4096, strict=True)
    height: int = Field(480, ge=16, le=4096, strict=True)
    profile: str = "fast"
    force_noise_std: float = Field(0.0, ge=0.0, allow_inf_nan=False)
    noise: WorldNoise = Field(default_factory=WorldNoise)
    looks: str = "detailed"
    robot: str = "mast"

    @field_validator("robot")
    @classmethod
    def _known_robot(cls, value: str) -> str:
        if value not in ROBOTS:
            raise ValueError(f"unknown robot; choose one of: {', '.join(ROBOTS)}")
        return value

    @field_validator("looks")
    @classmethod
    def _known_looks(cls, value: str) -> str:
        if value not in OBJECT_LOOKS:
            raise ValueError(f"unknown object looks; choose one of: {', '.join(OBJECT_LOOKS)}")
        return value

    @field_validator("profile")
    @classmethod
    def _known_profile(cls, value: str) -> str:
        if value not in RENDER_PROFILES:
            raise ValueError(f"unknown render profile; choose one of: {', '.join(RENDER_PROFILES)}")
        return value

    @classmethod
    def create(cls, naming: FieldNaming | None = None, **fields: Any) -> SceneConfig:
        """A validated config; a bad field raises `InputError` naming it (as `naming` spells it), its
        limits and the fix."""
        return _create(cls, "scene", naming, fields)

    def describe(self) -> dict[str, Any]:
        """The fields that differ from the defaults, always with layout and seed: what answers record."""
        data = self.model_dump(mode="json", exclude_defaults=True)
        return {"layout": self.layout, "seed": self.seed, **data}


class BridgeConfig(BaseModel):
    """A robot behind `attribot bridge serve`: its address `url` (tcp://HOST:PORT) and the time-out of
    one request. The shared token is never part of a config (it comes from ATTRIBOT_BRIDGE_TOKEN), so a
    saved run holds no secret."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    url: str = Field(pattern=r"^tcp://[^:/]+:\d+$")
    timeout_s: float = Field(10.0, gt=0, le=MAX_TIME_S, allow_inf_nan=False)

    @classmethod
    def create(cls, naming: FieldNaming | None = None, **fields: Any) -> BridgeConfig:
        return _create(cls, "bridge", naming, fields)

    def describe(self) -> dict[str, Any]:
        return {"url": self.url, **self.model_dump(mode="json", exclude_defaults=True, exclude={"url"})}


class Ai2ThorConfig(BaseModel):
    """An AI2-THOR scene: its name (FloorPlan1 to FloorPlan430), camera pixels and field of view."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    scene: str = "FloorPlan1"
    width: int = Field(640, ge=16, le=4096, strict=True)
    height: int = Field(480, ge=16, le=4096, strict=True)
    fov_deg: float = Field(90.0, gt=0, lt=180, allow_inf_nan=False)

    @classmethod
    def create(cls, naming: FieldNaming | None = None, **fields: Any) -> Ai2ThorConfig:
        return _create(cls, "ai2thor", naming, fields)

    def describe(self) -> dict[str, Any]:
        return {"scene": self.scene, **self.model_dump(mode="json", exclude_defaults=True)}


WorldConfig = SceneConfig | BridgeConfig | Ai2ThorConfig
WORLD_CONFIGS: Registry[type[BaseModel]] = Registry("world")
"""The typed config of each world, under the world's name (the same names as `EMBODIMENTS`)."""
WORLD_CONFIGS.register("mujoco", aliases=("sim",))(SceneConfig)
WORLD_CONFIGS.register("bridge")(BridgeConfig)
WORLD_CONFIGS.register("ai2thor")(Ai2ThorConfig)


def _create(cls: Any, what: str, naming: FieldNaming | None, fields: dict[str, Any]) -> Any:
    """`cls(**fields)`, a bad field an `InputError` naming it as `naming` spells it, and the fix."""
    naming = naming or KEYWORDS
    try:
        return cls(**fields)
    except ValidationError as exc:
        first = exc.errors()[0]
        name = ".".join(str(p) for p in first.get("loc", ())) or what
        field = name.split(".")[0]
        value = first.get("input")
        shown = naming.name(field) if field in cls.model_fields else name
        fix = _FIXES.get(field)
        raise InputError(
            f"{what} setting {name} ({shown}) = {value!r} is not valid: {first.get('msg', 'invalid')}",
            fix(naming) if fix else f"the {what} settings are: {', '.join(cls.model_fields)}",
        ) from None


_FIXES: dict[str, Callable[[FieldNaming], str]] = {
    "seed": lambda n: f"give a whole number from 0 to {MAX_SEED}, e.g. {n.example('seed', '7')}",
    "objects": lambda n: (
        "ask for at least 1 object (each layout has its own range), e.g. " + n.example("objects", "4")
    ),
    "width": lambda n: "give a width and height from 16 to 4096 pixels",
    "height": lambda n: "give a width and height from 16 to 4096 pixels",
    "profile": lambda n: f"choose one of: {', '.join(RENDER_PROFILES)}",
    "robot": lambda n: f"choose one of: {', '.join(ROBOTS)}, e.g. {n.example('robot', 'ep')}",
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
