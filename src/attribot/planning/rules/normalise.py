"""Normalisation shared by every family: lower case, accents and contractions folded, courtesy and
openings dropped, ordinals, and the reading of an object's name from what a family leaves over.

It imports the vocabulary (`attribot.lexicon`) and nothing that runs programs.
"""

from __future__ import annotations

import re
import unicodedata

from attribot.lexicon import (
    COLOR_ALIASES,
    COLOR_WORDS,
    DEICTIC_WORDS,
    FAR_WORDS,
    NEAR_WORDS,
    SIZE_ADJECTIVES,
    SIZE_COMPARATIVES,
    SIZE_SUPERLATIVES,
    WEIGHT_HEAVY,
    WEIGHT_LIGHT,
    paraphrased,
)
from attribot.planning.rules.forms import (
    ObjectSpec,
    Side,
)

# ---- the parser ----------------------------------------------------------------------------------------

_ORDINAL_WORDS = {
    w: i + 1
    for i, w in enumerate(
        "first second third fourth fifth sixth seventh eighth ninth tenth eleventh twelfth thirteenth "
        "fourteenth fifteenth sixteenth seventeenth eighteenth nineteenth twentieth".split()
    )
}
_PATTERNS: dict[str, re.Pattern[str]] = {}


def rx(pattern: str) -> re.Pattern[str]:
    """`pattern` compiled, once: the readers build their patterns from the vocabulary as strings."""
    compiled = _PATTERNS.get(pattern)
    if compiled is None:
        compiled = _PATTERNS[pattern] = re.compile(pattern)
    return compiled


_ORD = (
    r"(?:(?:second|third|fourth|fifth|\d+(?:st|nd|rd|th))\s+(?:to|from)\s+(?:the\s+)?last|penultimate|last|"
    + "|".join(_ORDINAL_WORDS)
    + r"|\d+(?:st|nd|rd|th))"
)
_SIDES: dict[str, Side] = {
    "left": "left",
    "right": "right",
    "top": "top",
    "upper": "top",
    "bottom": "bottom",
    "lower": "bottom",
}
_OPPOSITE: dict[str, Side] = {"left": "right", "right": "left", "top": "bottom", "bottom": "top"}

# size adjectives: word -> (measure, largest)
_SIZE = SIZE_ADJECTIVES
_SUPERLATIVE = SIZE_SUPERLATIVES
_COMPARATIVE = SIZE_COMPARATIVES
_SIZE_WORDS = "|".join(sorted([*_SIZE, *_SUPERLATIVE, *_COMPARATIVE], key=len, reverse=True))
_WEIGHT_HEAVY = WEIGHT_HEAVY
_WEIGHT_LIGHT = WEIGHT_LIGHT
_WEIGHT_WORDS = "|".join(sorted(_WEIGHT_HEAVY | _WEIGHT_LIGHT, key=len, reverse=True))
_NEAR = NEAR_WORDS
_FAR = FAR_WORDS
_DIST_WORDS = "|".join(sorted(_NEAR | _FAR, key=len, reverse=True))
_ME = r"(?:\s+(?:to|from)\s+(?:me|you|us|the\s+robot|the\s+camera))?"

# words that cannot be part of an object's name here: left over from a phrase the parser did not read
_STOP = {
    "from",
    "row",
    "rows",
    "column",
    "columns",
    "left",
    "right",
    "top",
    "bottom",
    "middle",
    "center",
    "centre",
    "is",
    "are",
    "which",
    "what",
    "where",
    "who",
    "how",
    "why",
    "or",
    "than",
    "and",
    "me",
    "you",
    "in",
    "on",
    "at",
    "to",
    "the",
    "a",
    "an",
    "not",
    "no",
    "leftmost",
    "rightmost",
    "topmost",
    "bottommost",
    "most",
    "least",
    "very",
    "side",
    "corner",
    "between",
    "next",
    "near",
    "behind",
    "under",
    "above",
    "below",
    "beside",
    "inside",
    "if",
    "does",
    "do",
    "there",
    "any",
    "all",
    "every",
    # verbs and persons of a sentence around a name, never part of it
    "would",
    "be",
    "will",
    "should",
    "might",
    "need",
    "want",
    "see",
    "think",
    "i",
    "we",
    "by",
    "has",
    "have",
    "seems",
    # verbs of a request and joining words, never part of a name
    "put",
    "onto",
    "into",
    "bring",
    "give",
    "tell",
    "weigh",
    "weighs",
    *_ORDINAL_WORDS,
    "last",
    "penultimate",
    *_SIZE,
    *_SUPERLATIVE,
    *_COMPARATIVE,
    "heaviest",
    "heavier",
    "heavy",
    "lightest",
    "lighter",
    "lightweight",
    *_NEAR,
    *_FAR,
    "distant",
}


