"""attribot: LLM-written programs over a perception-action API that discover object attributes.

The Python API, for scripts and notebooks:

    import attribot

    scene = attribot.Scene(attribot.SceneConfig(layout="household", seed=3))
    answer = attribot.ask("which object is the heaviest?", scene)
    print(answer.answer, answer.value, answer.unit)

`ask(query, world, settings, save_dir=..., **settings_fields)` plans a program and runs it;
`run_program(source, world, ...)` runs a given one; `replay(saved_dir)` runs a saved answer again; all
return the typed `Answer`. A world is a `Scene` (a world config, or a still image, with sensors and a
controller), a world config (`SceneConfig`, `BridgeConfig`, `Ai2ThorConfig`) or a world name.

Importing the package has no side effects: no render backend is chosen, no model is loaded, and the names
above load their modules when first used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from attribot.config import Ai2ThorConfig, BridgeConfig, SceneConfig, Settings, load_settings
    from attribot.planning.answer import Answer
    from attribot.session import Scene, ask, replay, run_program

__all__ = [
    "__version__",
    "ask",
    "run_program",
    "replay",
    "Scene",
    "SceneConfig",
    "BridgeConfig",
    "Ai2ThorConfig",
    "Settings",
    "load_settings",
    "Answer",
]

__version__ = "0.1.0"

_HOMES = {
    "ask": "attribot.session",
    "run_program": "attribot.session",
    "replay": "attribot.session",
    "Scene": "attribot.session",
    "SceneConfig": "attribot.config",
    "BridgeConfig": "attribot.config",
    "Ai2ThorConfig": "attribot.config",
    "Settings": "attribot.config",
    "load_settings": "attribot.config",
    "Answer": "attribot.planning.answer",
}


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'attribot' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(home), name)


def __dir__() -> list[str]:
    return sorted(__all__)
