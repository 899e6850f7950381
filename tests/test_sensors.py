"""Sensors as plug-ins: the registry and its names, a sensor defined in this file alone (registered here,
read by the MuJoCo world extended here) used from a program, through `--sensors` and in the prompt, the
refusals without it, and the built-in senses' preconditions, uncertainty and bridge path."""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterator

import numpy as np
import pytest
from typer.testing import CliRunner

from attribot.api import MissingSensor, PreconditionError, Robot
from attribot.api.prompt import build_prompt
from attribot.cli import app
from attribot.config import SceneConfig
from attribot.embodiments.bridge import BridgeWorld, EmbodimentDriver
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import BadPlugin, InputError, UnsupportedAction
from attribot.sensors import (
    SENSORS,
    Need,
    Sense,
    Sensor,
    State,
    check_sensors,
    register_reading,
    register_sensor,
    sensor_names,
)
from attribot.session import Scene, ask, run_program
from attribot.skills.safeguards import Safeguards
from conftest import Ball, BallController, BallWorld, world_perception

# ---- a lab's own sensor, defined here alone ------------------------------------------------------------

SUGAR_BRIX = {"banana": 20.0, "apple": 12.0, "tomato": 4.0}
"""What the extended world's near-infrared spectrometer reads on each kind of fruit (degrees Brix)."""

SPECTROMETER = Sensor(
    name="spectrometer",
    measures="a near-infrared spectrometer along the camera's axis: the sugar content of the fruit the "
    "camera is centred on, in degrees Brix (robot.measure_sugar)",
    aliases=("nir spectrometer", "near-infrared spectrometer"),
    senses=(
        Sense(
            quantity="sugar content",
            unit="°Bx",
            needs=Need.AIM,
            method="measure_sugar",
            readings=3,
            resolution=0.2,
            more=("sweet/sweeter/sweetest", "sugary/more sugary/most sugary"),
            less=("sour/sourer/sourest",),
            states=(State("sweet", 15.0, ">="), State("sour", 6.0, "<=")),
            nouns=("sugar content", "sweetness"),
            why="ripe and unripe fruit can look alike",
            doing="tasting",
            digits=1,
        ),
    ),
)
SWEETEST = """
def execute_command(image, robot):
    best, best_brix = None, 0.0
    for fruit in image.find("object"):
        robot.focus_on_patch(fruit)
        brix = robot.measure_sugar(fruit)
        if best is None or brix > best_brix:
            best, best_brix = fruit, brix
    return best
"""
FRUIT = SceneConfig(layout="household", seed=4, categories=("apple", "banana", "tomato"), objects=3)


