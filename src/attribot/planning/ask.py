"""One query, end to end: world or image -> API objects -> planner -> sandboxed run -> `Answer`.

`ask` plans the program (rules or an LLM), `execute` runs a given one; both share the same world set-up,
runner, answer assembly and saving, so that `attribot exec` replays exactly what `attribot ask` ran.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from attribot.config import SceneConfig, Settings
from attribot.errors import ConfigError, InputError
from attribot.files import check_regular_file, check_writable, write_whole
from attribot.frame import load_image
from attribot.planning.answer import Answer, AnswerError, AnswerObject
from attribot.planning.base import is_utf8_text

__all__ = [
    "Scene",
    "Watch",
    "ask",
    "execute",
    "build_answer",
    "save_answer",
    "check_save_dir",
    "SAVED_FILES",
    "answer_image",
]

SAVED_FILES = ("answer.json", "program.py", "settings.json", "answer.png", "episode.mp4")
"""What `save_answer` writes into its folder."""


@dataclass
class Scene:
    """Where a query runs: the world `world` built from `config`, or a still image file (`image`).

    Neither given: the default scene (`SceneConfig()`). `sensors` None: every sensor the world has (the
    camera alone for an image)."""

    config: SceneConfig | None = None
    image: Path | None = None
    world: str = "mujoco"
    sensors: Sequence[str] | None = None
    controller: str | None = None  # None: the world's own (servo in MuJoCo); "privileged": sim state
    still: bool = False  # the first camera image is all a program sees: the robot does not look around

    def __post_init__(self) -> None:
        if self.image is not None and self.config is not None:
            raise InputError(
                "a query runs either on an image or in a generated scene, not both",
                "drop --image, or drop the scene options (--layout, --seed, --objects, ...)",
            )
        if self.sensors is not None:
            if not list(self.sensors):
                raise InputError(
                    "no sensor named: --sensors is empty", "name at least one, e.g. --sensors camera"
                )
            if self.image is not None and set(self.sensors) - {"camera"}:
                others = ", ".join(sorted(set(self.sensors) - {"camera"}))
                raise InputError(
                    f"a still image has a camera only, not {others}",
                    "drop --sensors (or give --sensors camera), or drop --image to ask in a simulated scene",
                )
        if self.image is not None:  # a folder, a FIFO or /dev/zero is named as such, before any work
            check_regular_file(Path(self.image), "--image", "give the path of a PNG or JPEG file")
        if self.image is None and self.config is None:
            self.config = SceneConfig()

    def describe(self) -> dict[str, Any]:
        if self.image is not None:
            return {"image": str(self.image)}
        assert self.config is not None
        return {"world": self.world, **self.config.describe()}


@dataclass
class Watch:
    """Callbacks that see a query while it runs (the live demo), each called on the thread that runs it."""

    program: Callable[[str], None] | None = None  # each program, as its try starts
    call: Callable[[Any], None] | None = None  # each API call's TraceRecord, as the call ends
    frame: Callable[[Any, Any], None] | None = None  # each episode frame: robot camera, room camera (RGB)


def ask(
    query: str, scene: Scene, settings: Settings, save_dir: Path | None = None, watch: Watch | None = None
) -> Answer:
    """Answer `query` in `scene` with the planner named in `settings.planner`; `save_dir` keeps the
    answer JSON, the program, the resolved settings, the camera frame with the chosen box drawn and (in a
    simulated world) the episode video, whose frames `watch.frame` sees as they are taken."""
    from attribot.planning import PlanRequest, build_planner, check_query, solve

    text = check_query(query)
    check_save_dir(save_dir)
    planner = build_planner(settings.planner, settings)
    with _Session(scene, settings, record=save_dir is not None, watch=watch, title=text) as session:
        request = PlanRequest(query=text, sensors=session.sensors, embodied=session.world is not None)
        # solve() stops by itself when a planner repeats a program (the rules planner always does)
        solved = solve(planner, request, session.run, max_tries=settings.llm_max_tries)
        return session.finish(
            text,
            planner.name,
            solved.program,
            solved.result,
            len(solved.attempts),
            save_dir,
            settings,
            error=solved.error,
        )


def execute(
    program: str, scene: Scene, settings: Settings, query: str = "", save_dir: Path | None = None
) -> Answer:
    """Run a program written the way the prompt asks (`def execute_command(image, robot)`) in `scene`."""
    program = program.removeprefix("\ufeff")  # a byte-order mark, which Python itself accepts in a file
    if not program.strip():
        raise InputError("the program is empty", "give a file that defines execute_command(image, robot)")
    if not is_utf8_text(program) or not is_utf8_text(query):
        raise InputError("the program or the query is not valid UTF-8 text", "save it as UTF-8")
    check_save_dir(save_dir)
    with _Session(scene, settings, record=save_dir is not None, title=query) as session:
        return session.finish(query, "file", program, session.run(program), 1, save_dir, settings)


class _Session:
    """The world (or image), the API objects and the runner for one query; closes all of them."""

    def __init__(
        self,
        scene: Scene,
        settings: Settings,
        record: bool = False,
        watch: Watch | None = None,
        title: str = "",
    ) -> None:
        """`record`: film an episode video of the world (robot camera, room camera, the API call), which
        opens with a card showing `title` (the query)."""
        from attribot.api.patch import ImagePatch
        from attribot.api.perception import Perception
        from attribot.api.robot import Robot
        from attribot.api.safeguards import Safeguards, parse_checks
        from attribot.runner import ProgramRunner

        self.safeguards = Safeguards(parse_checks(settings.checks))
        self.start: Any = None  # the robot's state when the first try started, for the next tries
        self.first_image: Any = None
        self.scene = scene
        self.runs = 0
        self.world: Any = None
        self.world_started: float | None = None
        self.runner: Any = None
        self.recorder: Any = None
        self.watch = watch or Watch()
        try:
            if scene.image is not None:
                from attribot.models.base import parse_spec

                if parse_spec(settings.detector)[0] == "oracle":  # noisy or not, it reads simulator truth
                    raise ConfigError(
                        "--image needs a real detector: the default 'oracle' detector reads simulator "
                        "ground truth, which a still image does not have",
                        "set --detector hf:google/owlv2-base-patch16-ensemble (pip install "
                        "'attribot[models]') or ATTRIBOT_DETECTOR=remote:URL; `attribot backends` lists "
                        "the configuration",
                    )
                rgb = load_image(scene.image)  # a bad file fails before any model is loaded
                self.perception = Perception.from_settings(settings)
                self.sensors = list(scene.sensors or ["camera"])
                self.robot = Robot(sensors=self.sensors)
                self.image = ImagePatch.from_image(rgb, self.perception)
                if self.safeguards.on("look_again"):  # a still image is looked at again within itself
                    self.image.safeguards = self.safeguards
            else:
                from attribot.embodiments.base import EMBODIMENTS

                self.perception = Perception.from_settings(settings)
                world_cls: Any = EMBODIMENTS.get(scene.world)  # worlds are built from a SceneConfig
                self.world = world_cls(scene.config)
                self.world_started = self.world.world_time()
                have = {str(c) for c in self.world.capabilities()}
                self.sensors = list(
                    scene.sensors or [s for s in ("camera", "distance", "force") if s in have]
                )
                from attribot.control.base import build_controller

                controller = build_controller(self.world, scene.controller)
                self.robot = Robot(
                    sensors=self.sensors, world=self.world, controller=controller, safeguards=self.safeguards
                )
                if record and hasattr(self.world, "sim"):  # a simulated world can be filmed from outside
                    from attribot.embodiments.episode import EpisodeRecorder

                    robot = self.robot
                    self.recorder = EpisodeRecorder(
                        self.world,
                        caption=lambda: robot.activity,
                        readings=lambda: [m.describe() for m in robot.measurements],
                        tracked=lambda: getattr(robot.controller, "tracked", None),
                        target=lambda: (robot.acting_on, robot.acting_on_id),
                        title=title,
                        on_frame=self.watch.frame,
                    )
                self.image = self.robot.look(self.perception, survey=not scene.still)
                self.first_image = self.image
                if self.safeguards.on("reset"):
                    self.start = self.robot.snapshot()
            self.runner = ProgramRunner(classes=[ImagePatch, Robot])
        except BaseException:
            self.close()
            raise

    def run(self, program: str) -> Any:
        if self.runs and self.world is not None:
            # a failed try may have moved the robot or left an object in its gripper
            if self.robot.held is not None:
                self.robot.put_down()
            if self.start is not None:  # back to where the first try started, with its first image
                self.robot.restore(self.start, self.first_image)
                self.image = self.first_image
                self.safeguards.note(
                    "reset",
                    f"try {self.runs + 1}",
                    "caught",
                    "the robot was put back where the first try started",
                )
            else:  # a world that cannot put its robot back: start with empty hands from what it sees now
                self.image = self.robot.look(self.perception, survey=not self.scene.still)
                if self.safeguards.on("reset"):
                    self.safeguards.note(
                        "reset", f"try {self.runs + 1}", "unsettled", "this world cannot put the robot back"
                    )
        self.runs += 1
        if self.watch.program is not None:
            self.watch.program(program)
        return self.runner.run(program, args=[self.image, self.robot], on_call=self.watch.call)

    def _doubt(self, result: Any) -> str | None:
        """With `confidence`: a choice resting on measurements inside their uncertainty is measured again;
        the sentence saying it cannot tell, with both values, when it is still unsettled."""
        chosen = _answer_patch(result.value_object) if result is not None and result.error is None else None
        if chosen is None or self.world is None:
            return None
        try:
            return self.robot.settle(chosen)
        except Exception as exc:  # noqa: BLE001 (measuring again failed: keep the program's own answer)
            self.safeguards.note("confidence", "answer", "unsettled", f"measuring again failed: {exc}")
            return None

    def backends(self) -> dict[str, str]:
        names = self.perception.names()
        names["robot"] = self.robot.backend_name()
        return names

    def finish(
        self,
        query: str,
        planner: str,
        program: str | None,
        result: Any,
        attempts: int,
        save_dir: Path | None,
        settings: Settings,
        error: Any = None,
    ) -> Answer:
        doubt = self._doubt(result)
        answer = build_answer(
            doubt=doubt,
            error=error,
            query=query,
            planner=planner,
            program=program,
            result=result,
            attempts=attempts,
            backends=self.backends(),
            measurements=list(self.robot.measurements),
            world=self.scene.describe(),
            frame=self.image.frame,
        )
        answer.checks = [e.model_dump() for e in self.safeguards.events]
        if self.world_started is not None:
            answer.sim_s = round(self.world.world_time() - self.world_started, 3)
        if save_dir is not None:
            video = None
            if self.recorder is not None:
                lines = [answer.answer, *(m.describe() for m in self.robot.measurements)]
                video = self.recorder.finish(lines, answer_image(answer, self.image.frame.rgb))
            save_answer(answer, save_dir, rgb=self.image.frame.rgb, settings=settings, video=video)
        return answer

    def close(self) -> None:
        if self.runner is not None:
            self.runner.close()
        if self.world is not None:
            self.world.close()

    def __enter__(self) -> _Session:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def build_answer(
    *,
    query: str,
    planner: str,
    program: str | None,
    result: Any,
    attempts: int,
    backends: dict[str, str],
    measurements: Sequence[Any],
    world: dict[str, Any],
    frame: Any,
    error: Any = None,
    doubt: str | None = None,
) -> Answer:
    """Turn a run result into an `Answer`: the chosen object, its measured value, a sentence for a person.
    `error` is the planner's own error when no program ever ran (a reply with no code); `doubt` says that
    the measurements behind the program's choice cannot tell it from another (no object is chosen)."""
    trace = [t.model_dump(mode="json") for t in (result.trace if result is not None else [])]
    common = dict(
        query=query,
        program=program,
        planner=planner,
        backends=backends,
        attempts=attempts,
        trace=trace,
        world=world,
    )
    if result is None or result.error is not None:
        err = result.error if result is not None else error
        category = err.category if err is not None else "planner"
        message = err.message if err is not None else "no program was produced"
        return Answer(
            answer=f"no answer: {message}",
            error=AnswerError(category=category, message=message, line=getattr(err, "line", None)),
            **common,
        )
    if doubt is not None:
        return Answer(
            answer=f"no answer: {doubt}", error=AnswerError(category="uncertain", message=doubt), **common
        )
    stated = _stated(result.value_object)
    if stated is not None:
        return _stated_answer(stated, frame, common)
    chosen = _chosen_patch(result.value_object)
    if chosen is not None:
        category = _category(chosen, frame)
        obj = AnswerObject(id=chosen.object_id, category=category, box=tuple(round(v, 1) for v in chosen.box))
        measured = _last_measurement(chosen, measurements)
        where = ", ".join(f"{v:.0f}" for v in obj.box)
        name = category or "object"
        text = f"the {name}" + (f" ({obj.id})" if obj.id else "") + f" at [{where}]"
        if measured is None:
            return Answer(answer=text, object=obj, **common)
        text += f", measured {measured.reading()}"
        return Answer(answer=text, object=obj, value=float(measured.value), unit=measured.unit, **common)
    value = result.value
    raw = result.value_object
    if isinstance(raw, float) and not math.isfinite(raw):
        message = f"execute_command returned {raw}, which is no answer; return a finite number or an object"
        return Answer(
            answer=f"no answer: {message}",
            error=AnswerError(category="runtime", message=message),
            **common,
        )
    number = float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None
    if value is None:
        return Answer(
            answer="no answer: the program returned nothing",
            error=AnswerError(
                category="runtime",
                message="execute_command returned None; return the chosen ImagePatch or a value",
            ),
            **common,
        )
    text = value if isinstance(value, str) else json.dumps(value, default=str)
    return Answer(answer=str(text), value=number, **common)


