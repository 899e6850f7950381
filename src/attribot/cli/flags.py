"""The flags that several commands share, each declared once, and the settings and names built from them."""

from __future__ import annotations

import functools
import inspect
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import typer

from attribot.text import comma_names

# ---- option groups: flags that several commands share, each defined once -------------------------------


@dataclass(frozen=True)
class _Flag:
    """One flag of a group: the parameter name the command sees, its type, and its typer option."""

    name: str
    annotation: Any
    option: Any


def _flag(name: str, annotation: Any, *decls: str, metavar: str | None = None, **kwargs: Any) -> _Flag:
    default = kwargs.pop("default", None)
    return _Flag(name, annotation, typer.Option(default, *decls, metavar=metavar, **kwargs))


def _model_flag(model: str, field: str, annotation: Any, metavar: str) -> _Flag:
    """The flag of a field of the settings or of a config (`model`: its class in `attribot.config`):
    `--FIELD`, unset by default (the config's default, or the settings file's), and its help, the field's
    own description, read when the help is shown (`PlainFlags`: `attribot` starts without the models)."""
    return _flag(
        field, annotation, "--" + field.replace("_", "-"), metavar=metavar, help=f"{{{model}.{field}}}"
    )


SCENE_FLAGS = (
    _model_flag("SceneConfig", "layout", str | None, "NAME"),
    _model_flag("SceneConfig", "seed", int | None, "INT"),
    _model_flag("SceneConfig", "objects", int | None, "INT"),
    _flag("categories", str | None, "--categories", metavar="A,B", help="Comma-separated object "
          "categories to draw from, e.g. mug,apple."),
    _flag("option", list[str] | None, "--option", metavar="KEY=VALUE", help="A setting of the world, "
          "repeatable: a layout option in MuJoCo (pattern=grid, odd=size), a field of the world's config "
          "elsewhere (--world ai2thor --option scene=FloorPlan7)."),
    _model_flag("SceneConfig", "width", int | None, "PX"),
    _model_flag("SceneConfig", "height", int | None, "PX"),
    _model_flag("SceneConfig", "profile", str | None, "NAME"),
    _flag("world_noise", str | None, "--world-noise", metavar="SPEC", help="Imperfect sensing and "
          "acting in the simulator, seeded: a preset (clean, sensing, acting, realistic) and/or "
          "KEY=VALUE pairs, e.g. realistic,slip=0.3 (see attribot.noise.WorldNoise)."),
    _model_flag("SceneConfig", "robot", str | None, "NAME"),
    _flag("findable_by", str | None, "--findable-by", metavar="SPEC", help="Draw only objects the "
          "detector SPEC can name, e.g. coco (a closed-set detector is asked which catalog categories it "
          "can find; an open-vocabulary one finds them all)."),
)  # fmt: skip
WORLD_FLAGS = (
    _flag("world", str | None, "--world", metavar="NAME", help="World to ask in: {worlds} (default mujoco, "
          "the embedded scene; bridge: a robot)."),
    _flag("bridge_url", str | None, "--bridge-url", metavar="URL", help="With --world bridge: the robot's "
          "tcp://HOST:PORT; the token comes from ATTRIBOT_BRIDGE_TOKEN."),
    _flag("image", Path | None, "--image", metavar="FILE", help="Answer about this image file instead of a "
          "world."),
    _flag("sensors", str | None, "--sensors", metavar="A,B", help="Comma-separated robot sensors: "
          "camera, distance, force, temperature (infrared thermometer), grip (a gripper that feels how hard "
          "it squeezes), a registered sensor's name or the paper's names (default: all the world has)."),
    _flag("controller", str | None, "--controller", metavar="NAME", help="Robot controller: the world's own "
          "(default; in MuJoCo 'servo', which acts on what the camera and sensors perceive) or 'privileged' "
          "(MuJoCo only: reads the simulator's state to move and grasp, to compare against)."),
)  # fmt: skip


BACKEND_FLAGS = (
    _model_flag("Settings", "detector", str | None, "SPEC"),
    _model_flag("Settings", "vqa", str | None, "SPEC"),
    _model_flag("Settings", "language", str | None, "SPEC"),
    _model_flag("Settings", "checks", str | None, "NAMES"),
    _model_flag("Settings", "strategies", str | None, "NAMES"),
    _model_flag("Settings", "program_wall_s", float | None, "SECONDS"),
    _model_flag("Settings", "priors_scale", float | None, "FACTOR"),
)
PLANNER_FLAGS = (
    _model_flag("Settings", "planner", str | None, "NAME"),
    _model_flag("Settings", "llm_base_url", str | None, "URL"),
    _model_flag("Settings", "llm_model", str | None, "NAME"),
    _model_flag("Settings", "prompt", str | None, "NAME"),
    _model_flag("Settings", "llm_timeout_s", float | None, "SECONDS"),
    _model_flag("Settings", "llm_max_tokens", int | None, "TOKENS"),
    _model_flag("Settings", "llm_retries", int | None, "N"),
    _model_flag("Settings", "llm_max_tries", int | None, "N"),
)
OUTPUT_FLAGS = (
    _flag("as_json", bool, "--json", default=False, help="Print the whole answer as JSON."),
    _flag("save", Path | None, "--save", metavar="DIR", help="Keep the answer there: answer.json, "
          "program.py, settings.json, run.json (all that `attribot exec DIR` needs to replay it) and "
          "answer.png."),
)  # fmt: skip

