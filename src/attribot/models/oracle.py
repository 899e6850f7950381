"""Ground-truth perception: a detector and a VQA that read the simulator's segmentation and object truth.

These are honest stand-ins for real models, the offline defaults of the `detector` and `vqa` roles. They
do not look at pixels: they read `Frame.segmentation` and `Frame.objects`, which only a simulator gives.
What they know is what a perfect open-vocabulary detector and a literal-minded VQA model would know:
category names, synonyms, colour names and where each object is seen. They never answer what a camera
cannot settle (weight, distance, temperature): that must be measured or reasoned about.

Noun phrases ("a photo of the red apples", "the blue ones", "item") are matched by `match_phrase`:
lower case, articles and "a photo of"-style prefixes dropped, plurals folded, the head noun matched to
the category or a synonym, colour words filtering by the object's colour name; "item", "object",
"thing" (and "one") match every object.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from attribot.errors import ConfigError, InputError
from attribot.frame import Frame, ObjectTruth
from attribot.lexicon import COLOR_WORDS, GENERIC_NOUNS, SURFACE_WORDS, singular_forms, surface_kind, words
from attribot.models.base import DETECTORS, UNKNOWN, VQAS, Detection
from attribot.models.noise import (
    DetectorNoise,
    NoisyDetector,
    NoisyVQA,
    VQANoise,
    noise_options,
    split_options,
)

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = [
    "DEFAULT_MIN_PIXELS",
    "VisibleObject",
    "visible_objects",
    "match_phrase",
    "OracleDetector",
    "OracleVQA",
]

DEFAULT_MIN_PIXELS = 30
"""Objects with fewer visible pixels than this are not detected (a real detector would miss them too)."""

# Words dropped before matching: they carry no category or colour.
_DETERMINERS = frozenset(
    {
        "a", "an", "the", "this", "that", "these", "those", "some", "any", "all", "every", "each", "my",
        "your", "our", "its", "their", "of", "both", "few", "several", "many", "other", "another",
        "pair", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten",
    }
)  # fmt: skip

_PREFIX = re.compile(
    r"^(?:(?:a|an|the)\s+)?(?:photo|picture|image|pic|photograph|drawing|rendering|view|close up|closeup)"
    r"\s+of\s+"
)
# A phrase ends at a preposition or relative pronoun: "apple on the table" is an apple.
_CUT_WORDS = frozenset(
    {"on", "in", "at", "near", "next", "beside", "behind", "under", "with", "from", "of", "to", "inside",
     "above", "below", "by", "that", "which", "who", "for", "over", "between", "among"}
)  # fmt: skip


@dataclass(frozen=True)
class VisibleObject:
    """One object seen in a frame: its key in `frame.objects`, truth, xyxy box in this frame's pixels."""

    key: int
    truth: ObjectTruth
    box: tuple[float, float, float, float]
    pixels: int

    @property
    def category(self) -> str:
        return " ".join(words(self.truth.category))

    @property
    def center_x(self) -> float:
        return (self.box[0] + self.box[2]) / 2.0


def _require_truth(frame: Frame, role: str, flag: str) -> None:
    if not isinstance(frame, Frame):
        raise InputError(
            f"the oracle {role} takes an attribot Frame; got {type(frame).__name__}", "pass a Frame"
        )
    if not frame.has_truth:
        raise ConfigError(
            f"the oracle {role} needs simulator ground truth (a frame with segmentation and objects), "
            "and this frame has none: it is a plain image",
            f"configure a real {role}: `--{flag} hf:MODEL` or ATTRIBOT_{flag.upper()}=hf:MODEL "
            "(`attribot backends` lists the choices), or run on the simulator",
        )


def visible_objects(frame: Frame, min_pixels: int = DEFAULT_MIN_PIXELS) -> list[VisibleObject]:
    """Objects of `frame.objects` with at least `min_pixels` pixels in this frame's segmentation.

    Boxes are in this frame's own pixels (a crop's boxes are in the crop), `(x0, y0, x1, y1)` with x1, y1
    one past the last pixel, so a box's width is the number of pixel columns the object covers. Sorted
    left to right by box centre.
    """
    seg = frame.segmentation
    if seg is None:
        return []
    keys = [k for k in frame.objects if k >= 0]
    if not keys:
        return []
    flat = seg.reshape(-1).astype(np.int64)
    top = max(max(keys), int(flat.max(initial=-1)))
    counts = np.bincount(flat[flat >= 0], minlength=top + 1)
    found: list[VisibleObject] = []
    for key in keys:
        n = int(counts[key])
        if n < max(min_pixels, 1):
            continue
        ys, xs = np.nonzero(seg == key)
        box = (float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1))
        found.append(VisibleObject(key, frame.objects[key], box, n))
    found.sort(key=lambda v: (v.center_x, (v.box[1] + v.box[3]) / 2.0, v.truth.id))
    return found


