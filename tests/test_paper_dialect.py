"""Programs in the paper's (and ViperGPT's) dialect run unchanged: `execute_command(image)`,
`ImagePatch(image)`, `Robot(sensors=[...])` with the paper's sensor names, and object names where the
paper's Robot took them (`robot.pick_up("book")`); and the habits of the authors' released prompt: robot
methods called bare (`go_to_object("book")`) and on patches (`book_patch.measure_weight("book")`, then
`weight["book"]`), the list `find` returns used as the patch, `== "Yes"`, and no put_down between objects.
Truths come from the worlds' own state: the fake ball world's geometry, and MuJoCo scenes of all three
layouts."""

from __future__ import annotations

import json
import math
from textwrap import dedent

import numpy as np
import pytest

from attribot.api import ImagePatch, Perception, Robot
from attribot.config import SceneConfig, load_settings
from attribot.control.base import build_controller
from attribot.embodiments.mujoco import MujocoWorld
from attribot.runner import ProgramRunner
from attribot.session import Scene, ask, run_program
from conftest import (
    BALLS,
    CAM_HEIGHT,
    Ball,
    BallController,
    BallWorld,
    FakeLanguage,
    FakeVQA,
    WorldDetector,
    serve_chat_replies,
    world_perception,
)


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


# ---- the habits of the authors' released prompt, in a world whose geometry is the truth -------------------

THINGS = [
    Ball("m1", "mug", (2.0, 0.6, 0.5), 0.15, 0.4, celsius=80.0),
    Ball("l1", "lamp", (3.0, -0.9, 0.3), 0.2, 1.7),
    Ball("b1", "ball", (1.5, 0.1, 1.3), 0.1, 0.05),
    Ball("b2", "ball", (2.5, -0.3, 1.0), 0.1, 0.3),
]
ALL = ("camera", "distance", "force", "temperature", "grip")


def distance_to(ball: Ball) -> float:
    """What the rangefinder must read when centred on `ball`: from the camera to its near surface."""
    return float(np.linalg.norm(np.asarray(ball.center) - np.array([0.0, 0.0, CAM_HEIGHT]))) - ball.radius


def _things(runner, program: str, sensors=ALL, answers: dict[str, str] | None = None):
    world = BallWorld(THINGS)
    robot = Robot(sensors=sensors, world=world, controller=BallController(world))
    perception = Perception(WorldDetector(), FakeVQA(), FakeLanguage(answers))
    image = robot.look(perception)
    result = runner.run(dedent(program), args=[image, robot])
    world.perception = perception  # for the test to read what the backends were asked
    return result, robot, world


def test_robot_methods_run_as_bare_functions_and_on_patches(runner):
    result, robot, _ = _things(
        runner,
        """
        def execute_command(image):
            robot = Robot(sensors=["camera", "distance sensor", "force/torque sensor"])
            image_patch = ImagePatch(image)
            mug_patch = image_patch.find("mug")[0]
            lamp_patch = image_patch.find("lamp")[0]
            go_to_object(mug_patch)
            pick_up("mug")
            weight = mug_patch.measure_weight("mug")
            focus_on_patch(lamp_patch)
            distance = lamp_patch.measure_distance()
            return [weight["mug"], weight, distance, weight * 2, weight[mug_patch]]
        """,
    )
    assert result.ok, result.error
    mug, lamp = THINGS[0], THINGS[1]
    assert result.value[:2] == [pytest.approx(mug.mass, rel=0.02)] * 2
    assert result.value[2] == pytest.approx(distance_to(lamp), abs=0.01)
    assert result.value[3] == pytest.approx(2 * mug.mass, rel=0.02) and result.value[4] == result.value[0]
    assert [(m.kind, m.object_id) for m in robot.measurements] == [("weight", "m1"), ("distance", "l1")]
    calls = [t.call for t in result.trace]
    assert calls[0] == "Robot" and "Robot.pick_up" in calls and "Robot.measure_weight" in calls


def test_with_no_robot_made_the_bare_functions_are_the_sessions_robot(runner):
    result, robot, _ = _things(
        runner,
        """
        def execute_command(image, robot):
            lamp = image.find("lamp")[0]
            return measure_distance(lamp)
        """,
    )
    assert result.ok, result.error
    assert result.value == pytest.approx(distance_to(THINGS[1]), abs=0.01)
    assert [t.call for t in result.trace] == ["ImagePatch.find", "Robot", "Robot.measure_distance"]
    assert robot.measurements[-1].object_id == "l1"  # recorded on the session's robot


