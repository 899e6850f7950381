"""The one vocabulary: colour names, generic nouns, plurals and word tokens, read by the rules planner, the
oracle backends, the catalog language backend and the simulator's catalog alike. A word added here is known
everywhere (DESIGN.md, "One vocabulary").

It sits in the bottom layer and imports nothing of attribot but `attribot.sensors`, beside it: the words of
a sense (heavy, closer, hot, soft, empty, with their directions and thresholds) are held by the sense's
record, so that a sensor a lab registers brings its words along, and read from here (`sense_words`,
`sense_states`). The simulator paints with names from `COLOR_WORDS` (a test checks that every painted colour
is here), and the category names and synonyms stay with the catalog's data in `attribot.sim.catalog`, which
folds plurals with `singular_forms` from here.
"""

from __future__ import annotations

import re
from typing import Literal

from attribot.sensors import State, sense_of, vocabulary

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
    "SURFACE_LEVELS",
    "sense_words",
    "sense_states",
    "FUNCTION_WORDS",
    "SHORTHAND_WORDS",
    "PROPERTY_NOUNS",
    "surface_kind",
    "paraphrased",
    "expand_contractions",
    "state_holds",
    "temperature_state",
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

FUNCTION_WORDS: frozenset[str] = frozenset(
    """
    a an the some any every each all both either neither another other others such
    my your our their his her its mine yours ours theirs
    i me you we us he she him they them it myself yourself
    what which who whom whose where when why how whichever
    of in on at to from by for about into onto upon over under above below behind beside
    between among amongst near next inside outside across along around through toward towards up down off
    out than like unlike via per
    and or but if so because then while whether though nor yet
    is are was were be been being am do does did done have has had having will would shall should may might
    must could
    not no yes very really just only also too now here there please thanks thank actually maybe perhaps
    still already again ever never quite rather even exactly
    um uh er erm hmm hm ah oh hey hi hello ok okay alright well yeah yep nope huh wow sorry excuse pardon
    two three four five six seven eight nine ten eleven twelve
    looks look looking seems seem appears appear find show tell give get bring take pick grab go know think
    wonder want need see say mind help check let make keep put leave hold point guess reckon suppose
    many much more most less least few lot lots bit
    """.split()
)
"""Words that never name an object, whatever the query: articles and possessives, pronouns, question words,
prepositions, conjunctions, auxiliaries, fillers, the verbs of a request, number and quantity words. A planner
that has such a word left over has not read the query, and refuses it rather than searching for it
("which one's" is no object called "'s", "the object looks" none called "object looks"). Not here: "can",
which names a can, and "with" or "standing", which a name may hold ("the box with shoes", "the standing
lamp")."""

PROPERTY_NOUNS: frozenset[str] = frozenset(
    {
        "weight", "mass", "temperature", "distance", "size", "height", "width", "length", "fullness", "fill",
        "softness", "stiffness", "hardness", "firmness", "colour", "color", "position", "location",
    }
)  # fmt: skip
"""Nouns for what an object has (its weight, its temperature): after "X's" they make a possessive ("the book's
weight" is the weight of the book), where "X's" before anything else is "X is"."""

_SHORTHAND = {
    "u": "you", "ur": "your", "r": "are", "temp": "temperature", "pls": "please", "plz": "please",
    "plox": "please", "thx": "thanks", "whats": "what is", "wheres": "where is", "thats": "that is",
    "whos": "who is", "hows": "how is", "whichs": "which is", "theres": "there is", "heres": "here is",
    "isnt": "is not", "arent": "are not", "doesnt": "does not", "dont": "do not", "didnt": "did not",
    "wont": "will not", "cant": "can not", "im": "i am", "ive": "i have", "youre": "you are",
    "lemme": "let me", "gimme": "give me", "wanna": "want to", "gonna": "going to",
}  # fmt: skip
"""Words typed without their apostrophe, and text-message spellings, written out."""
SHORTHAND_WORDS: frozenset[str] = frozenset(_SHORTHAND)
"""The words of `_SHORTHAND`: words the planner reads though no dictionary holds them ("whats", "pls")."""
_SHORTHAND_WORDS = re.compile(r"\b(?:" + "|".join(_SHORTHAND) + r")\b")
_NOT = re.compile(r"\b([a-z]+)n't\b")
_NOT_STEMS = {"ca": "can", "wo": "will", "sha": "shall"}  # "can't", "won't", "shan't"
_SUFFIXES = (
    (re.compile(r"\bi'm\b"), "i am"),
    (re.compile(r"\blet's\b"), "let us"),
    (re.compile(r"(?<![a-z])'em\b"), "them"),
    (re.compile(r"([a-z])'re\b"), r"\1 are"),
    (re.compile(r"([a-z])'ve\b"), r"\1 have"),
    (re.compile(r"([a-z])'ll\b"), r"\1 will"),
    (re.compile(r"([a-z])'d\b"), r"\1 would"),
    (re.compile(r"([a-z])'s\s+got\b"), r"\1 has"),
)
_ONES_IS = re.compile(r"\bones\s+(?=(?:the\s+)?[a-z]+est\b)")  # "which ones heaviest": "one's", unmarked
_POSSESSIVE = re.compile(r"((?:[a-z]+\s+){0,2}[a-z]+)'s\s+(" + "|".join(sorted(PROPERTY_NOUNS)) + r")\b")
_DETERMINERS = frozenset({"the", "a", "an", "my", "your", "our", "this", "that"})


