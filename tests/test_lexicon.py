"""One vocabulary: what the simulator paints and names is known to the planner, the oracle and the catalog
language backend, because all of them read `attribot.lexicon` (the drift this guards against: the simulator
painted objects "teal", which the rules planner did not know as a colour)."""

from __future__ import annotations

import pytest

from attribot import lexicon
from attribot.planning.rules import GroundingQuery, parse_query
from attribot.sim.catalog import COLORS, categories, find_category


@pytest.mark.parametrize("color", sorted(COLORS))
def test_every_painted_colour_is_a_colour_word_the_planner_reads(color):
    assert color in lexicon.COLOR_WORDS
    parsed = parse_query(f"Where is the {color} mug?")
    assert isinstance(parsed, GroundingQuery)
    assert parsed.obj.colors == (color,) and parsed.obj.noun == "mug"


def test_colour_spellings_fold_to_one_name():
    parsed = parse_query("Where is the grey mug?")
    assert isinstance(parsed, GroundingQuery) and parsed.obj.noun == "mug"
    assert [lexicon.COLOR_ALIASES.get(c, c) for c in parsed.obj.colors] == ["gray"]
    assert lexicon.words("A Grey-Colour T-shirt") == ["a", "gray", "color", "t", "shirt"]


OWNERS: dict[str, set[str]] = {}
for _c in categories():
    for _word in (_c.name, *_c.synonyms):
        OWNERS.setdefault(_word, set()).add(_c.name)


@pytest.mark.parametrize("category", categories(), ids=lambda c: c.name)
def test_every_name_and_synonym_and_its_plural_finds_its_category(category):
    for name in (category.name, *category.synonyms):
        # a word two categories share ("ball": a ball, a basketball) finds one of them
        owners = {category.name} if name == category.name else OWNERS[name]
        plural = name + ("es" if name.endswith(("s", "x", "ch", "sh")) else "s")
        for word in (name, plural):
            found = find_category(word)
            assert found is not None and found.name in owners, word


def test_generic_nouns_stand_for_any_object():
    for noun in ("item", "objects", "thing", "one"):
        assert noun in lexicon.GENERIC_NOUNS
    parsed = parse_query("the heaviest item")
    assert all(o.generic for o in parsed.objects)


PARAPHRASE_EXAMPLES = [
    "which jar has the most in it",
    "which bottle holds the least",
    "what is the distance between you and the can",
    "the distance from me to the mug",
    "which object weighs the most",
    "which item weighing least",
    "is the apple weighs more",
    "which one weighs less",
    "the thing with the greatest mass",
    "which has the lowest weight",
    "the most massive object",
    "the least massive object",
    "which one is farthest away",
    "which is closest by",
    "which object is lowest in weight",
    "which item is highest in mass",
    "which one is heaviest by weight",
    "the largest by size",
    "the thing on the far right",
    "which thing is furthest to the left",
    "which is the left most item",
    "which item is hardest to lift",
    "which object is easiest to carry",
    "how many metres away is the lamp",
    "which kettle has just boiled",
    "the can that came out of the fridge",
    "a bottle from the fridge",
    "which jar has nothing in it",
    "which bottle needs refilling",
    "which ball gives the most when you squeeze it",
    "which ball gives the least when squeezed",
    "how much is left in the bottle",
    "does the bottle have anything in it",
    "which mug has got something in it",
    "is there anything in the mug",
    "which thing is the weightiest",
    "the least weighty box",
    "is the pot weightier than the pan",
    "how many kilos is the carrot",
    "what can i lift most easily",
    "which mug has the highest temperature",
    "which can has the lowest temperature",
    "how many degrees is the mug",
    "how many meters from you is the lamp",
    "how many centimetres across is the bowl",
    "how many cm tall is the lamp",
    "how far off is the vase",
    "how far is it to the kettle",
    "where did i leave my phone",
    "which one is nearest the camera",
    "is there water in the bottle",
]


@pytest.mark.parametrize(
    ("text", "meaning"),
    [
        ("which thing is furthest to the left?", "which thing is leftmost?"),
        ("the object furthest to the right", "the object rightmost"),
        ("which is the left most item", "which is the leftmost item"),
        ("what is on the far right?", "what is rightmost?"),
        ("which object is the most to the left?", "which object is leftmost?"),
        ("which thing is furthest from me?", "which thing is furthest from me?"),  # a distance stays one
        ("which item would be hardest to lift?", "which item would be heaviest?"),
        ("which ball is the hardest?", "which ball is the hardest?"),  # hard to squeeze is no weight
        ("which can came out of the fridge?", "which can is cold?"),
        ("which jar has nothing in it", "which jar is empty"),
        ("how much is left in the bottle?", "how full is the bottle?"),
        ("is there anything in the mug", "is the mug full"),
        ("which mug has got something in it", "which mug is full"),
        ("how many kilos is the carrot", "how heavy is the carrot"),
        ("how many degrees is the mug", "what temperature is the mug"),
        ("what can i lift most easily", "what is the lightest"),
    ],
)
def test_left_and_right_are_positions_and_lifting_is_weight(text, meaning):
    assert lexicon.paraphrased(text) == meaning


@pytest.mark.parametrize("text", PARAPHRASE_EXAMPLES)
def test_every_paraphrase_the_lexicon_rewrites_holds_a_cue(text):
    import re

    matching = [cues for p, _, cues in lexicon.ATTRIBUTE_PARAPHRASES if re.search(p, text)]
    assert matching, text
    # each pattern that matches runs only where one of its cues is: it must be here
    assert all(any(cue in text for cue in cues) for cues in matching), text


@pytest.mark.parametrize("text", PARAPHRASE_EXAMPLES)
def test_running_only_the_cued_patterns_reads_as_running_them_all(text):
    import re

    every = text
    for pattern, meaning, _ in lexicon.ATTRIBUTE_PARAPHRASES:
        every = re.sub(pattern, meaning, every)
    assert lexicon.paraphrased(text) == every


def test_each_paraphrase_pattern_has_an_example():
    import re

    for pattern, _, _ in lexicon.ATTRIBUTE_PARAPHRASES:
        assert any(re.search(pattern, e) for e in PARAPHRASE_EXAMPLES), pattern


@pytest.mark.parametrize(
    ("text", "meaning"),
    [
        ("which one's the heaviest?", "which one is the heaviest?"),
        ("the mug's hot?", "the mug is hot?"),
        ("what's the book's weight?", "what is the weight of the book?"),
        ("what is the tissue box's weight", "what is the weight of the tissue box"),
        ("which jar's got something in it", "which jar has something in it"),
        ("which of 'em's heaviest", "which of them is heaviest"),
        (
            "isn't the pot heavier? i'm sure it's not, we'd say",
            "is not the pot heavier? i am sure it is not, we would say",
        ),
        ("can't, won't, doesn't", "can not, will not, does not"),
        ("the mugs' weights", "the mugs weights"),
        ("whats the closest thing to u pls", "what is the closest thing to you please"),
        ("which ones heaviest", "which one is heaviest"),
        ("which ones are heavy", "which ones are heavy"),  # a plural stays one
    ],
)
def test_contractions_and_shorthand_are_written_out(text, meaning):
    assert lexicon.expand_contractions(text) == meaning


def test_no_function_word_is_a_category_name_or_synonym():
    """A word that never names an object must not be one a category is called: "can" names a can."""
    names = {w for c in categories() for name in (c.name, *c.synonyms) for w in name.split()}
    assert not names & lexicon.FUNCTION_WORDS