def _names_of(truth: ObjectTruth) -> set[str]:
    """Category and synonyms of one object, as space-joined token strings."""
    names = {" ".join(words(truth.category))}
    names.update(" ".join(words(s)) for s in truth.synonyms)
    return {n for n in names if n}


def _color_tokens(truth: ObjectTruth) -> set[str]:
    return set(words(truth.color))


def _clean(phrase: str) -> list[str]:
    text = " ".join(words(phrase))
    while True:  # "a photo of a picture of an apple"
        new = _PREFIX.sub("", text)
        if new == text:
            break
        text = new
    return text.split()


def _content(phrase: str) -> list[str]:
    """The words of a noun phrase that can name or colour an object: prefixes, determiners and
    anything after a preposition dropped."""
    tokens = _clean(phrase)
    # cut at the first preposition that follows some content ("apple on the table")
    for i, t in enumerate(tokens):
        if i > 0 and t in _CUT_WORDS and not (t == "of" and tokens[i - 1] == "pair"):
            tokens = tokens[:i]
            break
    return [t for t in tokens if t not in _DETERMINERS]


@dataclass(frozen=True)
class _Match:
    obj: VisibleObject
    quality: float  # 1.0: category or synonym; 0.8: head noun of a multi-word name; 0.9: generic word


def match_phrase(objects: Sequence[VisibleObject], phrase: str) -> list[VisibleObject]:
    """The objects among `objects` that the noun phrase names (unordered subset; see module doc)."""
    return [m.obj for m in _match(objects, phrase)]


def _match(objects: Sequence[VisibleObject], phrase: str) -> list[_Match]:
    tokens = _content(phrase)
    if not tokens:
        return []

    def color_ok(obj: VisibleObject, modifiers: Sequence[str]) -> bool:
        wanted = {t for t in modifiers if t in COLOR_WORDS}
        return wanted <= _color_tokens(obj.truth)

    names = {id(o): _names_of(o.truth) for o in objects}
    # 1. the longest multi-word tail of the phrase that is a category or synonym ("tennis racket")
    for k in range(len(tokens), 1, -1):
        tail, modifiers = tokens[-k:], tokens[:-k]
        forms = {" ".join([*tail[:-1], f]) for f in singular_forms(tail[-1])}
        hits = [o for o in objects if names[id(o)] & forms]
        if hits:
            return [_Match(o, 1.0) for o in hits if color_ok(o, modifiers)]
    last_forms = set(singular_forms(tokens[-1]))
    modifiers = tokens[:-1]
    # 2. the head noun: a one-word name exactly, or the last word of a multi-word one, which ranks
    # lower ("racket" is a racket before it is a tennis racket; "phone" finds the cell phone)
    found: list[_Match] = []
    for o in objects:
        if names[id(o)] & last_forms:
            found.append(_Match(o, 1.0))
        elif any(n.split()[-1] in last_forms for n in names[id(o)] if " " in n):
            found.append(_Match(o, 0.8))
    if found:
        return [m for m in found if color_ok(m.obj, modifiers)]
    # 3. generic words: every object, filtered by colour ("the blue ones", "red item", "red")
    if last_forms & GENERIC_NOUNS or all(t in COLOR_WORDS for t in tokens):
        mods = tokens if all(t in COLOR_WORDS for t in tokens) else modifiers
        return [_Match(o, 0.9) for o in objects if color_ok(o, mods)]
    return []


def _score(quality: float, pixels: int) -> float:
    # Saturating in visible pixels, so that bigger, less occluded views rank first; in [0, 1).
    return float(quality * pixels / (pixels + 500.0))


def _min_pixels_from(arg: str | None) -> int:
    if arg is None:
        return DEFAULT_MIN_PIXELS
    text = arg.strip().removeprefix("min_pixels=")
    if not text.isdigit():
        raise ConfigError(
            f"oracle backend argument {arg!r} is not a pixel count",
            "write `oracle` or `oracle:N`, N the fewest visible pixels to be seen (e.g. oracle:30)",
        )
    return int(text)


