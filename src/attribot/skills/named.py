"""Which objects the names of a question mean among those a program measured: one object a name, and no
two names one object. Read on the host after a program chose (`Measuring.settle`, `Measuring.as_named`):
a choice where a name has no object of its own is no answer (`named_twice`), and where a program measured
several objects under one name and took the extreme of all, the answer is its comparison made again among
the objects the detector is surest of under each name (`as_named`)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from attribot.lexicon import GENERIC_NOUNS, IRREGULAR_PLURALS
from attribot.priors import priors
from attribot.skills.checks import patch_named
from attribot.skills.robot_core import Measurement, _name_key, _without_article
from attribot.skills.sighting import Sighting

__all__ = ["named_twice", "as_named", "by_object", "combined", "Measured"]

Measured = Sequence[tuple[Measurement, Sighting]]
"""A session's measurements, each with the patch it measured, in measuring order."""


def by_object(measured: Measured, kind: str) -> list[list[tuple[Measurement, Sighting]]]:
    """The measurements of `kind` and their patches, one group per object measured, in measuring order."""
    groups: list[list[tuple[Measurement, Sighting]]] = []
    for m, p in measured:
        if m.kind != kind:
            continue
        at = _object_at([g[0][1] for g in groups], p)
        if at is None:
            groups.append([(m, p)])
        else:
            groups[at].append((m, p))
    return groups


def combined(groups: list[list[tuple[Measurement, Sighting]]]) -> list[tuple[float, float, Sighting]]:
    """Each object's readings (`by_object`'s groups) combined, inverse-variance mean: (value, sd, patch)."""
    out = []
    for g in groups:
        weights = [1.0 / max(m.uncertainty, 1e-6) ** 2 for m, _ in g]
        value = sum(w * m.value for w, (m, _) in zip(weights, g, strict=True)) / sum(weights)
        out.append((value, 1.0 / math.sqrt(sum(weights)), g[0][1]))
    return out


def named_twice(measured: Measured, kind: str) -> tuple[Sighting, Sighting] | None:
    """Two patches of different names measured for `kind` that show one object, where the names cannot
    each have an object of their own among those measured; or None. A question about the orange and the
    apple asks about two objects: where the detector gave one object both names (an apple boxed as an
    orange at 0.32 and as an apple at 0.35, in a room with no orange), the orange is not found, and a
    comparison of that object with itself is no answer. Names that each have an object besides are
    found: a program that measures every box of each name (a second box of "mug" on the vase) chose
    among objects, each measured. Two names of one thing by design are not counted: a generic word
    ("object") and the name, or one name twice ("the mug" found again)."""
    seen: list[Sighting] = []
    for m, p in measured:
        if m.kind == kind and all(p is not q for q in seen):
            seen.append(p)
    names = _names_of(by_object(measured, kind))
    unmatched = _without_object({k: {at for at, _ in found} for k, found in names.items() if _names_one(k)})
    if unmatched is None:
        return None
    pairs = (
        (mine, other)
        for mine in seen
        if _name_key(mine.label or "") == unmatched
        for other in seen
        if _two_names(mine.label, other.label) and other.same_object(mine)
    )
    return next(pairs, None)


def as_named(measured: Measured, kind: str, chosen: Sighting) -> tuple[Sighting, str] | None:
    """After a program chose `chosen` among objects measured for `kind` under two names or more: the
    object the question's names choose, with the sentence that says why, where it is not `chosen`;
    None where the program's choice stands.

    A question about "the bottle or the vase" names one vase. Where the detector boxed two things as a
    vase (the vase at 0.89, a jug beside it at 0.40) and the program measured both and took the closest
    of all, its answer hangs on the jug. Here each name means the object the detector is surest of
    under it (`_surest`: a sure box before a faint one or an inference, then the higher score), and the
    program's own comparison (the largest or the smallest of the values it measured) is made again
    among those. Nothing changes where a name is generic ("object") or plural, where every name has
    one object, where a name's objects are equally sure or the surest is no sure box, where two names'
    surest objects are one, or where the chosen value is no extreme."""
    groups = by_object(measured, kind)
    values = [v for v, _, _ in combined(groups)]
    of = _names_of(groups)
    if any(not _names_one(k) or any(_plural(p.label or "") for _, p in found) for k, found in of.items()):
        return None
    if len(of) < 2 or all(len({at for at, _ in found}) == 1 for found in of.values()):
        return None
    surest: dict[str, tuple[int, Sighting]] = {}
    for key, found in of.items():
        best = _surest(found)
        if best is None or any(best[0] == other[0] for other in surest.values()):
            return None
        surest[key] = best
    mine = next(i for i, g in enumerate(groups) if _object_at([p for _, p in g], chosen) is not None)
    pick = _extreme_among(values, mine, [at for at, _ in surest.values()])
    if pick is None or pick == mine:
        return None
    patch = next(p for at, p in surest.values() if at == pick)
    mine_name = _name_key(chosen.label or "")
    if mine_name not in surest:
        return None
    count = len({at for at, _ in of[mine_name]})
    surest_box = ", ".join(str(round(v)) for v in surest[mine_name][1].box)
    said = _without_article(chosen.label or "")
    return patch, (
        f"the question names one {said}: the one at [{surest_box}], the surest of the {count} the detector "
        f"boxed as {said}; the program chose {patch_named(chosen)}"
    )


