"""The language front end: a query the parser refused, read again with its words mended.

It runs only when the parser refuses a query as typed (so the queries it reads cost nothing more), and
mends words one by one, each change stated:

- a word the parser knows (its vocabulary: `attribot.lexicon`, the senses' words of `attribot.sensors` and
  the words its own patterns read, collected from its source) stays;
- a misspelling of such a word, within one or two edits, becomes it ("heavist" -> "heaviest", "teh" ->
  "the", "kilogrammes" -> "kilograms"); a misspelt name becomes the English word symspellpy's frequency
  dictionary holds nearest ("botle" -> "bottle"), where WordNet knows it;
- an adjective the parser does not read becomes the sense or size word WordNet says it means, in the same
  form ("chilliest" -> "coldest", "squidgiest" -> "softest", British and American spellings meeting in one
  synset), its lemma and degree from lemminflect;
- "then" after a comparative is "than".

The language data (WordNet from Debian's `wordnet-base`, read with nltk's reader; symspellpy's dictionary;
lemminflect's tables) loads once, on the first query that needs it. Where the data is missing, the front
end mends nothing and the refusal stands.
"""

from __future__ import annotations

import ast
import importlib.resources
import io
import re
from dataclasses import dataclass
from functools import cache, cached_property
from pathlib import Path
from typing import Any

from attribot.lexicon import (
    COLOR_ALIASES,
    COLOR_WORDS,
    FUNCTION_WORDS,
    GENERIC_NOUNS,
    PROPERTY_NOUNS,
    SHORTHAND_WORDS,
    SIZE_ADJECTIVES,
    SIZE_COMPARATIVES,
    SIZE_SUPERLATIVES,
    SURFACE_WORDS,
    sense_words,
)

__all__ = ["Mended", "mend", "unread", "could_mean", "kinds_of", "WORDNET_DIR", "language_data"]

WORDNET_DIR = Path("/usr/share/wordnet")
"""Where Debian's `wordnet-base` puts WordNet 3.0."""

_WORD = re.compile(r"[a-z]+")


@dataclass(frozen=True)
class Mended:
    """A query with its words mended, and what was read as what ("reading 'botle' as 'bottle'")."""

    text: str
    notes: tuple[str, ...]


# ---- the vocabulary the parser reads -------------------------------------------------------------------


@cache
def vocabulary() -> frozenset[str]:
    """Every word the rules parser reads: the lexicon's words, the senses' words, and the words written
    in the parser's own patterns (string literals of its modules and the lexicon's), so that no list here
    repeats them."""
    found: set[str] = set()
    for group in (FUNCTION_WORDS, GENERIC_NOUNS, COLOR_WORDS, PROPERTY_NOUNS, SIZE_ADJECTIVES):
        found.update(group)
    found.update(COLOR_ALIASES)
    found.update(SIZE_COMPARATIVES)
    found.update(SIZE_SUPERLATIVES)
    for phrase in (*SURFACE_WORDS, *sense_words()):
        found.update(phrase.split())
    import attribot.lexicon as lexicon
    import attribot.planning.rules as rules

    patterned: set[str] = set()
    sources = [Path(lexicon.__file__), *Path(rules.__file__).parent.rglob("*.py")]
    for path in sources:
        if path.name == "understand.py":
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        docstrings = {
            id(node.value)
            for node in ast.walk(tree)
            if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)
        }
        for node in ast.walk(tree):
            if (
                not isinstance(node, ast.Constant)
                or not isinstance(node.value, str)
                or id(node) in docstrings
            ):
                continue
            text = node.value
            # a pattern (it has a regex's marks) or a word or two; not a message or an example sentence
            if "\\" in text or "(?" in text or "|" in text or len(text.split()) <= 2:
                text = re.sub(r"\\[a-zA-Z]", " ", text)  # "\s", "\b": escapes, not letters of a word
                patterned.update(w for w in _WORD.findall(text) if len(w) >= 3)
    # a pattern's fragments ("amily" of "f(?:amily)") are no words: those English lacks are left out
    english = language_data().counts
    found.update(w for w in patterned if w in found or w in english or w in SHORTHAND_WORDS)
    return frozenset(found)


