"""One query, end to end: the composition root that wires a world (or an image), its controller, the
episode recorder, the perception backends and the sandboxed runner, then hands planning to a planner.

`ask` plans the program (rules or an LLM) and runs it, retrying with feedback; `run_program` runs a given
one; `replay` runs a `--save` folder again exactly as it was saved. All three share the same set-up,
answer assembly and saving, so that `attribot exec SAVED_DIR` replays exactly what `attribot ask` ran.
Planners only plan: everything that touches the world is here.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from attribot.config import (
    MAX_QUERY_CHARS,
    WORLD_CONFIGS,
    FieldNaming,
    Settings,
    WorldConfig,
    load_settings,
)
from attribot.errors import ConfigError, InputError
from attribot.files import check_regular_file
from attribot.frame import load_image
from attribot.models.base import without_oracle_vqa
from attribot.planning.answer import (
    Answer,
    answer_patch,
    build_answer,
    refusing_guess,
    result_problem,
    with_chosen,
)
from attribot.planning.query import asks_for_object, check_query, is_utf8_text
from attribot.saved_runs import (
    answer_image,
    check_save_dir,
    read_saved,
    save_answer,
    saved_scene,
)
from attribot.text import comma_names

__all__ = [
    "Scene",
    "Session",
    "Watch",
    "ask",
    "run_program",
    "replay",
    "load_saved",
]


@dataclass
class Scene:
    """Where a query runs: a world built from its typed `config` (`SceneConfig` for mujoco, `BridgeConfig`,
    `Ai2ThorConfig`), or a still image file (`image`).

    `world` None: the world whose config `config` is (mujoco without one). Neither config nor image: the
    default MuJoCo scene. `sensors` None: every sensor the world has (the camera alone for an image).
    `controller` None: the world's own (servo in MuJoCo); "privileged" reads the simulator's state.
    `still`: the first camera image is all a program sees (the robot does not look around)."""

    config: WorldConfig | None = None
    image: Path | str | None = None
    world: str | None = None
    sensors: Sequence[str] | None = None
    controller: str | None = None
    still: bool = False

    def __post_init__(self) -> None:
        named = (("world", self.world, "mujoco"), ("controller", self.controller, "servo"))
        for name, value, example in named:
            if value is not None and not isinstance(value, str):
                raise InputError(
                    f"Scene({name}={_shown(value)}): a {name} is given by its name (text), not as "
                    f"{type(value).__name__}",
                    f"give a name, e.g. Scene({name}={example!r}), or leave {name} out",
                )
        if not isinstance(self.still, bool):
            raise InputError(
                f"Scene(still={_shown(self.still)}) is not True or False", "give still=True or False"
            )
        if self.image is not None and (self.config is not None or self.world is not None):
            raise InputError(
                "a query runs either on an image or in a world, not both",
                "drop the image, or drop the world and its options (layout, seed, objects, ...)",
            )
        self._check_sensors()
        if self.image is not None:  # a missing file, a folder, a FIFO or /dev/zero is named before any work
            self.image = _path_of(self.image, "the image", "give the path of a PNG or JPEG file")
            check_regular_file(self.image, "the image", "give the path of a PNG or JPEG file")
            return
        self.world = self._world_name()
        if self.config is None:
            self.config = _default_config(self.world)

    def _check_sensors(self) -> None:
        if self.sensors is None:
            return
        if isinstance(self.sensors, str):
            self.sensors = comma_names(self.sensors)
        if not isinstance(self.sensors, list | tuple) or not all(isinstance(s, str) for s in self.sensors):
            raise InputError(
                f"sensors={self.sensors!r} is not a list of sensor names"[:300],
                "give names, e.g. sensors=['camera', 'distance'] or sensors='camera,distance'",
            )
        if not list(self.sensors):
            raise InputError("no sensor named: the sensors are empty", "name at least one, e.g. camera")
        if self.image is not None and set(self.sensors) - {"camera"}:
            others = ", ".join(sorted(set(self.sensors) - {"camera"}))
            raise InputError(
                f"a still image has a camera only, not {others}",
                "name the camera alone (or no sensors), or ask in a world instead of on an image",
            )

    def _world_name(self) -> str:
        """The world's registered name: the config's `world` tag, or the one given (checked against it)."""
        kinds = [kind for _, kind in WORLD_CONFIGS.items()]
        if self.config is not None and type(self.config) not in kinds:
            raise InputError(
                f"{type(self.config).__name__} is no world's config",
                f"give one of: {', '.join(dict.fromkeys(c.__name__ for c in kinds))}",
            )
        tag = None if self.config is None else self.config.world_name()
        if self.world is None:
            return tag or "mujoco"
        kind = WORLD_CONFIGS.get(self.world)  # an unknown world lists the known ones
        if tag is not None and tag != kind.world_name():
            raise InputError(
                f"the {self.world} world is configured by a {kind.__name__}, not a "
                f"{type(self.config).__name__}",
                f"give config={kind.__name__}(...), or the world the config is for",
            )
        return kind.world_name()

    def describe(self) -> dict[str, Any]:
        """What answers record under `world`: the image file, or the world and the config's own fields."""
        if self.image is not None:
            return {"image": str(self.image)}
        assert self.config is not None
        return {"world": self.world, **self.config.describe()}

    def saved(self, image_name: str | None = None) -> dict[str, Any]:
        """Everything needed to build this scene again (`Scene.from_saved`); the image under `image_name`."""
        return {
            "world": self.world,
            "config": self.config.model_dump(mode="json") if self.config is not None else None,
            "image": image_name if self.image is not None else None,
            "sensors": list(self.sensors) if self.sensors is not None else None,
            "controller": self.controller,
            "still": self.still,
        }

    @classmethod
    def from_saved(cls, data: dict[str, Any], folder: Path, trusted: bool = False) -> Scene:
        """The scene `saved()` described, its image file in `folder` (never outside it). A world that
        reaches a place (a robot's address) is refused unless `trusted` (see `replay`)."""
        return cls(**saved_scene(data, folder, trusted))

    def render(self) -> Any:
        """The camera's first image of this scene, an RGB uint8 array (H, W, 3): to look at in a notebook."""
        if self.image is not None:
            return load_image(Path(self.image))
        with self._built() as world:
            return world.observe().rgb

    def truth(self) -> Any:
        """The simulated scene's ground truth (`SceneInfo`: each object's id, category, mass, distance and
        box; the robot), to score an experiment's answers against the world's own state. Only a simulator
        knows it: a robot or a still image raises `UnsupportedAction`."""
        from attribot.errors import UnsupportedAction

        if self.image is None:
            with self._built() as world:
                if hasattr(world, "scene_info"):
                    return world.scene_info()
        raise UnsupportedAction(
            f"the {self.world or 'still image'} scene has no ground truth to read",
            "score against the embedded MuJoCo world, or keep the truth of your own scene",
        )

    def _built(self) -> Any:
        from attribot.embodiments.base import EMBODIMENTS

        world_cls: Any = EMBODIMENTS.get(str(self.world))
        return world_cls(self.config)