class OracleDetector:
    """Ground-truth detector (an honest stand-in for an open-vocabulary detector): simulator frames only.

    `detect(frame, queries)` returns one detection per object named by any of the noun phrases, boxes
    from the frame's segmentation, `object_id` the world's id, label the phrase that matched; best
    score first (score grows with visible pixels and falls for looser name matches). Objects with fewer
    than `min_pixels` visible pixels are not detected.
    """

    name = "oracle"

    def __init__(self, min_pixels: int = DEFAULT_MIN_PIXELS) -> None:
        if min_pixels < 1:
            raise ConfigError(f"min_pixels must be at least 1; got {min_pixels}", "use e.g. 30")
        self.min_pixels = int(min_pixels)

    def detect(self, frame: Frame, queries: Sequence[str]) -> list[Detection]:
        phrases = _check_queries(queries)
        _require_truth(frame, "detector", "detector")
        objects = visible_objects(frame, self.min_pixels)
        best: dict[int, tuple[float, str]] = {}
        for query in phrases:
            for part in re.split(r",|\bor\b|/", query):
                if not part.strip():
                    continue
                for m in _match(objects, part):
                    score = _score(m.quality, m.obj.pixels)
                    if m.obj.key not in best or score > best[m.obj.key][0]:
                        best[m.obj.key] = (score, query.strip())
        by_key = {o.key: o for o in objects}
        surfaces = [d for q in phrases for d in surface_detections(frame, q, self.min_pixels)]
        ranked = sorted(
            best.items(), key=lambda kv: (-kv[1][0], by_key[kv[0]].center_x, by_key[kv[0]].truth.id)
        )
        return [
            Detection(box=by_key[k].box, score=s, label=label, object_id=by_key[k].truth.id)
            for k, (s, label) in ranked
        ] + sorted({d.object_id: d for d in surfaces}.values(), key=lambda d: -d.score)


def surface_detections(frame: Frame, phrase: str, min_pixels: int = DEFAULT_MIN_PIXELS) -> list[Detection]:
    """Furniture and the floor that `phrase` names ("table" finds tables and coffee tables, "counter" the
    counters), boxes from the frame's surface layer; none when the phrase names no surface."""
    tokens = _content(phrase)
    kind = SURFACE_WORDS.get(" ".join(tokens[-2:])) or SURFACE_WORDS.get(tokens[-1]) if tokens else None
    if kind is None or frame.surfaces is None:
        return []
    found = []
    for index, name in enumerate(frame.surface_names):
        if not (surface_kind(name) == kind or surface_kind(name).endswith(" " + kind)):
            continue
        ys, xs = np.nonzero(frame.surfaces == index)
        if len(xs) < max(min_pixels, 1):
            continue
        box = (float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1))
        found.append(Detection(box=box, score=_score(1.0, len(xs)), label=phrase.strip(), object_id=name))
    return found


def _check_queries(queries: Sequence[str] | str) -> list[str]:
    if isinstance(queries, str):  # a single phrase passed bare: accept it, it is unambiguous
        queries = [queries]
    phrases = list(queries)
    if not phrases:
        raise InputError("no query given to the detector", "pass one or more noun phrases, e.g. ['apple']")
    for q in phrases:
        if not isinstance(q, str):
            raise InputError(f"a detector query must be text; got {type(q).__name__}", "pass noun phrases")
        if not words(q):
            raise InputError(f"detector query {q!r} is empty", "name what to find, e.g. 'apple' or 'red mug'")
    return phrases


# ---- VQA ---------------------------------------------------------------------------------------------

# Questions about properties a camera cannot settle: the oracle VQA refuses them.
_NON_VISUAL = re.compile(
    r"\b(?:weight|weigh|weighs|weighing|weighed|heavy|heavier|heaviest|heaviness|lightweight|lighter|"
    r"lightest|mass|kg|kilograms?|grams?|pounds?|lbs?|ounces?|distance|distant|far|farther|farthest|further|"
    r"furthest|close|closer|closest|near|nearer|nearest|nearby|away|meters?|metres?|centimet(?:er|re)s?|"
    r"temperature|hot|hotter|hottest|cold|colder|coldest|warm|warmer|warmest|cool|cooler|coolest|chilled|"
    r"boiling|degrees?|soft|softer|softest|hard|harder|hardest|firm|firmer|firmest|stiff|stiffer|stiffest|"
    r"squishy|squishier|squishiest|squashy|spongy|fragile|"
    r"sturdy|full|fuller|fullest|empty|emptier|emptiest|filled|contents?|inside|hollow|solid|price|cost|costs|expensive|cheap|cheaper|old|older|"
    r"age|smell|smells|taste|tastes|sound|loud|texture|material|made|volume|density|dense|strong|stronger|"
    r"breakable|edible|sharp|wet|dry|lift|carry|reach|reachable)\b"
    r"|\b(?:how|too|very|more|less|most|least|it|this|that|they|is|are)\s+light\b|\blight\s+enough\b"
)
_SCENE = r"(?:the|this|that)\s+(?:image|picture|photo|photograph|scene|frame|crop|patch|view|region)"
_THIS = r"(?:this|that|it|these|those|they)(?:\s+(?:object|item|thing|one)s?)?"
_COLOR_Q = r"colou?rs?"

