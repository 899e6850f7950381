"""attribot as a Python library (issue 18): the README's example runs as written, a notebook drives `ask`
and `run_program` on two scenes, and a `--save` folder replays to the same answer and the same trace."""

from __future__ import annotations

import contextlib
import io
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import attribot
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import InputError
from conftest import cli

README = Path(__file__).resolve().parents[1] / "README.md"


def readme_example() -> str:
    text = README.read_text(encoding="utf-8")
    section = text[text.index("## Python API") :]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def scene_truth(layout: str, seed: int) -> list:
    with MujocoWorld(layout=layout, seed=seed) as world:
        return list(world.scene_info().objects)


def test_the_readme_example_is_five_lines_and_runs_as_written(empty_settings):
    example = readme_example()
    assert len(example.strip().splitlines()) == 5
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(example, "README.md", "exec"), {})  # noqa: S102 (our own README's example)
    heaviest = max(scene_truth("triplet", 3), key=lambda o: o.mass_kg)
    assert f"({heaviest.id})" in out.getvalue() and out.getvalue().rstrip().endswith("kg")


def test_importing_attribot_loads_nothing_heavy():
    heavy = "('attribot.', 'mujoco', 'numpy')"
    code = f"import sys, attribot\nprint(sorted(m for m in sys.modules if m.startswith({heavy})))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and done.stdout.strip() == "[]", done.stdout + done.stderr
    assert {"ask", "run_program", "replay", "Scene", "Answer", "SceneConfig"} <= set(dir(attribot))
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        attribot.nope  # noqa: B018


def test_a_notebook_asks_and_runs_programs_on_two_scenes(empty_settings):
    """What a researcher types into a notebook: look at each scene, ask, run a program of one's own."""
    program = (
        "def execute_command(image, robot):\n"
        "    objects = sorted(image.find('object'), key=lambda p: p.horizontal_center)\n"
        "    print(len(objects), 'objects')\n"
        "    return objects[0], len(objects)\n"
    )
    for seed in (0, 2):
        scene = attribot.Scene(attribot.SceneConfig(layout="triplet", seed=seed, width=320, height=240))
        picture = scene.render()
        assert picture.shape == (240, 320, 3) and picture.dtype == np.uint8
        truth = scene_truth("triplet", seed)
        assert [o.id for o in scene.truth().objects] == [o.id for o in truth]  # what to score against
        answer = attribot.ask("Which object is the heaviest?", scene)
        assert isinstance(answer, attribot.Answer) and answer.ok
        assert answer.object.id == max(truth, key=lambda o: o.mass_kg).id
        assert answer.unit == "kg" and answer.world["seed"] == seed
        leftmost = attribot.run_program(program, scene, query="the leftmost object")
        seen = [o for o in truth if o.box]
        assert leftmost.ok and leftmost.object.id == min(seen, key=lambda o: o.box[0] + o.box[2]).id
        assert leftmost.value == len(seen) and leftmost.output == f"{len(seen)} objects\n"
        assert leftmost.returned[1] == len(seen)  # the other value of the returned tuple is kept


def test_ask_takes_a_world_config_a_name_and_settings_fields(empty_settings):
    config = attribot.SceneConfig(layout="triplet", seed=1, width=160, height=120)
    answer = attribot.ask("the leftmost object", config, checks="none")
    assert answer.ok and answer.checks == []
    with pytest.raises(InputError, match="no world's config|is no world"):
        attribot.ask("the leftmost object", 3)
    with pytest.raises(InputError, match="bridge world is configured by a BridgeConfig"):
        attribot.Scene(config, world="bridge")
    with pytest.raises(InputError, match="bridge world needs url"):
        attribot.Scene(world="bridge")


def test_a_saved_answer_replays_to_the_same_answer_and_trace(tmp_path, empty_settings):
    saved = tmp_path / "run"
    first = cli("ask", "Which object is the heaviest?", "--layout", "triplet", "--seed", "2", "--world-noise",
                "sensing", "--sensors", "camera,force", "--save", str(saved), "--json")  # fmt: skip
    assert first.returncode == 0, first.stderr
    again = cli("exec", str(saved), "--json")
    assert again.returncode == 0, again.stderr
    a, b = json.loads(first.stdout), json.loads(again.stdout)
    assert (a["answer"], a["object"], a["value"], a["world"]) == (
        b["answer"],
        b["object"],
        b["value"],
        b["world"],
    )

    def calls(answer: dict) -> list:
        return [{k: v for k, v in t.items() if k != "ms"} for t in answer["trace"]]

    assert calls(a) == calls(b) and len(calls(a)) > 3
    assert b["planner"] == "replay" and json.loads((saved / "run.json").read_text())["scene"]["sensors"] == [
        "camera",
        "force",
    ]
    # the program alone, without scene flags, runs in the scene saved beside it (not in scene 0)
    alone = cli("exec", str(saved / "program.py"), "--json")
    assert alone.returncode == 0 and json.loads(alone.stdout)["object"] == a["object"]
    assert "running in the scene saved beside it" in alone.stderr
    # flags with a saved folder would not replay it: refused, saying how to run its program elsewhere
    moved = cli("exec", str(saved), "--seed", "5")
    assert moved.returncode == 2 and "replays exactly as it was saved" in moved.stderr


def test_a_folder_without_a_program_is_refused_saying_so(tmp_path, empty_settings):
    saved = tmp_path / "failed"
    saved.mkdir()
    (saved / "answer.json").write_text("{}")
    (saved / "run.json").write_text("{}")
    done = cli("exec", str(saved))
    assert done.returncode == 2
    said = " ".join(done.stderr.split())
    assert "holds no program (program.py)" in said and "cannot be replayed" in said
    with pytest.raises(InputError, match="holds no program"):
        attribot.replay(saved)


def test_a_still_image_is_copied_into_the_save_folder_for_its_replay(tmp_path, empty_settings):
    from PIL import Image

    from attribot.saved_runs import save_answer
    from attribot.session import Scene, load_saved

    photo = tmp_path / "photo.png"
    Image.fromarray(np.zeros((8, 8, 3), np.uint8)).save(photo)
    answer = attribot.Answer(
        query="q", answer="a", planner="file", backends={}, attempts=1, program="x = 1\n"
    )
    save_answer(answer, tmp_path / "saved", settings=attribot.load_settings(), scene=Scene(image=photo))
    photo.unlink()  # the original is gone: the replay reads the copy
    program, scene, _, query = load_saved(tmp_path / "saved")
    assert program == "x = 1\n" and query == "q" and scene.image == tmp_path / "saved" / "input.png"


def test_the_wall_clock_limit_of_a_program_is_a_setting(empty_settings):
    """A real robot or a detector on a CPU needs longer than the simulator: `program_wall_s` (the
    --program-wall-s flag, ATTRIBOT_PROGRAM_WALL_S) bounds one program, its API calls included."""
    program = (
        "def execute_command(image, robot):\n"
        "    for name in ['object'] * 50:\n"
        "        found = image.find(name)\n"
        "    return found[0]\n"
    )
    scene = attribot.Scene(attribot.SceneConfig(layout="triplet", seed=3, width=160, height=120))
    short = attribot.run_program(program, scene, program_wall_s=0.05)
    assert short.error is not None and short.error.category == "timeout" and "0.05 s" in short.error.message
    roomy = attribot.run_program(program, scene, program_wall_s=120)
    assert roomy.error is None and roomy.object is not None
    done = cli("exec", "--help")
    assert "--program-wall-s" in done.stdout
