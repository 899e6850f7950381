"""The prompt is generated from the API classes: names, signatures and examples agree with the code."""

from __future__ import annotations

import ast
import inspect
import re
import textwrap

import jinja2
import pytest

from attribot.api import ImagePatch, Robot
from attribot.api.prompt import _environment, api_reference, build_prompt, offered_robot_methods
from attribot.errors import InputError, UnsupportedAction
from conftest import BALLS, BallController, BallWorld, perception_for, world_perception

ALL = ["camera", "distance", "force", "temperature", "grip"]
"""Every built-in sensor: what the ball world offers (a sensor a test registers is not among them)."""


def offered_to_all(cls: type) -> list[str]:
    """The API methods of `cls` a robot with ALL may call, in order."""
    if cls is not Robot:
        return list(cls.API_METHODS)
    return [m for m in cls.API_METHODS if Robot.REQUIRES.get(m, "camera") in ALL]


def python_block(prompt: str) -> str:
    blocks = re.findall(r"```python\n(.*?)```", prompt, flags=re.S)
    assert len(blocks) == 1
    return blocks[0]


def classes_in(prompt: str) -> dict[str, ast.ClassDef]:
    tree = ast.parse(python_block(prompt))
    return {node.name: node for node in tree.body if isinstance(node, ast.ClassDef)}


def signature_of(fn: ast.FunctionDef) -> tuple[list[tuple[str, str | None]], str | None]:
    params = [(a.arg, ast.unparse(a.annotation) if a.annotation else None) for a in fn.args.args]
    return params, ast.unparse(fn.returns) if fn.returns else None


def real_signature(cls: type, name: str) -> tuple[list[tuple[str, str | None]], str | None]:
    sig = inspect.signature(getattr(cls, name))
    params = [(p.name, None if p.annotation is p.empty else p.annotation) for p in sig.parameters.values()]
    ret = None if sig.return_annotation is sig.empty else sig.return_annotation
    return params, ret


@pytest.mark.parametrize("sensors", [ALL, ["camera"], ["camera", "distance"], ["force"]])
def test_every_method_in_the_prompt_exists_with_that_signature(sensors):
    classes = classes_in(build_prompt("the leftmost cup", sensors))
    assert set(classes) == {"ImagePatch", "Robot"}
    real = {"ImagePatch": ImagePatch, "Robot": Robot}
    for cname, node in classes.items():
        cls = real[cname]
        for fn in [n for n in node.body if isinstance(n, ast.FunctionDef)]:
            assert fn.name in cls.API_METHODS, f"{cname}.{fn.name} is in the prompt but not in API_METHODS"
            assert signature_of(fn) == real_signature(cls, fn.name)
        for ann in [n for n in node.body if isinstance(n, ast.AnnAssign)]:
            assert ann.target.id in cls.API_ATTRIBUTES
            assert (
                ast.unparse(ann.annotation)
                == inspect.signature(getattr(cls, ann.target.id).fget).return_annotation
            )


def test_every_public_method_is_in_the_full_prompt():
    classes = classes_in(build_prompt("which ball is heaviest?", ALL))
    for cls in (ImagePatch, Robot):
        node = classes[cls.__name__]
        methods = [n.name for n in node.body if isinstance(n, ast.FunctionDef)]
        attributes = [n.target.id for n in node.body if isinstance(n, ast.AnnAssign)]
        assert methods == offered_to_all(cls)
        assert attributes == list(cls.API_ATTRIBUTES)
        for name in offered_to_all(cls):
            assert ">>> def execute_command(image, robot):" in inspect.getdoc(getattr(cls, name)), name


