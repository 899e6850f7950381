"""The one vocabulary: colour names, generic nouns, plurals and word tokens, read by the rules planner, the
oracle backends, the catalog language backend and the simulator's catalog alike. A word added here is known
everywhere (DESIGN.md, "One vocabulary").

It sits in the bottom layer and imports nothing of attribot: the simulator paints with names from
`COLOR_WORDS` (a test checks that every painted colour is here), and the category names and synonyms stay
with the catalog's data in `attribot.sim.catalog`, which folds plurals with `singular_forms` from here.
"""

from __future__ import annotations

import re

__all__ = [
    "COLOR_WORDS",
    "COLOR_ALIASES",
    "GENERIC_NOUNS",
    "IRREGULAR_PLURALS",
    "DEICTIC_WORDS",
    "ATTRIBUTE_PARAPHRASES",
    "ATTRIBUTE_PARAPHRASE_CUES",
    "WEIGHT_HEAVY",
    "WEIGHT_LIGHT",
    "NEAR_WORDS",
    "FAR_WORDS",
    "SIZE_ADJECTIVES",
    "SIZE_SUPERLATIVES",
    "SIZE_COMPARATIVES",
    "WEIGHT_PHRASES",
    "SURFACE_WORDS",
    "SENSE_WORDS",
    "surface_kind",
    "paraphrased",
    "words",
    "singular_forms",
]

COLOR_ALIASES: dict[str, str] = {"grey": "gray", "golden": "gold", "colour": "color"}
"""Spellings folded to one name before any matching."""

COLOR_WORDS: frozenset[str] = frozenset(
    {
        "red", "green", "blue", "yellow", "orange", "purple", "violet", "pink", "brown", "black", "white",
        "gray", "silver", "gold", "beige", "tan", "cyan", "magenta", "teal", "navy", "maroon", "cream",
        "ivory", "turquoise", "olive", "lime", "copper", "bronze",
    }
)  # fmt: skip
"""Colour names (after folding `COLOR_ALIASES`): a filter for detectors, a word the planner reads."""

GENERIC_NOUNS: frozenset[str] = frozenset(
    {
        "item", "items", "object", "objects", "thing", "things", "one", "ones", "something", "stuff",
        "anything", "everything", "whatever",
    }
)  # fmt: skip
"""Head nouns that stand for any object ("the heaviest item")."""

DEICTIC_WORDS: frozenset[str] = frozenset(
    {
        "it",
        "its",
        "this",
        "that",
        "they",
        "them",
        "their",
        "theirs",
        "these",
        "those",
        "he",
        "she",
        "him",
        "her",
        "his",
        "hers",
        "mine",
        "yours",
        "ours",
        "here",
        "there",
    }
)
"""Pronouns and place words: they point at something and never name it, so a planner never searches them."""

# ---- the attributes: the words that name a weight, a distance or a size, and their direction ----------