def _possessive(match: re.Match[str]) -> str:
    """ "the tissue box's weight" -> "the weight of the tissue box": the owner is the words before "'s"
    that can name something, after the article."""
    words = match[1].split()
    start = len(words)
    while start > 0 and words[start - 1] not in FUNCTION_WORDS:
        start -= 1
    before, owner = words[:start], words[start:]
    if before and before[-1] in _DETERMINERS:
        before = before[:-1]
    if not owner:  # "it's weight": a typo of "its", no owner to name
        return " ".join([*before, "the", match[2], "of", "it"])
    return " ".join([*before, "the", match[2], "of", "the", *owner])


def expand_contractions(text: str) -> str:
    """Lower-case `text` with English contractions and shorthand written out: "n't" is "not", "'re" "are",
    "'ll" "will", "'d" "would", "'m" "am", "'s got" "has"; "X's" before a property noun is a possessive ("the
    book's weight" is "the weight of the book") and "is" otherwise ("which one's the heaviest", "the mug's
    hot"); a plural's "s'" is dropped; words typed without their apostrophe ("whats", "dont") and
    text-message spellings ("u", "pls") are written out.

    >>> expand_contractions("which one's the heaviest? the book's weight, pls")
    'which one is the heaviest? the weight of the book, please'
    """
    text = _SHORTHAND_WORDS.sub(
        lambda m: _SHORTHAND[m[0]], text.replace("\u2019", "'").replace("\u2018", "'")
    )
    if "'" in text:
        text = _NOT.sub(lambda m: _NOT_STEMS.get(m[1], m[1]) + " not", text)
        for pattern, meaning in _SUFFIXES:
            text = pattern.sub(meaning, text)
        text = _POSSESSIVE.sub(_possessive, text)
        text = re.sub(r"([a-z])'s\b", r"\1 is", text)
        text = re.sub(r"([a-z]s)'(?=\s|$)", r"\1", text)  # "the mugs' weights": the mugs
        text = text.replace("'", " ")
    return _ONES_IS.sub("one is ", text) if "ones " in text else text


# ---- the attributes: the words that name a weight, a distance or a size, and their direction ----------


def sense_words(quantities: tuple[str, ...] | None = None) -> dict[str, tuple[str, bool, str]]:
    """The words of the senses (`attribot.sensors`: each sense's record holds them), each with (its quantity:
    weight, distance, temperature, stiffness, fullness or a lab's own; whether it asks for more of it; its
    form: absolute "hot", comparative "hotter", superlative "hottest"), of every registered sense or of
    `quantities`. "Less" and "least" turn the direction round ("the least warm" is the coldest); softness
    is less stiffness.

    >>> sense_words(("temperature",))["least warm"]
    ('temperature', False, 'superlative')
    """
    words = vocabulary()[0]
    return {w: v for w, v in words.items() if quantities is None or v[0] in quantities}


def sense_states() -> dict[str, State]:
    """What a state word of `sense_words` means, as its sense's record states it: a threshold and the
    comparison a value in that state passes, in the sense's unit (°C, N/mm of squeeze, the share of a
    container's capacity). The planner's programs state them, and the simulator labels its objects' states
    with them."""
    return vocabulary()[1]


def _ends(quantity: str, more: bool) -> frozenset[str]:
    return frozenset(w for w, (_, way, _) in sense_words((quantity,)).items() if way == more)


WEIGHT_HEAVY: frozenset[str] = _ends("weight", True)
"""Words (and two-word phrases) that ask for more weight: the weight sense's (`attribot.sensors.builtin`)."""
WEIGHT_LIGHT: frozenset[str] = _ends("weight", False)
"""Words that ask for less weight."""
NEAR_WORDS: frozenset[str] = _ends("distance", False)
FAR_WORDS: frozenset[str] = _ends("distance", True)
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


