"""The flags that several commands share, each declared once, and the settings and names built from them."""

from __future__ import annotations

import functools
import inspect
import types
import typing
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import typer
from pydantic import BaseModel

from attribot.config import CommandLine, SceneConfig, Settings
from attribot.text import comma_names

# ---- option groups: flags that several commands share, each defined once -------------------------------


@dataclass(frozen=True)
class Flag:
    """One flag of a group: the parameter name the command sees, its type, and its typer option."""

    name: str
    annotation: Any
    option: Any


def _flag(name: str, annotation: Any, *decls: str, metavar: str | None = None, **kwargs: Any) -> Flag:
    default = kwargs.pop("default", None)
    return Flag(name, annotation, typer.Option(default, *decls, metavar=metavar, **kwargs))


_METAVARS = {int: "INT", float: "NUMBER", str: "TEXT", Path: "PATH"}
"""The placeholder of a field's value in --help where its `CommandLine` names none."""


def field_flags(model: type[BaseModel], group: str | None = None) -> tuple[Flag, ...]:
    """The flags of `model`'s fields (`Settings` or a world's config), in their order: one for each field
    with a description (in `group`, if given: its `CommandLine.group`), declared nowhere else. `--FIELD`,
    unset by default (the config's default, or the settings file's, then holds), typed as the field where
    it is a number, text or a path (else it takes text, which the field reads: `--checks all,-reset`), its
    help the field's description and its placeholder its `CommandLine.metavar` (`attribot.config`)."""
    flags = []
    for name, info in model.model_fields.items():
        shown = next((m for m in info.metadata if isinstance(m, CommandLine)), CommandLine())
        if not info.description or group not in (None, shown.group):
            continue
        annotation: Any = info.annotation
        union = typing.get_origin(annotation) in (typing.Union, types.UnionType)
        args = [a for a in (typing.get_args(annotation) if union else [annotation]) if a is not type(None)]
        if len(args) != 1 or args[0] not in _METAVARS:
            annotation, args = str, [str]
        metavar = shown.metavar or _METAVARS[args[0]]
        decl = "--" + name.replace("_", "-")
        flags.append(_flag(name, annotation | None, decl, metavar=metavar, help=info.description))
    return tuple(flags)


_SCENE_OWN = {
    "categories": _flag("categories", str | None, "--categories", metavar="A,B", help="Comma-separated "
                        "object categories to draw from, e.g. mug,apple."),
    "vocabulary": _flag("findable_by", str | None, "--findable-by", metavar="SPEC", help="Draw only objects "
                        "the detector SPEC can name, e.g. coco (a closed-set detector is asked which catalog "
                        "categories it can find; an open-vocabulary one finds them all)."),
    "options": _flag("option", list[str] | None, "--option", metavar="KEY=VALUE", help="A setting of the "
                     "world, repeatable: a layout option in MuJoCo (pattern=grid, odd=size), a field of the "
                     "world's config elsewhere (--world ai2thor --option scene=FloorPlan7)."),
    "noise": _flag("world_noise", str | None, "--world-noise", metavar="SPEC", help="Imperfect sensing and "
                   "acting in the simulator, seeded: a preset (clean, sensing, acting, realistic) and/or "
                   "KEY=VALUE pairs, e.g. realistic,slip=0.3 (see attribot.noise.WorldNoise)."),
}  # fmt: skip
"""The scene flags whose value the command line reads itself (a comma list, KEY=VALUE pairs, a noise spec, a
detector's name), under the `SceneConfig` field each fills; every other scene flag is a field's own."""

SCENE_FIELD_FLAGS = field_flags(SceneConfig)
_SCENE_BY_FIELD = {f.name: f for f in SCENE_FIELD_FLAGS} | _SCENE_OWN
SCENE_FLAGS = tuple(_SCENE_BY_FIELD[name] for name in SceneConfig.model_fields if name in _SCENE_BY_FIELD)
"""The scene flags in the order of `SceneConfig`'s fields."""
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
BACKEND_FLAGS = field_flags(Settings, "run")
"""The settings of a run (backends, checks, time limit, priors), from `Settings`."""
PLANNER_FLAGS = field_flags(Settings, "planner")
"""The planner's settings, from `Settings`."""
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
_FLAG_OF.update({field: f.option.param_decls[0] for field, f in _SCENE_OWN.items()}, url="--bridge-url")


def flag_name(field: str) -> str:
    """A config or settings field as a user of the command gives it: its flag, else `--option FIELD=`."""
    return _FLAG_OF.get(field) or f"--option {field}="


def flag_example(field: str, value: str) -> str:
    return f"{_FLAG_OF[field]} {value}" if field in _FLAG_OF else f"{flag_name(field)}{value}"


def flag_naming() -> Any:
    """Config and settings fields named by their flags, for the errors of configs built from flags."""
    from attribot.config import FieldNaming

    return FieldNaming(flag_name, flag_example)


def only(group: tuple[Flag, ...], *names: str) -> tuple[Flag, ...]:
    """The flags of `group` named `names`, in the group's order; a name the group lacks is a bug here."""
    unknown = set(names) - {f.name for f in group}
    assert not unknown, f"no such flags: {sorted(unknown)}"
    return tuple(f for f in group if f.name in names)


def without(group: tuple[Flag, ...], *names: str) -> tuple[Flag, ...]:
    """The flags of `group` but those named `names`."""
    return only(group, *(f.name for f in group if f.name not in names))


def with_flags(*groups: tuple[Flag, ...]) -> Any:
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


def _checks(spec: str | None) -> tuple[Any, ...] | None:
    """The mechanisms `--checks` names, read now, once (an unknown name is a usage error before any world
    is built); the settings take them as they are."""
    if spec is None:
        return None
    from attribot.mechanisms import parse_checks

    return parse_checks(spec)


def settings_of(given: Any) -> Any:
    """The settings of the backend and planner flags (those of the command's groups that were given), over the
    settings file and ATTRIBOT_* variables."""
    from attribot.config import load_settings

    return load_settings(
        naming=flag_naming(),
        checks=_checks(given_value(given, "checks")),
        **{f.name: given_value(given, f.name) for f in field_flags(Settings) if f.name != "checks"},
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
