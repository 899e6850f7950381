"""The catalog language model: weight and size comparisons from the object catalog, "unknown" otherwise."""

from __future__ import annotations

import itertools

import pytest

from attribot.config import Settings
from attribot.errors import ConfigError, InputError
from attribot.eval.corpus import paper_queries
from attribot.models.base import UNKNOWN, LanguageModel, build_backend
from attribot.models.catalog import CatalogLanguageModel, parse_comparison, resolve_item, split_items
from attribot.sim.catalog import categories

LM = CatalogLanguageModel()


@pytest.mark.parametrize(
    ("question", "expected"),
    [
        # superlatives over a list, in the phrasings programs and people write
        ("Out of the apple, book and laptop, which one is the heaviest?", "laptop"),
        ("Out of the apple, book and laptop, which one is more likely to be the lightest?", "apple"),
        ("Out of the apple, book and laptop, which one is more likely to be the heaviest one?", "laptop"),
        ("out of the apple, book, laptop, which one is the most lightweight", "apple"),
        ("Out of these items: apple, book, laptop, which one is the heaviest?", "laptop"),
        # what the rules planner and the API examples send
        (
            "Out of these items: remote control, lamp, which one is more likely to be the lightest one? "
            "Answer with the name of one item only.",
            "remote control",
        ),
        (
            "Out of these items: apple, mug, laptop, which one is usually the heaviest? Name it.",
            "laptop",
        ),
        (
            "apple, mug, laptop. Out of these items, which one is more likely to be the heaviest one?",
            "laptop",
        ),
        ("The items are: an apple, a book and a laptop. Which one is the heaviest?", "laptop"),
        ("Out of an apple, a book and a laptop, which one is the heaviest?", "laptop"),
        ("Which of the apple, book and laptop is the heaviest?", "laptop"),
        ("What is the heaviest item among the apple, the book and the laptop?", "laptop"),
        ("Which one weighs the most: egg, pot or fork?", "pot"),
        ("Which one weighs the least: egg, pot or fork?", "fork"),
        ("Given a dumbbell, a feather and a mug, which is the heaviest?", "dumbbell"),
        ("Out of the mugs and the apples, which are heavier?", "mugs"),  # plurals, named as asked
        ("Out of the red apple and the silver laptop, which one is lighter?", "red apple"),
        ("Out of the cell phones and the pencils, which one is lighter?", "pencils"),
        ("Out of the bowl of soup and the pencil, which is the heaviest?", "bowl of soup"),
        # pairs
        ("Which is bigger, a mug or a pot?", "pot"),
        ("Which is smaller, a mug or a pot?", "mug"),
        ("Which one is heavier: the toaster or the banana?", "toaster"),
        ("Which is the longest: a broom, a candle or an egg?", "broom"),
        ("Which is the largest weight, apple or laptop?", "laptop"),
        # yes / no
        ("Is a basketball heavier than an egg?", "yes"),
        ("Is an egg heavier than a basketball?", "no"),
        ("Is an egg lighter than a basketball?", "yes"),
        ("Does a laptop weigh more than a book?", "yes"),
        ("Does a laptop weigh less than a book?", "no"),
        ("Is a mug bigger than a pot?", "no"),
        ("Is a mug smaller than a pot?", "yes"),
        ("Is a mug heavier than a mug?", "no"),
        # cannot tell
        ("Out of these items, which one is more likely to be the heaviest one?", UNKNOWN),  # no items given
        ("Which one is the heaviest?", UNKNOWN),
        ("Out of the apple, book and kangaroo, which one is the heaviest?", UNKNOWN),  # not in the catalog
        ("Out of the pencil case and the apple, which one is the heaviest?", UNKNOWN),  # a compound it lacks
        ("Is a unicorn heavier than an egg?", UNKNOWN),
        ("What is the weight of an apple?", UNKNOWN),  # not a comparison
        ("Out of the apple and the mug, which one is closer to me?", UNKNOWN),  # distance: measure it
        ("Out of the apple and the mug, which one is warmer?", UNKNOWN),
        ("Out of the apple and the mug, which one is lighter in colour?", UNKNOWN),  # not a weight
        ("Which is taller, a pan or a mug?", UNKNOWN),  # the catalog has no heights
        ("Out of the apple and the mug, which one is heavier and bigger?", UNKNOWN),  # two properties
        ("Is this lightweight enough to pick up?", UNKNOWN),
        ("hello", UNKNOWN),
        ("?!", UNKNOWN),
        ("Write me a poem about laptops", UNKNOWN),
    ],
)
def test_question_table(question, expected):
    assert LM.complete(question) == expected