STATED_KEYS = frozenset({"object", "value", "unit", "yes", "text"})
"""A program may return a dict with these keys (plain values, "object" an ImagePatch) to state its answer:
the chosen object, the value of the attribute asked and its unit (a size in metres, not the distance
measured to scale it), "yes" the answer to a yes/no question, and "text" the sentence that says why."""


def _answer_patch(value_object: Any) -> Any:
    """The object a program's return chose: the patch itself, or a stated answer's "object"."""
    stated = _stated(value_object)
    return _chosen_patch(stated.get("object") if stated is not None else value_object)


def _stated(value_object: Any) -> dict[str, Any] | None:
    if not isinstance(value_object, dict) or not value_object or set(value_object) - STATED_KEYS:
        return None
    if not ({"object", "yes"} & set(value_object)):
        return None
    return value_object


def _stated_answer(stated: dict[str, Any], frame: Any, common: dict[str, Any]) -> Answer:
    chosen = _chosen_patch(stated.get("object"))
    obj = None
    parts = []
    yes = stated.get("yes")
    if isinstance(yes, bool):
        parts.append("yes" if yes else "no")
    if chosen is not None:
        category = _category(chosen, frame)
        obj = AnswerObject(id=chosen.object_id, category=category, box=tuple(round(v, 1) for v in chosen.box))
    raw = stated.get("value")
    value = float(raw) if isinstance(raw, int | float) and not isinstance(raw, bool) else None
    unit = stated.get("unit") if isinstance(stated.get("unit"), str) and value is not None else None
    text = stated.get("text")
    if isinstance(text, str) and text:
        parts.append(text)
    elif obj is not None:
        where = ", ".join(f"{v:.0f}" for v in obj.box)
        sentence = f"the {obj.category or 'object'}" + (f" ({obj.id})" if obj.id else "") + f" at [{where}]"
        if value is not None:
            sentence += f", {value:.3f} {unit or ''}".rstrip()
        parts.append(sentence)
    return Answer(
        answer=": ".join(parts) if len(parts) == 2 else (parts[0] if parts else ""),
        object=obj,
        value=value,
        unit=unit,
        boolean=yes if isinstance(yes, bool) else None,
        **common,
    )