_FLAG_OF = {
    f.name: f.option.param_decls[0]
    for group in (SCENE_FLAGS, WORLD_FLAGS, BACKEND_FLAGS, PLANNER_FLAGS)
    for f in group
}
_FLAG_OF.update(
    {"options": "--option", "noise": "--world-noise", "url": "--bridge-url", "vocabulary": "--findable-by"}
)


def flag_name(field: str) -> str:
    """A config or settings field as a user of the command gives it: its flag, else `--option FIELD=`."""
    return _FLAG_OF.get(field) or f"--option {field}="


def flag_example(field: str, value: str) -> str:
    return f"{_FLAG_OF[field]} {value}" if field in _FLAG_OF else f"{flag_name(field)}{value}"


def flag_naming() -> Any:
    """Config and settings fields named by their flags, for the errors of configs built from flags."""
    from attribot.config import FieldNaming

    return FieldNaming(flag_name, flag_example)


def only(group: tuple[_Flag, ...], *names: str) -> tuple[_Flag, ...]:
    """The flags of `group` named `names`, in the group's order; a name the group lacks is a bug here."""
    unknown = set(names) - {f.name for f in group}
    assert not unknown, f"no such flags: {sorted(unknown)}"
    return tuple(f for f in group if f.name in names)


def without(group: tuple[_Flag, ...], *names: str) -> tuple[_Flag, ...]:
    """The flags of `group` but those named `names`."""
    return only(group, *(f.name for f in group if f.name not in names))


def with_flags(*groups: tuple[_Flag, ...]) -> Any:
    """Add the flags of `groups` to a command; the command receives them together as `given`."""

    def decorate(fn: Any) -> Any:
        own = inspect.signature(fn, eval_str=True)
        flags = [f for group in groups for f in group]
        names = {f.name for f in flags}
        params = [p for p in own.parameters.values() if p.name != "given"] + [
            inspect.Parameter(
                f.name, inspect.Parameter.KEYWORD_ONLY, default=f.option, annotation=f.annotation
            )
            for f in flags
        ]

        @functools.wraps(fn)
        def command(**kwargs: Any) -> Any:
            given = SimpleNamespace(**{k: kwargs.pop(k) for k in list(kwargs) if k in names})
            return fn(**kwargs, given=given)

        command.__signature__ = own.replace(parameters=params)  # type: ignore[attr-defined]
        command.__annotations__ = {p.name: p.annotation for p in params}
        return command

    return decorate


def given_value(given: Any, name: str) -> Any:
    return getattr(given, name, None)


def _checks(spec: str | None) -> str | None:
    """`--checks` checked now (an unknown name is a usage error before any world is built)."""
    if spec is None:
        return None
    from attribot.mechanisms import parse_checks

    return ",".join(parse_checks(spec)) or "none"


def settings_of(given: Any) -> Any:
    """The settings of the backend and planner flags, over the settings file and ATTRIBOT_* variables."""
    from attribot.config import load_settings

    names = (
        "detector",
        "vqa",
        "language",
        "program_wall_s",
        "priors_scale",
        "strategies",
        "planner",
        "llm_base_url",
        "llm_model",
        "prompt",
        "llm_timeout_s",
        "llm_max_tokens",
        "llm_retries",
        "llm_max_tries",
    )
    return load_settings(
        naming=flag_naming(),
        checks=_checks(given_value(given, "checks")),
        **{n: given_value(given, n) for n in names},
    )


SUITE = typer.Option(
    "paper",
    "--suite",
    help="The suite: paper (the paper's five tasks), senses (temperature, softness, fullness) or realroom "
    "(rooms with things a closed-set detector cannot name, and questions about objects not there).",
)
TASKS = typer.Option(None, "--tasks", help="Comma-separated tasks (default: all of the suite's).")
LIMIT = typer.Option(None, "--limit", help="At most this many queries per task.")
ROOT_SEED = typer.Option(
    0,
    "--seed",
    metavar="INT",
    help="The root seed every item's scene and noise seeds derive from: 0 (default) draws the suite's own "
    "items, another number other scenes for every task (0 to 4000).",
)


def suite_tasks(suite: str, tasks: str | None) -> list[str]:
    from attribot.errors import InputError
    from attribot.eval.suite import suite_names, task_names

    if suite not in suite_names():
        raise InputError(f"unknown suite {suite!r}", f"use --suite with one of: {', '.join(suite_names())}")
    known = task_names(suite)
    chosen = comma_names(tasks) if tasks else known
    if not chosen:
        raise InputError("--tasks names no task", f"choose from: {', '.join(known)}")
    unknown = [t for t in chosen if t not in known]
    if unknown:
        raise InputError(f"unknown task {', '.join(unknown)}", f"choose from: {', '.join(known)}")
    return chosen