def _plain_adjectives() -> tuple[str, ...]:
    """The parser's one-word sense and size adjectives in their plain degree ("cold", "soft", "big")."""
    senses = [w for w, (_, _, form) in sense_words().items() if form == "absolute" and " " not in w]
    return tuple(dict.fromkeys([*senses, *SIZE_ADJECTIVES]))


# ---- the language data, loaded once ----------------------------------------------------------------------


class _Data:
    """WordNet, symspellpy's frequency dictionary and lemminflect, each loaded when first needed."""

    @cached_property
    def wordnet(self) -> Any:
        return _load_wordnet()

    @cached_property
    def counts(self) -> dict[str, int]:
        return _load_counts()

    @cached_property
    def words(self) -> list[str]:
        return list(self.counts)

    @cached_property
    def lemminflect(self) -> Any:
        try:
            import lemminflect
        except ImportError:
            return None
        return lemminflect

    @property
    def ready(self) -> bool:
        return self.lemminflect is not None


@cache
def language_data() -> _Data:
    """The language data, loaded once per process."""
    return _Data()


def _load_wordnet() -> Any:
    """nltk's WordNet reader over Debian's files, or None where either is missing. Debian ships no
    `lexnames` file (the reader wants one for lexicographer file names, which the front end does not
    read), so the reader is given numbered names."""
    if not (WORDNET_DIR / "data.noun").is_file():
        return None
    try:
        import nltk.data
        from nltk.corpus.reader.wordnet import WordNetCorpusReader
    except ImportError:
        return None
    if str(WORDNET_DIR) not in nltk.data.path:
        nltk.data.path.append(str(WORDNET_DIR))  # nltk reads only below its data paths

    class _DebianWordNet(WordNetCorpusReader):
        def open(self, file: str) -> Any:
            if file == "lexnames":
                return io.StringIO("".join(f"{i:02d}\tlex{i:02d}\t0\n" for i in range(64)))
            return super().open(file)

        def map_wn(self, version: str = "wordnet") -> None:
            return None  # no mapping to other WordNet versions: 3.0 is read as it is

    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return _DebianWordNet(str(WORDNET_DIR), None)


def _load_counts() -> dict[str, int]:
    """symspellpy's English frequency dictionary (82,765 words with their counts in a web corpus), read as
    a plain table: the words English uses, and how often."""
    try:
        dictionary = importlib.resources.files("symspellpy") / "frequency_dictionary_en_82_765.txt"
        text = dictionary.read_text(encoding="utf-8")
    except (ImportError, OSError):
        return {}
    counts: dict[str, int] = {}
    for line in text.splitlines():
        word, _, count = line.partition(" ")
        if count.isdigit():
            counts[word] = int(count)
    return counts


def _inflect(base: str, degree: str) -> str | None:
    data = language_data()
    if data.lemminflect is None:
        return None
    forms = data.lemminflect.getInflection(base, degree)
    return forms[0] if forms else None


# ---- synonyms of the parser's adjectives, from WordNet -----------------------------------------------------


@cache
def _synset_meanings() -> dict[str, str]:
    """WordNet synsets that mean one of the parser's plain sense or size adjectives, to it: the adjective's
    first synset, and where that heads a cluster, the synsets similar to it ("chilly" is similar to cold);
    a synset two of them claim stays with the first (the senses come before sizes)."""
    wordnet = language_data().wordnet
    if wordnet is None:
        return {}
    meanings: dict[str, str] = {}
    for base in _plain_adjectives():
        synsets = wordnet.synsets(base, "a")
        if not synsets:
            continue
        first = synsets[0]
        for synset in (first, *(first.similar_tos() if first.pos() == "a" else ())):
            meanings.setdefault(synset.name(), base)
    return meanings


