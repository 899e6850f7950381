"""Normalisation shared by every family: lower case, accents and contractions folded, courtesy and
openings dropped, ordinals, and the reading of an object's name from what a family leaves over.

It imports the vocabulary (`attribot.lexicon`) and nothing that runs programs.
"""

from __future__ import annotations

import re
import unicodedata
from typing import NamedTuple

from attribot.lexicon import (
    COLOR_ALIASES,
    COLOR_WORDS,
    DEICTIC_WORDS,
    FAR_WORDS,
    FUNCTION_WORDS,
    GENERIC_NOUNS,
    NEAR_WORDS,
    SIZE_ADJECTIVES,
    SIZE_COMPARATIVES,
    SIZE_SUPERLATIVES,
    WEIGHT_HEAVY,
    WEIGHT_LIGHT,
    expand_contractions,
    paraphrased,
    sense_words,
)
from attribot.planning.rules.forms import (
    MEASURED,
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
_STOP = FUNCTION_WORDS | {
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
    # the measured senses' words, each word of them ("distant" of "more distant"), but "light", which a
    # name may hold as a shade ("the light blue mug")
    *({token for word in sense_words(MEASURED) for token in word.split()} - {"light"}),
    *_NEAR,
    *_FAR,
}


_LEAD = (
    r"^(?:please\s+)?(?:(?:can|could)\s+you\s+)?(?:find\s+me|find|show(?:\s+me)?|point\s+(?:to|at|out)|select|check|"
    r"pick\s+up|pick\s+out|pick|get|give\s+me|locate|detect|identify|where\s+(?:is|are)|grab|look\s+(?:at|for)|"
    r"(?:i|we)\s+(?:am\s+|are\s+)?(?:looking\s+for|after)|(?:i|we)\s+(?:would\s+like|want|need)|"
    r"show\s+me\s+where|where\s+can\s+i\s+find|help\s+me\s+find)\s+"
)


class Normalised(NamedTuple):
    """A query as the readers start from it (see `_normalize`)."""

    text: str  # the opening ("find", "where is") and the article dropped
    opened: bool  # there was such an opening
    full: str  # the text before the opening was dropped, which the frames (actions) read
    question: bool  # asked as a question: a question mark, or a tag ("yes or no", "isn't it")


def _normalize(query: str) -> Normalised | None:
    """Lower case, accents folded, contractions written out (`attribot.lexicon.expand_contractions`),
    sentence ends joined like commas, other punctuation to spaces, fillers, courtesy and tags dropped
    (`_drop_fillers`: the one place they are), polite or imperative openings ("find", "where is") and
    articles dropped; None when the text holds letters outside a-z (another script), which the planner
    cannot read."""
    text = _DASH.sub(", ", query.lower()).replace("-", " ")
    if not text.isascii():  # lower-case ASCII letters are a-z already: only other text needs folding
        text = text.replace("\u2019", "'").replace("\u2018", "'")
        text = unicodedata.normalize("NFKD", text)
        text = "".join(ch for ch in text if not unicodedata.combining(ch))
        if any(ch.isalpha() and not ("a" <= ch <= "z") for ch in text):
            return None
    question = text.rstrip().endswith("?")
    text = expand_contractions(text)
    text = _SENTENCE_END.sub(",", text)
    text = re.sub(r"[^a-z0-9,\s]", " ", text)
    text = " ".join(text.split()).strip(" ,")
    text, tagged = _drop_fillers(text)
    if " where " in text:
        text = _FROM_WHERE.sub("from you", text)
    text = paraphrased(text)
    if "next to" in text:  # "the next to lightest" is the second lightest; "next to the lamp" stays
        text = _NEXT_TO_SUPERLATIVE.sub("second ", text)
    if " is" in text:  # "which would weigh the most" reads "which would is the heaviest": "which is"
        text = _AUXILIARY_IS.sub("is", text)
    # the opening carries no meaning for the attribute families; alone with a name, it asks where it is
    stripped = rx(_LEAD).sub("", text)
    return Normalised(_strip_article(stripped), stripped != text, text, question or tagged)


_DASH = re.compile(r"\s+[-\u2013\u2014]+\s+")  # "the mug or the kettle - which is hotter?": a clause's end
_SENTENCE_END = re.compile(r"(?:[?!.;:]+)(?=\s|$)")
# words and phrases that carry no meaning for a reading, wherever they stand
_COURTESY = re.compile(
    r"\bplease\b|\b(?:thanks|thank\s+you)\b|\bfor\s+me\b(?!\s+to)|\bkindly\b|\bjust\b|\bactually\b"
    r"|\b(?:right\s+now|at\s+the\s+moment|currently)\b"
    r"|\b(?:in|on|of)\s+(?:the|this)\s+(?:image|picture|photo|pic|frame|camera\s+view)\b"
    r"|\b(?:up|down|over|back)\s+(?=on\s+the\b)|\b(?:over|around|in)\s+(?:here|there)\b"
    r"|\b(?:very|absolute|absolutely|really)\s+(?=(?:[a-z]+est|most|least)\b)"
    r"|\b(?:any|much|even|slightly|somewhat|way|a\s+(?:bit|little|lot))\s+(?=(?:[a-z]+er|more|less)\s+than\b)"
)
# a filler or an opening at the start: "um,", "ok so", "hey robot,", "quick question:", "I wonder"
_OPENER = re.compile(
    r"^(?:(?:um+|uh+|erm*|hmm*|ah+|oh+|well|so|ok(?:ay)?|alright|all\s+right|now|and|hey|hi|hello|yo|listen"
    r"|sorry|excuse\s+me|pardon(?:\s+me)?|robot|attribot|quick\s+question|real\s+quick|one\s+more\s+thing)"
    r"(?:\s+(?:robot|there|attribot))?"
    r"|i\s+(?:wonder|was\s+wondering)|do\s+you\s+know|(?:can|could|would)\s+you\s+(?:please\s+)?"
    r"(?:tell\s+me|say)|would\s+you\s+mind\s+telling\s+me|(?:tell\s+me|let\s+me\s+know|say)(?=\s+(?:how|what"
    r"|which|where|if|whether)\b)|i\s+(?:would\s+like|want|need)\s+to\s+know|(?:take|have)\s+a\s+look\s+and"
    r"|go(?:\s+and)?(?=\s+(?:find|get|grab|bring|fetch|pick|see|check|look|tell)\b)"
    # "could you check which mug is hot", "see what is the heaviest", "work out which": the question inside
    r"|(?:(?:can|could|would|will)\s+you\s+)?(?:(?:please|quickly)\s+)?(?:check|see|find\s+out|work\s+out"
    r"|figure\s+out|determine|tell|guess|look\s+and\s+see|have\s+a\s+look)(?:\s+(?:for\s+)?me)?"
    r"(?=\s+(?:which|what|how|where)\b))\s*,?(?:\s+|$)"
)
# a tag at the end that makes a statement a question: "..., yes or no?", "isn't it?", "..., right?"
_TAG = re.compile(
    r",?\s+(?:yes\s+or\s+no|or\s+not|is\s+not\s+it|is\s+it\s+not|are\s+not\s+they|do\s+you\s+(?:think|know)"
    r"|would\s+you\s+say)$|,\s+(?:right|correct|true)$"  # "..., right?": not "furthest right"
)
# "tell me if the kettle is heavier than the mug": a yes/no question, asked inside a request
_EMBEDDED_QUESTION = re.compile(
    r"^(?:(?:(?:can|could|would)\s+you\s+)?(?:tell\s+me|let\s+me\s+know|say|check|find\s+out|i\s+wonder"
    r"|do\s+you\s+know)\s+(?:if|whether)|is\s+it\s+true\s+that)\s+"
    # "could you check is the kettle hotter than the mug": the question itself follows the request
    r"|^(?:(?:can|could|would)\s+you\s+)?(?:tell\s+me|let\s+me\s+know|say|check|find\s+out|see)\s+"
    r"(?=(?:is|are|does|do)\s)"
)
# what ends a query without adding to it: "then", "would you", a dangling "at", "roughly", a unit asked for
_TAIL = re.compile(
    r",?\s+(?:then|(?:would|could|will|can)\s+you|at|roughly|approximately|about|more\s+or\s+less|exactly)$"
    r"|,?\s+in\s+(?:kilos|kilograms?|kgs?|grams?|metres|meters|centimetres|centimeters|cm|millimetres|mm"
    r"|degrees(?:\s+celsius)?|celsius)\b"
    # "pick up the heaviest one and bring it here": the second verb acts on the same object
    r"|\s+and\s+(?:bring|give|hand|carry|take)\s+(?:it|them)(?:\s+(?:here|over|back|to\s+me))?$"
)
# "I'm thirsty. Which bottle is full?": a first sentence about the speaker, then the question
_CONTEXT = re.compile(
    r"^(?:i|i\s+am|we|we\s+are|my|our)\b[^,]*,\s*(?=(?:which|what|where|how|is|are|does|do|can|could)\b)"
)
# "there is a kettle here, is it hot?": "it" is the kettle
_ANTECEDENT = re.compile(
    r"^(?:there\s+(?:is|are)|(?:can|do)\s+you\s+see|you\s+(?:can\s+)?see|i\s+(?:have|see))\s+(?:a|an|the|some)\s+"
    r"(?P<name>[a-z]+(?:\s+[a-z]+)??)(?:\s+(?:here|there|somewhere|around))?\s*,\s*(?P<before>.*?)\bit\b"
    r"(?P<after>.*)$"
)
_WHO = re.compile(r"^who\s+(?=is\b|are\b)")  # "who's the heaviest?" asks which one is
_LOOKS = re.compile(r"\b(?:looks|seems|appears)(?:\s+to\s+be)?\b")  # "which object looks biggest": is
_NEGATIVE_QUESTION = re.compile(r"^(is|are|does|do)\s+not\s+")  # "isn't the pot heavier": is the pot heavier
# "one of these is not like the others, which one?", "I need the heaviest item, which is it?"
_TRAILING_WHICH = re.compile(r",\s*which(?:\s+one)?(?:\s+is\s+it)?$")
_REFERS_BACK = re.compile(r"\b(?:it|them|they|that\s+one)\b")


def _drop_fillers(text: str) -> tuple[str, bool]:
    """The text without what carries no meaning for a reading: courtesy ("please", "for me", "thanks"),
    fillers and openings ("um", "ok so", "quick question", "I wonder", "do you know"), a first sentence about
    the speaker, a tag ("..., yes or no?", "isn't it?"), a unit asked for ("in kilograms"), a second verb on
    the same object ("... and bring it here"); and whether a tag made it a question. Each pattern runs only
    where a cheap test says it may match: this runs for every query."""
    text = " ".join(_COURTESY.sub(" ", text).split()).strip(" ,")
    tagged = False
    for _ in range(3):  # "ok so, um, which...": openings one after the other
        before = text
        embedded = _EMBEDDED_QUESTION.match(text)
        if embedded is not None:
            text, tagged = text[embedded.end() :], True
        opener = _OPENER.match(text)
        if opener is not None:
            text = text[opener.end() :].strip(" ,")
        last = text[text.rfind(" ") + 1 :]
        if last in _TAG_ENDINGS:
            match = _TAG.search(text)
            if match is not None:
                text, tagged = text[: match.start()], True
        if last in _TAIL_ENDINGS or " in " in text:
            text = _TAIL.sub("", text)
        if text.endswith(("which", "which one", "is it")):
            text = _TRAILING_WHICH.sub("", text)
        text = text.strip(" ,")
        if text.startswith(_CONTEXT_STARTS):
            context = _CONTEXT.match(text)
            if context is not None and not _REFERS_BACK.search(text, context.end()):
                text = text[context.end() :]
        if text == before:
            break
    if text.startswith(_ANTECEDENT_STARTS):
        antecedent = _ANTECEDENT.match(text)
        if antecedent is not None:  # the question alone, with the name for "it"
            text = f"{antecedent['before']}the {antecedent['name']}{antecedent['after']}"
    if text.startswith(("who ", "is not ", "are not ", "does not ", "do not ")):
        text = _NEGATIVE_QUESTION.sub(r"\1 ", _WHO.sub("which ", text))
    if " than " in text and text.endswith((" is", " are", " does", " do", " was", " were")):
        text = _THAN_VERB.sub(r"\1", text)  # "further than the orange is": than the orange
    if "look" in text or "seem" in text or "appear" in text:
        text = _LOOKS.sub("is", text)
    return " ".join(text.split()).strip(" ,"), tagged


_THAN_VERB = re.compile(r"(\bthan\s+(?:[a-z]+\s+){0,3}?[a-z]+)\s+(?:is|are|does|do|was|were)$")
_TAG_ENDINGS = frozenset({"no", "not", "it", "they", "think", "know", "say", "right", "correct", "true"})
_TAIL_ENDINGS = frozenset(
    {"then", "you", "at", "roughly", "approximately", "about", "less", "exactly", "it", "them", "here",
     "over", "back", "me"}
)  # fmt: skip
_CONTEXT_STARTS = ("i ", "we ", "my ", "our ")
_ANTECEDENT_STARTS = ("there ", "can you", "do you", "you ", "i ")


_NEXT_TO_SUPERLATIVE = re.compile(r"\bnext\s+to\s+(?:the\s+)?(?=[a-z]+est\b)")
_FROM_WHERE = re.compile(r"\bfrom\s+where\s+(?:you|i|we)\s+(?:are|am|is|stand|stands)\b")
_AUXILIARY_IS = re.compile(r"\b(?:would|will|might|could|does|do|did)\s+is\b")


def _strip_article(text: str) -> str:
    return (
        rx(r"^(?:the|a|an|some|my|your|our|his|her|their|whichever)\s+").sub("", text.strip(" ,")).strip(" ,")
    )


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
    if len(words) > 6 or any(not rx(r"[a-z0-9]+").fullmatch(w) or w in _STOP for w in words):
        return None  # a word that never names an object: the phrase was not read, and is not searched
    if any(w in GENERIC_NOUNS for w in words[:-1]):
        return None  # "item pls", "object looks": a generic noun heads the name, nothing follows it
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