def _default_config(world: str) -> Any:
    kind: Any = WORLD_CONFIGS.get(world)
    try:
        return kind()
    except ValueError:  # pydantic's ValidationError: the world needs settings it has no default for
        fields = [n for n, f in kind.model_fields.items() if f.is_required()]
        raise InputError(
            f"the {world} world needs {', '.join(fields)}",
            f"give config={kind.__name__}({', '.join(f'{n}=...' for n in fields)})",
        ) from None


@dataclass
class _Parts:
    """What a session builds, so that `close` frees what was built when a later part fails."""

    world: Any = None
    runner: Any = None
    recorder: Any = None
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class Watch:
    """Callbacks that see a query while it runs (the live demo), each called on the thread that runs it."""

    program: Callable[[str], None] | None = None  # each program, as its try starts
    call: Callable[[Any], None] | None = None  # each API call's TraceRecord, as the call ends
    frame: Callable[[Any, Any], None] | None = None  # each episode frame: robot camera, room camera (RGB)


class Session:
    """The world (or image), the API objects and the runner for one query; closes all of them.

    `record`: film an episode video of the world (robot camera, room camera, the API call), which opens
    with a card showing `title` (the query); `watch` sees the programs, calls and frames as they happen."""

    def __init__(
        self,
        scene: Scene,
        settings: Settings,
        record: bool = False,
        watch: Watch | None = None,
        title: str = "",
    ) -> None:
        from attribot.priors import priors
        from attribot.skills.perception import Perception
        from attribot.skills.safeguards import Safeguards, strategies_named

        self.scene = scene
        self.settings = settings
        self.safeguards = Safeguards(
            settings.mechanisms, strategies_named(settings.strategies), priors(settings.priors_scale)
        )
        self.start: Any = None  # the robot's state when the first try started, for the next tries
        self.first_image: Any = None
        self.runs = 0
        self.world_started: float | None = None
        self.parts = _Parts()
        self.watch = watch or Watch()
        self.title = title
        try:
            if scene.image is not None:
                _check_image_detector(settings)
                rgb = load_image(Path(scene.image))  # a bad file fails before any model is loaded
                self.perception = Perception.from_settings(settings)
                self._still_image(rgb)
            else:
                self.perception = Perception.from_settings(settings)
                self._world(record)
            from attribot.api.patch import ImagePatch
            from attribot.api.robot import Robot
            from attribot.runner import Limits, ProgramRunner

            limits = Limits(wall_s=settings.program_wall_s)
            self.parts.runner = ProgramRunner(classes=[ImagePatch, Robot], limits=limits)
        except BaseException:
            self.close()
            raise

    @property
    def world(self) -> Any:
        return self.parts.world

    def _still_image(self, rgb: Any) -> None:
        from attribot.api.patch import ImagePatch
        from attribot.api.robot import Robot

        self.sensors = list(self.scene.sensors or ["camera"])
        self.robot = Robot(sensors=self.sensors)
        self.image = ImagePatch.from_image(rgb, self.perception)
        self.image.safeguards = self.safeguards  # a still image is looked at again within itself

    def _world(self, record: bool) -> None:
        from attribot.api.robot import Robot
        from attribot.control.base import build_controller
        from attribot.embodiments.base import EMBODIMENTS
        from attribot.sensors import sensor_names

        world_cls: Any = EMBODIMENTS.get(str(self.scene.world))
        world = self.parts.world = world_cls(self.scene.config)
        self.world_started = world.world_time()
        have = world.sensors()
        self.sensors = list(self.scene.sensors or [s for s in sensor_names() if s in have])
        controller = build_controller(world, self.scene.controller)
        self.robot = Robot(
            sensors=self.sensors, world=world, controller=controller, safeguards=self.safeguards
        )
        if record and hasattr(world, "sim"):  # a simulated world can be filmed from outside
            from attribot.embodiments.episode import EpisodeRecorder

            robot = self.robot
            self.parts.recorder = EpisodeRecorder(
                world,
                caption=lambda: robot.activity,
                readings=lambda: [m.describe() for m in robot.measurements],
                tracked=lambda: getattr(robot.controller, "tracked", None),
                target=lambda: (robot.acting_on, robot.acting_on_id),
                title=self.title,
                on_frame=self.watch.frame,
            )
        self.image = self.robot.look(self.perception, survey=not self.scene.still)
        self.first_image = self.image
        self.start = self.safeguards.reset.start(self.robot)

    def findable(self) -> str:
        """What `image.find` can find here, in words for the prompt."""
        return self.perception.findable(self.image.frame)

    def run(self, program: str) -> Any:
        """Run `program` on this session's image and robot; from the second run on, the robot first goes
        back to where the first run started (or, in a world that cannot put it back, empties its hands)."""
        if self.runs and self.world is not None:
            self._reset()
        self.runs += 1
        if self.watch.program is not None:
            self.watch.program(program)
        from attribot.runner.policy import names_sought

        # what the program will look for: looking harder for one name does not take another's object
        self.image.sought = names_sought(program)
        return self.parts.runner.run(program, args=[self.image, self.robot], on_call=self.watch.call)

    def _reset(self) -> None:
        # a failed try may have moved the robot or left an object in its gripper
        if self.robot.held is not None:
            self.robot.put_down()
        try_name = f"try {self.runs + 1}"
        if self.start is not None:  # back to where the first try started, with its first image
            self.robot.restore(self.start, self.first_image)
            self.image = self.first_image
            self.safeguards.reset.restored(try_name)
        else:  # a world that cannot put its robot back: start with empty hands from what it sees now
            self.image = self.robot.look(self.perception, survey=not self.scene.still)
            self.safeguards.reset.not_restored(try_name)

    def _as_named(self, result: Any) -> tuple[Any, str | None]:
        """The run's result with the object the question's names choose where the program chose another
        (`Robot.as_named`: a name means the object the detector is surest of under it), and the sentence
        that says why; the result as it was, and None, otherwise."""
        chosen = answer_patch(result.value_object) if result is not None and result.error is None else None
        named = None if chosen is None else self.robot.as_named(chosen)
        replaced = None if named is None else with_chosen(result.value_object, chosen, named[0])
        if named is None or replaced is None:
            return result, None
        return result.model_copy(update={"value_object": replaced}), named[1]

    def _doubt(self, result: Any) -> str | None:
        """With `confidence`: a choice resting on measurements inside their uncertainty is measured again;
        the sentence saying it cannot tell, with both values, when it is still unsettled."""
        chosen = answer_patch(result.value_object) if result is not None and result.error is None else None
        if chosen is None or self.world is None:
            return None
        try:
            return self.robot.settle(chosen)
        except Exception as exc:  # noqa: BLE001 (measuring again failed: keep the program's own answer)
            self.safeguards.confidence.note("answer", "unsettled", f"measuring again failed: {exc}")
            return None

    def backends(self) -> dict[str, str]:
        """What answered: each model backend's name, the robot's, and the plug-in strategies chosen (only
        when some were: the built-in ones are the default)."""
        names = self.perception.names()
        names["robot"] = self.robot.backend_name()
        if self.settings.strategies:
            names["strategies"] = ",".join(comma_names(self.settings.strategies))
        return names

    def finish(
        self, query: str, planner: str, solved: Any, save_dir: Path | None, prompt: str | None = None
    ) -> Answer:
        """The answer to `query` from the last run (`solved`: program, result, attempts, error; `prompt`: the
        prompt the planner showed a model, if any); saved in `save_dir` with the video of the episode when
        one was filmed."""
        result, named = self._as_named(solved.result)
        answer = build_answer(
            doubt=self._doubt(result),
            named=named,
            error=solved.error,
            query=query,
            planner=planner,
            prompt=prompt,
            program=solved.program,
            result=result,
            attempts=len(solved.attempts),
            backends=self.backends(),
            measurements=list(self.robot.measurements),
            world=self.scene.describe(),
            frame=self.image.frame,
        )
        if self.settings.guesses == "refuse":
            answer = refusing_guess(answer)
        answer.checks = [e.model_dump() for e in self.safeguards.events]
        answer.perception = self.perception.counts()
        if self.world_started is not None:
            answer.sim_s = round(self.world.world_time() - self.world_started, 3)
        if save_dir is not None:
            video = None
            if self.parts.recorder is not None:
                lines = [answer.answer, *(m.describe() for m in self.robot.measurements)]
                try:
                    video = self.parts.recorder.finish(lines, answer_image(answer, self.image.frame.rgb))
                except Exception as exc:  # the video is the least of a saved run: keep the rest
                    warnings.warn(
                        f"the episode video could not be finished ({type(exc).__name__}: {exc}); the answer, "
                        "program and settings are saved without it",
                        RuntimeWarning,
                        stacklevel=2,
                    )
            save_answer(
                answer,
                save_dir,
                rgb=self.image.frame.rgb,
                settings=self.settings,
                video=video,
                scene=self.scene,
            )
        return answer

    def close(self) -> None:
        if self.parts.runner is not None:
            self.parts.runner.close()
        if self.parts.world is not None:
            self.parts.world.close()

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _check_image_detector(settings: Settings) -> None:
    from attribot.models.base import parse_spec

    if parse_spec(settings.detector)[0] == "oracle":  # noisy or not, it reads simulator truth
        raise ConfigError(
            "a still image needs a real detector: the default 'oracle' detector reads simulator ground "
            "truth, which a still image does not have",
            "set the detector to coco or yolov5s (COCO's 80 classes, offline: pip install -e '.[coco]' and "
            "attribot fetch coco, or yolov5s), hf:google/owlv2-base-patch16-ensemble (open vocabulary: "
            "pip install -e '.[models]') or remote:URL (--detector, or ATTRIBOT_DETECTOR); `attribot "
            "backends` lists the configuration",
        )


