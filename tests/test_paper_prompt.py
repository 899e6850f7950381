"""The prompt as a choice (issue 31): `--prompt attribot` (generated from the API) or `--prompt paper` (the
structure of the paper authors' released prompt, in our words), rendered from package data with a strict
template for every sensor set, shown by the LLM planner, and named in every answer, eval record and report.
Programs an LLM writes from it (scripted here by a local OpenAI-compatible endpoint) answer right in
MuJoCo, with the truth from the simulator."""

from __future__ import annotations

import ast
import itertools
import json
import re
import textwrap
from textwrap import dedent

import jinja2
import pytest

from attribot.api import ImagePatch, Robot
from attribot.api.prompt import PROMPTS, _environment, build_paper_prompt
from attribot.config import PROMPTS as PROMPT_NAMES
from attribot.config import SceneConfig, load_settings
from attribot.errors import ConfigError
from attribot.eval.run import read_records
from attribot.planning import PlanRequest
from attribot.planning.llm import LLMPlanner
from attribot.runner import ProgramRunner
from attribot.sensors import SENSORS, Need, Sense, Sensor, check_sensors, register_sensor
from attribot.session import Scene, ask
from conftest import BallController, BallWorld, cli, serve_chat_replies, world_perception
from test_paper_dialect import THINGS, _truth

QUERY = "Out of these objects, which one is the most lightweight?"
BEYOND = ("distance", "force", "temperature", "grip")
SENSOR_SETS = [
    ["camera", *chosen] for n in range(len(BEYOND) + 1) for chosen in itertools.combinations(BEYOND, n)
]
PAPERS_OWN = ("focus_on_patch", "measure_distance", "measure_weight", "go_to_coords", "go_to_object",
              "pick_up", "put_on", "push")  # fmt: skip
"""The Robot methods the authors' prompt lists."""


def instruction(prompt: str) -> str:
    (line,) = [line for line in prompt.splitlines() if line.startswith("Instruction: ")]
    return line


def listed_sensors(prompt: str) -> list[str]:
    """The sensors the instruction line names, read back as the robot reads them."""
    said = re.match(r"Instruction: The robot is equipped with (.*?)\. ", instruction(prompt)).group(1)
    nouns = re.split(r", | and ", said)
    return check_sensors([re.sub(r"^an? ", "", noun) for noun in nouns])


def api_source(prompt: str) -> ast.Module:
    return ast.parse(prompt.split("\nWrite a Python function")[0])


def robot_methods(prompt: str) -> list[str]:
    robot = next(n for n in api_source(prompt).body if isinstance(n, ast.ClassDef) and n.name == "Robot")
    return [f.name for f in robot.body if isinstance(f, ast.FunctionDef) and f.name != "__init__"]


def examples(prompt: str) -> list[str]:
    """The programs of the prompt's `>>>` examples that define execute_command."""
    programs, lines = [], []
    for line in [*prompt.splitlines(), ""]:
        if line.strip().startswith(">>>"):
            lines.append(line.strip()[4:])
        elif lines:
            programs.append(textwrap.dedent("\n".join(lines)))
            lines = []
    return [p for p in programs if "def execute_command" in p]


@pytest.fixture
def spectrometer():
    sensor = register_sensor(
        Sensor(name="spectrometer", measures="sugar", aliases=("near-infrared spectrometer",),
               senses=(Sense("sugar content", "°Bx", needs=Need.AIM, method="measure_sugar"),))
    )  # fmt: skip
    try:
        yield sensor
    finally:
        SENSORS.unregister("spectrometer")


@pytest.mark.parametrize("embodied", [True, False])
@pytest.mark.parametrize("sensors", SENSOR_SETS, ids=["+".join(s) for s in SENSOR_SETS])
def test_the_paper_prompt_renders_for_every_sensor_set(sensors, embodied):
    prompt = build_paper_prompt(f"  {QUERY} ", sensors, embodied=embodied)
    assert "{{" not in prompt and "{%" not in prompt and "{#" not in prompt
    assert prompt.rstrip().endswith(f". {QUERY}") and instruction(prompt).startswith(
        "Instruction: The robot is equipped with a camera"
    )
    assert listed_sensors(prompt) == check_sensors(sensors)  # the words it uses read back as these sensors
    # the authors' API listing, with the methods of the senses beyond the paper's that this robot has
    beyond = [q.method for s in sensors if SENSORS.get(s).capability is None for q in SENSORS.get(s).senses]
    fullness = ["measure_fullness"] if "force" in sensors else []
    assert sorted(robot_methods(prompt)) == sorted([*PAPERS_OWN, *fullness, *beyond])
    assert set(robot_methods(prompt)) <= set(Robot.API_METHODS)  # each one runs
    assert ("cannot move or measure" in prompt) is (not embodied)
    for program in examples(prompt):
        ast.parse(program)


