"""The rules planner's language front end and compositional reading: misspellings, word forms, British
spellings, wrappers, denials, exclusions, "the next after", groups; what was read as what is said, and a
word it cannot place is named with what it could mean. No scene is drawn: readings and programs only."""

from __future__ import annotations

import pytest

from attribot.planning.rules import (
    Request,
    SenseQuery,
    Understood,
    UnsupportedQuery,
    WeightQuery,
    YesNoQuery,
    parse_query,
    rules_program,
)
from attribot.planning.rules.understand import WORDNET_DIR, kinds_of, mend

pytestmark = pytest.mark.skipif(
    not (WORDNET_DIR / "data.noun").is_file(), reason="Debian's wordnet-base is not installed"
)

SENSORS = ("camera", "distance", "force", "temperature", "grip")


@pytest.mark.parametrize(
    ("query", "note"),
    [
        ("whats the heavist thing here", "reading 'heavist' as 'heaviest'"),
        ("is teh toaster heavier then the carrot", "reading 'teh' as 'the'"),
        ("is teh toaster heavier then the carrot", "reading 'then' as 'than'"),
        ("which botle is empty", "reading 'botle' as 'bottle'"),
        ("which is the chilliest", "reading 'chilliest' as 'coldest'"),
        ("which is the squidgiest object", "reading 'squidgiest' as 'squishiest'"),
        ("how many kilogrammes does the kettle weigh", "reading 'kilogrammes' as 'kilograms'"),
        ("which is the closet object", "reading 'closet' as 'closest'"),
        ("wich is the heaviest thing", "reading 'wich' as 'which'"),
        ("is the lamp closre than the vase?", "reading 'closre' as 'closer'"),
    ],
)
def test_a_mended_reading_says_what_was_read_as_what(query: str, note: str) -> None:
    parsed = parse_query(query)
    assert isinstance(parsed, Understood)
    assert note in parsed.notes
    program = rules_program(query, SENSORS, True)
    assert note[1:] in program  # said in the program's comment and printed with its answer


@pytest.mark.parametrize(
    "query",
    [
        "the heaviest mug",
        "second smiley face from the left",
        "rightmost box with shoes in the middle row",
        "which object is wet",
        "Which mug is hot?",
    ],
)
def test_what_reads_as_typed_is_not_mended(query: str) -> None:
    try:
        parsed = parse_query(query)
    except UnsupportedQuery:
        return
    assert not isinstance(parsed, Understood)


def test_the_typos_of_names_are_mended_even_where_the_text_reads() -> None:
    """ "which botle is empty" reads as typed, searching a "botle": a word no dictionary holds is mended."""
    parsed = parse_query("which botle is empty")
    assert isinstance(parsed, Understood) and isinstance(parsed.inner, SenseQuery)
    assert parsed.inner.objects[0].noun == "bottle"


@pytest.mark.parametrize(
    ("query", "words"),
    [
        ("which object is xqzzy", "'xqzzy' is no word it knows"),
        ("which object is florpy", "reading 'florpy' as 'floppy'"),
    ],
)
def test_a_refusal_names_the_word_and_what_it_could_mean(query: str, words: str) -> None:
    with pytest.raises(UnsupportedQuery) as refused:
        parse_query(query)
    assert words in str(refused.value.reason)


@pytest.mark.parametrize(
    ("query", "kind"),
    [
        ("hey robot, could you please check which mug is hot?", SenseQuery),
        ("could you check is the kettle hotter than the mug", SenseQuery),
        ("is the mug any colder than the kettle?", SenseQuery),
        ("Is the cactus further from you than the orange is?", YesNoQuery),
        ("is the kettle much heavier than the mug", YesNoQuery),
        ("Point out the heaviest of the three", WeightQuery),
        ("which jar has the most in it", SenseQuery),
    ],
)
def test_wrappers_and_yes_no_forms(query: str, kind: type) -> None:
    assert isinstance(parse_query(query), kind)


def test_a_denied_state_chooses_the_other_end_and_refuses_when_every_one_is_in_it() -> None:
    parsed = parse_query("Which cup is not full?")
    assert isinstance(parsed, SenseQuery) and parsed.word == "not full" and not parsed.more
    program = rules_program("Which cup is not full?", SENSORS, True)
    assert "if min(values) > 0.5:" in program and "every one of them is full" in program


@pytest.mark.parametrize(
    "query",
    [
        "Apart from the kettle, which is the heaviest thing here?",
        "which is the heaviest thing except the kettle",
        "which object other than the kettle is the heaviest",
        "Except for the kettle, what is the heaviest item?",
    ],
)
def test_an_exclusion_leaves_the_named_object_out(query: str) -> None:
    parsed = parse_query(query)
    assert isinstance(parsed, Request) and [o.noun for o in parsed.exclude] == ["kettle"]
    program = rules_program(query, SENSORS, True)
    assert 'left_out = left_out + image.find("kettle")' in program and "same_box" in program


def test_the_next_after_orders_and_takes_the_one_past_the_named_object() -> None:
    query = "which object is the next heaviest after the toaster?"
    parsed = parse_query(query)
    assert isinstance(parsed, Request) and parsed.after is not None and parsed.after.noun == "toaster"
    program = rules_program(query, SENSORS, True)
    assert "position = order.index(reference)" in program
    assert "return candidates[order[position + 1]]" in program


def test_a_part_the_writer_cannot_honour_is_refused_not_dropped() -> None:
    # without a force sensor, weight is reasoned about by name, not ordered among the found objects
    with pytest.raises(UnsupportedQuery):
        rules_program("which object is the next heaviest after the toaster?", ("camera",), False)


def test_a_group_is_looked_for_with_its_kinds() -> None:
    assert {"carrot", "potato", "tomato"} <= set(kinds_of("vegetables"))
    assert {"apple", "banana", "orange"} <= set(kinds_of("fruits"))
    assert kinds_of("mugs") == () and kinds_of("things") == () and kinds_of("vegetable") == ()
    program = rules_program("Which of the vegetables is the lightest?", SENSORS, True)
    assert "carrot" in program and all(len(line) < 320 for line in program.splitlines())


def test_mend_is_none_for_a_query_with_nothing_to_mend() -> None:
    assert mend("which mug is the heaviest") is None