def test_robot_methods_offered_follow_the_sensors():
    prompt = build_prompt("which is closer to me?", ["camera"])
    robot = [n.name for n in classes_in(prompt)["Robot"].body if isinstance(n, ast.FunctionDef)]
    assert "measure_distance" not in robot and "measure_weight" not in robot and "go_to_object" in robot
    assert (
        "robot.measure_distance (needs the distance sensor), robot.measure_weight (needs the force sensor)"
        in prompt
    )
    assert "This robot's sensors:\n- camera: colour images" in prompt and "- distance:" not in prompt
    offered, missing = offered_robot_methods(["distance"])
    assert "measure_distance" in offered
    assert {"measure_weight": "force", "measure_temperature": "temperature"}.items() <= missing.items()
    # a sensor's methods and its line in the prompt come with the sensor, and only with it
    hot = build_prompt("which mug is hot?", ["camera", "infrared thermometer"])
    robot = [n.name for n in classes_in(hot)["Robot"].body if isinstance(n, ast.FunctionDef)]
    assert "measure_temperature" in robot and "measure_stiffness" not in robot
    assert (
        "- temperature: an infrared thermometer" in hot and "robot.measure_stiffness (needs the grip" in hot
    )
    # the docstring teaches the precondition
    assert "call robot.focus_on_patch(patch) first" in " ".join(hot.split())
    still = build_prompt("the leftmost cup", ALL, embodied=False)
    assert [n for n in classes_in(still)["Robot"].body if isinstance(n, ast.FunctionDef)] == []
    assert "still image" in still and "robot.measure_distance(patch)" not in still


def test_api_declarations_name_exactly_the_public_surface():
    for cls in (ImagePatch, Robot):
        declared = (
            set(cls.API_METHODS) | set(cls.API_ATTRIBUTES) | set(cls.HOST_METHODS) | set(cls.HOST_ATTRIBUTES)
        )
        assert len(declared) == len(cls.API_METHODS) + len(cls.API_ATTRIBUTES) + len(cls.HOST_METHODS) + len(
            cls.HOST_ATTRIBUTES
        ), "a name is declared twice"
        class_constants = {
            n for n in vars(cls) if n.isupper() or n.startswith("API_") or n.startswith("HOST_")
        }
        public = {n for n in dir(cls) if not n.startswith("_")} - class_constants
        # instance attributes set in __init__ count too
        world = BallWorld(BALLS)
        inst = (
            Robot(world=world, sensors=ALL) if cls is Robot else Robot(world=world).look(world_perception())
        )
        public |= {n for n in vars(inst) if not n.startswith("_")}
        assert public == declared, (
            f"{cls.__name__}: undeclared {public - declared}, missing {declared - public}"
        )
        for name in cls.API_METHODS:
            assert callable(getattr(cls, name))
        for name in cls.API_ATTRIBUTES:
            assert isinstance(inspect.getattr_static(cls, name), property)


def example_programs(cls: type, name: str) -> list[str]:
    """The programs in one docstring's `>>>` examples, each a separate block."""
    programs, lines = [], []
    for line in inspect.getdoc(getattr(cls, name)).splitlines() + [""]:
        if line.strip().startswith(">>>"):
            lines.append(line.strip()[4:] if len(line.strip()) > 3 else "")
        elif lines:
            programs.append(textwrap.dedent("\n".join(lines)))
            lines = []
    return programs


ALL_EXAMPLES = [
    (cls, name, prog)
    for cls in (ImagePatch, Robot)
    for name in offered_to_all(cls)
    for prog in example_programs(cls, name)
]


@pytest.mark.parametrize(
    ("cls", "name", "program"), ALL_EXAMPLES, ids=[f"{c.__name__}.{n}" for c, n, _ in ALL_EXAMPLES]
)
def test_docstring_examples_use_only_the_api_and_run(cls, name, program):
    tree = ast.parse(program)
    # every attribute a program touches on a patch or the robot is API (or list/str methods)
    api = set(ImagePatch.API_METHODS + ImagePatch.API_ATTRIBUTES + Robot.API_METHODS + Robot.API_ATTRIBUTES)
    used = {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)}
    assert used - api <= {"sort", "append"}, used - api
    assert name in used, f"the example of {name} does not call it"

    # and it runs: a world with balls of every name, a detector that finds them whatever they are called
    world = BallWorld(BALLS)
    robot = Robot(sensors=ALL, world=world, controller=BallController(world))
    image = robot.look(world_perception(relabel=True))
    namespace: dict = {}
    exec(compile(tree, f"<{cls.__name__}.{name} example>", "exec"), namespace)
    try:
        result = namespace["execute_command"](image, robot)
    except UnsupportedAction as exc:  # an action this fake world does not have: refused, by name
        assert "is not available in this world" in str(exc)
        return
    assert result is not None


