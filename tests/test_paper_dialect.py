"""Programs in the paper's (and ViperGPT's) dialect run unchanged: `execute_command(image)`,
`ImagePatch(image)`, `Robot(sensors=[...])` with the paper's sensor names, and object names where the
paper's Robot took them (`robot.pick_up("book")`)."""

from __future__ import annotations

import json
from textwrap import dedent

import pytest

from attribot.api import ImagePatch, Robot
from attribot.config import SceneConfig, load_settings
from attribot.embodiments.mujoco import MujocoWorld
from attribot.runner import ProgramRunner
from attribot.session import Scene, ask
from conftest import BALLS, BallController, BallWorld, serve_chat_replies, world_perception


@pytest.fixture(scope="module")
def runner():
    with ProgramRunner(classes=[ImagePatch, Robot]) as r:
        yield r


def _session(sensors=("camera", "distance", "force")):
    world = BallWorld(BALLS)
    robot = Robot(sensors=sensors, world=world, controller=BallController(world))
    return robot, robot.look(world_perception())


def _run(runner, program: str, sensors=("camera", "distance", "force")):
    robot, image = _session(sensors)
    return runner.run(dedent(program), args=[image, robot]), robot


def test_one_argument_entry_and_imagepatch_of_the_image(runner):
    result, _ = _run(
        runner,
        """
        def execute_command(image):
            image_patch = ImagePatch(image)
            balls = image_patch.find("ball")
            return max(balls, key=lambda b: b.area)
        """,
    )
    assert result.ok, result.error
    assert result.value_object.object_id == "b1"  # the nearest, largest-looking ball
    assert [t.call for t in result.trace] == ["ImagePatch", "ImagePatch.find"]


def test_viper_style_imagepatch_with_a_box_is_a_crop(runner):
    result, _ = _run(
        runner,
        """
        def execute_command(image):
            left_half = ImagePatch(image, 0, 0, image.width / 2, image.height)
            return left_half.width
        """,
    )
    assert result.ok, result.error
    assert result.value == pytest.approx(160)


@pytest.mark.parametrize(
    ("body", "words"),
    [
        ("return ImagePatch(5)", "takes the image given to execute_command, not a int"),
        ("return ImagePatch(image, 0, 0)", "needs all four coordinates"),
        ('return Robot(sensors=["camera", "IMU"])', "unknown sensor 'IMU'"),
        ("return Robot(sensors=123)", "sensors must be a list of names, got 123"),
        ('return Robot("camera")', "sensors must be a list of names, got 'camera'"),
    ],
)
def test_dialect_constructors_refuse_clearly(runner, body, words):
    result, _ = _run(runner, f"def execute_command(image):\n    {body}\n")
    assert not result.ok and result.error.category == "api"
    assert words in result.error.message


def test_robot_with_the_papers_sensor_names_is_the_session_robot_restricted(runner):
    result, robot = _run(
        runner,
        """
        def execute_command(image):
            robot = Robot(sensors=["camera", "distance sensor"])
            ball = image.find("ball")[0]
            metres = robot.measure_distance(ball)
            robot.measure_weight(ball)
            return metres
        """,
    )
    assert not result.ok and "needs the 'force' sensor" in result.error.message
    assert (
        "name it in the program's Robot(sensors=[...])" in result.error.message
    )  # not --sensors: it has one
    assert [m.kind for m in robot.measurements] == ["distance"]  # recorded on the session's robot
    robot.look(world_perception())  # the next program starts with every sensor it was given
    assert robot.sensors == ["camera", "distance", "force"]


def test_robot_refuses_a_sensor_the_session_was_not_given(runner):
    result, _ = _run(
        runner,
        'def execute_command(image):\n    return Robot(sensors=["camera", "force/torque sensor"])\n',
        sensors=("camera", "distance"),
    )
    assert not result.ok and "asks for the force sensor" in result.error.message
    assert "--sensors camera,distance,force" in result.error.message


def test_depth_camera_reads_as_camera_and_distance(runner):
    result, robot = _run(
        runner,
        """
        def execute_command(image):
            robot = Robot(sensors=["depth camera"])
            return robot.sensors
        """,
    )
    assert result.ok and result.value == ["camera", "distance"]


