"""Offline language answers about typical object properties, read from the object catalog.

`CatalogLanguageModel` is an honest stand-in for the LLM behind `language_query`, the offline default of
the `language` role. It answers comparative questions about weight and size over objects the catalog
(`attribot.sim.catalog`) knows, from typical values: the catalog's `typical_mass_kg` and the middle of
`size_range_m`. It says "unknown" whenever it cannot tell: a word the catalog does not know, a question
that is not a comparison of weight or size, or a weight question that hinges on an object whose look
does not tell its weight (a closed box may be empty or full: only measuring settles it).

Phrasings it reads (case and punctuation free):
- "Out of the apple, book and laptop, which one is the heaviest?", "... which one is more likely to be the
  lightest one?", "Out of these items: apple, book, laptop, which ...", "Which of X, Y and Z is the
  biggest?", "What is the heaviest item among X, Y, Z?", "Which is bigger, a mug or a pot?",
  "Which is heavier: X or Y?" -> the item, as the question names it (articles dropped);
- "Is a basketball heavier than an egg?", "Is X smaller than Y?", "Does X weigh more than Y?" -> "yes" / "no".
Lists may be "apple, book, laptop" or "an apple, a book and a laptop" (what a VQA model lists).

The senses beyond the paper's are guessed the same way, from priors: which is hotter or colder from the
temperatures a category can be at (a kettle may be boiling or cold, a can from the fridge or at room
temperature, the rest at room temperature), softer or harder from its stiffness states, fuller or emptier
only for containers (any of them may be either). A prior that the hidden states could swing is "unknown";
objects of one kind cannot be told apart by any prior, and the first is named.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from attribot.errors import ConfigError, InputError
from attribot.lexicon import (
    SIZE_ADJECTIVES,
    SIZE_COMPARATIVES,
    SIZE_SUPERLATIVES,
    WEIGHT_HEAVY,
    WEIGHT_LIGHT,
    WEIGHT_PHRASES,
    paraphrased,
    sense_words,
    singular_forms,
    words,
)
from attribot.models.base import LANGUAGE_MODELS, UNKNOWN
from attribot.sim.catalog import RIGID_N_PER_MM, ROOM_TEMPERATURE_C, Category, categories, find_category

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = ["CatalogLanguageModel", "Comparison", "parse_comparison", "split_items", "resolve_item"]


def _alternatives(words: Iterable[str]) -> str:
    return "|".join(sorted((re.escape(w).replace(r"\ ", r"\s+") for w in words), key=len, reverse=True))


# (pattern, +1 for "most", -1 for "least"), from the one vocabulary; questions are paraphrased first
# ("weighs the most" is "is the heaviest", "greatest weight" is "heaviest"), so weight comes before size
_WEIGHT_WORDS = [(_alternatives(WEIGHT_HEAVY - {"heavy"}), +1), (_alternatives(WEIGHT_LIGHT - {"light"}), -1)]
# the catalog knows each object's longest dimension, not its height: "taller" is left unknown
_SIZE_WORDS = [
    (
        _alternatives(
            w
            for table in (SIZE_SUPERLATIVES, SIZE_COMPARATIVES)
            for w, base in table.items()
            if SIZE_ADJECTIVES[base] in (("area", direction), ("length", direction))
        ),
        +1 if direction else -1,
    )
    for direction in (True, False)
]
_SENSES = {  # the senses the catalog's data spans (`_interval`), in their records' words
    attribute: [
        (_alternatives(w for w, (_, more, _) in sense_words((attribute,)).items() if more == up), sign)
        for up, sign in ((True, +1), (False, -1))
    ]
    for attribute in ("temperature", "stiffness", "fullness")
}
_ANY_KEYWORD = "|".join(
    [WEIGHT_PHRASES] + [p for p, _ in _WEIGHT_WORDS + _SIZE_WORDS + [x for t in _SENSES.values() for x in t]]
)

_LEADING = re.compile(
    r"^(?:(?:a|an|the|some|these|those|this|that|my|two|three|four|a pair of|pair of|a couple of|one|both"
    r"|\d+)\s+)+"
)
_LIST_NOUNS = re.compile(
    r"^(?:(?:the following|following|these|those|the|all the|all)\s+)?(?:items|objects|things|options|ones)"
    r"(?:\s+in (?:the|this) (?:image|picture|photo|scene))?\s*:?\s*"
)
_NOT_ITEMS = frozenset({"items", "objects", "things", "options", "ones", "these", "those", "them", "it"})
_VERB_TAIL = re.compile(r"\s+(?:is|are|would|will|could|might|seems?|weighs?)\b.*$")

_YES_NO = re.compile(
    r"^(?:is|are|would|will|does|do)\s+(?P<a>.+?)\s+(?:be\s+)?(?P<cmp>"
    + _ANY_KEYWORD
    + r")\s+than\s+(?P<b>.+)$"
)
_LIST_PATTERNS = [
    # "out of these items: apple, book, laptop, which one ...", "which is heaviest: x, y or z"
    re.compile(
        r"(?:items|objects|things|options|following)"
        r"(?:\s+(?:are|were|in (?:the|this) (?:image|picture|scene)))?"
        r"\s*:\s*(?P<list>.+?)(?:\s*[,.;]\s*(?:which|what)\b.*)?$"
    ),
    re.compile(r"^(?:which|what)\b[^:]*:\s*(?P<list>.+)$"),
    # "out of the apple, book and laptop, which one is the heaviest"; "apple or book, which is heavier"
    re.compile(
        r"^(?:(?:out of|among|amongst|between|from|of|given|considering|here are|with)\s+)?"
        r"(?P<list>.+?)\s*[,;:]\s*(?:which|what)\b"
    ),
    # "which is bigger, a mug or a pot"
    re.compile(
        r"^(?:which|what)\b[^,]*?\b(?:"
        + _ANY_KEYWORD
        + r")\b(?:\s+(?:one|item|object|thing))?\s*,\s*(?P<list>.+)$"
    ),
    # "which one of x, y and z is the heaviest", "what is the heaviest item among x, y, z"
    re.compile(r"^(?:which|what)\b.*?\b(?:of|among|amongst|out of|between|from)\s+(?P<list>.+)$"),
]


@dataclass(frozen=True)
class Comparison:
    """A parsed question: the property ("mass" or "size"), +1 for most / -1 for least, the items named,
    and for yes/no questions ("Is A heavier than B?") `yes_no` True with items `[A, B]`."""

    prop: str
    direction: int
    items: tuple[str, ...]
    yes_no: bool = False


def _normalise(question: str) -> str:
    text = question.lower().replace("’", "'")
    text = re.sub(r"[\"“”]+", " ", text)
    text = re.sub(r"(?:[?!]+|\.)(\s|$)", r",\1", text)  # sentence ends (not decimal points) join like commas
    # "out of these items", "what are the items in this image?" refer to a list given elsewhere in the
    # text: drop them, keep the list
    text = re.sub(
        r"\b(?:(?:out of|among|amongst|from|of)\s+(?:these|those|the|all the|all)\s+(?:items|objects|things)"
        r"|what are the (?:items|objects|things)(?:\s+in (?:the|this) (?:image|picture|photo|scene))?)\b",
        " ",
        text,
    )
    text = re.sub(r"\s*([,;:])(?:\s*[,;:])*\s*", r"\1 ", text)
    return " ".join(text.split()).strip(" ,;:")


def _property(text: str) -> tuple[str, int] | None:
    """The one (property, direction) the question asks about, or None when none or several."""
    if re.search(r"\b(?:colou?rs?|shades?|tones?|brightness|darker|darkest|brighter|brightest)\b", text):
        return None  # "lighter in colour" is not a weight
    found: set[tuple[str, int]] = set()
    rest = paraphrased(text)
    for prop, table in (("mass", _WEIGHT_WORDS), ("size", _SIZE_WORDS), *_SENSES.items()):
        for pattern, direction in table:
            if re.search(rf"\b(?:{pattern})\b", rest):
                found.add((prop, direction))
                rest = re.sub(rf"\b(?:{pattern})\b", " ", rest)
    return found.pop() if len(found) == 1 else None


def split_items(text: str) -> list[str]:
    """The items of a list as the question names them, articles dropped.

    >>> split_items("an apple, a book, and the laptop")
    ['apple', 'book', 'laptop']
    """
    text = _LIST_NOUNS.sub("", text.strip())
    parts = re.split(r"\s*(?:,|;|&|/|\band\b|\bor\b)\s*", text)
    items = []
    for part in parts:
        item = _LEADING.sub("", part.strip(" .:-'\"")).strip()
        if item and item not in _NOT_ITEMS:
            items.append(item)
    return items


def parse_comparison(question: str) -> Comparison | None:
    """The comparison a question asks for, or None when it is not a weight or size comparison."""
    text = _normalise(question)
    yn = _YES_NO.match(text)
    if yn:
        prop = _property(yn.group("cmp"))
        a, b = split_items(yn.group("a")), split_items(yn.group("b"))
        if prop is None or len(a) != 1 or len(b) != 1:
            return None
        return Comparison(prop[0], prop[1], (a[0], b[0]), yes_no=True)
    for pattern in _LIST_PATTERNS:
        m = pattern.search(text)
        if not m:
            continue
        listed = _VERB_TAIL.sub("", m.group("list"))
        items = split_items(listed)
        question_part = text.replace(listed, " ", 1)  # the property is asked outside the list
        prop = _property(question_part)
        if items and prop is not None:
            return Comparison(prop[0], prop[1], tuple(items))
    return None


@functools.cache
def _longest_phrase() -> int:
    """The most words of any catalog name or synonym."""
    return max(len(w.split()) for cat in categories() for w in cat.words)


def resolve_item(item: str) -> Category | None:
    """The catalog category an item names by its head noun, or None.

    The name or synonym must end the phrase (before any "of ..."), so modifiers are allowed and compounds
    are not mistaken for their first word: "gold vase" and "bowl of ramen" resolve, "pencil case" does not.

    >>> resolve_item("a red coffee mug").name, resolve_item("pencil case")
    ('mug', None)
    """
    tokens = words(item)
    for cut in ("of", "with", "in", "on", "for", "from", "full"):
        if cut in tokens[1:]:
            tokens = tokens[: tokens.index(cut, 1)]
    # only tails as long as the longest catalog phrase can match: the work stays linear in the item's
    # length (trying every tail of a 300-word item held the host for seconds)
    for k in range(min(len(tokens), _longest_phrase()), 0, -1):
        tail = tokens[-k:]
        for last in singular_forms(tail[-1]):
            phrase = " ".join([*tail[:-1], last])
            cat = find_category(phrase)
            if cat is not None and phrase in (w.lower() for w in cat.words):
                return cat
    return None


def _interval(cat: Category, prop: str) -> tuple[float, float] | None:
    """What is known of one object: a point (its typical value) or, when its look hides its weight (or its
    temperature, stiffness, contents), the whole range its hidden states span; None when the property does
    not apply (how full a thing that holds nothing is)."""
    if prop in ("temperature", "stiffness"):
        states = cat.temperatures if prop == "temperature" else cat.stiffness
        default = ROOM_TEMPERATURE_C if prop == "temperature" else (RIGID_N_PER_MM, RIGID_N_PER_MM)
        spans = [span or ROOM_TEMPERATURE_C for _, span in states] or [default]
        return min(lo for lo, _ in spans), max(hi for _, hi in spans)
    if prop == "fullness":
        return (0.0, 1.0) if cat.container else None
    if prop == "size":
        mid = (cat.size_range_m[0] + cat.size_range_m[1]) / 2.0
        return mid, mid
    if cat.deceptive:
        return float(cat.mass_range_kg[0]), float(cat.mass_range_kg[1])
    t = cat.typical_mass_kg
    return t, t


class CatalogLanguageModel:
    """Catalog language model: an honest stand-in for an LLM, answering weight and size comparisons.

    It compares typical values from `attribot.sim.catalog` (never a measurement). It answers "unknown"
    when a word is not in the catalog, when the question is not a weight or size comparison, and when
    the answer hinges on an object whose look does not tell its weight (a closed box, a ball that may be
    hollow or solid): such objects count with their whole mass range, and a comparison they could swing
    is left to the sensors.
    """

    name = "catalog"

    def complete(self, question: str) -> str:
        if not isinstance(question, str):
            raise InputError(f"a question must be text; got {type(question).__name__}", "ask a question")
        if not question.strip():
            raise InputError(
                "the question is empty", "ask e.g. 'Out of the apple and the book, which is heavier?'"
            )
        parsed = parse_comparison(question)
        if parsed is None:
            return UNKNOWN
        cats = [resolve_item(item) for item in parsed.items]
        if any(c is None for c in cats):
            return UNKNOWN
        known = [c for c in cats if c is not None]
        found = [_interval(c, parsed.prop) for c in known]
        spans = [s for s in found if s is not None]
        if len(spans) < len(found):
            return UNKNOWN
        if parsed.yes_no:
            (alo, ahi), (blo, bhi) = spans
            if parsed.direction < 0:  # "is A lighter than B" is "is B heavier than A"
                (alo, ahi), (blo, bhi) = (blo, bhi), (alo, ahi)
            if alo > bhi:
                return "yes"
            if ahi <= blo:
                return "no"
            return UNKNOWN
        return self._extreme(parsed, known, spans)

    @staticmethod
    def _extreme(parsed: Comparison, cats: list[Category], spans: list[tuple[float, float]]) -> str:
        for i, (lo, hi) in enumerate(spans):
            others = [s for j, s in enumerate(spans) if cats[j].name != cats[i].name]
            if parsed.direction > 0 and all(lo > o_hi for _, o_hi in others):
                return parsed.items[i]
            if parsed.direction < 0 and all(hi < o_lo for o_lo, _ in others):
                return parsed.items[i]
        return UNKNOWN  # a tie, or an object whose hidden weight could change the answer


@LANGUAGE_MODELS.register("catalog")
def _build(arg: str | None, settings: Settings) -> CatalogLanguageModel:
    """`catalog`: offline weight and size comparisons from the object catalog (takes no argument)."""
    if arg is not None:
        raise ConfigError(
            f"the catalog language backend takes no argument; got {arg!r}", "write just `catalog`"
        )
    return CatalogLanguageModel()


_build.reaches_out = lambda arg: False  # type: ignore[attr-defined]  # the catalog is package data


def _probe(arg: str | None, settings: Settings) -> tuple[bool | None, str]:
    """What `attribot backends` prints for the catalog: always usable, offline."""
    if arg is not None:
        return False, f"the catalog language backend takes no argument; got {arg!r}"
    return True, f"offline weight/size comparisons over {len(categories())} catalog categories, no model"


_build.probe = _probe  # type: ignore[attr-defined]