_ITEMS = re.compile(
    rf"^(?:what|which|list|name|tell me)\b.*\b(?:items|objects|things)\b(?:.*?\b(?:in|on)\s+{_SCENE})?.*$"
)
_COUNT = re.compile(
    rf"^how many\s+(?P<x>.+?)(?:\s+(?:are|is)\s+there|\s+do you see|\s+can you see|\s+are visible|"
    rf"\s+(?:are\s+)?(?:in|on)\s+{_SCENE}|\s+are)*$"
)
_COLOR_OF = [
    re.compile(rf"^(?:what|which)\s+{_COLOR_Q}\s+(?:is|are)\s+(?P<x>.+)$"),
    re.compile(rf"^what\s+(?:is|are)\s+the\s+{_COLOR_Q}\s+of\s+(?P<x>.+)$"),
    re.compile(rf"^what\s+(?:is|are)\s+(?P<x>.+?)\s+{_COLOR_Q}$"),  # "what is its colour", "the mug's colour"
]
_IDENTITY = [
    re.compile(rf"^what\s+(?:is|are)\s+{_THIS}$"),
    re.compile(r"^what\s+(?:object|item|thing)\s+(?:is|are)\s+(?:this|that|it)$"),
    re.compile(r"^what\s+(?:is|are)\s+the\s+(?:object|item|thing)s?$"),
    re.compile(rf"^what\s+(?:is|are)\s+(?:in|shown in|shown on|on|depicted in|visible in)\s+{_SCENE}$"),
    re.compile(rf"^what\s+(?:is|are)\s+(?:shown|pictured|depicted|visible)(?:\s+(?:in|on)\s+{_SCENE})?$"),
    re.compile(rf"^what\s+(?:do|can)\s+you\s+see(?:\s+(?:in|on)\s+{_SCENE})?$"),
    re.compile(r"^what\s+am\s+i\s+looking\s+at$"),
    re.compile(rf"^what\s+(?:is|are)\s+{_THIS}\s+(?:a\s+)?(?:picture|photo|image)\s+of$"),
]
_IS_THIS = re.compile(rf"^(?:is|are)\s+{_THIS}\s+(?P<x>.+)$")
_EXISTS = [
    re.compile(rf"^(?:is|are)\s+there\s+(?P<x>.+?)(?:\s+(?:in|on)\s+{_SCENE})?$"),
    re.compile(rf"^(?:does|do)\s+{_SCENE}\s+(?:contain|show|have|include|depict)s?\s+(?P<x>.+)$"),
    re.compile(rf"^(?:do|can)\s+you\s+see\s+(?P<x>.+?)(?:\s+(?:in|on)\s+{_SCENE})?$"),
]
_IS_THE_COLOR = re.compile(r"^(?:is|are)\s+(?P<x>(?:the|this|that|these|those)\s+.+?)\s+(?P<c>[a-z]+)$")


def _normalise_question(question: str) -> str:
    text = question.lower().replace("’", "'")
    text = re.sub(r"\bwhat's\b", "what is", text)
    text = re.sub(r"\bwhat're\b", "what are", text)
    text = re.sub(r"\bit's\b", "it is", text)
    text = re.sub(r"\bits\b", "it", text)
    text = re.sub(r"'s\b", "", text)  # "the mug's colour"
    return " ".join(words(text))