@pytest.mark.parametrize(
    ("body", "words"),
    [
        ('return image.find("ball").horizontal_center', "find('ball') found 2 objects"),
        ('return image.find("sofa").visual_query()', "find('sofa') found nothing"),
        ('go_to_object(image.find("ball"))', "got a list of 2 patches (the ball (b1) at ["),
        ('pick_up("ball")', "is ambiguous: the robot's camera sees 2 of them (the ball (b1) at ["),
        ('push("sofa")', "the robot's camera sees no 'sofa'"),
        (
            'Robot(sensors=["camera"])\n    Robot(sensors=["camera", "distance sensor"])\n'
            '    return measure_distance("mug")',
            "made 2 different ones (line 2: Robot(sensors=['camera']); line 3: Robot(sensors=['camera', "
            "'distance']))",
        ),
    ],
    ids=["list-of-several", "empty-list", "list-passed", "name-of-several", "no-such",
         "two-robots"],
)  # fmt: skip
def test_an_ambiguous_habit_is_refused_saying_which_and_how_to_write_it(runner, body, words):
    result, _, world = _things(runner, f"def execute_command(image):\n    {body}\n")
    assert not result.ok
    assert words in result.error.message
    # nothing was done to a guessed object
    assert world.held is None and getattr(world, "approached", None) is None


def test_a_name_right_after_looking_at_a_patch_means_that_patch(runner):
    """The authors' go_to_object and put_on examples: a loop asks each patch a question, then names the
    object, meaning the one it just looked at (the world has two balls: the name alone is ambiguous)."""
    result, robot, world = _things(
        runner,
        """
        def execute_command(image):
            robot = Robot(sensors=["camera", "force/torque sensor"])
            ball_patches = ImagePatch(image).find("ball")
            rightmost = max(ball_patches, key=lambda ball: ball.horizontal_center)
            for ball_patch in ball_patches:
                said = ball_patch.visual_query("What is this?")
                if ball_patch is rightmost:
                    go_to_object("ball")
                    pick_up("ball")
                    return measure_weight("ball")
        """,
    )
    assert result.ok, result.error
    assert world.held == "b2" and result.value == pytest.approx(THINGS[3].mass, rel=0.02)


def test_robots_made_alike_are_one_robot(runner):
    result, _, _ = _things(
        runner,
        """
        def distance_of(name):
            robot = Robot(sensors=["camera", "distance sensor"])
            return robot.measure_distance(name)

        def execute_command(image):
            Robot(sensors=["camera", "distance sensor"])
            return [distance_of("mug"), measure_distance("lamp")]
        """,
    )
    assert result.ok, result.error
    assert result.value == [
        pytest.approx(distance_to(THINGS[0]), abs=0.01),
        pytest.approx(distance_to(THINGS[1]), abs=0.01),
    ]


def test_the_papers_robot_does_what_a_reading_needs_and_weighs_one_object_after_another(runner):
    result, robot, world = _things(
        runner,
        """
        def execute_command(image):
            robot = Robot(sensors=["camera", "force/torque sensor", "thermometer"])
            image_patch = ImagePatch(image)
            weights = []
            for name in ["mug", "lamp"]:
                patch = image_patch.find(name)
                go_to_object(patch)
                pick_up(name)
                weights.append(patch.measure_weight(name))
            ball = image_patch.find("ball")[0]
            weights.append(ball.measure_weight())
            return [weights, image_patch.find("mug")[0].measure_temperature()]
        """,
    )
    assert result.ok, result.error
    weights, celsius = result.value
    assert weights == [pytest.approx(t.mass, rel=0.02) for t in (THINGS[0], THINGS[1], THINGS[2])]
    assert celsius == pytest.approx(THINGS[0].celsius, abs=0.5)  # it turned to the mug before reading
    assert world.held == "b1"  # each pick-up put the one before down first


def test_the_sessions_robot_keeps_refusing_what_a_call_lacks(runner):
    result, _, world = _things(
        runner,
        """
        def execute_command(image, robot):
            return robot.measure_temperature(image.find("mug")[0])
        """,
    )
    assert not result.ok and "call robot.focus_on_patch(patch) right before" in result.error.message


def test_answers_compare_as_the_papers_prompt_writes_them(runner):
    result, _, world = _things(
        runner,
        """
        def execute_command(image):
            said = image.language_query("Is a mug heavier than a feather?")
            return [said == "Yes", said == "yes", said != "no", said, image.visual_query()]
        """,
        answers={"Is a mug heavier than a feather?": " Yes."},
    )
    assert result.ok, result.error
    assert result.value[:3] == [True, True, True] and result.value[3] == " Yes."
    assert world.perception.vqa.questions[-1] == "What is this?"  # asked nothing, it says what it shows