@cache
def _meaning(word: str) -> str | None:
    """The parser's plain adjective an English adjective means, by its first two WordNet senses: one of
    them is a synset of `_synset_meanings`, or a satellite of one that heads a cluster."""
    wordnet = language_data().wordnet
    if wordnet is None:
        return None
    meanings = _synset_meanings()
    for synset in wordnet.synsets(word, "a")[:2]:
        near = (synset, *synset.similar_tos()) if synset.pos() == "s" else (synset,)
        for candidate in near:
            if candidate.name() in meanings:
                return meanings[candidate.name()]
    return None


@cache
def _meaning_words() -> tuple[str, ...]:
    """The one-word adjectives whose first senses `_meaning` places: what a word WordNet lacks is matched
    to ("squidgy" is two edits from "squishy")."""
    wordnet = language_data().wordnet
    if wordnet is None:
        return ()
    found: dict[str, None] = {}
    for name in _synset_meanings():
        synset = wordnet.synset(name)
        for near in (synset, *(synset.similar_tos() if synset.pos() == "a" else ())):
            for lemma in near.lemma_names():
                if "_" not in lemma and "-" not in lemma:
                    found[lemma.lower()] = None
    return tuple(w for w in found if _meaning(w) is not None)


# ---- mending --------------------------------------------------------------------------------------------


def _edits(word: str) -> int:
    """How many edits a misspelling of a word this long may have."""
    return 1 if len(word) <= 5 else 2


_OPENING_WORDS = ("which", "what", "where", "how", "who", "whats", "is", "are", "does", "do", "can", "could")
"""How questions open: a misspelt first word is one of these where one is as near as any other word."""


def _nearest_known(word: str, first: bool = False) -> str | None:
    """The parser's word nearest `word` by edits (transpositions count one), if one is nearest."""
    from rapidfuzz.distance import OSA
    from rapidfuzz.process import extract

    limit = _edits(word)
    found = extract(word, _vocabulary_list(), scorer=OSA.distance, score_cutoff=limit, limit=8)
    # one that keeps the first letter (typists miss it least: "smiley" is no "amily")
    hits: list[tuple[str, float]] = [(str(w), score) for w, score, _ in found if w[0] == word[0]]
    if not hits:
        return None
    best = min(score for _, score in hits)
    nearest = [w for w, score in hits if score == best]
    if first and len(nearest) > 1:  # "wich is ...": which, not with
        nearest = [w for w in nearest if w in _OPENING_WORDS] or nearest
    return _tie_broken(word, nearest)


def _tie_broken(word: str, nearest: list[str]) -> str | None:
    """One of several words as near to `word`: the one with its letters swapped ("closre": closer); else
    among the senses' words (the parser's attribute words) the ones ending as it does ("coldr": colder, not
    cold or color), taken when they mean one thing ("frthest": farthest or furthest); else the far commonest
    in English ("teh": the, not ten or tea)."""
    if len(nearest) == 1:
        return nearest[0]
    swapped = [w for w in nearest if sorted(w) == sorted(word)]
    if len(swapped) == 1:
        return swapped[0]
    dropped = [w for w in nearest if _holds_in_order(w, word)]  # "toastr": toaster, a letter dropped
    if len(dropped) == 1:
        return dropped[0]
    senses = sense_words()
    attribute = [w for w in nearest if w in senses]
    if attribute:
        attribute = [w for w in attribute if w[-1] == word[-1]] or attribute
        if len({senses[w] for w in attribute}) == 1:
            return sorted(attribute)[0]
    return _commonest(nearest)


def _holds_in_order(longer: str, word: str) -> bool:
    """Whether `word` is `longer` with letters dropped."""
    letters = iter(longer)
    return len(longer) > len(word) and all(ch in letters for ch in word)


