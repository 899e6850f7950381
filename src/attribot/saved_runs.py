"""Saved runs: what `--save` (`save_dir`) writes, and reading it back for a replay, as a stranger's data.

`save_answer` writes a folder (`SAVED_FILES`: the answer, its program, the settings without secrets, the
scene in `RUN_FILE`, the image with the answer drawn, the episode video); `check_save_dir` refuses, before
any work, a folder that cannot take one. `read_saved` reads a folder back within bounds and decides what it
may choose: how its program ran (`SAVED_CHOICES`), and, only with trust (`TRUST_SAVED`), the backends and
worlds that reach a place (an endpoint, a model, a robot). `attribot.session` builds the scene and runs it.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any, Protocol

from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictStr, ValidationError

from attribot.config import (
    MAX_QUERY_CHARS,
    WORLD_CONFIGS,
    FieldNaming,
    Settings,
    load_settings,
    plain_input,
    world_config,
)
from attribot.errors import ConfigError, InputError
from attribot.files import check_writable, inside, read_capped, read_json, write_whole
from attribot.planning.answer import Answer
from attribot.text import shown_url

__all__ = [
    "SAVED_FILES",
    "RUN_FILE",
    "TRUST_SAVED",
    "SAVED_CHOICES",
    "TRUSTED_CHOICES",
    "read_program",
    "read_saved",
    "saved_scene",
    "replay_settings",
    "check_save_dir",
    "save_answer",
    "answer_image",
]

SAVED_FILES = ("answer.json", "program.py", "settings.json", "run.json", "answer.png", "episode.mp4")
"""What `save_answer` writes into its folder (and `input` + the image's suffix for a still image)."""
RUN_FILE = "run.json"
"""The saved run's scene, query and planner: with settings.json, all that a replay needs."""


def read_program(path: Path, what: str = "the program file") -> str:
    """The text of a program file: a regular file no larger than a program may be (checked before it is
    read), UTF-8 (a byte-order mark is not part of the code)."""
    from attribot.runner import Limits

    fix = "give a .py file that defines execute_command(image, robot)"
    data = read_capped(path, what, 4 * Limits().max_source_chars + 3, fix)  # UTF-8: at most 4 bytes a char
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{what} {str(path)!r} is not UTF-8 text", "save it as UTF-8") from None


TRUST_SAVED = "--trust-saved-backends"
"""The flag (and, as `trust_saved_backends=True`, the keyword) that lets a saved folder choose its
endpoints, models and world: it decides where the user's keys, tokens and images go."""
SAVED_CHOICES = (
    "checks",
    "strategies",
    "program_wall_s",
    "detector_threshold",
    "llm_temperature",
    "perception_noise",
)
"""The settings a saved folder decides on its own: how its program ran; none of them names a place."""
TRUSTED_CHOICES = ("llm_base_url", "llm_model", "hf_device", "hf_dtype")
"""What a trusted saved folder decides besides its backends: the endpoint and model its openai: backends
used, and where its hf: models ran."""
_SAVED_FIX = "give a folder written by `attribot ask --save`, unchanged"


def saved_scene(data: dict[str, Any], folder: Path, trusted: bool = False) -> dict[str, Any]:
    """The fields of the scene `Scene.saved()` described (`attribot.session.Scene`), its image file in
    `folder` (never outside it). A world that reaches a place (a robot's address) is refused unless
    `trusted` (see `attribot.session.replay`)."""
    fix = "give a folder written by `attribot ask --save`, unchanged"
    if data.get("image"):
        return {
            "image": inside(folder, data["image"], "the saved image", fix),
            "sensors": data.get("sensors"),
        }
    world = str(data.get("world") or "mujoco")
    kind: Any = WORLD_CONFIGS.get(world)
    saved = data.get("config")
    # the world beside the config names it (folders saved before configs carried their world's tag),
    # and is the one whose place the trust check below reads: a tag inside the config does not choose
    config = None if saved is None else world_config({**saved, "world": kind.world_name()})
    if kind.REACHES_OUT is not None and "url" not in kind.model_fields and not trusted:
        raise ConfigError(
            f"the saved run in {str(folder)!r} ran in the {world} world: replaying it would build that "
            f"world, and {kind.REACHES_OUT}",
            f"run its program in a world you choose (attribot exec {str(folder / 'program.py')!r} "
            f"--world {world}), or, for a folder you made, replay with {TRUST_SAVED} "
            "(Python: trust_saved_backends=True)",
        )
    if "url" in kind.model_fields and not trusted:
        where = shown_url(str(getattr(config, "url", "")))
        raise ConfigError(
            f"the saved run in {str(folder)!r} ran in the {world} world at {where!r}: replaying it would "
            "act there and send your ATTRIBOT_BRIDGE_TOKEN to it",
            f"run its program on your own robot (attribot exec {str(folder / 'program.py')!r} --world "
            f"{world} --bridge-url tcp://HOST:PORT), or, for a folder you made, replay with "
            f"{TRUST_SAVED} (Python: trust_saved_backends=True)",
        )
    return {
        "config": config,
        "world": world,
        "sensors": data.get("sensors"),
        "controller": data.get("controller"),
        "still": bool(data.get("still", False)),
    }


class _SavedScene(BaseModel):
    """The scene part of a saved run.json (what `Scene.saved` writes), checked before any of it is used."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    world: StrictStr | None = Field(None, max_length=100)
    config: dict[str, Any] | None = None
    image: StrictStr | None = Field(None, max_length=255)
    sensors: list[StrictStr] | None = Field(None, max_length=64)
    controller: StrictStr | None = Field(None, max_length=100)
    still: StrictBool = False


class _SavedRun(BaseModel):
    """A saved run.json: the query, the planner that wrote the program, the scene."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    query: StrictStr = Field("", max_length=MAX_QUERY_CHARS)
    planner: StrictStr = Field("", max_length=100)
    scene: _SavedScene


def read_saved(
    folder: Path, *, trust_saved_backends: bool = False
) -> tuple[str, dict[str, Any], Settings, str]:
    """The program, scene (its fields: `saved_scene`), settings and query of a saved folder; a folder that
    lacks one says which, and one whose files lead out of it, are too large, or ask for a place your own
    settings do not name (an endpoint, a model, a robot; see `attribot.session.replay`) is refused, naming
    what."""
    if not folder.is_dir():
        raise InputError(f"{str(folder)!r} is not a folder", "give the folder that --save wrote")
    missing = [name for name in ("program.py", RUN_FILE, "settings.json") if not (folder / name).exists()]
    if missing:
        what = (
            "no program (program.py): its run never produced one"
            if "program.py" in missing
            else f"no {' or '.join(missing)}"
        )
        raise InputError(
            f"the folder {str(folder)!r} holds {what}, so it cannot be replayed",
            "give a folder written by `attribot ask --save` whose answer has a program, or a .py file",
        )
    program = read_program(inside(folder, "program.py", "the saved program", _SAVED_FIX))
    run = _saved_run(read_json(inside(folder, RUN_FILE, "the saved run", _SAVED_FIX), "the saved run",
                               _SAVED_FIX), folder)  # fmt: skip
    saved = read_json(inside(folder, "settings.json", "the saved settings", _SAVED_FIX), "the saved settings",
                      _SAVED_FIX)  # fmt: skip
    scene = saved_scene(run.scene.model_dump(), folder, trusted=trust_saved_backends)
    settings = replay_settings(saved, folder, trust_saved_backends)
    return program, scene, settings, run.query


def _saved_run(data: Any, folder: Path) -> _SavedRun:
    try:
        return _SavedRun.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first.get("loc", ())) or "the file"
        raise InputError(
            f"the saved run {str(folder / RUN_FILE)!r} is not one attribot wrote: {where}: "
            f"{first.get('msg', 'invalid')}",
            _SAVED_FIX,
        ) from None