# ---- the library's entry points ---------------------------------------------------------------------


def _scene_of(world: Scene | WorldConfig | str | None) -> Scene:
    if isinstance(world, Scene):
        return world
    if world is None:
        return Scene()
    if isinstance(world, str):
        return Scene(world=world)
    if isinstance(world, BaseModel):
        return Scene(config=world)
    raise InputError(
        f"world={world!r} is no world",
        "give a world name ('mujoco'), a world config (SceneConfig(seed=3)) or a Scene",
    )


def _settings_of(
    settings: Settings | None, overrides: dict[str, Any], naming: FieldNaming | None = None
) -> Settings:
    if settings is not None and not isinstance(settings, Settings):
        raise InputError(
            f"settings={_shown(settings)} is not attribot's Settings",
            "give attribot.load_settings(...) or leave it out, and give settings fields as keywords "
            "(e.g. ask(query, scene, planner='rules'))",
        )
    if settings is None:
        return load_settings(naming, **overrides)
    if not overrides:
        return settings
    return load_settings(naming, **{**settings.model_dump(), **overrides})


def _shown(value: Any) -> str:
    """A value from a caller, short, for a message."""
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _path_of(value: Any, what: str, fix: str) -> Path:
    """A path given to the Python API: text or a path object, with no NUL byte."""
    if not isinstance(value, str | Path) and not hasattr(value, "__fspath__"):
        raise InputError(f"{what} must be a path (text or pathlib.Path), not {type(value).__name__}", fix)
    try:
        path = Path(value)
    except TypeError:  # an os.PathLike that gives bytes
        raise InputError(f"{what} must be a path given as text, not bytes", fix) from None
    if isinstance(value, str) and not value.strip():  # Path("") would be the current folder
        raise InputError(f"{what} is empty", fix)
    if "\x00" in str(path):
        raise InputError(f"{what} {str(path)!r} holds a NUL byte, which no file name can", fix)
    return path