def _chosen_patch(value_object: Any) -> Any:
    from attribot.api.patch import ImagePatch

    if isinstance(value_object, ImagePatch):
        return value_object
    if isinstance(value_object, list) and len(value_object) == 1 and isinstance(value_object[0], ImagePatch):
        return value_object[0]
    return None


def _category(patch: Any, frame: Any) -> str | None:
    if patch.object_id is not None:
        for truth in frame.objects.values():
            if truth.id == patch.object_id:
                return truth.category
    return patch.label or None


def _last_measurement(patch: Any, measurements: Sequence[Any]) -> Any:
    """The last measurement the program took of the chosen object, or None."""
    if patch.object_id is None:
        return None
    return next((m for m in reversed(measurements) if m.object_id == patch.object_id), None)


def check_save_dir(directory: Path | None) -> None:
    """Refuse, before any work, a `--save` folder that cannot take the answer: a file (or something under
    one), a place that cannot be written (/dev/null, /proc/self), or a folder that already holds an
    earlier answer (never overwritten silently)."""
    if directory is None:
        return
    fix = "give --save a new folder (it is created), e.g. --save runs/mug-1"
    path = Path(directory)
    if path.exists() and not path.is_dir():
        raise InputError(f"--save {str(path)!r} is a file, not a folder", fix)
    existing = path
    while not existing.exists():
        if existing.parent == existing:
            break
        existing = existing.parent
    if not existing.is_dir():
        raise InputError(f"--save {str(path)!r} lies under {str(existing)!r}, which is a file", fix)
    earlier = [name for name in SAVED_FILES if (path / name).exists()]
    if earlier:
        raise InputError(
            f"--save {str(path)!r} already holds {', '.join(earlier)} of an earlier answer",
            "give a new folder, or remove the old answer first",
        )
    check_writable(existing, f"--save {str(path)!r}", fix)