def replay_settings(saved: Any, folder: Path, trusted: bool = False) -> Settings:
    """The settings a replay of `folder` runs with (`saved`: its settings.json, as data): your own (file
    and ATTRIBOT_* variables), with the folder's choices of how its program ran (`SAVED_CHOICES`) and of
    its backends where they name no place (the oracle, the catalog, coco's own files). A backend that
    reaches a place and is not your own is refused, naming it, unless `trusted`."""
    from attribot.models.base import ROLES, reaches_out

    source = f"the saved settings {str(folder / 'settings.json')!r}"
    if not isinstance(saved, dict):
        raise InputError(f"{source} is not a table of settings", _SAVED_FIX)
    unknown = sorted(set(saved) - set(Settings.model_fields))
    if unknown:
        raise InputError(f"{source} holds settings attribot has not: {', '.join(unknown)[:200]}", _SAVED_FIX)
    own = load_settings()

    def yours(key: str) -> bool:  # the folder's value is your own (saved with a URL's password left out)
        theirs, mine = saved.get(key), getattr(own, key)
        return theirs is None or theirs == mine or (isinstance(mine, str) and theirs == shown_url(mine))

    keys = SAVED_CHOICES + (TRUSTED_CHOICES if trusted else ())
    chosen = {k: saved[k] for k in keys if not yours(k)}
    for role in ROLES:
        theirs, mine = saved.get(role), getattr(own, role)
        if yours(role):
            continue
        if not isinstance(theirs, str):
            raise InputError(f"{source}: {role} is not a backend spec", _SAVED_FIX)
        try:
            plain_input(Settings, role, theirs)
        except ValueError as exc:
            raise InputError(f"{source}: {role} {shown_url(repr(theirs))[:200]}: {exc}", _SAVED_FIX) from None
        if trusted or not reaches_out(role, theirs):
            chosen[role] = theirs
            continue
        raise ConfigError(
            f"{source} names the {role} {shown_url(theirs)!r}, and yours is {shown_url(mine)!r}: a saved "
            "folder does not choose where your keys, tokens and camera images go",
            f"set the {role} yourself (ATTRIBOT_{role.upper()} or attribot.toml) to replay with it, or, for "
            f"a folder you made, replay with {TRUST_SAVED} (Python: trust_saved_backends=True)",
        )
    if not chosen:
        return own
    naming = FieldNaming(lambda field: source, lambda field, value: f"{field} = {value}")
    return load_settings(naming, **{**own.model_dump(), **chosen})