def _check_watch(watch: Any) -> None:
    if watch is not None and not isinstance(watch, Watch):
        raise InputError(
            f"watch={_shown(watch)} is not a Watch", "give attribot.session.Watch(call=...) or leave it out"
        )
    for name in ("program", "call", "frame"):
        seen = getattr(watch, name, None)
        if seen is not None and not callable(seen):
            raise InputError(
                f"Watch({name}={_shown(seen)}) is not a function", f"give {name}=a function, or None"
            )


def _save_path(save_dir: Any) -> Path | None:
    if save_dir is None:
        return None
    return _path_of(save_dir, "save_dir", "give a new folder for the answer, e.g. save_dir='runs/mug-1'")


def ask(
    query: str,
    world: Scene | WorldConfig | str | None = None,
    settings: Settings | None = None,
    *,
    save_dir: Path | str | None = None,
    watch: Watch | None = None,
    **overrides: Any,
) -> Answer:
    """Answer `query` in `world` with the planner of the settings, and return the typed `Answer`.

    `world`: a `Scene`, a world config (`SceneConfig(layout="triplet", seed=3)`), a world name, or None for
    the default scene. `settings`: None reads attribot.toml and ATTRIBOT_* variables; `overrides` are
    settings fields that win over both (`planner="llm"`, `detector="oracle?noise=realistic"`).
    `save_dir`: keep the answer, program, settings, scene and image there, for `replay`. `watch`: callbacks
    that see each program, API call and episode frame as it happens (the live demo)."""
    text = check_query(query)  # the one check of the query on its way to the planner
    _check_watch(watch)
    scene = _scene_of(world)
    settings = _settings_of(settings, overrides)
    settings = without_oracle_vqa(settings) or settings  # a real detector: no simulator truth
    save = _save_path(save_dir)
    check_save_dir(save)
    from attribot.planning import PlanRequest, build_planner, solve

    planner = build_planner(settings.planner, settings)
    with Session(scene, settings, record=save is not None, watch=watch, title=text) as session:
        request = PlanRequest(
            query=text,
            sensors=session.sensors,
            embodied=session.world is not None,
            findable=session.findable(),
            same_start=session.start is not None,
        )
        wants_object = asks_for_object(text)
        # solve() stops by itself when a planner repeats a program (the rules planner always does)
        solved = solve(
            planner,
            request,
            session.run,
            max_tries=settings.llm_max_tries,
            check=lambda result: result_problem(result, wants_object),
        )
        # a planner that shows a model a prompt names it (the llm planner: attribot or paper)
        return session.finish(text, planner.name, solved, save, prompt=getattr(planner, "prompt", None))


