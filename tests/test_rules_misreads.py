"""The rules planner never searches for leftover words: "of these", "one", "object here" stand for the
candidates in view, and what it cannot place it refuses instead of reading a wrong noun (issue: "a planner
that guesses wrong silently is worse than one that refuses")."""

from __future__ import annotations

import pytest

from attribot.planning.rules import UnsupportedQuery, WeightQuery, parse_query


@pytest.mark.parametrize(
    ("query", "heaviest"),
    [
        ("Which of these is the heaviest?", True),
        ("Which item is the lightest one?", False),
        ("What is the heaviest object here?", True),
        ("the lightest of the three", False),
        ("the heaviest of these", True),
        ("Which one is the heaviest?", True),
        ("the lightest thing in front of me", False),
        ("Out of these objects, which one is the most lightweight?", False),
        ("Out of the three items, which one is the heaviest?", True),
        ("Among these, which is the heaviest?", True),
    ],
)
def test_the_candidate_set_words_mean_any_object_in_view(query, heaviest):
    parsed = parse_query(query)
    assert isinstance(parsed, WeightQuery) and parsed.heaviest is heaviest
    assert not parsed.named and all(o.generic for o in parsed.objects), parsed


@pytest.mark.parametrize(
    "query",
    [
        "Is this heavier than that?",
        "Which is heavier, it or the book?",
        "Is it closer than the mug?",
        "the heaviest thing of theirs",
        "Which of them weighs more than it?",
    ],
)
def test_pronouns_with_nothing_to_refer_to_are_refused_not_searched(query):
    with pytest.raises(UnsupportedQuery):
        parse_query(query)


def test_named_lists_hold_names_not_generic_words():
    parsed = parse_query(
        "Out of the kettle, the backpack and the tissue box, which one is the most lightweight?"
    )
    assert isinstance(parsed, WeightQuery) and parsed.named
    assert [o.noun for o in parsed.objects] == ["kettle", "backpack", "tissue box"]
