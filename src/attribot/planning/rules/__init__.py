"""The offline planner: a deterministic parser for the query families of the paper and beyond.

It reads location, size, weight and distance queries (see `FAMILIES`) and writes the same kind of program
an LLM writes against the API: `find` the objects the query names, then order or measure them. Rows and
columns are found by clustering box centres, not by cutting the image into equal bands (the failure the
paper reports for GPT-3.5). "long" and "short" follow the object's orientation (the longer box side).
Weight and distance are measured with the robot's sensors when it has them; otherwise the program uses
the paper's VQA + language-model chain (weight) or a visual proxy that it states in a comment
(distance). A query outside these families raises `UnsupportedQuery`, which lists what is supported: the
planner never guesses.

A question is read in parts: the frames around a reading (an action, a scope, a narrowing, objects left out
with "apart from", "the next ... after" an object) come off first, then the families read what is left. A
query the parser refuses as typed, or one holding a word no dictionary knows, is read again with its words
mended by the language front end (`understand`: misspellings, WordNet synonyms in their degree, British
spellings); the program says what was read as what, and a refusal names the words it could not place and
what they could mean.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from attribot.planning.query import check_query
from attribot.planning.rules.families import FAMILY_REGISTRY
from attribot.planning.rules.forms import (
    Among,
    DistanceQuery,
    GroundingQuery,
    LineSpec,
    LocationQuery,
    MeasureQuery,
    ObjectSpec,
    OddQuery,
    ParsedQuery,
    Pick,
    Region,
    Request,
    SenseQuery,
    SizeQuery,
    Understood,
    UnsupportedQuery,
    WeightQuery,
    YesNoQuery,
)
from attribot.planning.rules.read import parse_query
from attribot.planning.rules.write import write_program

if TYPE_CHECKING:
    from attribot.planning.rules.planner import RulesPlanner

FAMILIES: dict[str, tuple[str, ...]] = {name: family.examples for name, family in FAMILY_REGISTRY.items()}
"""The families the rules planner reads, each with example phrasings (each family module registers its
own)."""

__all__ = [
    "FAMILIES",
    "UnsupportedQuery",
    "ObjectSpec",
    "LineSpec",
    "Pick",
    "LocationQuery",
    "SizeQuery",
    "WeightQuery",
    "DistanceQuery",
    "GroundingQuery",
    "MeasureQuery",
    "OddQuery",
    "YesNoQuery",
    "SenseQuery",
    "Among",
    "Region",
    "Request",
    "ParsedQuery",
    "Understood",
    "parse_query",
    "write_program",
    "rules_program",
    "RulesPlanner",
]


def rules_program(query: str, sensors: Sequence[str] = ("camera",), embodied: bool = False) -> str:
    """Parse `query` and write its program in one step."""
    return write_program(parse_query(query), check_query(query), sensors, embodied)


def __getattr__(name: str) -> Any:
    if name == "RulesPlanner":  # with the planner protocol, which loads the API: only when asked
        from attribot.planning.rules.planner import RulesPlanner

        return RulesPlanner
    raise AttributeError(f"module 'attribot.planning.rules' has no attribute {name!r}")