def test_the_paper_prompt_offers_a_registered_sensor_in_the_papers_words(spectrometer):
    prompt = build_paper_prompt(QUERY, ["camera", "spectrometer"], findable="objects by a short name")
    assert (
        instruction(prompt)
        == f"Instruction: The robot is equipped with a camera and a near-infrared spectrometer. {QUERY}"
    )
    assert "measure_sugar" in robot_methods(prompt) and "the sugar content of the object, in °Bx" in prompt
    assert "- What find can detect here: objects by a short name." in prompt


def test_the_paper_prompts_examples_run_in_the_paper_dialect():
    """Every example of the listing runs in the sandbox on a world of balls that answer to any name: the
    template teaches nothing the runtime refuses."""
    prompt = build_paper_prompt(QUERY, ["camera", "distance", "force", "temperature", "grip"])
    programs, ran = examples(prompt), 0
    assert len(programs) >= 14
    with ProgramRunner(classes=[ImagePatch, Robot]) as runner:
        for program in programs:
            world = BallWorld(THINGS)
            robot = Robot(sensors=["camera", "distance", "force", "temperature", "grip"], world=world,
                          controller=BallController(world))  # fmt: skip
            result = runner.run(program, args=[robot.look(world_perception(relabel=True)), robot])
            ran += result.ok
            if not result.ok:  # only what the ball world cannot do (drive to a point, place on something)
                assert "is not available in this world" in result.error.message, (program, result.error)
    assert ran >= len(programs) - 3


def test_the_template_is_strict_and_the_names_agree_with_the_setting():
    with pytest.raises(jinja2.UndefinedError):
        _environment().get_template("paper.jinja").render(query="x", sensors=["camera"])
    assert tuple(PROMPTS) == PROMPT_NAMES
    assert {p.name: p.entry for p in PROMPTS.values()} == {
        "attribot": "execute_command(image, robot)",
        "paper": "execute_command(image)",
    }


def test_the_prompt_setting_is_read_from_flags_and_the_environment_and_checked(monkeypatch, empty_settings):
    assert load_settings().prompt == "attribot"
    monkeypatch.setenv("ATTRIBOT_PROMPT", "paper")
    assert load_settings().prompt == "paper"
    with pytest.raises(ConfigError, match="unknown prompt; choose one of: attribot, paper"):
        load_settings(prompt="papers")
    done = cli("ask", QUERY, "--prompt", "vipergpt")
    assert done.returncode == 2
    assert "error: setting prompt = 'vipergpt' (from --prompt)" in done.stderr and "\nfix: " in done.stderr


def test_the_llm_planner_shows_the_prompt_chosen():
    request = PlanRequest(query=QUERY, sensors=["camera", "distance"], embodied=True)
    paper = LLMPlanner(load_settings(prompt="paper")).messages(request)[0]["content"]
    ours = LLMPlanner(load_settings(prompt="attribot")).messages(request)[0]["content"]
    assert paper.startswith("import math") and instruction(paper).endswith(
        f"a camera and a distance sensor. {QUERY}"
    )
    assert "def execute_command(image, robot):" in ours and "Instruction:" not in ours


# ---- programs in the authors' habits, from a scripted endpoint ---------------------------------------------

TRIPLET = SceneConfig(layout="triplet", seed=3, width=320, height=240)
LIGHTEST = """
def execute_command(image):
    robot = Robot(sensors=["camera", "force/torque sensor"])
    image_patch = ImagePatch(image)
    object_patches = image_patch.find("object")
    lightest_patch, lightest_weight = None, None
    for object_patch in object_patches:
        go_to_object(object_patch)
        pick_up(object_patch)
        weight = object_patch.measure_weight("object")
        if lightest_weight is None or weight < lightest_weight:
            lightest_patch, lightest_weight = object_patch, weight
    return lightest_patch
"""


