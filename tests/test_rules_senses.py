"""The rules planner reads the senses beyond the paper's (temperature, softness, fullness): which object is
at one end, yes/no about a state or two objects, how much; programs that measure with the right sensor and
its precondition; refusals without the sensor; answers checked against the world's state."""

from __future__ import annotations

import json
import random
from pathlib import Path

import pytest

from attribot.config import SceneConfig
from attribot.errors import InputError
from attribot.planning.rules import Request, SenseQuery, parse_query, rules_program
from attribot.runner import check_program
from attribot.session import Scene, ask

ALL = ["camera", "distance", "force", "temperature", "grip"]
DATA = Path(__file__).parent / "data"


@pytest.mark.parametrize(
    ("query", "attribute", "more", "ask_", "noun"),
    [
        ("Which mug is hot?", "temperature", True, "which", "mug"),
        ("which cup is warm", "temperature", True, "which", "cup"),
        ("the coldest can", "temperature", False, "which", "can"),
        ("Which can is the coldest", "temperature", False, "which", "can"),
        ("which of these cans is the least warm", "temperature", False, "which", "cans"),
        ("Is the kettle hot?", "temperature", True, "whether", "kettle"),
        ("How hot is the kettle?", "temperature", True, "how", "kettle"),
        ("what's the temperature of the mug", "temperature", True, "how", "mug"),
        ("the softest ball", "stiffness", False, "which", "ball"),
        ("which ball is the squishiest", "stiffness", False, "which", "ball"),
        ("Which ball is the hardest?", "stiffness", True, "which", "ball"),
        ("is the apple hard?", "stiffness", True, "whether", "apple"),
        ("Which bottle is empty?", "fullness", False, "which", "bottle"),
        ("is the mug full?", "fullness", True, "whether", "mug"),
        ("How full is the bottle?", "fullness", True, "how", "bottle"),
        ("which jar has nothing in it", "fullness", False, "which", "jar"),
    ],
)
def test_the_sense_questions_read_with_their_meaning(query, attribute, more, ask_, noun):
    parsed = parse_query(query)
    assert isinstance(parsed, SenseQuery)
    assert (parsed.attribute, parsed.more, parsed.ask, parsed.objects[0].noun) == (
        attribute,
        more,
        ask_,
        noun,
    )


def test_named_comparisons_ranks_scopes_and_actions_frame_the_senses():
    named = parse_query("Which is hotter, the kettle or the mug?")
    assert (
        isinstance(named, SenseQuery) and named.named and [o.noun for o in named.objects] == ["kettle", "mug"]
    )
    both = parse_query("Is the kettle hotter than the mug?")
    assert isinstance(both, SenseQuery) and both.ask == "whether" and both.named
    second = parse_query("the second coldest can")
    assert isinstance(second, SenseQuery) and second.rank == 2 and not second.more
    framed = parse_query("bring me the coldest can on the table")
    assert isinstance(framed, Request) and framed.scope == "table" and framed.action == "pick"
    assert isinstance(framed.inner, SenseQuery) and framed.inner.attribute == "temperature"
    # the paper's families keep their meaning: weight is no temperature, "hardest to lift" is weight
    assert type(parse_query("which item would be hardest to lift?")).__name__ == "WeightQuery"
    assert type(parse_query("the heaviest mug")).__name__ == "WeightQuery"


@pytest.mark.parametrize(
    ("query", "method", "before"),
    [
        ("Which mug is hot?", "measure_temperature", "focus_on_patch"),
        ("the softest ball", "measure_stiffness", "pick_up"),
        ("Which bottle is empty?", "measure_fullness", "pick_up"),
        ("Is the kettle hot?", "measure_temperature", "focus_on_patch"),
        ("Is the bottle fuller than the mug?", "measure_fullness", "pick_up"),
        ("How soft is the ball?", "measure_stiffness", "pick_up"),
    ],
)
def test_programs_measure_with_the_sensor_after_its_precondition(query, method, before):
    program = rules_program(query, ALL, embodied=True)
    assert check_program(program) is None
    assert f"robot.{before}(patch)" in program and f"robot.{method}(patch)" in program
    assert program.index(f"robot.{before}(patch)") < program.index(f"robot.{method}(patch)")


@pytest.mark.parametrize(
    ("query", "sensor"),
    [("Which mug is hot?", "temperature"), ("the softest ball", "grip"), ("Is the mug full?", "force")],
)
def test_without_the_sensor_the_query_is_refused_saying_which_to_add(query, sensor):
    with pytest.raises(InputError, match=f"no {sensor} sensor") as refused:
        rules_program(query, ["camera"], embodied=True)
    assert f"--sensors camera,{sensor}" in refused.value.fix
    with pytest.raises(InputError, match="a still image has no robot"):
        rules_program(query, ALL, embodied=False)


def test_a_yes_no_about_a_state_states_its_threshold_in_the_program():
    program = rules_program("Is the kettle hot?", ALL, embodied=True)
    assert "yes = value >= 40.0" in program and '"yes": yes' in program
    empty = rules_program("is the bottle empty", ALL, embodied=True)
    assert "yes = value < 0.5" in empty


def _truth(config: SceneConfig) -> dict[str, object]:
    return {o.id: o for o in Scene(config).truth().objects}


def test_which_mug_is_hot_is_answered_from_the_thermometer():
    config = SceneConfig(layout="household", seed=6, categories=("mug", "kettle", "can"), objects=3)
    truth = _truth(config)
    hot = max(truth.values(), key=lambda o: o.temperature_c)
    answer = ask("What's the hottest thing here?", Scene(config, sensors=["camera", "temperature"]))
    assert answer.error is None, answer.error
    assert answer.object.id == hot.id and answer.unit == "°C"
    assert answer.value == pytest.approx(hot.temperature_c, abs=0.5)


def test_yes_no_answers_carry_the_boolean_and_the_value():
    config = SceneConfig(layout="household", seed=10, categories=("kettle",), objects=1)
    (kettle,) = _truth(config).values()
    answer = ask("Is the kettle hot?", Scene(config, sensors=["camera", "temperature"]))
    assert answer.error is None, answer.error
    assert answer.boolean is (kettle.temperature_c >= 40.0) and answer.unit == "°C"
    assert ("hot" in answer.answer) and str(round(answer.value, 1))[:2] in answer.answer


def test_the_senses_phrasing_set_is_split_with_its_seed_and_states_its_meaning():
    rows = (DATA / "generalisation_senses.jsonl").read_text().splitlines()
    order = list(range(len(rows)))
    random.Random(29).shuffle(order)
    half = len(rows) // 2
    tuning = (DATA / "generalisation_senses_tuning.jsonl").read_text().splitlines()
    test = (DATA / "generalisation_senses_test.jsonl").read_text().splitlines()
    assert tuning == [rows[i] for i in sorted(order[:half])]
    assert test == [rows[i] for i in sorted(order[half:])]
    for row in map(json.loads, rows):
        assert row["attr"] in ("temperature", "stiffness", "fullness")
        assert row["kind"] in ("extreme", "state", "yesno", "compare", "measure")
        assert row.get("dir") in ("max", "min") or row["kind"] in ("state", "measure")
    # the planner's own generalisation set is not touched by the senses
    assert not any("temperature" in line for line in (DATA / "generalisation.jsonl").read_text().splitlines())
