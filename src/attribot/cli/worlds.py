"""The world a command runs in, from its scene and world flags."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from attribot.cli.flags import SCENE_FIELD_FLAGS, flag_example, flag_name, flag_naming, given_value
from attribot.cli.output import fail, prefetch_rendering
from attribot.text import comma_names


def layout_options(option: list[str] | None) -> dict[str, Any]:
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


def scene_fields(given: Any) -> dict[str, Any]:
    """The SceneConfig fields the scene flags give (options still as `--option` pairs)."""
    categories = given_value(given, "categories")
    names = None if categories is None else tuple(comma_names(categories))
    if names == ():
        raise fail(
            "--categories names no category", "give comma-separated names, e.g. --categories mug,apple"
        )
    fields = {f.name: given_value(given, f.name) for f in SCENE_FIELD_FLAGS}
    fields["categories"] = names
    if given_value(given, "findable_by") is not None:
        fields["vocabulary"] = findable_vocabulary(given.findable_by)
        if names and fields["vocabulary"] is not None:
            from attribot.sim.catalog import find_category

            unfound = [n for n in names if (c := find_category(n)) and c.name not in fields["vocabulary"]]
            if unfound:
                raise fail(
                    f"--findable-by {given.findable_by} cannot find {', '.join(unfound)} (--categories)",
                    f"name only categories it can find ({', '.join(fields['vocabulary'][:8])}, ...), "
                    "or drop --findable-by",
                )
    if given_value(given, "world_noise") is not None:
        from attribot.noise import world_noise as parse_world_noise

        fields["noise"] = parse_world_noise(given.world_noise, given_value(given, "seed") or 0)
    return {k: v for k, v in fields.items() if v is not None}


def findable_vocabulary(spec: str) -> tuple[str, ...] | None:
    """The categories the detector `spec` can find (`--findable-by`); None when it finds any."""
    from attribot.config import load_settings
    from attribot.eval.subset import closed_set_detector
    from attribot.models.base import findable_categories

    detector = closed_set_detector(spec, load_settings(naming=flag_naming()))
    return None if detector is None else findable_categories(detector)


def scene_config(given: Any) -> Any:
    """The `SceneConfig` of the scene flags, or None when no flag was given."""
    from attribot.config import SceneConfig

    fields = scene_fields(given)
    options = layout_options(given_value(given, "option"))
    if options:
        fields["options"] = options
    return SceneConfig.create(naming=flag_naming(), **fields) if fields else None


def scene_world(config: Any) -> Any:
    prefetch_rendering()
    from attribot.config import SceneConfig
    from attribot.embodiments.mujoco import MujocoWorld

    return MujocoWorld(config or SceneConfig())


def query_scene(given: Any) -> Any:
    """The world to ask in, from the scene and world flags; called first, so that the OpenGL probe overlaps
    the slow imports."""
    image = given_value(given, "image")
    name = _world_name(given)
    config = None if image is not None else _world_config(name, given)
    if image is None and name == "mujoco":
        prefetch_rendering()
    from attribot.session import Scene

    sensors = given_value(given, "sensors")
    names = None if sensors is None else comma_names(sensors)
    if names == []:
        raise fail("no sensor named: --sensors is empty", "name at least one, e.g. --sensors camera")
    if given_value(given, "controller") is not None and image is not None:
        raise fail("--controller acts in a world, and --image is a still image", "drop one of the two")
    if image is not None and (scene_fields(given) or given_value(given, "option")):
        raise fail(
            "a query runs either on an image or in a generated scene, not both",
            "drop --image, or drop the scene options (--layout, --seed, --objects, ...)",
        )
    if image is not None:
        _check_image_file(image)
        return Scene(image=image, sensors=names)
    return Scene(config=config, world=name, sensors=names, controller=given_value(given, "controller"))


def _check_image_file(image: Path) -> None:
    """A missing image is said as such, with its path, before any detector is looked at."""
    from attribot.files import check_regular_file

    if not image.exists():
        raise fail(f"no such file: {str(image)!r} (--image)", "give the path of a PNG or JPEG file")
    check_regular_file(image, "--image", "give the path of a PNG or JPEG file")


def _world_name(given: Any) -> str:
    """The world the flags choose (--world, or bridge when only --bridge-url is given), checked."""
    from attribot.config import WORLD_CONFIGS

    world, url = given_value(given, "world"), given_value(given, "bridge_url")
    name = world or ("bridge" if url else "mujoco")
    if name not in WORLD_CONFIGS:
        raise fail(
            f"--world {name!r} is not a world here", f"choose --world {' or '.join(WORLD_CONFIGS.names())}"
        )
    if given_value(given, "image") is not None and (world is not None or url is not None):
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
        return scene_config(given)
    fields = {**scene_fields(given), **layout_options(given_value(given, "option"))}
    if given_value(given, "bridge_url") is not None:
        fields["url"] = given.bridge_url
    if "noise" in fields:
        raise fail(
            f"--world-noise makes the simulator imperfect, and --world {name} is not the simulator",
            "drop --world-noise (a real robot brings its own), or use --world mujoco",
        )
    unknown = [field for field in fields if field not in kind.settable()]
    if unknown:
        raise fail(
            f"{', '.join(flag_name(f).rstrip('=') for f in unknown)} does not apply to --world {name}",
            f"its settings are: {', '.join(flag_name(f).rstrip('=') for f in kind.settable())}",
        )
    required = [f for f, info in kind.model_fields.items() if info.is_required() and f not in fields]
    if required:
        raise fail(
            f"--world {name} needs {', '.join(flag_name(f).rstrip('=') for f in required)}",
            "give it, e.g. " + ", ".join(flag_example(f, "...") for f in required),
        )
    return kind.create(naming=flag_naming(), **fields)
