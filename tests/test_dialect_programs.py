"""A held-out style set for each prompt dialect (issue 51), written the way LLMs write programs from each
prompt, against scenes no other test uses, each judged against the world's own state (`scene_info()`):

- attribot's prompt (`execute_command(image, robot)`): `robot.put_on(obj)` to put a weighed object back,
  dict comprehensions, the uncertainty of a reading, prints before the return;
- ViperGPT's habits (`execute_command(image)`, `ImagePatch(image)`, an empty-list guard, a robot made in
  the program with `Robot(sensors=[...])` and its methods called on it with a put_down after each weighing);
- the paper authors' prompt (bare robot functions, object names, `put_on(patch)` given the object just
  weighed meaning "put it back", a measurement read by name, no put_down).

Weak programs fail with an error that names the fix in the words of the prompt the model was shown, and
the correction answers after one round of feedback, through `attribot ask --planner llm --prompt ...` against
a scripted OpenAI-compatible endpoint on 127.0.0.1.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from attribot.config import SceneConfig, load_settings
from attribot.session import Scene, run_program
from conftest import EMPTY_SETTINGS, serve_chat_replies
from fakes.programs import Truth, ask_llm_cli, closest, heaviest, lightest, program, truth_of


def rightmost(objects: list[Any]) -> str:
    return max((o for o in objects if o.box), key=lambda o: o.box[0] + o.box[2]).id


def second_from_right(objects: list[Any]) -> str:
    return sorted((o for o in objects if o.box), key=lambda o: -(o.box[0] + o.box[2]))[1].id


def of_category(category: str) -> Truth:
    def truth(objects: list[Any]) -> str:
        (found,) = [o for o in objects if o.category == category]
        return found.id

    return truth


DATA = Path(__file__).parent / "data" / "dialect_programs.jsonl"
"""The strong programs: dialect, name, query, scene (a SceneConfig's fields), truth (a name in TRUTHS or
`category:NAME`, the one object of that category) and the program text; benchmarks/accuracy_dialects.py
runs the same set under noise."""

TRUTHS: dict[str, Truth] = {
    "heaviest": heaviest,
    "lightest": lightest,
    "closest": closest,
    "rightmost": rightmost,
    "second_from_right": second_from_right,
}


@dataclass(frozen=True)
class Strong:
    dialect: str  # attribot | viper | paper
    name: str
    query: str
    config: SceneConfig
    truth: Truth
    source: str


def _strong(row: dict[str, Any]) -> Strong:
    truth = row["truth"]
    judge = of_category(truth.split(":", 1)[1]) if truth.startswith("category:") else TRUTHS[truth]
    return Strong(
        row["dialect"], row["name"], row["query"], SceneConfig(**row["scene"]), judge, row["program"]
    )


STRONG = [_strong(json.loads(line)) for line in DATA.read_text(encoding="utf-8").splitlines() if line.strip()]


@pytest.mark.parametrize("case", STRONG, ids=[f"{c.dialect}: {c.name}" for c in STRONG])
def test_a_strong_program_of_each_dialect_answers_right(case, empty_settings):
    answer = run_program(case.source, Scene(case.config), load_settings(), query=case.query)
    assert answer.error is None, answer.error
    assert answer.object is not None and answer.object.id == truth_of(case.config, case.truth), answer.answer
    put_back = [t for t in answer.trace if t["call"] == "Robot.put_on"]
    if "put it back" in case.name or "put back" in case.name or "put_on" in case.name:
        assert put_back and all(t["error"] is None for t in put_back)
        assert all("put it back where it was picked up" in t.get("note", "") for t in put_back), put_back


# ---- weak programs: an error in the prompt's words, and the correction answers after one retry ------------


@dataclass(frozen=True)
class Weak:
    prompt: str  # the prompt the model was shown: attribot | paper
    name: str
    query: str
    args: tuple[str, ...]
    config: SceneConfig
    truth: Truth
    weak: str
    fixed: str
    said: tuple[str, ...]  # words the feedback must hold
    unsaid: tuple[str, ...] = ()  # and words it must not


WEAK = [
    Weak(
        "attribot",
        "goes on to the next object holding the last",
        "Which object is the heaviest?",
        ("--layout", "triplet", "--seed", "4"),
        SceneConfig(layout="triplet", seed=4),
        heaviest,
        program("""
            def execute_command(image, robot):
                weights = []
                for obj in image.find("object"):
                    robot.go_to_object(obj)
                    robot.pick_up(obj)
                    weights.append((robot.measure_weight(obj), obj))
                return max(weights, key=lambda pair: pair[0])[1]
        """),
        program("""
            def execute_command(image, robot):
                weights = []
                for obj in image.find("object"):
                    robot.go_to_object(obj)
                    robot.pick_up(obj)
                    weights.append((robot.measure_weight(obj), obj))
                    robot.put_down()
                return max(weights, key=lambda pair: pair[0])[1]
        """),
        ("does not drive to another object", "call robot.put_down() first", "robot.put_on(patch)"),
        ("could not line its arm up",),
    ),
    Weak(
        "paper",
        "ViperGPT's simple_query, which this API does not have",
        "the rightmost cup",
        ("--layout", "household", "--seed", "3", "--categories", "cup", "--objects", "3"),
        SceneConfig(layout="household", seed=3, categories=("cup",), objects=3),
        rightmost,
        program("""
            def execute_command(image):
                image_patch = ImagePatch(image)
                cup_patches = image_patch.find("cup")
                print(image_patch.simple_query("How many cups are there?"))
                return max(cup_patches, key=lambda cup: cup.horizontal_center)
        """),
        program("""
            def execute_command(image):
                image_patch = ImagePatch(image)
                cup_patches = image_patch.find("cup")
                return max(cup_patches, key=lambda cup: cup.horizontal_center)
        """),
        ("simple_query", "visual_query", "execute_command(image)"),
        ("execute_command(image, robot)",),
    ),
    Weak(
        "paper",
        "puts on a table with nothing in the gripper",
        "Which object is the heaviest?",
        ("--layout", "triplet", "--seed", "8"),
        SceneConfig(layout="triplet", seed=8),
        heaviest,
        program("""
            def execute_command(image):
                robot = Robot(sensors=["camera", "force/torque sensor"])
                image_patch = ImagePatch(image)
                object_patches = image_patch.find("object")
                put_on(object_patches[0])
                return object_patches[0]
        """),
        program("""
            def execute_command(image):
                robot = Robot(sensors=["camera", "force/torque sensor"])
                image_patch = ImagePatch(image)
                object_patches = image_patch.find("object")
                weights = []
                for object_patch in object_patches:
                    go_to_object(object_patch)
                    pick_up(object_patch)
                    weights.append(object_patch.measure_weight("object"))
                    put_on(object_patch)
                return object_patches[weights.index(max(weights))]
        """),
        ("call go_to_object(obj) and pick_up(obj) first", "execute_command(image)"),
        ("robot.go_to_object", "execute_command(image, robot)", "back where it started"),
    ),
]


def fenced(source: str) -> str:
    return f"```python\n{source}```\n"


@pytest.mark.parametrize("case", WEAK, ids=[f"{c.prompt}: {c.name}" for c in WEAK])
def test_a_weak_program_of_each_dialect_fails_in_its_words_and_its_correction_answers(
    case, httpserver, tmp_path
):
    requests = serve_chat_replies(httpserver, [fenced(case.weak), fenced(case.fixed)])
    url, cache = httpserver.url_for("/v1"), str(tmp_path / "cache")
    done = ask_llm_cli(case.query, case.args, url, cache, EMPTY_SETTINGS, case.prompt)
    assert done.returncode == 0, done.stderr + done.stdout[-2000:]
    answer = json.loads(done.stdout)
    assert answer["error"] is None and answer["attempts"] == 2 and len(requests) == 2, answer["answer"]
    assert answer["object"]["id"] == truth_of(case.config, case.truth), answer["answer"]
    feedback = requests[1]["messages"][-1]["content"]
    for words in case.said:
        assert words in feedback, feedback
    for words in case.unsaid:
        assert words not in feedback, feedback