def _commonest(words: list[str]) -> str | None:
    """The word of `words` at least ten times as common as any other, by symspellpy's counts, or None."""
    known = language_data().counts
    counts = sorted(((known.get(w, 0), w) for w in words), reverse=True)
    if counts[0][0] > 0 and (len(counts) == 1 or counts[0][0] >= 10 * counts[1][0]):
        return counts[0][1]
    return None


@cache
def _vocabulary_list() -> list[str]:
    return sorted(w for w in vocabulary() if len(w) >= 3)


def _lemmas(word: str) -> dict[str, tuple[str, ...]]:
    """lemminflect's lemmas of a word of its dictionary, by part of speech; empty for a word it lacks."""
    data = language_data()
    return dict(data.lemminflect.getAllLemmas(word)) if data.lemminflect is not None else {}


def _is_english(word: str) -> bool:
    """Whether English has the word: lemminflect's dictionary or the frequency dictionary holds it."""
    return bool(_lemmas(word)) or word in language_data().counts


def _as_sense_word(word: str, english: bool) -> str | None:
    """An adjective in a form the parser does not read ("chilliest"), as the parser's word it means in the
    same degree ("coldest"), or None. `english`: lemminflect's dictionary holds the word."""
    data = language_data()
    degree = "JJS" if word.endswith("est") else "JJR" if word.endswith("er") else "JJ"
    if english:
        lemmas = _lemmas(word).get("ADJ", (word,))  # "scalding": a verb's form to lemminflect
    else:
        lemmas = data.lemminflect.getLemma(word, "ADJ") if degree != "JJ" else (word,)
    for lemma in lemmas:
        base = _meaning(lemma)
        wordnet = language_data().wordnet
        if (
            base is None
            and len(lemma) >= 6
            and (not english or wordnet is not None and not wordnet.synsets(lemma))
        ):
            base = _nearest_meaning(lemma)
        if base is None:
            continue
        if degree == "JJ":
            return base
        inflected = _inflect(base, degree)
        if inflected is not None and inflected in vocabulary():
            return inflected
        return f"{'more' if degree == 'JJR' else 'most'} {base}"
    return None


def _nearest_meaning(lemma: str) -> str | None:
    """The sense adjective of the WordNet synonym nearest a word WordNet does not know ("squidgy" is two
    edits from "squishy", which means soft), when one is nearest and keeps its first letter."""
    from rapidfuzz.distance import OSA
    from rapidfuzz.process import extract

    hits = extract(lemma, _meaning_words(), scorer=OSA.distance, score_cutoff=2, limit=4)
    if not hits:
        return None
    best = min(score for _, score, _ in hits)
    bases = {_meaning(w) for w, score, _ in hits if score == best and w[0] == lemma[0]}
    return bases.pop() if len(bases) == 1 else None


def _distance(word: str, other: str) -> int:
    from rapidfuzz.distance import OSA

    return int(OSA.distance(word, other))


def _speller_word(word: str) -> str | None:
    """The English word nearest a word English lacks ("botle" -> "bottle"), by edits (rapidfuzz over
    symspellpy's frequency dictionary), keeping its first letter, when no other as near is half as common."""
    from rapidfuzz.distance import OSA
    from rapidfuzz.process import extract

    data = language_data()
    if len(word) < 3 or not data.counts:
        return None
    found = extract(word, data.words, scorer=OSA.distance, score_cutoff=_edits(word), limit=32)
    hits: list[tuple[str, float]] = [
        (str(w), score) for w, score, _ in found if w[0] == word[0] and score > 0
    ]
    if len(word) == 3:  # three letters are near too many words: only two of them swapped ("mgu": mug)
        hits = [(w, score) for w, score in hits if sorted(w) == sorted(word)]
    if not hits:
        return None
    best = min(score for _, score in hits)
    nearest = [w for w, score in hits if score == best]
    # the commonest, a swap ("bottel") or a dropped letter ("toastr": toaster, not toast) counted five times
    weighted = sorted(
        ((data.counts[w] * (5 if _slipped(w, word) else 1), w) for w in nearest),
        reverse=True,
    )
    if len(weighted) > 1 and weighted[1][0] * 2 > weighted[0][0]:
        return None
    return weighted[0][1]