def test_prompt_has_query_sensors_guidelines_and_format():
    prompt = build_prompt("  the second   cup from the left ", ["camera", "distance"])
    assert "Query: the second cup from the left\n" in prompt
    assert "- camera: colour images" in prompt and "- distance: an infrared rangefinder" in prompt
    assert "- force:" not in prompt and "except ActionFailed as error" in prompt
    assert "def execute_command(image, robot):" in prompt
    assert "exactly one fenced ```python code block" in prompt
    assert "y grows upward" in prompt
    assert "{{" not in prompt and "{%" not in prompt


@pytest.mark.parametrize(
    ("query", "sensors", "match"),
    [
        ("", ALL, "empty"),
        ("   ", ALL, "empty"),
        (None, ALL, "empty"),
        ("x" * 1001, ALL, "more than 500"),
        ("cup", ["lidar"], "unknown sensor"),
    ],
)
def test_bad_prompt_input(query, sensors, match):
    with pytest.raises(InputError, match=match):
        build_prompt(query, sensors)


def test_template_is_strict():
    with pytest.raises(jinja2.UndefinedError):
        _environment().get_template("program.jinja").render(query="x")


def test_api_text_lives_only_in_the_classes():
    from importlib import resources

    template = resources.files("attribot.api").joinpath("prompts", "program.jinja").read_text()
    assert "def find" not in template and "class ImagePatch" not in template
    assert api_reference(ALL) in build_prompt("q", ALL)
    # the only docstrings in the prompt are the classes' own
    assert textwrap.indent('"""' + inspect.getdoc(ImagePatch.find), 8 * " ") in api_reference(ALL)
    assert perception_for() is not None


def test_the_prompt_says_what_the_detector_can_find_here():
    """Issue 18: "bring the lightest cup to the table" needs to know that the table can be found."""
    from attribot.config import SceneConfig, Settings
    from attribot.embodiments.mujoco import MujocoWorld
    from attribot.skills.perception import Perception

    with MujocoWorld(SceneConfig(layout="household", seed=0, width=320, height=240)) as world:
        frame = world.observe()
    findable = Perception.from_settings(Settings()).findable(frame)
    assert findable.startswith('objects by a short name ("cup"')
    assert "furniture and the floor in view:" in findable and "table" in findable.split("in view:")[1]
    prompt = build_prompt("bring the lightest cup to the table", ALL, findable=findable)
    assert f"- What `image.find` can find here: {findable}." in prompt
    assert "{{" not in build_prompt("x", ALL) and "can find here" not in build_prompt("x", ALL)

    # a detector that reads pixels (a real one) gets no word of the simulator's segmentation
    class PixelsOnly:
        name, pixels_only = "pixels", True

        def detect(self, frame, queries):
            return []

    base = Perception.from_settings(Settings())
    real = Perception(detector=PixelsOnly(), vqa=base.vqa, language=base.language)
    assert real.findable(frame) == 'objects by a short name ("cup", "ball", "apple")'


def test_a_program_facing_class_is_checked_as_it_is_defined():
    """The facade programs see is checked when its class is defined: a public method it does not declare
    (host work belongs to the session) or a program method without an example program is refused."""
    from attribot.skills.checks import check_facade

    def documented(self):
        """Does it.

        >>> def execute_command(image, robot):
        >>>     return robot.act()
        """

    check_facade(Robot, {"OWN_METHODS": ("act",), "act": documented})
    with pytest.raises(TypeError, match=r"defines \['helper'\] without declaring"):
        check_facade(Robot, {"OWN_METHODS": ("act",), "act": documented, "helper": documented})
    with pytest.raises(TypeError, match="act has no docstring with an example program"):
        check_facade(Robot, {"OWN_METHODS": ("act",), "act": lambda self: None})
