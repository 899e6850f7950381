"""The query families the rules planner reads, one module each, found through one registry.

A family registers a `Family`: the example phrasings it illustrates itself with (the refusal shows
them), its readers (each tried in the order of its number, the first reading that accounts for the
whole text wins) and its program writer for the parsed forms it owns. A new family is one new module here
and its name in `FAMILY_REGISTRY`'s list.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any

from attribot.registry import Registry

__all__ = ["Reading", "Family", "FAMILY_REGISTRY", "readers"]


@dataclass(frozen=True)
class Reading:
    """A query as the readers see it, once the frames around it (action, scope, narrowing) are off."""

    text: str  # normalised
    plain: str  # the same, "which cup is the tallest" said as "the tallest cup"
    opened: bool  # an opening such as "find" or "where is" came first
    whole: str  # what the reading by meaning reads
    original: str  # as asked, for refusals
    question: bool = False  # asked as a question ("mug hot?"): a statement of a state or a comparison asks it


Reader = Callable[[Reading], Any]
"""A reader: the parsed form of the reading, or None when it is not this family's."""


@dataclass(frozen=True)
class Family:
    examples: tuple[str, ...]
    readers: tuple[tuple[int, Reader], ...] = ()
    forms: tuple[type, ...] = ()  # the parsed forms its writer writes
    write: Callable[[Any, Any], None] | None = None  # (the program writer, the parsed form)


FAMILY_REGISTRY: Registry[Family] = Registry(
    "query family",
    tuple(
        f"attribot.planning.rules.families.{m}"
        for m in (
            "location",
            "size",
            "attributes",
            "measure",
            "odd",
            "grounding",
            "yesno",
            "frames",
            "senses",
        )
    ),
)


@cache
def readers() -> list[Reader]:
    """Every family's readers, in the order they are tried."""
    ordered = sorted(
        (
            (order, i, reader)
            for i, (_, family) in enumerate(FAMILY_REGISTRY.items())
            for order, reader in family.readers
        ),
        key=lambda t: (t[0], t[1]),
    )
    return [reader for _, _, reader in ordered]
