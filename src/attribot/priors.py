"""Perception priors of our own: what a person knows of everyday things at a glance (a knife lies flat, a mug
is about 10 cm tall, a basketball is put on the floor), coarse and deliberately wide.

The error-catching mechanisms weigh what depth and colour see against these (`attribot.skills.harder`: sizes,
heights, spans, places and colours of a kind; `attribot.skills.measuring`: what an empty container weighs and
holds), and the coco detector reads its everyday names of a class here. Never the simulator's catalog, its
meshes or its renderer's colours (DESIGN.md, "Control acts on perception only"): a real robot in a real room
knows no more than this table.

The table is package data, `attribot/data/priors.toml` (its header says what each field means and where
the values come from: common knowledge, coarse), checked on load by the pydantic models below: an unknown
key, a negative or reversed range, a colour it does not define or a name given to two kinds is refused with
an error that names the kind and the field. `priors(scale)` is the table with every length scaled by
`scale` (`Settings.priors_scale`, within `SCALE_RANGE`), for an ablation on how much the mechanisms lean on
these numbers; masses are left as they are.
"""

from __future__ import annotations

import re
import tomllib
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Annotated, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    model_validator,
)

from attribot.errors import ConfigError
from attribot.lexicon import COLOR_WORDS, singular_forms

__all__ = [
    "PLACES",
    "SCALE_RANGE",
    "Kind",
    "Priors",
    "Range",
    "load_priors",
    "priors",
]

SCALE_RANGE = (0.25, 4.0)
"""The factors `priors(scale)` takes: a quarter to four times every length (a mug of 2.5 cm to 40 cm), a wide
enough ablation; outside it the ranges say nothing a person would recognise."""

Place = Literal["floor", "table", "counter", "shelf", "desk", "chair", "bed", "sofa", "wall"]
PLACES: tuple[str, ...] = Place.__args__  # type: ignore[attr-defined]
"""Where a thing may usually be put ("floor" is the floor or the ground)."""


def _range(value: tuple[float, float]) -> tuple[float, float]:
    low, high = value
    if not (low > 0 and high > 0):
        raise ValueError(f"a range must be positive; got [{low}, {high}]")
    if low > high:
        raise ValueError(f"a range is [smallest, largest]; got [{low}, {high}]")
    return value


Range = Annotated[tuple[float, float], AfterValidator(_range)]
"""(low, high), both positive, low <= high."""
Rgb = tuple[
    Annotated[int, Field(ge=0, le=255)],
    Annotated[int, Field(ge=0, le=255)],
    Annotated[int, Field(ge=0, le=255)],
]