def state_holds(word: str, value: float) -> bool:
    """Whether `value` (in the sense's unit) is in the state `word` of `sense_states`.

    >>> state_holds("cold", 19.99), state_holds("cold", 12.0)
    (False, True)
    """
    return sense_states()[word].holds(value)


def temperature_state(celsius: float) -> str:
    """The word for a temperature: "hot", "warm", "cold" or "cool" by its sense's states, "room" otherwise.

    >>> temperature_state(85.0), temperature_state(19.99), temperature_state(4.0)
    ('hot', 'room', 'cold')
    """
    found = sense_of("temperature")
    return "room" if found is None else found[1].grade(celsius)


_CONTENTS = r"(?:anything|something|stuff|water|coffee|tea|juice|milk|soda|liquid|drink)"
"""What a container holds, as a question names it."""

ATTRIBUTE_PARAPHRASES: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    # verb phrases of weight, to the adjective they mean
    (r"\b(?:weighs?|weighing)\s+(?:the\s+)?most\b", "is the heaviest", ("weigh",)),
    (r"\b(?:weighs?|weighing)\s+(?:the\s+)?least\b", "is the lightest", ("weigh",)),
    (r"\b(?:weighs?|weighing)\s+more\b", "is heavier", ("weigh",)),
    (r"\b(?:weighs?|weighing)\s+less\b", "is lighter", ("weigh",)),
    (
        r"\b(?:has|have|with)\s+(?:the\s+)?(?:greatest|highest|largest|biggest|most)\s+(?:mass|weight)\b",
        "is the heaviest",
        ("mass", "weight"),
    ),
    (
        r"\b(?:has|have|with)\s+(?:the\s+)?(?:least|lowest|smallest)\s+(?:mass|weight)\b",
        "is the lightest",
        ("mass", "weight"),
    ),
    (r"\b(?:lowest|least|smallest)\s+in\s+(?:weight|mass)\b", "lightest", ("mass", "weight")),
    (r"\b(?:highest|greatest|largest|biggest|most)\s+in\s+(?:weight|mass)\b", "heaviest", ("mass", "weight")),
    (r"\b(heaviest|lightest|heavier|lighter)\s+(?:in|by)\s+(?:weight|mass)\b", r"\1", ("mass", "weight")),
    (r"\b(largest|biggest|smallest|larger|bigger|smaller)\s+(?:in|by)\s+size\b", r"\1", (" size",)),
    (r"\b(?:greatest|highest|largest|biggest|most|more)\s+(?:weight|mass)\b", "heaviest", ("mass", "weight")),
    (r"\b(?:lowest|smallest|least|less)\s+(?:weight|mass)\b", "lightest", ("mass", "weight")),
    (r"\bmost\s+massive\b", "heaviest", ("mass",)),
    (r"\bleast\s+massive\b", "lightest", ("mass",)),
    # left and right are positions in the picture, not distances: "furthest to the left", "far right",
    # "left-most" (hyphens are spaces by now), "on the very left" are the leftmost and the rightmost
    (
        r"\b(?:on|at|to|in)\s+the\s+(?:very|far|furthest|farthest|extreme)\s+(left|right)(?:\s+(?:side|end|edge))?\b",
        r"\1most",
        ("left", "right"),
    ),
    (
        r"\b(?:the\s+)?(?:furthest|farthest|further|farther|most|far)\s+(?:to\s+(?:the\s+)?|on\s+the\s+)?(left|right)\b",
        r"\1most",
        ("left", "right"),
    ),
    (r"\b(left|right)\s+most\b", r"\1most", ("left", "right")),
    # what weight does to a person: hard or easy to lift
    (
        r"\b(?:hardest|heaviest)\s+(?:one\s+)?to\s+(?:lift|carry|pick\s+up)\b",
        "heaviest",
        ("lift", "carry", "pick"),
    ),
    (r"\beasiest\s+(?:one\s+)?to\s+(?:lift|carry|pick\s+up)\b", "lightest", ("lift", "carry", "pick")),
    (
        r"\bhow\s+many\s+(?:metres|meters|feet|inches|centimetres|centimeters)\s+away\b",
        "how far away",
        ("away",),
    ),
    # "nearest the camera" is nearest to it
    (
        r"\b(closest|nearest|closer|nearer)\s+(?=(?:me|you|us|the\s+robot|the\s+camera)\b)",
        r"\1 to ",
        ("est me", "est you", "est us", "est the", "er me", "er you", "er us", "er the"),
    ),
    # distance: "farthest away", "closest by" mean the adjective alone
    (
        r"\b(farthest|furthest|farther|further|closest|nearest|closer|nearer)\s+(?:away|by)\b",
        r"\1",
        ("away", " by"),
    ),
    # what the senses' states are said with: a drink from the fridge is cold, a jar with nothing in it empty
    (r"\b(?:has|have)\s+(?:just\s+)?(?:been\s+)?boiled\b", "is hot", ("boiled",)),
    (
        r"\b(?:came|come|comes|is|are|was|were|just)\s+(?:out\s+of|from)\s+the\s+fridge\b",
        "is cold",
        ("fridge",),
    ),
    (r"\b(?:from|out\s+of)\s+the\s+fridge\b", "cold", ("fridge",)),
    (r"\b(?:has|have)\s+nothing\s+(?:left\s+)?in\s+(?:it|them)\b", "is empty", ("nothing",)),
    (
        r"\b(?:needs?|needing)\s+(?:a\s+)?(?:refilling|refill|filling\s+up)\b",
        "is empty",
        ("refill", "filling"),
    ),
    (r"\bgives?\s+the\s+most\s+when\s+(?:you\s+|i\s+)?squeezed?(?:\s+it)?\b", "is the softest", ("squeeze",)),
    (
        r"\bgives?\s+the\s+least\s+when\s+(?:you\s+|i\s+)?squeezed?(?:\s+it)?\b",
        "is the hardest",
        ("squeeze",),
    ),
    (r"\bhow\s+much\s+is\s+(?:left|still)\s+in\b", "how full is", ("left", "still")),
    # how much a container holds: "which jar has the most in it" is the fullest
    (
        r"\b(?:has|have|holds?|contains?)\s+(?:got\s+)?the\s+most(?:\s+(?:left\s+)?(?:in|inside)\s+(?:it|them))?$",
        "is the fullest",
        ("the most",),
    ),
    (
        r"\b(?:has|have|holds?|contains?)\s+(?:got\s+)?the\s+least(?:\s+(?:left\s+)?(?:in|inside)\s+(?:it|them))?$",
        "is the emptiest",
        ("the least",),
    ),
    # something in a container: it is not empty ("is there anything in the mug" asks whether it is full;
    # "water", "coffee" are what is in it, never the object asked about)
    (
        r"\b(?:does|do)\s+(.+?)\s+(?:have|hold|contain)\s+"
        + _CONTENTS
        + r"(?:\s+(?:in|inside)\s+(?:it|them))?$",
        r"is \1 full",
        ("have", "hold", "contain"),
    ),
    (
        r"\b(?:has|have)\s+(?:got\s+)?" + _CONTENTS + r"\s+(?:left\s+)?(?:in|inside)\s+(?:it|them)\b",
        "is full",
        ("has", "have"),
    ),
    (
        r"\bis\s+(?:there\s+)?" + _CONTENTS + r"\s+(?:left\s+)?(?:in|inside)\s+"
        r"((?:the|my|your|this|that)\s+[a-z]+(?:\s+[a-z]+)?)$",
        r"is \1 full",
        (" in",),
    ),
    # weight in other words and units: "the weightiest", "how many kilos is the carrot"
    (r"\b(?:most\s+weighty|weightiest)\b", "heaviest", ("weight",)),
    (r"\b(?:least\s+weighty)\b", "lightest", ("weight",)),
    (r"\bweightier\b", "heavier", ("weight",)),
    (
        r"\bhow\s+many\s+(?:kilos|kilograms?|kgs?|grams?|pounds|lbs?)\s+(?:is|are|does|do)\s+(.+?)(?:\s+weighs?)?$",
        r"how heavy is \1",
        ("how many",),
    ),
    (
        r"\b(?:can|could)\s+(?:i|you|we)\s+(?:lift|carry|pick\s+up)\s+(?:the\s+)?most\s+easily\b",
        "is the lightest",
        ("easily",),
    ),
    # temperature as a quantity: "the highest temperature" is the hottest, "how many degrees" asks it
    (
        r"\b(?:has|have|with)\s+(?:the\s+)?(?:highest|greatest)\s+temperature\b",
        "is the hottest",
        ("temperature",),
    ),
    (r"\b(?:has|have|with)\s+(?:the\s+)?lowest\s+temperature\b", "is the coldest", ("temperature",)),
    (
        r"\bhow\s+many\s+degrees(?:\s+(?:celsius|centigrade))?\s+(?=is\b|are\b)",
        "what temperature ",
        ("how many",),
    ),
    # distances and sizes in units: "how many meters from you", "how many centimetres across"
    (
        r"\bhow\s+many\s+(?:metres|meters|feet|inches|centimetres|centimeters|cm)\s+(away|from)\b",
        r"how far \1",
        ("how many",),
    ),
    (
        r"\bhow\s+many\s+(?:metres|meters|inches|centimetres|centimeters|cm|millimetres|mm)\s+across\b",
        "how big",
        ("how many",),
    ),
    (
        r"\bhow\s+many\s+(?:metres|meters|inches|centimetres|centimeters|cm|millimetres|mm)\s+(wide|long|tall|high)\b",
        r"how \1",
        ("how many",),
    ),
    (r"\bhow\s+far\s+off\b", "how far away", ("far off",)),
    # "what is the distance between you and the can", "the distance from you to the mug": how far it is
    (
        r"\b(?:what\s+is\s+)?(?:the\s+)?distance\s+(?:between\s+(?:you|me|us|the\s+robot)\s+and"
        r"|from\s+(?:you|me|us|the\s+robot)\s+to|(?:to|of))\s+(?=(?:the|a|an|my|your|that|this)\b)",
        "how far away is ",
        ("distance",),
    ),
    # where something was left is where it is
    (
        r"\bwhere\s+(?:did|have)\s+(?:i|we|you)\s+(?:leave|left|put|place|placed)\s+",
        "where is ",
        ("where did", "where have"),
    ),
    (
        r"\bhow\s+far\s+(?:away\s+)?is\s+it\s+(?:from\s+(?:here|you|me)\s+)?to\b",
        "how far away is",
        ("is it",),
    ),
)
"""(pattern, replacement, cues) that turn paraphrases of an attribute into the words the planner reads
("Which object weighs the most?" is "Which object is the heaviest?"), applied in order to lower-case text;
every text a pattern matches holds one of its cues (a test checks it), so that a pattern runs only where one
is: most texts skip most patterns."""