def test_a_name_stands_for_the_patch_the_program_acted_on(runner):
    robot, image = _session()
    approached = image.find("ball")[1]  # not the first: the name must mean this one, not any ball
    program = """
def execute_command(image):
    robot = Robot(sensors=["camera", "force/torque sensor"])
    balls = image.find("ball")
    robot.go_to_object(balls[1])
    robot.pick_up("ball")
    kg = robot.measure_weight("the ball")
    robot.put_down()
    return kg
"""
    result = runner.run(program, args=[image, robot])
    assert result.ok, result.error
    assert robot.measurements[-1].object_id == approached.object_id
    assert result.value == pytest.approx(next(b.mass for b in BALLS if b.id == approached.object_id))


def test_an_entry_that_needs_more_arguments_is_a_clear_error(runner):
    result, _ = _run(runner, "def execute_command(image, robot, extra):\n    return 1\n")
    assert not result.ok and "needs 3 arguments" in result.error.message


# ---- in the MuJoCo world, through `attribot exec` and the LLM planner --------------------------------------

PAPER_WEIGHT_PROGRAM = """
def execute_command(image):
    image_patch = ImagePatch(image)
    robot = Robot(sensors=["camera", "force/torque sensor"])
    items = image_patch.find("object")
    lightest = None
    lightest_weight = None
    for item in items:
        robot.go_to_object(item)
        robot.pick_up(item)
        weight = robot.measure_weight(item)
        robot.put_down()
        if lightest_weight is None or weight < lightest_weight:
            lightest = item
            lightest_weight = weight
    return lightest
"""


@pytest.fixture(scope="module")
def triplet_truth() -> dict:
    with MujocoWorld(layout="triplet", seed=3) as world:
        return world.scene_info().model_dump(mode="json")


def test_a_paper_style_weight_program_runs_through_attribot_exec(tmp_path, triplet_truth):
    from test_ask import cli

    program = tmp_path / "paper.py"
    program.write_text(PAPER_WEIGHT_PROGRAM)
    done = cli("exec", str(program), "--layout", "triplet", "--seed", "3", "--json")
    assert done.returncode == 0, done.stderr
    answer = json.loads(done.stdout)
    lightest = min(triplet_truth["objects"], key=lambda o: o["mass_kg"])
    assert answer["object"]["id"] == lightest["id"]
    assert answer["unit"] == "kg" and answer["value"] == pytest.approx(lightest["mass_kg"], rel=0.05)


def test_names_in_robot_calls_through_attribot_exec(tmp_path):
    from test_ask import cli

    with MujocoWorld(layout="household", seed=7) as world:
        objects = world.scene_info().objects
    counts = {o.category: sum(p.category == o.category for p in objects) for o in objects}
    target = next(o for o in objects if counts[o.category] == 1)
    program = tmp_path / "named.py"
    program.write_text(
        "def execute_command(image):\n"
        '    robot = Robot(sensors=["camera", "distance sensor"])\n'
        f'    return robot.measure_distance("{target.category}")\n'
    )
    done = cli("exec", str(program), "--layout", "household", "--seed", "7", "--json")
    assert done.returncode == 0, done.stderr
    answer = json.loads(done.stdout)
    assert answer["value"] == pytest.approx(target.distance_m, abs=0.25)
    assert answer["trace"][0]["call"] == "Robot"


def test_the_llm_planner_runs_a_reply_in_the_papers_style(httpserver, tmp_path, triplet_truth):
    requests = serve_chat_replies(httpserver, [f"Here is the program:\n```python\n{PAPER_WEIGHT_PROGRAM}```"])
    settings = load_settings(
        planner="llm", llm_base_url=httpserver.url_for("/v1"), llm_model="fake", cache_dir=tmp_path / "c"
    )
    answer = ask(
        "Out of these objects, which one is the most lightweight?",
        Scene(SceneConfig(layout="triplet", seed=3)),
        settings,
    )
    lightest = min(triplet_truth["objects"], key=lambda o: o["mass_kg"])
    assert answer.error is None and answer.object is not None and answer.object.id == lightest["id"]
    assert len(requests) == 1
    # the prompt still teaches the two-argument form
    prompt = json.dumps(requests[0]["messages"])
    assert "def execute_command(image, robot)" in prompt