def _slipped(meant: str, typed: str) -> bool:
    """Whether `typed` is `meant` with two letters swapped or letters dropped: the commonest slips."""
    return sorted(meant) == sorted(typed) or _holds_in_order(meant, typed)


_COMPARATIVE_BEFORE_THEN = re.compile(r"\b([a-z]+er)((?:\s+(?:to|from)\s+(?:me|you|us))?)\s+then\b")
# British spellings to American ones, where the American is the parser's word ("kilogrammes", "metres")
_AMERICAN = (("tre", "ter"), ("our", "or"), ("mme", "m"), ("grey", "gray"), ("ise", "ize"), ("yse", "yze"))


def mend(query: str, refused: bool = False) -> Mended | None:
    """`query` with its misspelt and unread words mended, and what was read as what; None when nothing
    was mended (or the language data is not installed). `refused`: the query as typed was refused, and a
    real word one slip from a sense word is mended too."""
    if not language_data().ready:
        return None
    known = vocabulary()
    text = query.lower().replace("\u2019", "'")
    notes: list[str] = []
    pieces: list[str] = []
    last = 0
    for match in _WORD.finditer(text):
        word = match[0]
        pieces.append(text[last : match.start()])
        last = match.end()
        contraction = text[match.end() : match.end() + 1] == "'"  # "what's": read as it is
        first = not text[: match.start()].strip(" ,.!?")
        replacement = None if contraction else _mend_word(word, refused, first)
        if replacement is not None and replacement != word:
            notes.append(f"reading {word!r} as {replacement!r}")
            word = replacement
        pieces.append(word)
    pieces.append(text[last:])
    mended = "".join(pieces)
    for then in _COMPARATIVE_BEFORE_THEN.finditer(mended):
        if then[1] in known:
            mended = mended[: then.end() - 4] + "than" + mended[then.end() :]
            notes.append("reading 'then' as 'than'")
            break
    if not notes:
        return None
    return Mended(mended, tuple(dict.fromkeys(notes)))


@cache
def _mend_word(word: str, refused: bool = False, first: bool = False) -> str | None:
    """What a word of a query is read as, when not as itself: a sense word for an adjective the parser does
    not read, the parser's word for a misspelling of one, the English word for a misspelt one. `refused`:
    the query as typed was refused, and an English word one slip from a sense word is read as it ("which is
    the closet object": closest). `first`: the word opens the query."""
    if word in vocabulary() or len(word) <= 2:
        return None
    english = _is_english(word)
    if english:
        sense = _as_sense_word(word, True)
        slip = _slip_of_sense_word(word) if refused else None
        return sense or _american(word) or _rare_for(word) or slip
    nearest = _nearest_known(word, first)
    if word.endswith(("est", "er")) or len(word) >= 6:
        sense = _as_sense_word(word, False)
        if sense is not None and (nearest is None or _distance(word, sense) < _distance(word, nearest)):
            return sense
    spelt = _speller_word(word)
    if spelt is not None and (nearest is None or _distance(word, spelt) < _distance(word, nearest)):
        return spelt  # "bottel": bottle (one swap), not the parser's "bottom" (two edits)
    return nearest


def _american(word: str) -> str | None:
    """The parser's word a British spelling is ("kilogrammes" -> "kilograms"), or None."""
    known = vocabulary()
    for british, american in _AMERICAN:
        if british in word:
            spelt = word.replace(british, american)
            if spelt in known:
                return spelt
    return None