def test_a_programs_own_names_win_over_the_bare_functions_and_the_policy_is_as_strict(runner):
    mine, _, world = _things(
        runner,
        """
        def pick_up(thing):
            return "mine"

        def execute_command(image):
            return pick_up("mug")
        """,
    )
    assert mine.ok and mine.value == "mine" and world.held is None
    by_index, _, _ = _things(runner, 'def execute_command(image):\n    return measure_weight("mug")[0]\n')
    assert not by_index.ok and "a measurement is indexed by the object's name" in by_index.error.message
    peek, _, _ = _things(runner, "def execute_command(image):\n    return go_to_object.__globals__\n")
    assert not peek.ok and peek.error.category == "policy"


# ---- the same habits in MuJoCo scenes of all three layouts, the truth from the simulator -------------------


def _mujoco(layout: str, seed: int, **fields) -> SceneConfig:
    return SceneConfig(layout=layout, seed=seed, width=320, height=240, **fields)


def _truth(config: SceneConfig) -> list:
    with MujocoWorld(config) as world:
        return world.scene_info().objects


def _one(objects: list, category: str):
    (found,) = [o for o in objects if o.category == category]
    return found


HABITS = [
    (
        "weight-dictionary-of-a-find-list",  # the authors' measure_weight example, word for word but the book
        _mujoco("household", 4),
        "How heavy is the tomato?",
        """
        def execute_command(image):
            robot = Robot(sensors=["camera", "force/torque sensor"])
            image_patch = ImagePatch(image)
            tomato_patch = image_patch.find("tomato")
            go_to_object("tomato")
            pick_up("tomato")
            weight = tomato_patch.measure_weight("tomato")
            return weight["tomato"]
        """,
        lambda answer, objects: answer.value == pytest.approx(_one(objects, "tomato").mass_kg, rel=0.05),
    ),
    (
        "distance-of-a-focused-find-list",  # the authors' measure_distance example
        _mujoco("household", 4),
        "How far away is the bowl?",
        """
        def execute_command(image):
            robot = Robot(sensors=["camera", "distance sensor"])
            image_patch = ImagePatch(image)
            bowl_patch = image_patch.find("bowl")
            focus_on_patch(bowl_patch)
            distance = bowl_patch.measure_distance("bowl")
            return distance
        """,
        lambda answer, objects: answer.value == pytest.approx(_one(objects, "bowl").distance_m, abs=0.25),
    ),
    (
        "lightest-by-names-no-put-down",
        _mujoco("triplet", 3),
        "Out of these objects, which one is the most lightweight?",
        """
        def execute_command(image):
            robot = Robot(sensors=["camera", "force/torque sensor"])
            image_patch = ImagePatch(image)
            weights = {}
            for object_patch in image_patch.find("object"):
                name = object_patch.visual_query("What is this?")
                go_to_object(object_patch)
                pick_up(name)
                weights[name] = object_patch.measure_weight(name)[name]
            lightest = min(weights, key=weights.get)
            return image_patch.find(lightest)[0]
        """,
        lambda answer, objects: answer.object.id == min(objects, key=lambda o: o.mass_kg).id,
    ),
    (
        "farthest-of-look-alikes-with-a-depth-camera",
        _mujoco("arrangement", 1),
        "Which jar is the farthest from me?",
        """
        def execute_command(image):
            robot = Robot(sensors=["depth camera"])
            jar_patches = ImagePatch(image).find("jar")
            distances = []
            for jar_patch in jar_patches:
                jar_patch.focus_on_patch(jar_patch)
                distances.append(jar_patch.measure_distance("jar"))
            return jar_patches[distances.index(max(distances))]
        """,
        lambda answer, objects: answer.object.id == max(objects, key=lambda o: o.distance_m).id,
    ),
    (
        "weight-of-the-one-that-answers-Yes",
        _mujoco("arrangement", 1),
        "How heavy is the white jar?",
        """
        def execute_command(image):
            robot = Robot(sensors=["camera", "force sensor"])
            image_patch = ImagePatch(image)
            for jar_patch in image_patch.find("jar"):
                is_white = True if jar_patch.visual_query("Is this jar white?") == "Yes" else False
                if is_white:
                    go_to_object(jar_patch)
                    pick_up("jar")
                    return jar_patch.measure_weight("jar")
        """,
        lambda answer, objects: (
            answer.value == pytest.approx(next(o for o in objects if o.color == "white").mass_kg, rel=0.05)
        ),
    ),
    (
        "heaviest-of-look-alikes-named-after-a-question",  # the name alone is ambiguous: 3 jars
        _mujoco("arrangement", 1),
        "Which object is the heaviest?",
        """
        import math

        def execute_command(image):
            robot = Robot(sensors=["camera", "F/T sensor"])
            heaviest, most = None, -math.inf
            for patch in ImagePatch(image).find("object"):
                name = patch.visual_query("What is this object?")
                robot.go_to_object(name)
                robot.pick_up(name)
                kg = robot.measure_weight(name)
                if kg > most:
                    heaviest, most = patch, kg
            return heaviest
        """,
        lambda answer, objects: answer.object.id == max(objects, key=lambda o: o.mass_kg).id,
    ),
    (
        "closer-of-two-by-name-without-a-robot",
        _mujoco("triplet", 0),
        "Which one is closer to me, the toaster or the bottle?",
        """
        def execute_command(image, robot):
            focus_on_patch(image.find("toaster")[0])
            toaster = measure_distance("toaster")
            focus_on_patch(image.find("bottle")[0])
            bottle = measure_distance("bottle")
            return image.find("toaster")[0] if toaster < bottle else image.find("bottle")[0]
        """,
        lambda answer, objects: (
            answer.object.id
            == min((_one(objects, "toaster"), _one(objects, "bottle")), key=lambda o: o.distance_m).id
        ),
    ),
]