@pytest.mark.parametrize(
    ("question", "expected"),
    [
        # a closed box may be empty (0.2 kg) or full (6 kg): only what it surely beats or loses to is settled
        ("Which is heavier: the box or the feather?", "box"),
        ("Which is heavier: the box or the laptop?", UNKNOWN),
        ("Out of the box, laptop and feather, which one is the lightest?", "feather"),
        ("Out of the box, laptop and feather, which one is the heaviest?", UNKNOWN),
        ("Out of the box, laptop and suitcase, which one is the lightest?", UNKNOWN),
        ("Is the box heavier than the laptop?", UNKNOWN),
        ("Is the feather heavier than the box?", "no"),
        ("Is the box heavier than the feather?", "yes"),
        ("Is a ball heavier than a basketball?", UNKNOWN),  # hollow or solid
        ("Is a box heavier than a box?", UNKNOWN),  # two boxes: either may be the full one
        # its look settles its size
        ("Which is bigger, the box or the egg?", "box"),
        ("Is a box bigger than an egg?", "yes"),
    ],
)
def test_deceptive_objects_are_left_to_measurement(question, expected):
    assert LM.complete(question) == expected


def _paper_rows(task: str) -> list[str]:
    rows = [q.model_dump(exclude_none=True) for q in paper_queries()]
    return [r["items"] for r in rows if r["task"] == task]


# The paper's scene and triplet item lists (ai2thor_weight_scene_items, weight_triplet_items_seen_by_vqa),
# asked with the paper's template; expected answers by hand, for the lists the catalog covers.
PAPER_CASES = [
    ("a lamp, remote control, and a lamp", "remote control", "lamp"),
    ("a laptop and a cd", "cd", "laptop"),
    ("a basketball, fork, and knife", "fork", "basketball"),
    ("a banana, tennis racket, and a book", "banana", "book"),
    ("a bowl of ramen, a spoon and a pencil", "pencil", "bowl of ramen"),
    # one item the catalog lacks: it cannot tell
    ("a pot, a plant, and a cactus", UNKNOWN, UNKNOWN),
    ("a cell phone and a pen", UNKNOWN, UNKNOWN),
    ("a book and a desk", UNKNOWN, UNKNOWN),
    ("basketball, remote control, couch", UNKNOWN, UNKNOWN),
    ("a gold vase, a phone, and a coffee table", UNKNOWN, UNKNOWN),
    ("a laptop, a chair, and a credit card", UNKNOWN, UNKNOWN),
    ("a basketball, a couch, a chair, and a box", UNKNOWN, UNKNOWN),
]


@pytest.mark.parametrize(("items", "lightest", "heaviest"), PAPER_CASES)
def test_paper_item_lists(items, lightest, heaviest):
    known = _paper_rows("ai2thor_weight_scene_items") + _paper_rows("weight_triplet_items_seen_by_vqa")
    assert items in known  # the lists are the paper's own
    assert LM.complete(f"Out of the {items}, which one is the most lightweight?") == lightest
    assert LM.complete(f"Out of the {items}, which one is the heaviest?") == heaviest
    assert LM.complete(f"What are the items in this image? {items}. Which one is the lightest?") == lightest