@dataclass(frozen=True)
class _OneRun:
    """A given program's single run, in the shape `Session.finish` reads from a planner's `SolveResult`."""

    program: str
    result: Any
    attempts: tuple[Any, ...] = (None,)
    error: Any = None


def run_program(
    program: str,
    world: Scene | WorldConfig | str | None = None,
    settings: Settings | None = None,
    *,
    query: str = "",
    save_dir: Path | str | None = None,
    planner: str = "file",
    **overrides: Any,
) -> Answer:
    """Run a program written the way the prompt asks (`def execute_command(image, robot)`) in `world` and
    return its `Answer`; `query` is recorded only. `world`, `settings`, `overrides` and `save_dir` as for
    `ask`."""
    if not isinstance(program, str):
        raise InputError(f"the program must be text, not {type(program).__name__}", "pass the source")
    program = program.removeprefix("\ufeff")  # a byte-order mark, which Python itself accepts in a file
    if not program.strip():
        raise InputError("the program is empty", "give a file that defines execute_command(image, robot)")
    for name, text in (("query", query), ("planner", planner)):
        if not isinstance(text, str):
            raise InputError(f"the {name} must be text, not {type(text).__name__}", f"pass {name}='...'")
    if not is_utf8_text(program) or not is_utf8_text(query):
        raise InputError("the program or the query is not valid UTF-8 text", "save it as UTF-8")
    if len(query) > MAX_QUERY_CHARS or len(planner) > 100:
        raise InputError(
            f"the query is {len(query)} characters long, more than the {MAX_QUERY_CHARS} allowed"
            if len(query) > MAX_QUERY_CHARS
            else f"the planner's name is {len(planner)} characters long",
            "it is recorded only: give the question the program answers, briefly",
        )
    scene = _scene_of(world)
    settings = _settings_of(settings, overrides)
    save = _save_path(save_dir)
    check_save_dir(save)
    with Session(scene, settings, record=save is not None, title=query) as session:
        return session.finish(query, planner, _OneRun(program, session.run(program)), save)


def load_saved(folder: Path, *, trust_saved_backends: bool = False) -> tuple[str, Scene, Settings, str]:
    """The program, scene, settings and query of a saved folder (`attribot.saved_runs.read_saved`, which
    says what a folder lacks and refuses what it may not choose)."""
    program, scene, settings, query = read_saved(folder, trust_saved_backends=trust_saved_backends)
    return program, Scene(**scene), settings, query


def replay(
    folder: Path | str, *, save_dir: Path | str | None = None, trust_saved_backends: bool = False
) -> Answer:
    """Run the program of a `save_dir` folder again, in its saved scene with its saved settings (secrets
    come from the environment, as they were never saved): the same answer and the same trace.

    A saved folder is a stranger's data: its files are read only inside it, within bounds, and the
    backends and worlds that reach a place (an endpoint, a model, a robot) come from your own settings;
    a folder that used others is refused, naming them, unless `trust_saved_backends` (it then decides
    where your keys, tokens and camera images go: only for folders you made)."""
    folder = _path_of(folder, "the saved folder", "give the folder that --save wrote")
    program, scene, settings, query = load_saved(folder, trust_saved_backends=trust_saved_backends)
    return run_program(program, scene, settings, query=query, save_dir=save_dir, planner="replay")