@pytest.mark.parametrize(
    ("config", "query", "program", "right"), [h[1:] for h in HABITS], ids=[h[0] for h in HABITS]
)
def test_a_program_in_the_authors_habits_answers_right_in_mujoco(
    config, query, program, right, empty_settings
):
    answer = run_program(dedent(program), Scene(config), load_settings(), query=query)
    assert answer.error is None, answer.answer
    assert right(answer, _truth(config)), answer.answer


@pytest.mark.slow  # the LLM path of each habit; test_paper_prompt.py runs it by default on two
@pytest.mark.parametrize(
    ("config", "query", "program", "right"), [h[1:] for h in HABITS], ids=[h[0] for h in HABITS]
)
def test_the_llm_planner_shown_the_paper_prompt_runs_a_reply_in_those_habits(
    config, query, program, right, httpserver, tmp_path, empty_settings
):
    requests = serve_chat_replies(httpserver, [f"```python\n{dedent(program).strip()}\n```"])
    settings = load_settings(
        planner="llm", prompt="paper", llm_base_url=httpserver.url_for("/v1"), llm_model="scripted",
        cache_dir=tmp_path / "cache",
    )  # fmt: skip
    answer = ask(query, Scene(config), settings)
    assert answer.error is None and answer.attempts == 1 and answer.prompt == "paper", answer.answer
    assert right(answer, _truth(config)), answer.answer
    shown = requests[0]["messages"][0]["content"]  # every sensor the MuJoCo robot has, in the paper's words
    assert (
        "Instruction: The robot is equipped with a camera, a distance sensor, a force/torque sensor, a "
        f"thermometer and a gripper force sensor. {query}"
    ) in shown


def test_put_on_a_receptacle_by_its_name_places_the_held_object_on_it(runner, empty_settings):
    program = """
    def execute_command(image):
        robot = Robot(sensors=["camera"])
        image_patch = ImagePatch(image)
        apple_patch = image_patch.find("apple")
        go_to_object(apple_patch)
        pick_up("apple")
        go_to_object("plate")
        put_on("plate")
        return apple_patch
    """
    with MujocoWorld(_mujoco("household", 5, categories=("apple", "plate"), objects=2)) as world:
        robot = Robot(sensors=["camera"], world=world, controller=build_controller(world))
        image = robot.look(Perception.from_settings(load_settings()))
        result = runner.run(dedent(program), args=[image, robot])
        assert result.ok, result.error
        world.step(1.0)
        ids = {o.category: o.id for o in world.scene_info().objects}
        key = world.sim.key_of_id
        apple, plate = (world.sim.object_position(key[ids[c]]) for c in ("apple", "plate"))
        assert world.held_object() is None and math.dist(apple[:2], plate[:2]) < 0.08
        assert (
            world.sim.object_bounds(key[ids["apple"]])[0][2]
            > world.sim.object_bounds(key[ids["plate"]])[1][2] - 0.01
        )
