"""Import what is used (issue 50, item 3): an oracle question imports no other backend and no other world, and
a registry's look-up of a built-in name imports the one module that registers it. Each check runs in a fresh
interpreter, since this one has imported everything the other tests used."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

from conftest import EMPTY_SETTINGS

UNUSED = (
    "attribot.models.hf",
    "attribot.models.coco",
    "attribot.models.remote",
    "attribot.models.openai_chat",
    "attribot.planning.llm",
    "attribot.embodiments.ai2thor",
    "attribot.embodiments.bridge",
    "attribot.bridge",
    "attribot.server",
)
"""What an oracle question on the MuJoCo world never needs: the other backends, planners and worlds."""

SMALL = {"layout": "triplet", "seed": 1, "width": 160, "height": 120}


def fresh(code: str) -> dict:
    """Run `code` in a fresh interpreter with empty settings; it prints one JSON line, returned here."""
    env = {**os.environ, "ATTRIBOT_CONFIG": str(EMPTY_SETTINGS)}
    env.pop("ATTRIBOT_PLUGINS", None)
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, env=env, timeout=300
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


MODULES = """
import json, sys
print(json.dumps(sorted(m for m in sys.modules if m.startswith("attribot"))))
"""


def modules_after(code: str) -> list[str]:
    """The attribot modules imported once `code` has run in a fresh interpreter."""
    return fresh(textwrap.dedent(code) + MODULES)


def unused_in(modules: list[str]) -> list[str]:
    return [m for m in modules if any(m == u or m.startswith(u + ".") for u in UNUSED)]


def test_an_oracle_question_imports_no_other_backend_or_world():
    modules = modules_after(
        f"""
        import attribot
        answer = attribot.ask("which object is the heaviest?", attribot.SceneConfig(**{SMALL!r}))
        assert answer.backends["detector"] == "oracle", answer.backends
        """
    )
    assert "attribot.models.oracle" in modules and "attribot.embodiments.mujoco" in modules
    assert unused_in(modules) == []


def test_the_cli_ask_imports_no_other_backend_or_world():
    args = [
        "ask",
        "which object is the heaviest?",
        "--layout",
        "triplet",
        "--width",
        "160",
        "--height",
        "120",
    ]
    modules = modules_after(
        f"""
        import runpy, sys
        sys.argv = ["attribot", *{args!r}]
        try:
            runpy.run_module("attribot.cli", run_name="__main__")
        except SystemExit as exc:
            assert not exc.code, exc.code
        """
    )
    assert "attribot.models.oracle" in modules
    assert unused_in(modules) == []


def test_making_a_scene_config_imports_the_layouts_not_the_world_nor_mujoco():
    # its checks live with the layouts they check (attribot.sim.scene), not in the world that builds them
    modules = modules_after(
        """
        import sys
        from attribot.config import SceneConfig
        SceneConfig(layout="household", seed=1, categories=("mug", "apple"))
        assert "mujoco" not in sys.modules, "making a config loaded MuJoCo"
        """
    )
    assert "attribot.sim.scene" in modules
    world = ("attribot.sim.world", "attribot.sim.model", "attribot.sim.render", "attribot.sim.robot_ep")
    assert [m for m in modules if m in world] == []
    assert unused_in(modules) == []


OPTIONAL_HOMES = (
    "attribot.models.hf",
    "attribot.models.coco",
    "attribot.models.remote",
    "attribot.models.openai_chat",
    "attribot.embodiments.ai2thor",
    "attribot.embodiments.bridge",
    "attribot.planning.llm",
    "attribot.sim.robot_ep",
)
"""Homes that a look-up of another name must leave unimported."""


@pytest.mark.parametrize(
    ("registry", "name", "home"),
    [
        ("attribot.models.base:DETECTORS", "oracle", "attribot.models.oracle"),
        ("attribot.models.base:DETECTORS", "coco", "attribot.models.coco"),
        ("attribot.models.base:VQAS", "openai", "attribot.models.openai_chat"),
        ("attribot.models.base:LANGUAGE_MODELS", "catalog", "attribot.models.catalog"),
        ("attribot.embodiments.base:EMBODIMENTS", "sim", "attribot.embodiments.mujoco"),
        ("attribot.embodiments.base:EMBODIMENTS", "bridge", "attribot.embodiments.bridge"),
        ("attribot.planning.base:PLANNERS", "rules", "attribot.planning.rules.planner"),
        ("attribot.sim.bodies:BODIES", "ep", "attribot.sim.robot_ep"),
    ],
)
def test_a_look_up_imports_only_the_module_that_registers_the_name(registry, name, home):
    module, attr = registry.split(":")
    found = fresh(
        f"""
        import importlib, json, sys
        registry = getattr(importlib.import_module({module!r}), {attr!r})
        homes = set(registry._homes.values())
        registry.get({name!r})
        print(json.dumps(sorted(m for m in homes if m in sys.modules)))
        """
    )
    assert home in found
    # no other backend, planner, world or body comes with it
    assert [m for m in found if m in OPTIONAL_HOMES and m != home] == []


def test_every_built_in_name_has_the_home_that_registers_it():
    # homes and registrations must not drift apart: a home's module registers the name it is the home of,
    # and every built-in name of a registry with homes has one (else a look-up of it imports every module)
    wrong = fresh(
        """
        import importlib, json, sys
        from attribot.registry import Registry
        for module in ("attribot.models.base", "attribot.embodiments.base", "attribot.planning.base",
                       "attribot.control.base", "attribot.sim.bodies"):
            importlib.import_module(module)
        wrong = []
        for registry in list(Registry._every):
            for name, home in registry._homes.items():
                importlib.import_module(home)
                shared = [r for r in Registry._every if r._homes == registry._homes]
                if not any(name in r._entries or name in r._aliases for r in shared):
                    wrong.append(f"{registry.kind} {name!r}: {home} does not register it")
        for registry in list(Registry._every):
            if registry._homes and registry.kind != "controller":  # worlds add theirs from above
                for name in [*registry.names(), *registry._aliases]:
                    if name not in registry._homes:
                        wrong.append(f"{registry.kind} {name!r} has no home")
        print(json.dumps(wrong))
        """
    )
    assert wrong == []


def test_the_tasks_are_listed_in_one_order_whichever_module_was_imported_first():
    # a test or a lab that imports the embodied tasks first must not move them ahead of the still-image
    # ones: a dataset's, a report's and the CLI's order is the registry's declared order of its modules
    listing = """
        import importlib, json
        from attribot.eval.suite import TASKS
        for module in {first}:
            importlib.import_module(module)
        print(json.dumps(TASKS.names()))
        """
    declared = fresh(listing.format(first="()"))
    late = fresh(listing.format(first='("attribot.eval.tasks.realroom", "attribot.eval.tasks.embodied")'))
    assert late == declared
    assert declared[0] == "location" and declared[-1].endswith("_realroom")
