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
        "anything", "everything",
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
    (r"\bmost\s+massive\b", "heaviest"),
    (r"\bleast\s+massive\b", "lightest"),
    # distance: "farthest away", "closest by" mean the adjective alone
    (r"\b(farthest|furthest|farther|further|closest|nearest|closer|nearer)\s+(?:away|by)\b", r"\1"),
    # contractions
    (r"\bwhat's\b", "what is"),
    (r"\bwhich's\b", "which is"),
)
"""(pattern, replacement) pairs that turn paraphrases of an attribute into the words the planner reads
("Which object weighs the most?" is "Which object is the heaviest?"), applied in order to lower-case text."""

ATTRIBUTE_PARAPHRASE_CUES: tuple[str, ...] = ("weigh", "mass", "weight", "away", " by", "'s", " size")
"""Every text one of `ATTRIBUTE_PARAPHRASES` matches holds one of these (a test checks it), so that a query
without any can skip the patterns."""

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