def _rare_for(word: str) -> str | None:
    """The parser's word one edit from a rare English word, keeping its first letter, where English uses
    it over two hundred times as often ("wich" -> "which"): a misspelling that happens to be a word."""
    counts = language_data().counts
    if len(word) < 3:
        return None
    from rapidfuzz.distance import OSA
    from rapidfuzz.process import extract

    hits = extract(word, _vocabulary_list(), scorer=OSA.distance, score_cutoff=1, limit=8)
    own = counts.get(word, 0)
    near = [w for w, _, _ in hits if w[0] == word[0] and counts.get(w, 0) > 200 * max(own, 1)]
    return near[0] if len(near) == 1 else None


def _slip_of_sense_word(word: str) -> str | None:
    """The senses' word one edit from an English word of five letters or more, keeping its first letter."""
    if len(word) < 5:
        return None
    from rapidfuzz.distance import OSA
    from rapidfuzz.process import extract

    senses = [w for w in sense_words() if " " not in w]
    hits = extract(word, senses, scorer=OSA.distance, score_cutoff=1, limit=8)
    nearest = [str(w) for w, _, _ in hits if w[0] == word[0]]
    return _tie_broken(word, nearest) if nearest else None


def could_mean(query: str) -> str:
    """What the words of a refused query that neither the parser nor English knows could mean, for the
    refusal: "'wich' could be 'which' or 'with'"; empty when there is none."""
    from rapidfuzz.distance import OSA
    from rapidfuzz.process import extract

    known = vocabulary()
    english = language_data().counts
    said = []
    for word in dict.fromkeys(_WORD.findall(query.lower())):
        if len(word) <= 2 or word in known or word in english:
            continue
        hits = extract(word, _vocabulary_list(), scorer=OSA.distance, score_cutoff=2, limit=12)
        near = sorted((score, w) for w, score, _ in hits if w[0] == word[0])[:3]
        if near:
            said.append(f"{word!r} could be " + " or ".join(repr(w) for _, w in near))
        else:
            said.append(f"{word!r} is no word it knows")
    return "; ".join(said)


def unread(query: str) -> bool:
    """Whether `query` holds a word that is neither the parser's nor in the English frequency dictionary (a
    misspelling, most likely): then a reading of it as typed may search for a misspelt name, and the mended
    reading is tried. Cheap: the data it needs is the vocabulary and the frequency dictionary."""
    known = vocabulary()
    english = language_data().counts  # a plain table: no lemminflect (nor numpy) to read a query
    for word in _WORD.findall(query.lower()):
        if len(word) > 2 and word not in known and word not in english:
            return True
    return False


# ---- kinds ------------------------------------------------------------------------------------------------


@cache
def kinds_of(noun: str) -> tuple[str, ...]:
    """The common kinds WordNet lists under a plural noun that names a group ("vegetables": carrot, potato,
    ...): one-word hyponyms, to five levels, that WordNet's sense counts or the frequency dictionary show in
    common use. Empty for a singular,
    a generic noun ("things"), a noun with fewer than eight such kinds, which names objects of its own
    rather than a group ("bottles": a jug is no bottle to most people), and one with over a hundred, too
    broad to list ("foods", "containers")."""
    data = language_data()
    if noun in GENERIC_NOUNS or data.wordnet is None:
        return ()
    singular = data.wordnet.morphy(noun, "n")
    if singular is None or singular == noun:
        return ()
    synsets = data.wordnet.synsets(singular, "n")
    if not synsets:
        return ()
    found: dict[str, None] = {}
    for synset in synsets[0].closure(lambda s: s.hyponyms(), depth=5):
        for lemma in synset.lemmas():
            name = lemma.name().lower()
            common = lemma.count() > 0 or data.counts.get(name, 0) >= 500_000
            if not (name.isalpha() and common and name != singular):
                continue
            if synset in data.wordnet.synsets(name, "n")[:3]:  # what the word mostly means ("key" no fruit)
                found[name] = None
    return tuple(sorted(found)) if 8 <= len(found) <= 100 else ()