_LEAD = (
    r"^(?:please\s+)?(?:(?:can|could)\s+you\s+)?(?:find|show(?:\s+me)?|point\s+(?:to|at)|select|pick\s+up|pick|get|"
    r"give\s+me|locate|detect|identify|where\s+(?:is|are)|grab|look\s+(?:at|for)|i\s+am\s+looking\s+for|"
    r"show\s+me\s+where|where\s+can\s+i\s+find|help\s+me\s+find)\s+"
)


def _normalize(query: str) -> tuple[str, bool, str] | None:
    """Lower case, accents folded, punctuation to spaces, polite or imperative openings ("find", "where
    is") and articles dropped, and whether there was such an opening; None when the text holds letters
    outside a-z (another script), which the planner cannot read. The third item is the text before the
    opening was dropped, which the frames (actions) read."""
    text = query.lower().replace("\u2019", "'").replace("-", " ")
    if not text.isascii():  # lower-case ASCII letters are a-z already: only other text needs folding
        text = unicodedata.normalize("NFKD", text)
        text = "".join(ch for ch in text if not unicodedata.combining(ch))
        if any(ch.isalpha() and not ("a" <= ch <= "z") for ch in text):
            return None
    text = re.sub(r"[^a-z0-9',\s]", " ", text)
    text = " ".join(text.split()).strip(" ,")
    for short, full in _CONTRACTIONS:
        if short in text:
            text = text.replace(short, full)
    text = _COURTESY.sub(" ", text)
    if " where " in text:
        text = _FROM_WHERE.sub("from you", text)
    text = " ".join(text.split()).strip(" ,")
    text = paraphrased(text)
    if "next to" in text:  # "the next to lightest" is the second lightest; "next to the lamp" stays
        text = _NEXT_TO_SUPERLATIVE.sub("second ", text)
    if " is" in text:  # "which would weigh the most" reads "which would is the heaviest": "which is"
        text = _AUXILIARY_IS.sub("is", text)
    # the opening carries no meaning for the attribute families; alone with a name, it asks where it is
    stripped = rx(_LEAD).sub("", text)
    return _strip_article(stripped), stripped != text, text


_CONTRACTIONS = (
    ("doesn't", "does not"),
    ("don't", "do not"),
    ("isn't", "is not"),
    ("aren't", "are not"),
    ("where's", "where is"),
    ("what's", "what is"),
    ("which's", "which is"),
    ("i'm", "i am"),
    ("that's", "that is"),
    ("it's", "it is"),
    ("there's", "there is"),
    ("who's", "who is"),
    ("how's", "how is"),
    ("you're", "you are"),
)
# courtesy carries no meaning: "please", "for me", "thanks", and "I'm looking for" is "find"
_COURTESY = re.compile(
    r"\bplease\b|\b(?:thanks|thank\s+you)\b|\bfor\s+me\b(?!\s+to)|\bkindly\b"
    r"|^(?:hey|hi|hello|ok|okay)(?:\s+(?:robot|there|attribot))?\s*,?"
    r"|\b(?:right\s+now|at\s+the\s+moment|currently)\b|,?\s+or\s+not$"
    r"|^(?:(?:can|could|would)\s+you\s+)?(?:tell\s+me|let\s+me\s+know|say)\s+(?=how\b|what\b|which\b|where\b)"
)


_NEXT_TO_SUPERLATIVE = re.compile(r"\bnext\s+to\s+(?:the\s+)?(?=[a-z]+est\b)")
_FROM_WHERE = re.compile(r"\bfrom\s+where\s+(?:you|i|we)\s+(?:are|am|is|stand|stands)\b")
_AUXILIARY_IS = re.compile(r"\b(?:would|will|might|could|does|do|did)\s+is\b")


def _strip_article(text: str) -> str:
    return rx(r"^(?:the|a|an|some)\s+").sub("", text.strip(" ,")).strip(" ,")


