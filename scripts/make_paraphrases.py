"""Regenerates tests/data/paraphrases.jsonl: everyday phrasings of the query families, each with its meaning.

Run: `.venv/bin/python scripts/make_paraphrases.py` (deterministic: the same file every time).

Each line: {"query", "family", ...meaning}: family is weight | distance | size | measurement | grounding |
odd; `most` says the direction (heaviest / nearest / largest: true), `noun` the candidates' noun ("object"
for any), `named` the listed names of a comparison (or null), `quantity` what a measurement measures.
The phrasings are written by hand as fragments (openings, attribute expressions, candidate sets) and
combined; they are a regression set for the rules planner, not the acceptance's unseen phrasings.
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "tests" / "data" / "paraphrases.jsonl"

GENERIC = ("object", "item", "thing")
NOUNS = ("mug", "book", "apple", "bottle", "box")

WEIGHT = {
    True: (
        "Which {n} is the heaviest?",
        "Which {n} weighs the most?",
        "What is the heaviest {n}?",
        "the heaviest {n}",
        "Find the heaviest {n}.",
        "Which {n} has the greatest mass?",
        "Show me the heaviest {n}",
        "Which {n} is heaviest?",
        "point at the heaviest {n}",
        "which {n} weighs most",
        "the most heavy {n}",
        "Which {n} has the most weight?",
        "Which {n} would be the heaviest?",
        "Which {n} is heavier than the others?",
        "Which {n} is highest in weight?",
        "Can you tell me which {n} is the heaviest?",
    ),
    False: (
        "Which {n} is the lightest?",
        "Which {n} weighs the least?",
        "What is the lightest {n}?",
        "the lightest {n}",
        "Find the most lightweight {n}.",
        "Which {n} has the lowest mass?",
        "Show me the lightest {n}",
        "Which {n} is lightest?",
        "the least heavy {n}",
        "which {n} weighs least",
        "the {n} that is the lightest",
        "Which {n} has the least weight?",
        "Which {n} weighs less than all the others?",
        "Which {n} is lowest in weight?",
        "I need the lightest {n}",
    ),
}
DISTANCE = {
    True: (
        "Which {n} is the closest to me?",
        "the nearest {n}",
        "Which {n} is closest to the robot?",
        "Find the closest {n}",
        "Which {n} is the nearest to the camera?",
        "which {n} is nearest",
        "the {n} closest to me",
        "What is the closest {n}?",
        "Which {n} in front of you is the nearest?",
        "Which {n} is closer to me than the others?",
    ),
    False: (
        "Which {n} is the farthest away?",
        "the farthest {n}",
        "Which {n} is furthest from me?",
        "which {n} is the most distant",
        "Which {n} is farthest away from the robot?",
        "the {n} farthest from me",
        "What is the furthest {n}?",
        "Find the farthest {n}",
        "What's the farthest {n} you can see?",
    ),
}
SIZE = {
    True: (
        "the largest {n}",
        "Which {n} is the largest?",
        "the biggest {n}",
        "which {n} is the tallest",
        "Which {n} is the largest by size?",
    ),
    False: (
        "the smallest {n}",
        "Which {n} is the smallest?",
        "the tiniest {n}",
        "which {n} is the shortest",
        "What is the smallest {n} here?",
    ),
}
# "Which of the three objects is the heaviest?": the candidate set is any object in view
CANDIDATE_SETS = {
    ("weight", True): (
        "Which of the three objects is the heaviest?",
        "Which of these three items is the heaviest?",
        "Which of the objects is heaviest?",
        "Of all the things here, which weighs the most?",
    ),
    ("weight", False): (
        "Which of the three is the lightest?",
        "Among these, which one would be the lightest?",
        "Which one of the items weighs the least?",
    ),
    ("distance", True): (
        "Which of the 3 objects is the closest to me?",
        "Of all the items, which is nearest?",
    ),
    ("distance", False): ("Which of these things is the farthest away?",),
    ("size", True): ("Which of the objects is the biggest?",),
    ("size", False): ("Which of these items is the smallest?",),
}
NAMED_WEIGHT = {
    True: (
        "Out of the {a}, the {b} and the {c}, which one is the heaviest?",
        "Give me the heaviest of the {a}, the {b} and the {c}",
        "Is the {a} heavier than the {b}?",
        "Which is heavier: the {a} or the {b}?",
        "Does the {a} weigh more than the {b}?",
        "Which is heavier, the {a}, the {b} or the {c}?",
    ),
    False: (
        "Out of the {a}, the {b} and the {c}, which one is the most lightweight?",
        "Give me the lightest of the {a}, the {b} and the {c}",
        "Is the {a} lighter than the {b}?",
        "Between the {a} and the {b}, which is lighter?",
    ),
}
NAMED_DISTANCE = {
    True: (
        "Is the {a} or the {b} closer to me?",
        "Is the {a} closer to me than the {b}?",
        "Which is closer to me: the {a} or the {b}?",
    ),
    False: (
        "Is the {a} or the {b} farther from me?",
        "Is the {a} farther from me than the {b}?",
        "Which one is farther away, the {a} or the {b}?",
    ),
}
MEASURE = {
    "distance": (
        "How far away is the {a}?",
        "How far is the {a}?",
        "What's the distance to the {a}?",
        "How far away from me is the {a}?",
    ),
    "weight": ("How heavy is the {a}?", "How much does the {a} weigh?", "What is the weight of the {a}?"),
}
GROUNDING = ("Where is the {a}?", "Find the {a}", "Point at the {a}", "Show me the {a}", "the {c} {a}")
ODD = (
    "the odd one out",
    "Which object does not belong?",
    "which one is different",
    "What is the odd one out?",
    "Which one is different from the others?",
)
COLOURS = ("red", "blue", "teal", "green")


def rows() -> list[dict]:
    out: list[dict] = []
    for (family, table), noun in itertools.product(
        (("weight", WEIGHT), ("distance", DISTANCE), ("size", SIZE)), GENERIC + NOUNS
    ):
        for most, forms in table.items():
            for form in forms:
                out.append({"query": form.format(n=noun), "family": family, "most": most, "noun": noun})
    for (family, most), forms in CANDIDATE_SETS.items():
        out += [{"query": q, "family": family, "most": most, "noun": "object"} for q in forms]
    triples = [("apple", "book", "kettle"), ("mug", "bottle", "lamp"), ("phone", "box", "chair")]
    for family, table in (("weight", NAMED_WEIGHT), ("distance", NAMED_DISTANCE)):
        for (a, b, c), (most, forms) in itertools.product(triples, table.items()):
            for form in forms:
                named = [a, b, c] if "{c}" in form else [a, b]
                out.append(
                    {"query": form.format(a=a, b=b, c=c), "family": family, "most": most, "named": named}
                )
    for (quantity, forms), noun in itertools.product(MEASURE.items(), NOUNS):
        for form in forms:
            out.append(
                {"query": form.format(a=noun), "family": "measurement", "quantity": quantity, "noun": noun}
            )
    for form, (noun, colour) in itertools.product(GROUNDING, zip(NOUNS, COLOURS * 2, strict=False)):
        out.append({"query": form.format(a=noun, c=colour), "family": "grounding", "noun": noun})
    out += [{"query": q, "family": "odd", "noun": "object"} for q in ODD]
    seen: set[str] = set()
    return [r for r in out if not (r["query"] in seen or seen.add(r["query"]))]


def main() -> None:
    OUT.parent.mkdir(parents=True, exist_ok=True)
    data = rows()
    OUT.write_text("".join(json.dumps(r, sort_keys=True) + "\n" for r in data))
    print(f"{len(data)} phrasings -> {OUT}")


if __name__ == "__main__":
    main()