def fenced(source: str) -> str:
    return f"Here is the function:\n\n```python\n{dedent(source).strip()}\n```\n"


def test_ask_with_the_paper_prompt_runs_the_reply_and_names_the_prompt(httpserver, tmp_path):
    requests = serve_chat_replies(httpserver, [fenced(LIGHTEST)])
    done = cli(
        "ask", QUERY, "--layout", "triplet", "--seed", "3", "--width", "320", "--height", "240",
        "--sensors", "camera,force", "--planner", "llm", "--prompt", "paper", "--llm-base-url",
        httpserver.url_for("/v1"), "--llm-model", "scripted", "--json", cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    answer = json.loads(done.stdout)
    assert answer["prompt"] == "paper" and answer["planner"] == "llm"
    assert answer["object"]["id"] == min(_truth(TRIPLET), key=lambda o: o.mass_kg).id
    shown = requests[0]["messages"][0]["content"]
    assert (
        instruction(shown)
        == f"Instruction: The robot is equipped with a camera and a force/torque sensor. {QUERY}"
    )


def test_an_ambiguous_name_goes_back_to_the_model_which_writes_it_again(httpserver, tmp_path):
    jars = SceneConfig(layout="arrangement", seed=1, width=320, height=240)
    guessed = """
    def execute_command(image):
        robot = Robot(sensors=["camera", "force/torque sensor"])
        go_to_object("jar")
        pick_up("jar")
        return measure_weight("jar")
    """
    each = """
    def execute_command(image):
        robot = Robot(sensors=["camera", "force/torque sensor"])
        jar_patches = ImagePatch(image).find("jar")
        weights = [jar_patch.measure_weight("jar") for jar_patch in jar_patches]
        return jar_patches[weights.index(max(weights))]
    """
    requests = serve_chat_replies(httpserver, [fenced(guessed), fenced(each)])
    settings = load_settings(
        planner="llm", prompt="paper", llm_base_url=httpserver.url_for("/v1"), llm_model="scripted",
        cache_dir=tmp_path / "cache",
    )  # fmt: skip
    answer = ask("Which jar is the heaviest?", Scene(jars, sensors=["camera", "force"]), settings)
    assert answer.error is None and answer.attempts == 2 and answer.prompt == "paper"
    assert answer.object.id == max(_truth(jars), key=lambda o: o.mass_kg).id
    feedback = requests[1]["messages"][-1]["content"]
    assert "go_to_object('jar') is ambiguous: the robot's camera sees 3 of them" in feedback
    assert "as one ```python code block that defines execute_command(image)." in feedback


def test_eval_records_the_prompt_and_a_run_folder_refuses_another(httpserver, tmp_path):
    serve_chat_replies(httpserver, [fenced(LIGHTEST)])
    out = tmp_path / "run"
    url = httpserver.url_for("/v1")
    args = ["eval", "--tasks", "weight_embodied", "--methods", "pa-api,vqa+llm", "--limit", "1",
            "--planner", "llm", "--llm-base-url", url, "--llm-model", "scripted"]  # fmt: skip
    done = cli(*args, "--prompt", "paper", "--out", str(out), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    records = {r.method: r for r in read_records(out)}
    assert records["pa-api"].prompt == "paper" and records["pa-api"].status == "right", records["pa-api"]
    assert records["vqa+llm"].prompt is None  # a model asked directly, shown no program prompt
    assert json.loads((out / "run.json").read_text())["prompt"] == "paper"
    other = cli(*args, "--out", str(out), cwd=tmp_path)  # the default prompt, attribot
    assert other.returncode == 2
    assert "prompt: this run 'attribot', the directory 'paper'" in other.stderr
    report = cli("report", str(out), "--out", str(tmp_path / "report.html"))
    assert report.returncode == 0, report.stderr
    page = (tmp_path / "report.html").read_text()
    assert (
        "<tr><th>prompt</th><td>paper</td></tr>" in page
        and "program (from the paper prompt) and trace" in page
    )