class OracleVQA:
    """Ground-truth VQA (an honest stand-in for a VQA model): templated questions, simulator frames only.

    Answers, over the frame (or crop) given: "What is this?" / "What is in the image?" (the object with
    the most visible pixels), "What colour is it?" / "What color is the X?", "Is this a X?" / "Is there a
    X?" / "Is the X red?" ("yes" / "no"), "What are the items in this image?" (category names, comma
    separated, left to right), "How many X are there?" (a number). Everything else, and every question
    about what a camera cannot settle (weight, distance, temperature, contents), gets "unknown".
    """

    name = "oracle"

    def __init__(self, min_pixels: int = DEFAULT_MIN_PIXELS) -> None:
        if min_pixels < 1:
            raise ConfigError(f"min_pixels must be at least 1; got {min_pixels}", "use e.g. 30")
        self.min_pixels = int(min_pixels)

    def answer(self, frame: Frame, question: str) -> str:
        if not isinstance(question, str):
            raise InputError(f"a question must be text; got {type(question).__name__}", "ask a question")
        q = _normalise_question(question)
        if not q:
            raise InputError("the question is empty", "ask e.g. 'What is this?'")
        _require_truth(frame, "vqa", "vqa")
        if _NON_VISUAL.search(q):
            return UNKNOWN  # must be measured or reasoned about, not seen
        objects = visible_objects(frame, self.min_pixels)
        dominant = max(objects, key=lambda o: (o.pixels, -o.center_x)) if objects else None

        if q.startswith("how many"):
            m = _COUNT.match(q)
            return str(len(_match(objects, m.group("x")))) if m else UNKNOWN
        for pattern in _COLOR_OF:
            m = pattern.match(q)
            if m:
                return self._color(objects, dominant, m.group("x"))
        if _ITEMS.match(q):
            colors = [t for t in q.split() if t in COLOR_WORDS]
            chosen = [o for o in objects if set(colors) <= _color_tokens(o.truth)]
            return ", ".join(o.category for o in chosen) if chosen else "nothing"
        if any(p.match(q) for p in _IDENTITY):
            return dominant.category if dominant else UNKNOWN
        m = _IS_THE_COLOR.match(q)
        if m and m.group("c") in COLOR_WORDS:  # "is the mug red?", "is this apple green?"
            target = _best(_match(objects, m.group("x")))
            if target is None or not target.truth.color:
                return UNKNOWN
            return _yes(m.group("c") in _color_tokens(target.truth))
        m = _IS_THIS.match(q)
        if m:
            return _yes(dominant is not None and bool(_match([dominant], m.group("x"))))
        for pattern in _EXISTS:
            m = pattern.match(q)
            if m:
                return _yes(bool(_match(objects, m.group("x"))))
        return UNKNOWN

    @staticmethod
    def _color(objects: list[VisibleObject], dominant: VisibleObject | None, phrase: str) -> str:
        if re.fullmatch(_THIS, phrase) or phrase == "":
            target = dominant
        else:
            target = _best(_match(objects, phrase))
        if target is None or not target.truth.color:
            return UNKNOWN
        return " ".join(words(target.truth.color))


def _best(matches: list[_Match]) -> VisibleObject | None:
    if not matches:
        return None
    return max(matches, key=lambda m: (_score(m.quality, m.obj.pixels), -m.obj.center_x)).obj


def _yes(flag: bool) -> str:
    return "yes" if flag else "no"


def _probe(arg: str | None, settings: Settings) -> tuple[bool | None, str]:
    """What `attribot backends` prints for the oracle: usable on simulator frames only."""
    try:
        head, options = split_options(arg)
        n = _min_pixels_from(head)
        kind: type[DetectorNoise] | type[VQANoise] = VQANoise if "wrong" in options else DetectorNoise
        noise_options(options, kind, "vqa" if kind is VQANoise else "detector")
    except ConfigError as exc:
        return False, str(exc)
    noisy = f"; seeded noise: {', '.join(f'{k}={v}' for k, v in options.items())}" if options else ""
    return (
        True,
        f"ground truth, no model; simulator frames only (needs segmentation), objects >= {n} px{noisy}",
    )


@DETECTORS.register("oracle")
def _build_detector(arg: str | None, settings: Settings) -> OracleDetector | NoisyDetector:
    """`oracle`, `oracle:N` (objects need N visible pixels, default 30), and seeded noise options:
    `oracle?miss=0.1&false_pos=0.05&jitter_px=4&confuse=0.05&seed=0` or `oracle?noise=realistic`."""
    head, options = split_options(arg)
    detector = OracleDetector(_min_pixels_from(head))
    noise = DetectorNoise(**noise_options(options, DetectorNoise, "detector", settings.perception_noise))
    return detector if noise.clean else NoisyDetector(detector, noise)


@VQAS.register("oracle")
def _build_vqa(arg: str | None, settings: Settings) -> OracleVQA | NoisyVQA:
    """`oracle`, `oracle:N` (objects need N visible pixels, default 30), and seeded wrong answers:
    `oracle?wrong=0.1&seed=0` or `oracle?noise=realistic`."""
    head, options = split_options(arg)
    vqa = OracleVQA(_min_pixels_from(head))
    noise = VQANoise(**noise_options(options, VQANoise, "vqa", settings.perception_noise))
    return vqa if noise.clean else NoisyVQA(vqa, noise)


# the oracle reads the simulator's truth in this process: its options name no place
_build_detector.reaches_out = _build_vqa.reaches_out = lambda arg: False  # type: ignore[attr-defined]


_build_detector.probe = _probe  # type: ignore[attr-defined]
_build_vqa.probe = _probe  # type: ignore[attr-defined]