WEIGHT_HEAVY: frozenset[str] = frozenset(
    {"heaviest", "heavier", "heavy", "most heavy", "more heavy", "least lightweight", "less lightweight",
     "least light"}
)  # fmt: skip
"""Words (and two-word phrases) that ask for more weight."""
WEIGHT_LIGHT: frozenset[str] = frozenset(
    {"lightest", "lighter", "light", "lightweight", "most lightweight", "more lightweight", "least heavy",
     "less heavy"}
)  # fmt: skip
"""Words that ask for less weight."""
NEAR_WORDS: frozenset[str] = frozenset({"closer", "closest", "nearer", "nearest"})
FAR_WORDS: frozenset[str] = frozenset(
    {"farther", "farthest", "further", "furthest", "more distant", "most distant"}
)
WEIGHT_PHRASES = (
    r"weighs?\s+(?:the\s+)?(?:most|least|more|less)"
    r"|(?:greatest|highest|largest|biggest|most|more|lowest|smallest|least|less)\s+(?:weight|mass)"
)
"""A regex of the verb and noun phrases of weight ("weighs the most", "greatest mass") that
`ATTRIBUTE_PARAPHRASES` turns into adjectives, for parsers that must find them in place."""
SIZE_ADJECTIVES: dict[str, tuple[str, bool]] = {
    "big": ("area", True), "large": ("area", True), "huge": ("area", True),
    "small": ("area", False), "little": ("area", False), "tiny": ("area", False),
    "tall": ("height", True), "high": ("height", True),
    "long": ("length", True), "short": ("length", False),
    "wide": ("width", True), "broad": ("width", True), "narrow": ("width", False),
    "thin": ("thickness", False), "thick": ("thickness", True), "slim": ("thickness", False),
}  # fmt: skip
"""Size adjectives: the dimension each measures (area, height, length, width, thickness) and whether it asks
for more of it."""
SIZE_SUPERLATIVES: dict[str, str] = {
    "biggest": "big", "largest": "large", "hugest": "huge", "smallest": "small", "littlest": "little",
    "tiniest": "tiny", "tallest": "tall", "longest": "long", "shortest": "short", "widest": "wide",
    "broadest": "broad", "narrowest": "narrow", "thinnest": "thin", "thickest": "thick", "slimmest": "slim",
}  # fmt: skip
SIZE_COMPARATIVES: dict[str, str] = {
    "bigger": "big", "larger": "large", "smaller": "small", "taller": "tall", "longer": "long",
    "shorter": "short", "wider": "wide", "narrower": "narrow", "thinner": "thin", "thicker": "thick",
    "tinier": "tiny",
}  # fmt: skip


def _sense(
    attribute: str, more: bool, absolute: str, comparative: str, superlative: str
) -> dict[str, tuple[str, bool, str]]:
    return {
        absolute: (attribute, more, "absolute"),
        comparative: (attribute, more, "comparative"),
        superlative: (attribute, more, "superlative"),
        f"more {absolute}": (attribute, more, "comparative"),
        f"most {absolute}": (attribute, more, "superlative"),
        f"less {absolute}": (attribute, not more, "comparative"),
        f"least {absolute}": (attribute, not more, "superlative"),
    }


SENSE_WORDS: dict[str, tuple[str, bool, str]] = {
    **_sense("temperature", True, "hot", "hotter", "hottest"),
    **_sense("temperature", True, "warm", "warmer", "warmest"),
    **_sense("temperature", False, "cold", "colder", "coldest"),
    **_sense("temperature", False, "cool", "cooler", "coolest"),
    "chilled": ("temperature", False, "absolute"),
    "boiling": ("temperature", True, "absolute"),
    **_sense("stiffness", True, "hard", "harder", "hardest"),
    **_sense("stiffness", True, "firm", "firmer", "firmest"),
    **_sense("stiffness", True, "stiff", "stiffer", "stiffest"),
    "rigid": ("stiffness", True, "absolute"),
    "more rigid": ("stiffness", True, "comparative"),
    "most rigid": ("stiffness", True, "superlative"),
    **_sense("stiffness", False, "soft", "softer", "softest"),
    **_sense("stiffness", False, "squishy", "squishier", "squishiest"),
    **_sense("stiffness", False, "squashy", "squashier", "squashiest"),
    "spongy": ("stiffness", False, "absolute"),
    **_sense("fullness", True, "full", "fuller", "fullest"),
    "filled": ("fullness", True, "absolute"),
    **_sense("fullness", False, "empty", "emptier", "emptiest"),
}
"""The words of the senses beyond the paper's, each with (its attribute: temperature, stiffness or
fullness; whether it asks for more of it; its form: absolute "hot", comparative "hotter", superlative
"hottest"). "Less" and "least" turn the direction round ("the least warm" is the coldest); softness is less
stiffness."""

