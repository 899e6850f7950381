"""`attribot ask` and `attribot exec` end to end: the offline defaults on the embedded world, answers
checked against the simulator's truth, replay of a saved program, an LLM planner on a loopback server,
and the errors a user meets."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from attribot.config import SceneConfig, load_settings
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import ConfigError, InputError
from attribot.session import Scene, ask, run_program
from conftest import cli, serve_chat_replies

LAYOUT, SEED = "household", 7


@pytest.fixture(scope="module")
def truth() -> dict:
    with MujocoWorld(layout=LAYOUT, seed=SEED) as world:
        return world.scene_info().model_dump(mode="json")


def by_category(truth: dict) -> dict[str, dict]:
    return {o["category"]: o for o in truth["objects"]}


def test_distance_query_measures_and_picks_the_truly_closer_object(truth):
    objs = by_category(truth)
    names = sorted(objs)[:2]
    answer = ask(
        f"Is the {names[0]} or the {names[1]} closer to me?",
        Scene(SceneConfig(layout=LAYOUT, seed=SEED)),
        load_settings(),
    )
    assert answer.error is None, answer.error
    expected = min(names, key=lambda n: objs[n]["distance_m"])
    assert answer.object is not None and answer.object.category == expected
    assert answer.object.id == objs[expected]["id"]
    assert answer.unit == "m"
    # the rangefinder reads the near surface: within the object's size of its centre distance
    assert abs(answer.value - objs[expected]["distance_m"]) < objs[expected]["size_m"] / 2 + 0.05
    calls = [t["call"] for t in answer.trace]
    assert calls.count("Robot.measure_distance") == 2
    assert answer.backends == {
        "detector": "oracle",
        "vqa": "oracle",
        "language": "catalog",
        "robot": "servo",
    }


def test_where_is_and_than_queries_answer_with_the_right_object(truth):
    objs = by_category(truth)
    target = sorted(objs)[0]
    answer = ask(f"Where is the {target}?", Scene(SceneConfig(layout=LAYOUT, seed=SEED)), load_settings())
    assert answer.error is None, answer.error
    assert answer.object is not None and answer.object.id == objs[target]["id"]
    near, far = sorted(sorted(objs)[:2], key=lambda n: objs[n]["distance_m"])
    answer = ask(
        f"Is the {far} closer to me than the {near}?",
        Scene(SceneConfig(layout=LAYOUT, seed=SEED)),
        load_settings(),
    )
    assert answer.error is None, answer.error
    assert answer.object.id == objs[near]["id"] and answer.unit == "m"  # no: measured, the other one is


def test_how_far_and_how_heavy_measure_the_named_object(truth):
    objs = by_category(truth)
    target = next(n for n in sorted(objs) if objs[n]["pickable"])
    answer = ask(
        f"How far away is the {target}?", Scene(SceneConfig(layout=LAYOUT, seed=SEED)), load_settings()
    )
    assert answer.error is None, answer.error
    assert answer.object.id == objs[target]["id"] and answer.unit == "m"
    assert abs(answer.value - objs[target]["distance_m"]) < objs[target]["size_m"] / 2 + 0.05
    answer = ask(
        f"How much does the {target} weigh?", Scene(SceneConfig(layout=LAYOUT, seed=SEED)), load_settings()
    )
    assert answer.error is None, answer.error
    assert answer.unit == "kg" and answer.value == pytest.approx(objs[target]["mass_kg"], rel=0.03)


def test_weight_query_weighs_each_candidate_with_the_force_sensor(truth):
    objs = by_category(truth)
    pickable = sorted(n for n, o in objs.items() if o["pickable"])
    listed = ", the ".join(pickable[:-1]) + f" and the {pickable[-1]}"
    answer = ask(
        f"Out of the {listed}, which one is the heaviest?",
        Scene(SceneConfig(layout=LAYOUT, seed=SEED)),
        load_settings(),
    )
    assert answer.error is None, answer.error
    expected = max(pickable, key=lambda n: objs[n]["mass_kg"])
    assert answer.object.category == expected
    assert answer.unit == "kg"
    assert answer.value == pytest.approx(objs[expected]["mass_kg"], rel=0.03)
    assert "N)" in answer.answer  # newtons shown beside kilograms
    assert sum(t["call"] == "Robot.measure_weight" for t in answer.trace) == len(pickable)


def test_without_a_force_sensor_the_program_reasons_instead_of_weighing(truth):
    answer = ask(
        "Which object is the heaviest?",
        Scene(SceneConfig(layout=LAYOUT, seed=SEED), sensors=["camera"]),
        load_settings(),
    )
    calls = {t["call"] for t in answer.trace}
    assert "Robot.measure_weight" not in calls
    assert "ImagePatch.language_query" in calls


def test_ask_saves_and_exec_replays_the_same_answer(tmp_path, truth):
    query = "Out of the " + " and the ".join(sorted(by_category(truth))[:2]) + ", which one is closer to me?"
    first = ask(query, Scene(SceneConfig(layout=LAYOUT, seed=SEED)), load_settings(), save_dir=tmp_path)
    assert first.error is None
    saved = json.loads((tmp_path / "answer.json").read_text())
    assert saved["object"]["id"] == first.object.id
    assert json.loads((tmp_path / "settings.json").read_text())["detector"] == "oracle"
    with Image.open(tmp_path / "answer.png") as im:
        drawn = np.asarray(im.convert("RGB"))
    with MujocoWorld(layout=LAYOUT, seed=SEED) as world:
        plain = world.observe().rgb
    x0, y0, x1, y1 = (int(v) for v in first.object.box)
    assert not np.array_equal(drawn[y0:y1, x0:x1], plain[y0:y1, x0:x1])  # the box is drawn there
    replay = run_program(
        (tmp_path / "program.py").read_text(),
        Scene(SceneConfig(layout=LAYOUT, seed=SEED)),
        load_settings(),
        query=query,
    )
    assert replay.planner == "file"
    assert replay.object == first.object and replay.value == pytest.approx(first.value)


def test_a_program_may_return_a_plain_value():
    program = 'def execute_command(image, robot):\n    return len(image.find("item"))\n'
    answer = run_program(program, Scene(SceneConfig(layout=LAYOUT, seed=SEED)), load_settings())
    assert answer.error is None and answer.object is None
    with MujocoWorld(layout=LAYOUT, seed=SEED) as world:
        visible = [o for o in world.scene_info().objects if o.box is not None]
    assert answer.value == len(visible)


@pytest.mark.parametrize(
    ("program", "category"),
    [
        ("import os\ndef execute_command(image, robot):\n    return os.getcwd()\n", "policy"),
        ("def execute_command(image, robot):\n    return 1 / 0\n", "runtime"),
        ("def execute_command(image, robot):\n    return image.find('')\n", "api"),
        ("def execute_command(image, robot)\n    return 1\n", "syntax"),
        ("def execute_command(image, robot):\n    return None\n", "runtime"),
    ],
)
def test_program_errors_become_structured_answers(program, category):
    answer = run_program(program, Scene(SceneConfig(layout=LAYOUT, seed=SEED)), load_settings())
    assert answer.error is not None and answer.error.category == category
    assert answer.object is None and answer.answer.startswith("no answer")


def test_image_mode_needs_a_real_detector(tmp_path):
    path = tmp_path / "photo.png"
    Image.fromarray(np.zeros((8, 8, 3), np.uint8)).save(path)
    with pytest.raises(ConfigError, match="needs a real detector"):
        ask("the heaviest item", Scene(image=path), load_settings())


@pytest.mark.parametrize("query", ["", "   ", "x" * 600])
def test_empty_or_overlong_queries_are_refused(query):
    with pytest.raises(InputError):
        ask(query, Scene(SceneConfig(layout=LAYOUT, seed=SEED)), load_settings())


def test_cli_json_output_and_exit_codes(tmp_path):
    ok = cli("ask", "Which object is the heaviest?", "--layout", LAYOUT, "--seed", str(SEED), "--json")
    assert ok.returncode == 0, ok.stderr
    data = json.loads(ok.stdout)
    assert set(data) >= {
        "query",
        "answer",
        "object",
        "value",
        "program",
        "planner",
        "backends",
        "attempts",
        "trace",
        "error",
    }
    assert data["error"] is None and data["object"]["box"][2] > data["object"]["box"][0]
    assert {"call", "args", "result", "ms"} <= set(data["trace"][0])

    bad = tmp_path / "escape.py"
    bad.write_text("def execute_command(image, robot):\n    return image.__class__\n")
    refused = cli("exec", str(bad), "--json")
    assert refused.returncode == 1
    assert json.loads(refused.stdout)["error"]["category"] == "policy"

    corrupt = tmp_path / "corrupt.png"
    corrupt.write_bytes(b"\x89PNG\r\n\x1a\n broken")
    err = cli("ask", "the red cup", "--image", str(corrupt), "--detector", "hf:/nowhere")
    assert (
        err.returncode == 2 and "cannot be read as an image" in err.stderr and "Traceback" not in err.stderr
    )

    for args, needle in [
        (("ask", ""), "query is empty"),
        (("ask", "the heaviest item", "--layout", "garage"), "unknown layout"),
        (("ask", "the heaviest item", "--sensors", "camera,sonar"), "unknown sensor"),
        (("ask", "tell me a joke"), "supported families"),
        (("exec", str(tmp_path / "missing.py")), "does not exist"),
    ]:
        res = cli(*args)
        assert res.returncode == 2, (args, res.stderr)
        assert needle in res.stderr and "Traceback" not in res.stderr


def test_llm_planner_end_to_end_with_feedback(httpserver, tmp_path, truth):
    """A loopback OpenAI-compatible server: the first reply has no code, the second a working program."""
    target = sorted(by_category(truth))[0]
    program = (
        "```python\ndef execute_command(image, robot):\n"
        f"    patches = image.find('{target}')\n    return patches[0]\n```"
    )
    requests = serve_chat_replies(httpserver, ["I think it is the one on the left.", program])
    settings = load_settings(
        planner="llm", llm_base_url=httpserver.url_for("/v1"), llm_model="fake", cache_dir=tmp_path / "cache"
    )
    answer = ask(f"Where is the {target}?", Scene(SceneConfig(layout=LAYOUT, seed=SEED)), settings)
    assert answer.error is None, answer.error
    assert answer.planner == "llm" and answer.attempts == 2
    assert answer.object.category == target
    assert len(requests) == 2
    assert "no code" in json.dumps(requests[1]["messages"][-1]).lower()


def test_llm_that_never_writes_code_gives_a_structured_no_code_answer(httpserver, tmp_path):
    serve_chat_replies(httpserver, ["Sorry, I cannot help with that."])
    settings = load_settings(
        planner="llm",
        llm_base_url=httpserver.url_for("/v1"),
        llm_model="fake",
        llm_max_tries=2,
        cache_dir=tmp_path / "cache",
    )
    answer = ask("Which object is the heaviest?", Scene(SceneConfig(layout=LAYOUT, seed=SEED)), settings)
    assert answer.attempts == 2 and answer.object is None
    assert answer.error is not None and "no code" in answer.error.message


def test_a_retry_starts_with_empty_hands_and_a_fresh_view(httpserver, tmp_path, truth):
    """The first program picks an object up and fails; the second must still be able to weigh."""
    target = next(o for o in truth["objects"] if o["pickable"])["category"]
    first = (
        "```python\ndef execute_command(image, robot):\n"
        f"    p = image.find('{target}')[0]\n    robot.go_to_object(p)\n    robot.pick_up(p)\n"
        "    return 1 / 0\n```"
    )
    second = (
        "```python\ndef execute_command(image, robot):\n"
        f"    p = image.find('{target}')[0]\n    robot.go_to_object(p)\n    robot.pick_up(p)\n"
        "    w = robot.measure_weight(p)\n    robot.put_down()\n    return w\n```"
    )
    requests = serve_chat_replies(httpserver, [first, second])
    settings = load_settings(
        planner="llm", llm_base_url=httpserver.url_for("/v1"), llm_model="fake", cache_dir=tmp_path / "c"
    )
    answer = ask(f"How heavy is the {target}?", Scene(SceneConfig(layout=LAYOUT, seed=SEED)), settings)
    assert answer.error is None, answer.error
    assert answer.attempts == 2 and len(requests) == 2
    mass = next(o["mass_kg"] for o in truth["objects"] if o["category"] == target)
    assert answer.value == pytest.approx(mass, rel=0.03)


def test_image_mode_runs_through_a_real_detector_and_vqa(tmp_path):
    """`--image` with transformers backends (tiny random OWLv2 and BLIP-2 saved to disk, loaded by path):
    the whole flow runs; what random weights find is arbitrary, so the answer is an object or a structured
    runtime error raised by the program, never a crash."""
    pytest.importorskip("transformers", reason="needs the models extra")
    from fakes.hf_random import save_random

    owl, blip = tmp_path / "owl", tmp_path / "blip"
    save_random("owlv2-tiny", owl)
    save_random("blip2-tiny", blip)
    with MujocoWorld(layout="triplet", seed=3, width=320, height=240) as world:
        photo = tmp_path / "photo.png"
        Image.fromarray(world.observe().rgb).save(photo)
    settings = load_settings(detector=f"hf:{owl}", vqa=f"hf:{blip}")
    for query in ("the leftmost item", "the heaviest item"):
        answer = ask(query, Scene(image=photo), settings, save_dir=tmp_path / query.replace(" ", "-"))
        assert answer.backends["detector"].startswith("hf:") and answer.backends["vqa"].startswith("hf:")
        assert answer.world == {"image": str(photo)}
        saved = {p.name for p in (tmp_path / query.replace(" ", "-")).iterdir()}
        assert "answer.json" in saved and "episode.mp4" not in saved  # a still image has no episode
        assert answer.trace and answer.trace[0]["call"] in ("ImagePatch.find", "ImagePatch.visual_query")
        if answer.error is not None:
            assert answer.error.category == "runtime", answer.error
        else:
            assert answer.object is not None or answer.answer