def _sugar(world: MujocoWorld) -> float:
    """The spectrometer of the extended world: the fruit under the centre of the image (the beam hits what
    it hits), NaN on anything else."""
    frame = world.observe()
    h, w = frame.segmentation.shape
    key = int(frame.segmentation[h // 2, w // 2])
    if key < 0:
        return math.nan
    return SUGAR_BRIX.get(frame.objects[key].category, math.nan)


@pytest.fixture
def spectrometer() -> Iterator[Sensor]:
    """The spectrometer registered, with the MuJoCo world's reading of it, for one test: what a lab writes."""
    register_sensor(SPECTROMETER)
    register_reading("spectrometer", "mujoco", _sugar)
    try:
        yield SPECTROMETER
    finally:
        SENSORS.unregister("spectrometer")
        assert "measure_sugar" not in Robot.API_METHODS and not hasattr(Robot, "measure_sugar")


def test_a_sensor_defined_in_a_test_is_read_by_a_program(spectrometer):
    answer = run_program(SWEETEST, Scene(FRUIT, sensors=["camera", "near-infrared spectrometer"]))
    assert answer.error is None, answer.error
    truth = {o.id: o.category for o in Scene(FRUIT).truth().objects}
    assert truth[answer.object.id] == "banana"
    assert answer.unit == "°Bx" and answer.value == pytest.approx(20.0)
    readings = [t for t in answer.trace if t["call"] == "Robot.measure_sugar"]
    assert sorted(r["result"] for r in readings) == [4.0, 12.0, 20.0]


@pytest.mark.parametrize(
    ("query", "truth"),
    [
        ("Which object is the sweetest?", "banana"),
        ("the least sweet one", "tomato"),
        ("which one is sourer, the apple or the banana?", "apple"),
    ],
)
def test_a_labs_sense_is_asked_in_its_own_words_through_the_rules_planner(spectrometer, query, truth):
    """The record's words alone teach the offline planner the sense: no planner code names it."""
    answer = ask(query, Scene(FRUIT, sensors=["camera", "spectrometer"]), planner="rules")
    assert answer.error is None, answer.error
    categories = {o.id: o.category for o in Scene(FRUIT).truth().objects}
    assert categories[answer.object.id] == truth
    assert "robot.measure_sugar(patch)" in answer.program and "robot.focus_on_patch(patch)" in answer.program


def test_a_labs_sense_states_and_amounts_come_from_its_record(spectrometer):
    scene = Scene(FRUIT, sensors=["camera", "spectrometer"])
    sweet = ask("is the banana sweet?", scene, planner="rules")
    assert sweet.error is None and sweet.boolean is True and "20.0 °Bx: sweet" in sweet.answer
    how = ask("how sweet is the tomato?", scene, planner="rules")
    assert how.error is None and how.value == pytest.approx(4.0) and how.unit == "°Bx"
    with pytest.raises(InputError, match="only a sensor settles.*no spectrometer sensor.*can look alike"):
        ask("Which object is the sweetest?", Scene(FRUIT, sensors=["camera"]), planner="rules")
    SENSORS.unregister("spectrometer")  # the words leave with the record
    try:
        with pytest.raises(InputError):
            ask("Which object is the sweetest?", scene, planner="rules")
    finally:
        register_sensor(SPECTROMETER)


def test_the_prompt_shows_the_sensor_and_its_method_only_when_the_robot_has_it(spectrometer):
    have = build_prompt("which fruit is the sweetest?", ["camera", "spectrometer"])
    assert "def measure_sugar(self, patch: ImagePatch) -> float:" in have
    assert "- spectrometer: a near-infrared spectrometer" in have
    text = " ".join(have.split())  # the docstring written from the record teaches the precondition
    assert "sugar content of the object in `patch`, in °Bx" in text
    assert "call robot.focus_on_patch(patch) first" in text
    without = build_prompt("which fruit is the sweetest?", ["camera"])
    assert "def measure_sugar" not in without
    assert "robot.measure_sugar (needs the spectrometer sensor)" in without


def test_the_cli_takes_the_sensor_in_sensors(spectrometer, empty_settings, tmp_path):
    program = tmp_path / "sweetest.py"
    program.write_text(SWEETEST)
    scene = ["--layout", "household", "--seed", "4", "--categories", "apple,banana,tomato", "--objects", "3"]
    done = CliRunner().invoke(
        app, ["exec", str(program), *scene, "--sensors", "camera,spectrometer", "--json"]
    )
    assert done.exit_code == 0, done.output
    answer = json.loads(done.output)
    assert answer["object"]["category"] == "banana" and answer["unit"] == "°Bx"
    refused = CliRunner().invoke(app, ["exec", str(program), *scene, "--sensors", "camera", "--json"])
    assert refused.exit_code == 1
    error = json.loads(refused.output)["error"]["message"]
    assert "needs the 'spectrometer' sensor" in error and "--sensors camera,spectrometer" in error


PLUGIN = '''
"""A lab's spectrometer: its record, and the MuJoCo world taught to read it."""
import math

from attribot.sensors import Need, Sense, Sensor, register_reading, register_sensor

register_sensor(Sensor(
    name="spectrometer", measures="the sugar content of the fruit centred",
    senses=(Sense("sugar content", "°Bx", needs=Need.AIM, method="measure_sugar"),),
))
BRIX = {"banana": 20.0, "apple": 12.0, "tomato": 4.0}


def read(world):
    frame = world.observe()
    h, w = frame.segmentation.shape
    key = int(frame.segmentation[h // 2, w // 2])
    return BRIX.get(frame.objects[key].category, math.nan) if key >= 0 else math.nan


register_reading("spectrometer", "mujoco", read)
'''


def test_the_real_command_takes_a_labs_sensor_from_a_plugin_module(tmp_path, monkeypatch):
    from conftest import cli

    (tmp_path / "lab_spectrometer.py").write_text(PLUGIN)
    (tmp_path / "sweetest.py").write_text(SWEETEST)
    monkeypatch.setenv("PYTHONPATH", f"{tmp_path}:{os.environ.get('PYTHONPATH', '')}")
    monkeypatch.setenv("ATTRIBOT_PLUGINS", "lab_spectrometer")
    scene = ["--layout", "household", "--seed", "4", "--categories", "apple,banana,tomato", "--objects", "3"]
    done = cli("exec", str(tmp_path / "sweetest.py"), *scene, "--sensors", "camera,spectrometer", "--json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["object"]["category"] == "banana"
    monkeypatch.setenv("ATTRIBOT_PLUGINS", "no_such_lab_module")
    missing = cli("exec", str(tmp_path / "sweetest.py"), *scene)
    assert (
        missing.returncode == 2 and "ATTRIBOT_PLUGINS names the module 'no_such_lab_module'" in missing.stderr
    )


def test_a_robot_without_the_sensor_refuses_naming_it_and_the_fix(spectrometer):
    with MujocoWorld(FRUIT) as world:
        robot = Robot(sensors=["camera"], world=world)
        image = robot.look(world_perception_of(world), survey=False)
        fruit = image.find("banana")[0]
        with pytest.raises(MissingSensor, match="needs the 'spectrometer' sensor") as refused:
            robot.measure_sugar(fruit)
        assert "--sensors camera,spectrometer" in refused.value.fix
    with BallWorld([Ball("b1", "ball", (2.0, 0.0, 1.0), 0.2, 0.3)]) as balls:
        with pytest.raises(UnsupportedAction, match="has no spectrometer sensor") as lacking:
            Robot(sensors=["spectrometer"], world=balls)
        assert "leave 'spectrometer' out of --sensors" in lacking.value.fix


def world_perception_of(world: MujocoWorld):  # the oracle detector, as a session builds it
    from attribot.api import Perception
    from attribot.config import load_settings

    return Perception.from_settings(load_settings())


# ---- the registry ---------------------------------------------------------------------------------------


def test_names_and_aliases_resolve_through_the_registry():
    assert check_sensors(["infrared thermometer", "Force/Torque sensor", "depth camera"]) == [
        "temperature",
        "force",
        "camera",
        "distance",
    ]
    assert check_sensors(["tactile sensor"]) == ["camera", "grip"]
    with pytest.raises(InputError, match="unknown sensor 'sonar'") as unknown:
        check_sensors(["sonar"])
    assert all(name in unknown.value.fix for name in ("temperature", "grip", "distance"))
    assert sensor_names()[:3] == ["camera", "distance", "force"]
    with pytest.raises(ValueError, match="registered twice"):
        register_sensor(Sensor(name="thermo", measures="", aliases=("thermometer",)))


def test_a_sense_that_takes_another_senses_words_is_refused():
    """A lab's sense that says "hotter" would be read as temperature: refused, naming the word and both."""
    grill = Sensor(
        name="grill probe",
        measures="a probe",
        senses=(Sense("doneness", "%", more=("done/more done/most done", "hot/hotter/hottest")),),
    )
    with pytest.raises(BadPlugin, match=r"'hot', 'hotter', 'hottest' already says the temperature"):
        register_sensor(grill)
    assert "grill probe" not in SENSORS


def test_a_sensor_method_that_robot_has_already_is_refused():
    register_sensor(Sensor(name="clash", measures="", senses=(Sense("x", "", method="pick_up"),)))
    try:
        with pytest.raises(Exception, match="Robot has already"):
            _ = Robot.API_METHODS
    finally:
        SENSORS.unregister("clash")
    assert "pick_up" in Robot.API_METHODS


# ---- the built-in senses on the geometric world: preconditions, uncertainty -----------------------------


def _robot(balls: list[Ball], sensors: list[str]) -> tuple[BallWorld, Robot, object]:
    world = BallWorld(balls)
    robot = Robot(sensors=sensors, world=world, controller=BallController(world))
    return world, robot, robot.look(world_perception(), survey=False)


def test_the_thermometer_reads_what_the_camera_is_centred_on_and_says_so():
    hot = Ball("hot", "mug", (2.0, 0.6, 0.5), 0.15, 0.4, celsius=64.0)
    cold = Ball("cold", "mug", (3.0, -0.9, 0.3), 0.2, 0.3, celsius=5.0)
    _, robot, image = _robot([hot, cold], ["camera", "thermometer"])
    first, second = sorted(image.find("mug"), key=lambda p: p.object_id)
    with pytest.raises(PreconditionError, match="not centred on") as unaimed:
        robot.measure_temperature(first)
    assert "robot.focus_on_patch(patch)" in unaimed.value.fix
    robot.focus_on_patch(second)
    with pytest.raises(PreconditionError):  # centred on the other one: its reading would be that one's
        robot.measure_temperature(first)
    assert robot.measure_temperature(second) == pytest.approx(64.0)
    robot.focus_on_patch(first)
    assert robot.measure_temperature(first) == pytest.approx(5.0)
    m = robot.measurements[-1]
    assert m.unit == "°C" and m.kind == "temperature" and m.samples == 5 and m.uncertainty >= 0.1
    assert m.reading() == "5.0 °C"


def test_the_squeeze_needs_the_object_in_the_gripper():
    soft = Ball("soft", "ball", (2.0, 0.6, 0.5), 0.15, 0.1, n_per_mm=0.3)
    _, robot, image = _robot([soft], ["camera", "grip"])
    ball = image.find("ball")[0]
    with pytest.raises(PreconditionError, match="in the gripper, and the robot holds nothing"):
        robot.measure_stiffness(ball)
    robot.go_to_object(ball)
    robot.pick_up(ball)
    assert robot.measure_stiffness(ball) == pytest.approx(0.3)
    assert robot.measurements[-1].reading() == "0.30 N/mm"


def test_confidence_applies_to_a_new_sense_it_cannot_tell_two_equal_temperatures():
    a = Ball("a", "mug", (2.0, 0.6, 0.5), 0.15, 0.4, celsius=21.0)
    b = Ball("b", "mug", (3.0, -0.9, 0.3), 0.2, 0.3, celsius=21.05)
    world = BallWorld([a, b])
    robot = Robot(
        sensors=["camera", "temperature"],
        world=world,
        controller=BallController(world),
        safeguards=Safeguards(),
    )
    image = robot.look(world_perception(), survey=False)
    patches = image.find("mug")
    values = []
    for patch in patches:
        robot.focus_on_patch(patch)
        values.append(robot.measure_temperature(patch))
    chosen = patches[int(np.argmax(values))]
    doubt = robot.settle(chosen)
    assert doubt is not None and "cannot tell the mug" in doubt and "°C" in doubt
    again = [m for m in robot.measurements if m.kind == "temperature"]
    assert len(again) > 2  # measured again, focusing first, before saying so


# ---- the world and the bridge -------------------------------------------------------------------------


def test_the_mujoco_world_offers_the_new_senses_and_refuses_a_squeeze_with_nothing_held():
    with MujocoWorld(layout="triplet", seed=3, width=160, height=120) as world:
        assert {"camera", "distance", "force", "temperature", "grip"} <= world.sensors()
        assert math.isnan(world.read_sensor("grip"))
        assert 15.0 < world.read_sensor("temperature") < 30.0  # a triplet has nothing hot or cold
        with pytest.raises(UnsupportedAction, match="no spectrometer sensor|cannot read a spectrometer"):
            world.read_sensor("spectrometer")


def test_the_bridge_states_the_robots_sensors_and_reads_them():
    from test_bridge import TOKEN, serving, url

    config = SceneConfig(layout="household", seed=7, width=160, height=120)
    with serving(lambda: EmbodimentDriver(MujocoWorld(config))) as (server, _):
        with BridgeWorld(url=url(server), token=TOKEN) as bridge, MujocoWorld(config) as direct:
            assert {"temperature", "grip"} <= bridge.sensors()
            assert bridge.read_sensor("temperature") == pytest.approx(direct.read_sensor("temperature"))
            assert math.isnan(bridge.read_sensor("grip"))  # nothing held: it read nothing
            with pytest.raises(UnsupportedAction, match="has no 'spectrometer' sensor"):
                bridge._call({"op": "read", "sensor": "spectrometer"})


def test_a_robot_that_states_no_sensors_keeps_working_and_refuses_the_new_ones():
    from test_bridge import TOKEN, RecordingDriver, serving, url

    with serving(RecordingDriver) as (server, _), BridgeWorld(url=url(server), token=TOKEN) as bridge:
        assert bridge.sensors() == {"camera"}
        with pytest.raises(UnsupportedAction, match="has no temperature sensor"):
            Robot(sensors=["camera", "temperature"], world=bridge)