@pytest.mark.parametrize("task", ["ai2thor_weight_scene_items", "weight_triplet_items_seen_by_vqa"])
def test_every_paper_list_answers_one_of_its_items_or_unknown(task):
    for items in _paper_rows(task):
        listed = split_items(items)
        for template in (
            "Out of the {}, which one is the most lightweight?",
            "Out of the {}, which one is the heaviest?",
        ):
            answer = LM.complete(template.format(items))
            assert answer == UNKNOWN or answer in listed, (items, answer)
            if any(resolve_item(i) is None for i in listed):
                assert answer == UNKNOWN, items


def test_pairs_over_the_whole_catalog_agree_with_typical_masses_in_every_phrasing():
    plain = [c for c in categories() if not c.deceptive]
    for a, b in itertools.permutations(plain, 2):
        ma, mb = a.typical_mass_kg, b.typical_mass_kg
        if ma == mb:
            continue
        heavier, lighter = (a, b) if ma > mb else (b, a)
        assert LM.complete(f"Is a {a.name} heavier than a {b.name}?") == ("yes" if ma > mb else "no")
        assert LM.complete(f"Which is heavier, the {a.name} or the {b.name}?") == heavier.name
        assert (
            LM.complete(f"Out of the {a.name} and the {b.name}, which one is the lightest?") == lighter.name
        )


def test_every_category_and_synonym_resolves_to_itself():
    for cat in categories():
        for word in cat.words:
            assert resolve_item(f"the {word}") is cat or resolve_item(word).name == word, word


@pytest.mark.parametrize(
    ("text", "items"),
    [
        ("apple, book, laptop", ["apple", "book", "laptop"]),
        ("an apple, a book and a laptop", ["apple", "book", "laptop"]),
        ("a basketball, a couch, a chair, and a box", ["basketball", "couch", "chair", "box"]),
        ("pillows, sheets, and a bed", ["pillows", "sheets", "bed"]),
        ("a pair of jeans & a hat", ["jeans", "hat"]),
        ("these items", []),
        ("", []),
    ],
)
def test_split_items(text, items):
    assert split_items(text) == items


def test_parse_comparison_reports_property_and_direction():
    c = parse_comparison("Which is smaller, a mug or a pot?")
    assert c is not None and (c.prop, c.direction, c.items, c.yes_no) == ("size", -1, ("mug", "pot"), False)
    c = parse_comparison("Is a mug heavier than a pot?")
    assert c is not None and (c.prop, c.direction, c.items, c.yes_no) == ("mass", 1, ("mug", "pot"), True)
    assert parse_comparison("What colour is the mug?") is None


@pytest.mark.parametrize("question", ["", "   ", None, 3])
def test_empty_or_non_text_question_is_an_error(question):
    with pytest.raises(InputError):
        LM.complete(question)


def test_registered_builder():
    lm = build_backend("language", "catalog", Settings())
    assert isinstance(lm, LanguageModel) and lm.name == "catalog"
    with pytest.raises(ConfigError, match="no argument"):
        build_backend("language", "catalog:gpt", Settings())
    assert "honest stand-in" in (CatalogLanguageModel.__doc__ or "")


def test_probe_for_the_backends_listing():
    from attribot.models.base import probe_backend

    ok = probe_backend("language", "catalog", Settings())
    assert ok.available is True and "catalog categories" in ok.detail
    assert probe_backend("language", "catalog:x", Settings()).available is False


def test_the_host_work_of_a_long_question_grows_linearly(monkeypatch):
    # issue 22 item 1: a 1,990-character question held the host for 45 s: every tail of a long item was
    # looked up, each lookup itself trying every run of words
    import attribot.models.catalog as catalog

    looked_up: list[str] = []
    real = catalog.find_category

    def counting(phrase: str):
        looked_up.append(phrase)
        return real(phrase)

    monkeypatch.setattr(catalog, "find_category", counting)
    for words in (100, 400):
        looked_up.clear()
        question = "Which is heavier: " + "red " * words + "mug or apple"
        assert len(question) <= 2000 and LM.complete(question).endswith("red mug")
        assert len(looked_up) <= 8  # a few short tails per item, whatever the item's length
        assert max(len(p.split()) for p in looked_up) <= 3