def _names_of(groups: list[list[tuple[Measurement, Sighting]]]) -> dict[str, list[tuple[int, Sighting]]]:
    """Each name measured (as compared, `_name_key`) with its objects: (the object's index among
    `by_object`'s groups, the patch measured under that name), one pair a measurement."""
    of: dict[str, list[tuple[int, Sighting]]] = {}
    for at, group in enumerate(groups):
        for _, p in group:
            of.setdefault(_name_key(p.label or ""), []).append((at, p))
    return of


def _two_names(a: str | None, b: str | None) -> bool:
    """Whether two labels name two objects: both given, neither a generic word, and different as compared
    (`_name_key`: "the Mugs" is "mug")."""
    keys = [_name_key(x or "") for x in (a, b)]
    return all(_names_one(k) for k in keys) and keys[0] != keys[1]


def _names_one(key: str) -> bool:
    """Whether a compared name (`_name_key`) names one kind of object: given, and no generic word."""
    return bool(key) and key.split()[-1] not in GENERIC_NOUNS


def _object_at(objects: Sequence[Sighting], patch: Sighting) -> int | None:
    """Where `patch`'s object is among `objects` (one patch per object: the same patch, or `same_object`),
    or None."""
    return next((i for i, o in enumerate(objects) if o is patch or o.same_object(patch)), None)


def _without_object(of: dict[str, set[int]]) -> str | None:
    """A name that cannot have an object of its own when each name takes one of its objects, no two names
    the same (a matching of names to objects, by augmenting paths); None where every name can."""
    taken: dict[int, str] = {}

    def place(name: str, tried: set[int]) -> bool:
        for obj in sorted(of[name] - tried):
            tried.add(obj)
            if obj not in taken or place(taken[obj], tried):
                taken[obj] = name
                return True
        return False

    return next((name for name in of if not place(name, set())), None)


_SURENESS = {"sure box": 2, "seen nearer": 2, "faint box": 1}
"""How sure a patch's evidence is: the detector's sure box (seen here or nearer), its faint box, and below
both an inference (elimination, a look-alike) or none."""


def _surest(found: list[tuple[int, Sighting]]) -> tuple[int, Sighting] | None:
    """The object (its index, its patch) the detector is surest of among those `found` under one name: by
    evidence, then score; None where two objects are equally sure (the oracle's boxes all score 1), or
    where the surest of several is no sure box: among faint boxes and inferences the score does not tell
    the object named from the things it cannot name (`attribot.models.base.GUESSED`)."""

    def sureness(p: Sighting) -> tuple[int, float]:
        return _SURENESS.get(p.evidence or "", 0), p.score if p.score is not None else 0.0

    best: dict[int, tuple[tuple[int, float], Sighting]] = {}
    for at, p in found:
        if at not in best or sureness(p) > best[at][0]:
            best[at] = (sureness(p), p)
    ranked = sorted(best.items(), key=lambda item: item[1][0], reverse=True)
    if len(ranked) > 1 and (ranked[0][1][0] == ranked[1][1][0] or ranked[0][1][0][0] < _SURENESS["sure box"]):
        return None
    return ranked[0][0], ranked[0][1][1]


def _extreme_among(values: Sequence[float], mine: int, among: Sequence[int]) -> int | None:
    """The object among `among` whose value is the extreme that `mine`'s is among all `values` (the
    smallest, or the largest); None where `mine`'s is neither, or where two tie for it."""
    low, high = min(values), max(values)
    if values.count(values[mine]) > 1 or values[mine] not in (low, high):
        return None
    chosen = sorted(among, key=lambda i: values[i], reverse=values[mine] == high)
    if len(chosen) > 1 and values[chosen[0]] == values[chosen[1]]:
        return None
    return chosen[0]


def _plural(label: str) -> bool:
    """Whether an object's name reads as a plural ("the apples", "two mice"): such a name may mean several
    objects. A name whose last word is itself a kind's word in the priors ("cactus", "scissors") is not."""
    name = _without_article(label.lower())
    last = name.split()[-1] if name else ""
    if last in IRREGULAR_PLURALS:
        return True
    if not last.endswith("s") or last.endswith("ss"):
        return False
    kind = priors().find(name)
    return kind is None or all(w.split()[-1] != last for w in kind.words)