class Kind(BaseModel):
    """One kind of everyday thing (see `attribot/data/priors.toml` for each field's meaning); lengths in
    metres, masses in kilograms."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str
    coco: str | None = None
    also: tuple[str, ...] = ()
    size_m: Range
    height_m: Range
    across_m: Range
    places: tuple[Place, ...] = Field(min_length=1)
    colours: tuple[str, ...] = ()
    empty_kg: Range | None = None
    holds_kg: Range | None = None

    @model_validator(mode="after")
    def _consistent(self) -> Kind:
        # the largest extent bounds how far it rises and how far it spans (a little slack for rounding)
        for what, (_, high) in (("height_m", self.height_m), ("across_m", self.across_m)):
            if high > self.size_m[1] * 1.001:
                raise ValueError(f"{what} reaches {high}, past the largest size {self.size_m[1]}")
        if (self.empty_kg is None) != (self.holds_kg is None):
            raise ValueError("a container gives both empty_kg and holds_kg")
        if len(set(self.places)) != len(self.places):
            raise ValueError("a place is named twice")
        return self

    @property
    def words(self) -> tuple[str, ...]:
        """Its name and its other names."""
        return (self.name, *self.also)

    @property
    def container(self) -> bool:
        """Whether the table knows what it weighs empty and what it holds."""
        return self.empty_kg is not None and self.holds_kg is not None

    @property
    def placement(self) -> Literal["floor", "surface"] | None:
        """Where it is put, as the mechanisms tell places apart: "floor" (only on the floor), "surface" (on
        furniture, never the floor), None (either: nothing rules a place out)."""
        if set(self.places) <= {"floor", "wall"}:
            return "floor"
        if "floor" not in self.places:
            return "surface"
        return None

    def scaled(self, factor: float) -> Kind:
        """This kind with every length multiplied by `factor` (masses kept)."""
        if factor == 1.0:
            return self

        def times(r: tuple[float, float]) -> tuple[float, float]:
            return (r[0] * factor, r[1] * factor)

        return self.model_copy(
            update={
                "size_m": times(self.size_m),
                "height_m": times(self.height_m),
                "across_m": times(self.across_m),
            }
        )


class Priors(BaseModel):
    """The whole table: the colours it names (sRGB, 0-255) and the kinds, keyed by their everyday name."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    colours: dict[str, Rgb]
    kinds: dict[str, Kind]
    scale: float = 1.0  # the factor the lengths were scaled by (`scaled`)
    _words: dict[str, Kind] = PrivateAttr(default_factory=dict)
    _classes: dict[str, tuple[Kind, ...]] = PrivateAttr(default_factory=dict)
    _hash: int = PrivateAttr(0)

    @model_validator(mode="before")
    @classmethod
    def _named(cls, data: object) -> object:
        # each kind's table is keyed by its name; the name is its own field once loaded
        if isinstance(data, dict) and isinstance(data.get("kinds"), dict):
            kinds = {k: {**v, "name": k} if isinstance(v, dict) else v for k, v in data["kinds"].items()}
            data = {**data, "kinds": kinds}
        return data

    @model_validator(mode="after")
    def _coherent(self) -> Priors:
        unknown = sorted(set(self.colours) - COLOR_WORDS)
        if unknown:
            raise ValueError(f"colours {unknown} are not colour words of attribot.lexicon")
        seen: dict[str, str] = {}
        for kind in self.kinds.values():
            missing = [c for c in kind.colours if c not in self.colours]
            if missing:
                raise ValueError(f"kind {kind.name!r} names colours the table does not define: {missing}")
            for word in kind.words:
                key = _key(word)
                if key in seen and seen[key] != kind.name:
                    raise ValueError(
                        f"the name {word!r} is given to two kinds: {seen[key]!r} and {kind.name!r}"
                    )
                seen[key] = kind.name
        return self

    def scaled(self, factor: float) -> Priors:
        """The table with every length multiplied by `factor` (within `SCALE_RANGE`)."""
        _check_scale(factor)
        if factor == 1.0:
            return self
        kinds = {name: kind.scaled(factor) for name, kind in self.kinds.items()}
        return Priors(colours=self.colours, kinds=kinds, scale=self.scale * factor)

    def find(self, phrase: str) -> Kind | None:
        """The kind a word or phrase names (a name or another name, or a plural of either), or None: whole
        phrases first ("cell phones"), then the longest known run of words inside it ("the red coffee mug":
        coffee mug, a cup)."""
        text = re.sub(r"[^a-z ]+", " ", phrase.lower()).split()
        table = self._by_word()
        for n in range(len(text), 0, -1):  # longest first: "tennis ball" beats "ball"
            for i in range(len(text) - n + 1):
                head, last = text[i : i + n - 1], text[i + n - 1]
                for form in singular_forms(last):
                    kind = table.get(" ".join([*head, form]))
                    if kind is not None:
                        return kind
        return None

    def of_class(self, coco: str) -> tuple[Kind, ...]:
        """The kinds a closed-set detector's class covers (a sports ball: a tennis ball to a basketball)."""
        return self._by_class().get(coco, ())

    def class_sizes(self, coco: str) -> tuple[float, float] | None:
        """The smallest and largest size (metres) of the kinds of the class `coco`; None for a class the
        table does not know."""
        kinds = self.of_class(coco)
        if not kinds:
            return None
        return (min(k.size_m[0] for k in kinds), max(k.size_m[1] for k in kinds))

    def class_of(self, phrase: str) -> str | None:
        """The COCO class of the kind `phrase` names, or None."""
        kind = self.find(phrase)
        return None if kind is None else kind.coco

    def model_post_init(self, context: object, /) -> None:
        self._words = {_key(w): kind for kind in self.kinds.values() for w in kind.words}
        classes: dict[str, list[Kind]] = {}
        for kind in self.kinds.values():
            if kind.coco is not None:
                classes.setdefault(kind.coco, []).append(kind)
        self._classes = {c: tuple(ks) for c, ks in classes.items()}
        self._hash = hash((self.scale, tuple(self.kinds), tuple(self.colours)))

    def __hash__(self) -> int:  # a table is a cache key of the mechanisms (equal tables hash alike)
        return self._hash

    def _by_word(self) -> dict[str, Kind]:
        return self._words

    def _by_class(self) -> dict[str, tuple[Kind, ...]]:
        return self._classes


def _key(word: str) -> str:
    return " ".join(re.sub(r"[^a-z ]+", " ", word.lower()).split())


def _check_scale(factor: float) -> None:
    low, high = SCALE_RANGE
    if not (low <= factor <= high):
        raise ConfigError(
            f"the priors' scale must be within {low} to {high}; got {factor}",
            "give a factor such as 0.7 or 1.3 (1.0: the table as written)",
        )


def load_priors(path: Path | None = None) -> Priors:
    """The table at `path` (default: the package's `attribot/data/priors.toml`), checked; a file that is no
    TOML or breaks a rule raises `ConfigError` naming the file and what is wrong."""
    where = str(path) if path is not None else "attribot/data/priors.toml"
    try:
        if path is None:
            text = resources.files("attribot").joinpath("data", "priors.toml").read_text(encoding="utf-8")
        else:
            text = path.read_text(encoding="utf-8")
        data = tomllib.loads(text)
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(
            f"cannot read the perception priors {where}: {exc}", "fix or restore the file"
        ) from None
    try:
        return Priors.model_validate(data)
    except ValidationError as exc:
        lines = "; ".join(
            f"{'.'.join(str(p) for p in err['loc']) or 'the file'}: {err['msg']}" for err in exc.errors()[:5]
        )
        raise ConfigError(
            f"the perception priors {where} are not valid: {lines}",
            "each kind gives size_m, height_m, across_m (positive [low, high]) and places, and no other key "
            "than those the file's header lists",
        ) from None


@cache
def _shipped() -> Priors:
    return load_priors()


@cache
def priors(scale: float = 1.0) -> Priors:
    """The package's table, every length scaled by `scale` (1.0: as written; `SCALE_RANGE`), read once."""
    _check_scale(scale)
    return _shipped().scaled(scale)