ATTRIBUTE_PARAPHRASES: tuple[tuple[str, str], ...] = (
    # verb phrases of weight, to the adjective they mean
    (r"\b(?:weighs?|weighing)\s+(?:the\s+)?most\b", "is the heaviest"),
    (r"\b(?:weighs?|weighing)\s+(?:the\s+)?least\b", "is the lightest"),
    (r"\b(?:weighs?|weighing)\s+more\b", "is heavier"),
    (r"\b(?:weighs?|weighing)\s+less\b", "is lighter"),
    (
        r"\b(?:has|have|with)\s+(?:the\s+)?(?:greatest|highest|largest|biggest|most)\s+(?:mass|weight)\b",
        "is the heaviest",
    ),
    (r"\b(?:has|have|with)\s+(?:the\s+)?(?:least|lowest|smallest)\s+(?:mass|weight)\b", "is the lightest"),
    (r"\b(?:lowest|least|smallest)\s+in\s+(?:weight|mass)\b", "lightest"),
    (r"\b(?:highest|greatest|largest|biggest|most)\s+in\s+(?:weight|mass)\b", "heaviest"),
    (r"\b(heaviest|lightest|heavier|lighter)\s+(?:in|by)\s+(?:weight|mass)\b", r"\1"),
    (r"\b(largest|biggest|smallest|larger|bigger|smaller)\s+(?:in|by)\s+size\b", r"\1"),
    (r"\b(?:greatest|highest|largest|biggest|most|more)\s+(?:weight|mass)\b", "heaviest"),
    (r"\b(?:lowest|smallest|least|less)\s+(?:weight|mass)\b", "lightest"),
    (r"\bmost\s+massive\b", "heaviest"),
    (r"\bleast\s+massive\b", "lightest"),
    # left and right are positions in the picture, not distances: "furthest to the left", "far right",
    # "left-most" (hyphens are spaces by now), "on the very left" are the leftmost and the rightmost
    (
        r"\b(?:on|at|to|in)\s+the\s+(?:very|far|furthest|farthest|extreme)\s+(left|right)(?:\s+(?:side|end|edge))?\b",
        r"\1most",
    ),
    (
        r"\b(?:the\s+)?(?:furthest|farthest|further|farther|most|far)\s+(?:to\s+(?:the\s+)?|on\s+the\s+)?(left|right)\b",
        r"\1most",
    ),
    (r"\b(left|right)\s+most\b", r"\1most"),
    # what weight does to a person: hard or easy to lift
    (r"\b(?:hardest|heaviest)\s+(?:one\s+)?to\s+(?:lift|carry|pick\s+up)\b", "heaviest"),
    (r"\beasiest\s+(?:one\s+)?to\s+(?:lift|carry|pick\s+up)\b", "lightest"),
    (r"\bhow\s+many\s+(?:metres|meters|feet|inches|centimetres|centimeters)\s+away\b", "how far away"),
    # distance: "farthest away", "closest by" mean the adjective alone
    (r"\b(farthest|furthest|farther|further|closest|nearest|closer|nearer)\s+(?:away|by)\b", r"\1"),
    # what the senses' states are said with: a drink from the fridge is cold, a jar with nothing in it empty
    (r"\b(?:has|have)\s+(?:just\s+)?(?:been\s+)?boiled\b", "is hot"),
    (r"\b(?:came|come|comes|is|are|was|were|just)\s+(?:out\s+of|from)\s+the\s+fridge\b", "is cold"),
    (r"\b(?:from|out\s+of)\s+the\s+fridge\b", "cold"),
    (r"\b(?:has|have)\s+nothing\s+(?:left\s+)?in\s+(?:it|them)\b", "is empty"),
    (r"\b(?:needs?|needing)\s+(?:a\s+)?(?:refilling|refill|filling\s+up)\b", "is empty"),
    (r"\bgives?\s+the\s+most\s+when\s+(?:you\s+|i\s+)?squeezed?(?:\s+it)?\b", "is the softest"),
    (r"\bgives?\s+the\s+least\s+when\s+(?:you\s+|i\s+)?squeezed?(?:\s+it)?\b", "is the hardest"),
    (r"\bhow\s+much\s+is\s+(?:left|still)\s+in\b", "how full is"),
    # contractions
    (r"\bwhat's\b", "what is"),
    (r"\bwhich's\b", "which is"),
)
"""(pattern, replacement) pairs that turn paraphrases of an attribute into the words the planner reads
("Which object weighs the most?" is "Which object is the heaviest?"), applied in order to lower-case text."""


