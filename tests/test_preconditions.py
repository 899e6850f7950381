"""What a robot action needs is checked before the robot moves (attribot.skills.preconditions), and a refusal
names the call to make in the dialect the program was written in: `robot.put_down()` on the robot it was
given, `put_down()` on bare functions or a `Robot(sensors=[...])` it made. `put_on` given the object held
puts it back where it was picked up, and the trace says so. Truths: the fake ball world's own state (what
it holds, what the robot last drove to)."""

from __future__ import annotations

from textwrap import dedent

import pytest

from attribot.api import ImagePatch, Robot
from attribot.runner import ProgramRunner
from attribot.skills.preconditions import State, Verdict, call_text, check_action
from conftest import BALLS, BallController, BallWorld, world_perception


@pytest.fixture(scope="module")
def runner():
    with ProgramRunner(classes=[ImagePatch, Robot]) as r:
        yield r


def _run(runner, program: str):
    world = BallWorld(BALLS)
    robot = Robot(sensors=("camera", "distance", "force"), world=world, controller=BallController(world))
    image = robot.look(world_perception())
    return runner.run(dedent(program), args=[image, robot]), world


@pytest.mark.parametrize(
    "program",
    [
        """
        def execute_command(image, robot):
            ball = image.find("ball")[1]
            robot.go_to_object(ball)
            robot.pick_up(ball)
            kg = robot.measure_weight(ball)
            robot.put_on(ball)
            return kg
        """,
        """
        def execute_command(image):
            robot = Robot(sensors=["camera", "force/torque sensor"])
            image_patch = ImagePatch(image)
            ball_patch = image_patch.find("ball")[1]
            go_to_object(ball_patch)
            pick_up("ball")
            weight = ball_patch.measure_weight("ball")
            put_on("ball")
            return weight
        """,
    ],
    ids=["attribot", "paper"],
)
def test_put_on_the_object_held_puts_it_back_and_the_trace_says_so(runner, program):
    result, world = _run(runner, program)
    assert result.ok, result.error
    assert world.held is None  # put down: the world's gripper is empty
    put_on = [t for t in result.trace if t.call == "Robot.put_on"]
    assert put_on and put_on[-1].error is None
    assert "put it back where it was picked up" in (put_on[-1].note or ""), put_on[-1]


# (what the program does, the program, words of the error, the fix in the dialect's words)
REFUSALS = [
    (
        "go to a second object holding the first",
        """
        def execute_command(image, robot):
            first, second = image.find("ball")[:2]
            robot.go_to_object(first)
            robot.pick_up(first)
            robot.measure_weight(first)
            robot.go_to_object(second)
        """,
        ["in the gripper", "does not drive to another object"],
        ["call robot.put_down() first", "robot.put_on(patch)"],
    ),
    (
        "pick up holding another",
        """
        def execute_command(image, robot):
            first, second = image.find("ball")[:2]
            robot.go_to_object(first)
            robot.pick_up(first)
            robot.pick_up(second)
        """,
        ["needs an empty gripper"],
        ["call robot.put_down() first"],
    ),
    (
        "weigh what is not held",
        """
        def execute_command(image, robot):
            first, second = image.find("ball")[:2]
            robot.go_to_object(first)
            robot.pick_up(first)
            robot.measure_weight(second)
        """,
        ["in the gripper, and the robot holds ball"],
        ["call robot.put_down() first, then robot.go_to_object(patch) and robot.pick_up(patch)"],
    ),
    (
        "push holding an object",
        """
        def execute_command(image, robot):
            first, second = image.find("ball")[:2]
            robot.go_to_object(first)
            robot.pick_up(first)
            robot.push(second)
        """,
        ["in the gripper"],
        ["call robot.put_down() first"],
    ),
    (
        "put on with an empty gripper, paper dialect",
        """
        def execute_command(image):
            robot = Robot(sensors=["camera"])
            image_patch = ImagePatch(image)
            put_on(image_patch.find("ball")[0])
        """,
        ["it is empty"],
        ["call go_to_object(obj) and pick_up(obj) first", "then put_on(patch)"],
    ),
    (
        "put down with an empty gripper, paper dialect",
        """
        def execute_command(image):
            robot = Robot(sensors=["camera"])
            put_down()
        """,
        ["it is empty"],
        ["call pick_up(patch) before put_down()"],
    ),
]


@pytest.mark.parametrize(("name", "program", "said", "fix"), REFUSALS, ids=[r[0] for r in REFUSALS])
def test_a_call_that_makes_no_physical_sense_is_refused_before_anything_moves(
    runner, name, program, said, fix
):
    result, world = _run(runner, program)
    assert not result.ok and result.error.category == "api", result.error
    for words in [*said, *fix]:
        assert words in result.error.message, result.error.message
    if "paper" in name:
        assert "robot." not in result.error.message  # the paper's prompt calls the functions bare
    failed = result.trace[-1]
    assert failed.error is not None
    acted = [t for t in result.trace if t.error is None and t.call in ("Robot.go_to_object", "Robot.pick_up")]
    if acted:  # the robot still stands where it went and holds what it held: the refused call moved nothing
        first = acted[-1].args[0]["object_id"]
        assert world.approached == first and world.held == first


def test_the_checks_are_one_function_that_every_action_asks():
    patch = type(
        "P", (), {"same_object": lambda self, other: self is other, "label": "cup", "object_id": None}
    )
    cup, mug = patch(), patch()
    held = State(held=cup, near=cup, dialect="attribot")
    assert check_action("put_on", cup, held) is Verdict.PUT_BACK
    assert check_action("go_to_object", cup, held) is Verdict.ALREADY
    assert check_action("put_on", mug, held) is Verdict.MET
    assert call_text("put_down", "", "paper") == "put_down()"
    assert call_text("pick_up", "patch", "attribot") == "robot.pick_up(patch)"


def test_what_the_robot_a_program_made_arranged_is_noted_on_that_calls_record_alone(runner):
    result, world = _run(
        runner,
        """
        def execute_command(image):
            robot = Robot(sensors=["camera", "force/torque sensor"])
            first, second = ImagePatch(image).find("ball")[:2]
            kg = first.measure_weight("ball")
            pick_up(second)
            return [kg, second.measure_weight("ball")]
        """,
    )
    assert result.ok, result.error
    weigh, pick, again = [t for t in result.trace if t.call in ("Robot.measure_weight", "Robot.pick_up")]
    assert "went to it first" in weigh.note and "picked it up first" in weigh.note
    assert "down first" in pick.note and "went to it first" in pick.note  # the first put down, then on
    assert again.note is None  # the second is held: nothing arranged
    assert world.held == pick.args[0]["object_id"]
