"""The rules parser on raw edge strings: what it reads, and what it refuses (never a guess)."""

from __future__ import annotations

import pytest

from attribot.config import Settings
from attribot.errors import InputError
from attribot.planning import PlanRequest, build_planner
from attribot.planning.rules import (
    DistanceQuery,
    LineSpec,
    LocationQuery,
    ObjectSpec,
    Pick,
    SizeQuery,
    UnsupportedQuery,
    WeightQuery,
    parse_query,
)


@pytest.mark.parametrize(
    ("query", "error", "match"),
    [
        ("", InputError, "empty"),
        ("   \n\t ", InputError, "empty"),
        ("the second dog from the right " * 40, InputError, "more than the 500"),
        ("asdf qwer zxcv", UnsupportedQuery, "cannot read"),
        ("what is the meaning of life", UnsupportedQuery, "cannot read"),
        ("the dog", UnsupportedQuery, "cannot read"),  # no attribute: which dog?
        ("how heavy is it", UnsupportedQuery, "cannot read"),  # a pronoun with nothing to refer to
        ("find the thing", UnsupportedQuery, "cannot read"),  # generic: which thing?
        ("the dog from the left", UnsupportedQuery, "cannot read"),  # a direction with nothing to count
        ("the 0th dog from the left", UnsupportedQuery, "cannot read"),
        ("the cup on the table next to the lamp", UnsupportedQuery, "cannot read"),  # relations
        ("the second row column", UnsupportedQuery, "cannot read"),
        ("the dog in the left row", UnsupportedQuery, "cannot read"),  # rows have no left
        ("the dog in the top column", UnsupportedQuery, "cannot read"),
        ("second top right cocktail", UnsupportedQuery, "cannot read"),  # two ways to read it
        ("???", UnsupportedQuery, "no words"),
        ("第二只狗", UnsupportedQuery, "outside the English alphabet"),
        ("is the dog or the cat bigger than the horse", UnsupportedQuery, "cannot read"),
    ],
)
def test_refusals(query, error, match):
    with pytest.raises(error, match=match) as info:
        parse_query(query)
    if error is UnsupportedQuery:
        # the fix lists every family with an example, and the way out
        for family in ("location", "size", "weight", "distance", "--planner llm"):
            assert family in info.value.fix
        assert isinstance(info.value, InputError)


@pytest.mark.parametrize(
    ("query", "expected"),
    [
        ("third from the top", LocationQuery(ObjectSpec("object"), None, Pick("ordinal", "top", 3))),
        ("The SECOND dog from the right!", None),
        ("  find the second   dog from the right.  ", None),
        ("Please point to the 2nd dog from the right", None),
        ("the second dög from the right", None),
        ("the 21st dog from the left", LocationQuery(ObjectSpec("dog"), None, Pick("ordinal", "left", 21))),
        ("the last dog from the left", LocationQuery(ObjectSpec("dog"), None, Pick("ordinal", "right", 1))),
        (
            "the second-to-last umbrella in the top row",
            LocationQuery(ObjectSpec("umbrella"), LineSpec("row", 1), Pick("ordinal", "right", 2)),
        ),
        ("the one on the left", LocationQuery(ObjectSpec("one"), None, Pick("ordinal", "left", 1))),
        (
            "the second top row",
            LocationQuery(ObjectSpec("object"), LineSpec("row", 1), Pick("ordinal", "left", 2)),
        ),
        ("which is the second dog from the right", None),
        ("the tallest", SizeQuery(ObjectSpec("object"), "tallest", "height", True, 1)),
        ("the heaviest", WeightQuery((ObjectSpec("object"),), heaviest=True)),
        ("which one is the heaviest?", WeightQuery((ObjectSpec("object"),), heaviest=True)),
        ("the mug nearest to me", DistanceQuery((ObjectSpec("mug"),), nearest=True)),
        (
            "Which is closer to me, the laptop or the tv?",
            DistanceQuery((ObjectSpec("laptop"), ObjectSpec("tv")), True, True),
        ),
        (
            "Out of the mugs, which one is farthest from me?",
            DistanceQuery((ObjectSpec("mugs"),), False, True),
        ),
        ("Which object is the closest to me?", DistanceQuery((ObjectSpec("object"),), nearest=True)),
        ("Which item is farthest from the robot?", DistanceQuery((ObjectSpec("item"),), nearest=False)),
        ("Which mug is the closest?", DistanceQuery((ObjectSpec("mug"),), nearest=True)),
        ("Which red cup is the heaviest?", WeightQuery((ObjectSpec("cup", ("red",)),), heaviest=True)),
        ("the light box", WeightQuery((ObjectSpec("box"),), heaviest=False)),
        ("rightmost light", LocationQuery(ObjectSpec("light"), None, Pick("ordinal", "right", 1))),
    ],
)
def test_readings(query, expected):
    parsed = parse_query(query)
    if expected is None:  # spelled differently, read the same as the plain form
        expected = parse_query("the second dog from the right")
    assert parsed == expected


def test_rules_planner_is_registered_deterministic_and_ignores_feedback():
    planner = build_planner("rules", Settings())
    request = PlanRequest(query="top right cocktail", sensors=["camera"], embodied=False)
    first = planner.plan(request)
    assert first.program == planner.plan(request, ()).program
    assert first.reply is None and not first.cached
    with pytest.raises(UnsupportedQuery):
        planner.plan(PlanRequest(query="sing me a song", sensors=["camera"], embodied=False))


def test_every_listed_example_reads_as_its_family():
    """The examples the refusal message shows must themselves be read, as the family they illustrate."""
    from attribot.planning.rules import (
        FAMILIES,
        DistanceQuery,
        GroundingQuery,
        LocationQuery,
        MeasureQuery,
        OddQuery,
        Request,
        SenseQuery,
        SizeQuery,
        WeightQuery,
        YesNoQuery,
    )

    kinds = {
        "senses": SenseQuery,
        "odd one out": OddQuery,
        "location": LocationQuery,
        "size": SizeQuery,
        "weight": WeightQuery,
        "distance": DistanceQuery,
        "grounding": GroundingQuery,
        "measurement": MeasureQuery,
        "yes/no": YesNoQuery,
        "scope": Request,
        "action": Request,
        "composition": WeightQuery | Request,
    }
    assert set(FAMILIES) == set(kinds)
    for family, examples in FAMILIES.items():
        for example in examples:
            assert isinstance(parse_query(example), kinds[family]), (family, example)
