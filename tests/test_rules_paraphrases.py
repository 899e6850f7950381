"""Ordinary phrasings of the paper's questions, answered on generated scenes and checked against the
simulator's truth (the phrasings the issue found refused or misread)."""

from __future__ import annotations

import pytest

from attribot.config import SceneConfig, load_settings
from attribot.embodiments.mujoco import MujocoWorld
from attribot.planning.rules import GroundingQuery, MeasureQuery, SizeQuery, parse_query
from attribot.session import Scene, ask


@pytest.fixture(scope="module")
def triplet() -> list[dict]:
    with MujocoWorld(layout="triplet", seed=3) as world:
        return [o.model_dump() for o in world.scene_info().objects]


@pytest.fixture(scope="module")
def household() -> list[dict]:
    with MujocoWorld(layout="household", seed=7) as world:
        return [o.model_dump() for o in world.scene_info().objects]


def _ask(query: str, layout: str, seed: int, sensors: list[str]):
    answer = ask(query, Scene(SceneConfig(layout=layout, seed=seed), sensors=sensors), load_settings())
    assert answer.error is None, answer.error
    return answer


@pytest.mark.parametrize(
    ("query", "heaviest"),
    [
        ("Which object weighs the most?", True),
        ("Which item has the greatest mass?", True),
        ("Which of these weighs the least?", False),
        ("What is the heaviest object here?", True),
    ],
)
def test_weight_paraphrases_are_measured_and_right(triplet, query, heaviest):
    answer = _ask(query, "triplet", 3, ["camera", "force"])
    pick = max if heaviest else min
    assert answer.object.id == pick(triplet, key=lambda o: o["mass_kg"])["id"]
    assert answer.unit == "kg"


def test_the_lightest_of_named_objects(triplet):
    names = [o["category"] for o in triplet]
    query = f"Give me the lightest of the {names[0]}, the {names[1]} and the {names[2]}"
    answer = _ask(query, "triplet", 3, ["camera", "force"])
    assert answer.object.id == min(triplet, key=lambda o: o["mass_kg"])["id"]


def test_farthest_away_from_the_robot(household):
    answer = _ask("Which object is farthest away from the robot?", "household", 7, ["camera", "distance"])
    assert answer.object.id == max(household, key=lambda o: o["distance_m"])["id"]


def test_whats_the_distance_to(household):
    target = household[0]
    answer = _ask(f"What's the distance to the {target['category']}?", "household", 7, ["camera", "distance"])
    assert answer.value == pytest.approx(target["distance_m"], abs=0.25)


def test_a_colour_and_a_category_name_one_object(household):
    target = household[1]
    parsed = parse_query(f"the {target['color']} {target['category']}")
    assert isinstance(parsed, GroundingQuery)
    answer = _ask(f"the {target['color']} {target['category']}", "household", 7, ["camera"])
    assert answer.object.id == target["id"]


@pytest.mark.parametrize(
    ("query", "kind", "adjective", "noun"),
    [
        ("Which item is the largest?", SizeQuery, "largest", "item"),
        ("which cup is the tallest", SizeQuery, "tallest", "cup"),
        ("Which mug is the second largest?", SizeQuery, "largest", "mug"),
    ],
)
def test_which_x_is_the_yest_reads_as_the_yest_x(query, kind, adjective, noun):
    parsed = parse_query(query)
    assert isinstance(parsed, kind) and parsed.adjective == adjective and parsed.obj.noun == noun


def test_measure_reads_what_is_contracted():
    parsed = parse_query("What's the distance to the book?")
    assert isinstance(parsed, MeasureQuery) and parsed.quantity == "distance" and parsed.obj.noun == "book"


def _odd_truth(config: SceneConfig) -> str:
    with MujocoWorld(config) as world:
        (odd,) = [o.id for o in world.scene_info().objects if o.odd_one_out]
    return odd