class _Rebuildable(Protocol):
    """What `save_answer` reads of a scene (`attribot.session.Scene`): its image, and what builds it again."""

    image: Path | str | None

    def saved(self, image_name: str | None = None) -> dict[str, Any]: ...


# ---- saving -----------------------------------------------------------------------------------------


def check_save_dir(directory: Path | None) -> None:
    """Refuse, before any work, a save folder that cannot take the answer: a file (or something under
    one), a place that cannot be written (/dev/null, /proc/self), or a folder that already holds an
    earlier answer (never overwritten silently)."""
    if directory is None:
        return
    fix = "give the answer a new folder (it is created), e.g. runs/mug-1"
    path = Path(directory)
    if path.exists() and not path.is_dir():
        raise InputError(f"the save folder {str(path)!r} is a file, not a folder", fix)
    existing = path
    while not existing.exists():
        if existing.parent == existing:
            break
        existing = existing.parent
    if not existing.is_dir():
        raise InputError(f"the save folder {str(path)!r} lies under {str(existing)!r}, which is a file", fix)
    earlier = [name for name in SAVED_FILES if (path / name).exists()]
    if earlier:
        raise InputError(
            f"the save folder {str(path)!r} already holds {', '.join(earlier)} of an earlier answer",
            "give a new folder, or remove the old answer first",
        )
    check_writable(existing, f"the save folder {str(path)!r}", fix)


def save_answer(
    answer: Answer,
    directory: Path,
    rgb: Any = None,
    settings: Settings | None = None,
    video: bytes | None = None,
    scene: _Rebuildable | None = None,
) -> list[Path]:
    """Write answer.json, program.py, settings.json, (with `scene`) run.json and a copy of its image,
    (with `rgb`) answer.png with the chosen box drawn, and (with `video`, MP4 bytes) episode.mp4.

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
    if scene is not None:
        image_name = None
        if scene.image is not None:  # the replay needs the picture, wherever the original lives later
            image_name = "input" + Path(scene.image).suffix.lower()
            shutil.copyfile(scene.image, directory / image_name)
            written.append(directory / image_name)
        run = {"query": answer.query, "planner": answer.planner, "scene": scene.saved(image_name)}
        put(RUN_FILE, json.dumps(run, indent=2).encode("utf-8"))
    if rgb is not None:
        put("answer.png", _png(answer_image(answer, rgb)))
    if video:
        put("episode.mp4", video)
    return written


def answer_image(answer: Answer, rgb: Any) -> Any:
    """A copy of `rgb` (the robot's first image) with the answer's box drawn and named, if it has one."""
    from attribot.draw import draw_boxes

    boxes = [] if answer.object is None else [(answer.object.box, answer.object.category or "answer")]
    return draw_boxes(rgb, boxes)


def _png(rgb: Any) -> bytes:
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgb).save(buf, format="PNG")
    return buf.getvalue()