def _ordinal(text: str) -> tuple[int, bool]:
    """(k, counted from the far end) of an ordinal: "second" (2, False), "second to last" (2, True)."""
    text = " ".join(text.split())
    if text == "last":
        return 1, True
    if text == "penultimate":
        return 2, True
    match = re.fullmatch(r"(\w+)\s+(?:to|from)\s+(?:the\s+)?last", text)
    if match:
        return _ordinal(match.group(1))[0], True
    if text in _ORDINAL_WORDS:
        return _ORDINAL_WORDS[text], False
    match = re.fullmatch(r"(\d+)(?:st|nd|rd|th)", text)
    if match:
        return int(match.group(1)), False
    raise ValueError(text)


# "of these", "among the three", "out of them": the candidate set is what is in view, any object
_COUNT_WORDS = r"(?:two|three|four|five|six)"
_CANDIDATE_SET = re.compile(
    r"^(?:of|among|out\s+of|from)\s+(?:them|all"
    r"|(?:these|those|(?:all\s+)?the)(?:\s+" + _COUNT_WORDS + r")?(?:\s+(?:ones|items|objects|things))?)$"
)
_HERE = re.compile(r"\s+(?:here|there|around|in\s+view|in\s+front\s+of\s+(?:me|you|us|the\s+robot))$")
_HERE_ENDINGS = ("here", "there", "around", "view", "me", "you", "us", "robot")
_SET_OPENINGS = ("of ", "among ", "out of ", "from ")
# words that never name an object: left over from a phrase the parser did not place ("of these")
_NOT_A_NAME = DEICTIC_WORDS | {"of"}


_RELATIVE_REST = re.compile(r"\s+(?:that|which|who)\s+(?:is|are|sits|stands)$")


def _object(phrase: str) -> ObjectSpec | None:
    """The object named by what is left of a phrase, or None when the rest is not a plain name."""
    phrase = _strip_article(phrase)
    if phrase.startswith(("that ", "this ")) and not phrase.startswith(("that is", "this is", "that one")):
        phrase = phrase[5:]  # "that kettle" names the kettle; "that" alone names nothing
    if phrase.endswith((" is", " are", " sits", " stands")):
        phrase = _RELATIVE_REST.sub("", phrase)  # "the thing that is" (leftmost): the thing
    phrase = re.sub(r"\s+(?:in|of|from)\s+(?:the\s+)?(?:image|picture|photo|frame|scene|view)$", "", phrase)
    if phrase.endswith(_HERE_ENDINGS):  # the cheap test first: _object runs for every family tried
        phrase = _HERE.sub("", phrase)
    if phrase.startswith(_SET_OPENINGS) and _CANDIDATE_SET.match(phrase):
        return ObjectSpec("object")
    words = phrase.split()
    if any(w in _NOT_A_NAME for w in words):
        return None
    if not words:
        return ObjectSpec("object")
    if len(words) > 6 or any(not rx(r"[a-z0-9']+").fullmatch(w) or w in _STOP for w in words):
        return None
    if all(w.isdigit() for w in words):
        return None
    colors = tuple(w for w in words[:-1] if COLOR_ALIASES.get(w, w) in COLOR_WORDS)
    noun_words = [w for w in words if w not in colors] if colors else words
    if not noun_words:
        return None
    noun = " ".join(noun_words)
    if noun in ("items", "objects", "things", "ones"):
        noun = noun[:-1]
    elif noun in ("whatever", "anything", "everything", "something", "stuff"):
        noun = "object"  # what a detector is asked for: any object
    return ObjectSpec(noun=noun, colors=colors)


def _take(pattern: str, text: str) -> tuple[re.Match[str] | None, str]:
    """The first match of `pattern` and the text with it cut out."""
    match = rx(pattern).search(text)
    if match is None:
        return None, text
    return match, " ".join((text[: match.start()] + " " + text[match.end() :]).split())


def _split_names(text: str) -> tuple[ObjectSpec, ...] | None:
    parts = [p for p in re.split(r"\s*,\s*(?:and\s+|or\s+)?|\s+(?:and|or)\s+", text) if p.strip()]
    specs: list[ObjectSpec] = []
    for part in parts:
        spec = _object(part)
        if spec is None or spec.generic:  # a list names objects: "one" or "item" is no name
            return None
        if spec not in specs:
            specs.append(spec)
    return tuple(specs) or None


_PRONOUNS = DEICTIC_WORDS


def _named(text: str) -> ObjectSpec | None:
    """A specific object's name: not generic ("the item"), not a pronoun ("it": nothing to refer to)."""
    obj = _object(text)
    if obj is None or obj.generic or obj.noun in _PRONOUNS:
        return None
    return obj