@pytest.mark.parametrize(
    ("query", "odd", "seed", "pattern"),
    [
        ("the odd one out", "category", 1, "row"),
        ("Which object does not belong?", "category", 2, "grid"),
        ("What is the odd one out?", "color", 1, "row"),
        ("which one is different", "color", 4, "grid"),
    ],
)
def test_the_odd_one_out_by_kind_and_colour(query, odd, seed, pattern):
    config = SceneConfig(layout="arrangement", seed=seed, options={"odd": odd, "pattern": pattern})
    answer = ask(query, Scene(config, sensors=["camera"]), load_settings())
    assert answer.error is None and answer.object.id == _odd_truth(config)


def test_the_odd_one_out_by_size_measures_what_perspective_hides():
    """With the distance sensor a size is pixels times metres; most arrangements are read right (thin
    objects lying at different angles still fool it now and then)."""
    right = total = 0
    for seed in range(4):
        for pattern in ("row", "grid", "column"):
            config = SceneConfig(layout="arrangement", seed=seed, options={"odd": "size", "pattern": pattern})
            answer = ask("the odd one out", Scene(config, sensors=["camera", "distance"]), load_settings())
            total += 1
            right += answer.object is not None and answer.object.id == _odd_truth(config)
    assert right / total >= 0.8, f"{right} of {total}"


def test_the_odd_one_outs_value_is_the_attribute_that_decided_never_the_distance():
    """By size, the value is its size in metres (the distance measured on the way is not the answer); by
    kind, there is no value."""
    config = SceneConfig(layout="arrangement", seed=0, options={"odd": "size", "pattern": "row"})
    with MujocoWorld(config) as world:
        (odd,) = [o for o in world.scene_info().objects if o.odd_one_out]
    answer = ask("spot the odd one out", Scene(config, sensors=["camera", "distance"]), load_settings())
    assert answer.object is not None and answer.object.id == odd.id
    assert answer.unit == "m" and answer.value == pytest.approx(odd.size_m, rel=0.35)
    assert abs(answer.value - odd.distance_m) > 0.5, "the size, not the rangefinder's distance"
    config = SceneConfig(layout="arrangement", seed=1, options={"odd": "category", "pattern": "row"})
    answer = ask("spot the odd one out", Scene(config, sensors=["camera", "distance"]), load_settings())
    assert answer.object is not None and answer.object.id == _odd_truth(config)
    assert answer.value is None and answer.unit is None


def test_how_far_is_the_closest_measures_the_chosen_object(household):
    answer = _ask("How far is the closest object?", "household", 7, ["camera", "distance"])
    nearest = min(household, key=lambda o: o["distance_m"])
    assert answer.object.id == nearest["id"] and answer.unit == "m"
    assert answer.value == pytest.approx(nearest["distance_m"], abs=0.25)


def test_a_measure_and_a_choice_of_different_attributes_is_refused():
    from attribot.planning.rules import UnsupportedQuery

    with pytest.raises(UnsupportedQuery):
        parse_query("How far is the heaviest box?")


@pytest.mark.parametrize(
    ("query", "largest"), [("Which object is the largest?", True), ("the tiniest object", False)]
)
def test_with_a_distance_sensor_a_size_is_in_the_world_not_in_the_picture(query, largest):
    """Household seed 40100: a near tomato looks bigger than a far plate. The camera alone goes by the
    picture; with the rangefinder, pixels times metres find the object that is bigger in the world."""
    with MujocoWorld(layout="household", seed=40100) as world:
        seen = [o for o in world.scene_info().objects if o.box is not None]
    by_size = sorted(seen, key=lambda o: o.size_m)
    truth = (by_size[-1] if largest else by_size[0]).id
    measured = _ask(query, "household", 40100, ["camera", "distance"])
    assert measured.object.id == truth
    assert "robot.measure_distance" in measured.program
    assert _ask(query, "household", 40100, ["camera"]).object.id != truth  # perspective fooled the picture