def paraphrased(text: str) -> str:
    """Lower-case `text` with every paraphrase of `ATTRIBUTE_PARAPHRASES` turned into the words it means
    ("Which one weighs the most?" -> "which one is the heaviest?").

    >>> paraphrased("Which item has the greatest mass?")
    'which item is the heaviest?'
    """
    text = text.lower()
    if any(cue in text for cue in ATTRIBUTE_PARAPHRASE_CUES):  # most texts have none: skip the patterns
        for pattern, meaning in _COMPILED_PARAPHRASES:
            text = pattern.sub(meaning, text)
    return text


ATTRIBUTE_PARAPHRASE_CUES: tuple[str, ...] = (
    "weigh", "mass", "weight", "away", " by", "'s", " size", "left", "right", "lift", "carry", "boiled",
    "fridge", "nothing", "refill", "filling", "squeeze",
)  # fmt: skip
"""Every text one of `ATTRIBUTE_PARAPHRASES` matches holds one of these (a test checks it), so that a query
without any can skip the patterns."""

SURFACE_WORDS: dict[str, str] = {
    "table": "table", "tables": "table", "desk": "table", "dining table": "table",
    "kitchen table": "table", "coffee table": "coffee table", "counter": "counter", "countertop": "counter",
    "kitchen counter": "counter", "worktop": "counter", "shelf": "shelf", "shelves": "shelf",
    "bookshelf": "shelf", "shelving": "shelf", "floor": "floor", "ground": "floor",
}  # fmt: skip
"""Words for the surfaces objects stand on (furniture and the floor), to the kind of surface they name: what
the oracle detector finds as furniture and what the planner reads as a scope ("on the table")."""


def surface_kind(name: str) -> str:
    """The kind of a simulator surface from its name: "coffee_table_0" -> "coffee table", "shelf_2_low" ->
    "shelf", "floor" -> "floor".

    >>> surface_kind("counter_2")
    'counter'
    """
    return re.sub(r"_\d+(?:_low)?$", "", name).replace("_", " ")


IRREGULAR_PLURALS: dict[str, str] = {
    "knives": "knife", "mice": "mouse", "geese": "goose", "teeth": "tooth", "feet": "foot",
    "people": "person", "men": "man", "women": "woman", "children": "child", "leaves": "leaf",
    "shelves": "shelf", "loaves": "loaf", "dice": "die", "cacti": "cactus",
}  # fmt: skip


def words(text: str) -> list[str]:
    """Lower-case word tokens of `text`: punctuation and hyphens become spaces, colour spellings folded.

    >>> words("A Photo of two T-shirts!")
    ['a', 'photo', 'of', 'two', 't', 'shirts']
    """
    tokens = re.sub(r"[^a-z0-9]+", " ", text.lower()).split()
    return [COLOR_ALIASES.get(t, t) for t in tokens]


def singular_forms(word: str) -> list[str]:
    """The word itself and the singulars it may be the plural of, most likely first.

    >>> singular_forms("boxes")
    ['boxes', 'boxe', 'box']
    """
    forms = [word]
    if word in IRREGULAR_PLURALS:
        forms.append(IRREGULAR_PLURALS[word])
    if len(word) > 2 and word.endswith("s") and not word.endswith("ss"):  # "cds" -> "cd"
        forms.append(word[:-1])
        if word.endswith("es"):
            forms.append(word[:-2])
        if word.endswith("ies"):
            forms.append(word[:-3] + "y")
        if word.endswith("ves"):
            forms.extend([word[:-3] + "f", word[:-3] + "fe"])
    return list(dict.fromkeys(forms))


_COMPILED_PARAPHRASES = [(re.compile(p), meaning) for p, meaning in ATTRIBUTE_PARAPHRASES]