def answer_image(answer: Answer, rgb: Any) -> Any:
    """A copy of `rgb` (the robot's first image) with the answer's box drawn and named, if it has one."""
    from attribot.draw import draw_boxes

    boxes = [] if answer.object is None else [(answer.object.box, answer.object.category or "answer")]
    return draw_boxes(rgb, boxes)


def save_answer(
    answer: Answer,
    directory: Path,
    rgb: Any = None,
    settings: Settings | None = None,
    video: bytes | None = None,
) -> list[Path]:
    """Write answer.json, program.py, settings.json, (with `rgb`) answer.png with the chosen box drawn, and
    (with `video`, MP4 bytes) episode.mp4.

    Each file is written beside its place and renamed into it, so that a file is whole or absent."""
    directory.mkdir(parents=True, exist_ok=True)
    written = []

    def put(name: str, data: bytes) -> None:
        write_whole(directory / name, data)
        written.append(directory / name)

    put("answer.json", answer.model_dump_json(indent=2).encode("utf-8"))
    if answer.program:
        put("program.py", answer.program.encode("utf-8"))
    if settings is not None:
        put("settings.json", json.dumps(settings.public_dict(), indent=2, default=str).encode("utf-8"))
    if rgb is not None:
        import io

        from PIL import Image

        buf = io.BytesIO()
        Image.fromarray(answer_image(answer, rgb)).save(buf, format="PNG")
        put("answer.png", buf.getvalue())
    if video:
        put("episode.mp4", video)
    return written