def paraphrased(text: str) -> str:
    """Lower-case `text` with every paraphrase of `ATTRIBUTE_PARAPHRASES` turned into the words it means
    ("Which one weighs the most?" -> "which one is the heaviest?").

    >>> paraphrased("Which item has the greatest mass?")
    'which item is the heaviest?'
    """
    text = text.lower()
    cued = {i for cue in _CUE.findall(text) for i in _PATTERNS_OF_CUE[cue]}
    for i in sorted(cued):  # in the table's order: a later pattern may read what an earlier one wrote
        pattern, meaning = _COMPILED_PARAPHRASES[i]
        text = pattern.sub(meaning, text)
    return text


ATTRIBUTE_PARAPHRASE_CUES: tuple[str, ...] = tuple(
    dict.fromkeys(cue for _, _, cues in ATTRIBUTE_PARAPHRASES for cue in cues)
)
"""Every cue of `ATTRIBUTE_PARAPHRASES`: a text with none of these is no paraphrase."""

SURFACE_WORDS: dict[str, str] = {
    "table": "table", "tables": "table", "desk": "table", "dining table": "table",
    "kitchen table": "table", "coffee table": "coffee table", "counter": "counter", "countertop": "counter",
    "kitchen counter": "counter", "worktop": "counter", "shelf": "shelf", "shelves": "shelf",
    "bookshelf": "shelf", "shelving": "shelf", "floor": "floor", "ground": "floor",
}  # fmt: skip
"""Words for the surfaces objects stand on (furniture and the floor), to the kind of surface they name: what
the oracle detector finds as furniture and what the planner reads as a scope ("on the table")."""


SURFACE_LEVELS: dict[str, Literal["top", "bottom"]] = {
    "top": "top", "upper": "top", "uppermost": "top", "highest": "top", "topmost": "top",
    "bottom": "bottom", "lower": "bottom", "lowest": "bottom", "bottommost": "bottom",
}  # fmt: skip
"""Words for a board of a shelf ("the bottom shelf"), to the board: "top" or "bottom"."""


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


_COMPILED_PARAPHRASES = [(re.compile(p), meaning) for p, meaning, _ in ATTRIBUTE_PARAPHRASES]
_PATTERNS_OF_CUE = {
    cue: [i for i, (_, _, cues) in enumerate(ATTRIBUTE_PARAPHRASES) if cue in cues]
    for cue in ATTRIBUTE_PARAPHRASE_CUES
}
_CUE = re.compile(
    "|".join(re.escape(cue) for cue in sorted(ATTRIBUTE_PARAPHRASE_CUES, key=len, reverse=True))
)
