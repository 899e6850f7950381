#!/usr/bin/env python3
"""The planner understands, not matches: typos, word forms, denials, exclusions, groups and wrappers,
answered on generated scenes and checked against the world.

Three sets, kept apart:

- tuning (tests/data/understanding_tuning.jsonl): the questions of the issue that asked for this reading,
  the only ones looked at while writing it;
- test (tests/data/understanding_test.jsonl): a held-out battery written before it was first scored, not
  tuned on;
- generated (built here from `--gen-seed`): every sense x form x filter x wrapper, with a typo injected into
  the sense word or the noun in every other row, to show that new combinations of known parts are read.

Rows use the schema of benchmarks/accuracy_english.py (its scenes, truths and judge) and add:

- `exclude`: a category in the scene (`named`) left out of the choice ("apart from the kettle");
- `after`: a category in the scene; the truth is the object just past it in the order asked ("the next
  heaviest after the toaster"), when the values on either side of it are clearly apart;
- `group`: the categories of a group ("the fruits": apple, banana, orange); the scene (`named`) holds others
  too (in view), and the truth is chosen among the group's;
- `typo`: the generated row had a typo injected (reported apart: a typo may cost at most one refusal in ten).

An answer is right, refused (the planner said it cannot read the query, or any other failure with no
answer) or a misread (a confident answer about another object or attribute).

    .venv/bin/python benchmarks/accuracy_understanding.py --part tuning
    .venv/bin/python benchmarks/accuracy_understanding.py --part test
    .venv/bin/python benchmarks/accuracy_understanding.py --part generated --gen-seed 0 [--limit N]
    .venv/bin/python benchmarks/accuracy_understanding.py --typo-check --gen-seeds 5

`--typo-check` draws no scene: for every row of the generated set with a typo (over `--gen-seeds` draws), it
compares the program written for it with the program written for the same row without the typo (the
query's own comment and the stated reading aside). The same program gives the same answer; another one
searches a misread name and finds nothing, or is a misreading.
"""

from __future__ import annotations

import argparse
import json
import random
from pathlib import Path
from typing import Any

import accuracy_english as english
import accuracy_generalisation as everyday
import accuracy_senses as senses
from attribot.config import SceneConfig

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"
PARTS = {
    "tuning": DATA / "understanding_tuning.jsonl",
    "test": DATA / "understanding_test.jsonl",
}
SENSORS = english.SENSORS


def _value(o: Any, attr: str) -> float | None:
    if attr in english.SENSES:
        return senses._value(o, attr)
    if attr == "weight" and not o.pickable:
        return None
    return everyday._value(o, attr)


def _apart(a: float, b: float, attr: str) -> bool:
    return senses._apart(a, b, attr) if attr in english.SENSES else everyday._apart(a, b, attr)


def _truth(row: dict[str, Any], visible: list[Any]) -> Any:
    inner = {k: v for k, v in row.items() if k not in ("exclude", "after", "group", "named", "typo")}
    if row["kind"] in ("yesno", "compare") and "named" in row:
        inner["named"] = row["named"]
    if "named" in row and sorted(o.category for o in visible) != sorted(row["named"]):
        return None  # every object of the scene in view, and none other
    if "exclude" in row:
        left_out = [o for o in visible if o.category == row["exclude"]]
        if len(left_out) != 1:
            return None
        rest = [o for o in visible if o is not left_out[0]]
        truth = english._truth(inner, rest)
        # the exclusion must matter: the object left out would have been chosen without it
        return truth if truth is not None and english._truth(inner, visible) == left_out[0].id else None
    if "group" in row:
        pool = [o for o in visible if o.category in row["group"]]
        if len(pool) < 2 or len(pool) == len(visible):
            return None
        return english._truth(inner, pool)
    if "after" in row:
        pool = [o for o in visible if _value(o, row["attr"]) is not None]
        ranked = sorted(pool, key=lambda o: _value(o, row["attr"]), reverse=row["dir"] == "max")  # type: ignore[arg-type, return-value]
        at = [i for i, o in enumerate(ranked) if o.category == row["after"]]
        if len(at) != 1 or at[0] + 1 >= len(ranked):
            return None
        i = at[0]
        values = [_value(o, row["attr"]) for o in ranked]
        for j in (i - 1, i + 1):
            k = j + 1
            if 0 <= j < len(values) - 1 and not _apart(values[j], values[k], row["attr"]):  # type: ignore[arg-type]
                return None
        return ranked[i + 1].id
    return english._truth(inner, visible)


def _config(row: dict[str, Any], seed: int) -> SceneConfig:
    if "named" in row and row["kind"] not in ("yesno", "compare"):
        named = tuple(row["named"])
        return SceneConfig(layout="household", seed=seed, categories=named, objects=len(named))
    return english._config(row, seed)


def scene_for(row: dict[str, Any], seed: int) -> tuple[SceneConfig, Any] | None:
    """A scene the question applies to and its truth, or None when none could be generated."""
    return english.scene_for(row, seed, _config, _truth)


# ---- the generated set ---------------------------------------------------------------------------------

SENSE_PARTS: dict[str, dict[str, Any]] = {
    # attr: the noun of a scene of one kind, the superlatives of each end, comparatives, a pair to compare,
    # the objects of a scene with one left out, and the one left out for each end
    "weight": {"noun": "object", "max": "heaviest", "min": "lightest", "cmp": ("heavier", "lighter"),
               "pair": ("dumbbell", "book"), "others": ("dumbbell", "book", "mug", "apple"),
               "drop": {"max": "dumbbell", "min": "apple"}},
    "distance": {"noun": "object", "max": "farthest", "min": "closest", "cmp": ("farther", "closer"),
                 "pair": ("lamp", "vase"), "others": ("lamp", "vase", "book", "mug"),
                 "drop": {"max": "lamp", "min": "lamp"}},
    "temperature": {"noun": "mug", "max": "hottest", "min": "coldest", "cmp": ("hotter", "colder"),
                    "pair": ("kettle", "can"), "others": ("kettle", "mug", "can"),
                    "drop": {"max": "kettle", "min": "can"}},
    "stiffness": {"noun": "ball", "max": "hardest", "min": "softest", "cmp": ("harder", "softer"),
                  "pair": ("apple", "foam ball"), "others": ("ball", "apple", "foam ball", "tennis ball"),
                  "drop": {"max": "apple", "min": "foam ball"}},
    "fullness": {"noun": "bottle", "max": "fullest", "min": "emptiest", "cmp": ("fuller", "emptier"),
                 "pair": ("bottle", "jar"), "others": ("bottle", "mug", "jar"),
                 "drop": {"max": "bottle", "min": "bottle"}},
}  # fmt: skip
WRAPPERS = (
    "{q}?",
    "hey robot, could you check {q}?",
    "please tell me {q}",
    "ok so {q} for me",
    "{q}, thanks",
)
FILTERS = ("none", "exclude", "group")
FORMS = ("superlative", "which-is", "yesno")
FRUITS = ("apple", "banana", "orange")


def _typo(word: str, rng: random.Random) -> str:
    """One slip of the keyboard in `word`, past its first letter: a letter dropped, doubled, two swapped."""
    i = rng.randrange(1, len(word) - 1)
    slip = rng.choice(("drop", "double", "swap"))
    if slip == "drop":
        return word[:i] + word[i + 1 :]
    if slip == "double":
        return word[:i] + word[i] + word[i:]
    return word[:i] + word[i + 1] + word[i] + word[i + 2 :]


def generate(seed: int) -> list[dict[str, Any]]:
    """Every sense x form x filter x wrapper, both ends, a typo in every other row (in the sense word or the
    noun, chosen by `seed`); combinations a form does not take (a yes/no question with a filter) left out."""
    rng = random.Random(seed)
    rows = []
    for attr, parts in SENSE_PARTS.items():
        for end in ("max", "min"):
            for form in FORMS:
                for filt in FILTERS:
                    if form == "yesno" and filt != "none":
                        continue
                    if filt == "group" and attr not in ("weight", "distance"):
                        continue
                    for w_index, wrapper in enumerate(WRAPPERS):
                        typo = (len(rows) + w_index) % 2 == 1
                        rows.append(_row(attr, parts, end, form, filt, wrapper, typo, rng))
    return rows


def _row(
    attr: str, parts: dict[str, Any], end: str, form: str, filt: str, wrapper: str, typo: bool,
    rng: random.Random,
) -> dict[str, Any]:  # fmt: skip
    word = parts[end] if form != "yesno" else parts["cmp"][0 if end == "max" else 1]
    noun = parts["noun"]
    row: dict[str, Any] = {"form": f"{form}/{filt}", "attr": attr, "dir": end}
    if filt == "group":
        noun = "fruits"
        row.update(named=[*FRUITS, "book", "mug"], group=list(FRUITS), noun="object")
    elif filt == "exclude":
        # left out: the object most often at the end asked, so that leaving it out changes the answer
        row.update(named=list(parts["others"]), exclude=parts["drop"][end], noun="object")
        noun = "thing"  # any of the scene's objects but the one left out
    target = rng.choice(("word", "noun")) if typo else None
    if target == "noun" and noun in ("object", "thing") or form == "yesno" and target == "noun":
        target = "word"
    if typo and target == "word":
        word = _typo(word, rng)
    elif typo:
        noun = _typo(noun, rng)
    if form == "yesno":
        a, b = parts["pair"]
        question = f"is the {a} {word} than the {b}"
        row.update(kind="yesno", named=[a, b])
    else:
        row.update(kind="extreme")
        row.setdefault("noun", parts["noun"])
        if form == "superlative":
            question = (
                f"which is the {word} {noun}" if filt != "group" else f"which of the {noun} is the {word}"
            )
        else:
            question = f"which {noun} is the {word}" if filt != "group" else f"the {word} of the {noun}"
    row["query"] = wrapper.format(q=question)
    if filt == "exclude" and wrapper == WRAPPERS[0]:
        row["query"] = f"apart from the {row['exclude']}, {row['query']}"
    elif filt == "exclude":
        row["query"] = wrapper.format(q=f"{question} except the {row['exclude']}")
    row["typo"] = typo
    return row


def typo_check(seeds: int) -> None:
    """Print how many typo rows of the generated set are written as the same program as without the typo."""
    from attribot.errors import InputError
    from attribot.planning.rules import rules_program

    def body(program: str) -> str:
        said = ("# Query", "# Reading", 'print("Understood')
        return "\n".join(line for line in program.splitlines() if not line.strip().startswith(said))

    same = other = refused = 0
    for seed in range(seeds):
        rng = random.Random(seed)
        for attr, parts in SENSE_PARTS.items():
            for end in ("max", "min"):
                for form in FORMS:
                    for filt in FILTERS:
                        if (form == "yesno" and filt != "none") or (
                            filt == "group" and attr not in ("weight", "distance")
                        ):
                            continue
                        for wrapper in WRAPPERS:
                            typo = _row(attr, parts, end, form, filt, wrapper, True, rng)
                            clean = _row(attr, parts, end, form, filt, wrapper, False, random.Random(0))
                            try:
                                want = body(rules_program(clean["query"], SENSORS, True))
                            except InputError:
                                continue
                            try:
                                got = body(rules_program(typo["query"], SENSORS, True))
                            except InputError:
                                refused += 1
                                continue
                            if got == want:
                                same += 1
                            else:
                                other += 1
                                without = clean["query"]
                                print(f"  another program: {typo['query']!r} (without the typo {without!r})")
    total = same + other + refused
    print(
        f"# typo check, gen-seeds 0-{seeds - 1}: {same}/{total} = {same / max(total, 1):.3f} the same "
        f"program as without the typo, {other} another program, {refused} refused"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=[*sorted(PARTS), "generated"], default="tuning")
    parser.add_argument("--seed", type=int, default=0, help="the draw of the scenes")
    parser.add_argument("--gen-seed", type=int, default=0, help="the draw of the typos of the generated set")
    parser.add_argument(
        "--limit", type=int, default=None, help="every n-th generated row only, n chosen to keep this many"
    )
    parser.add_argument("--print", action="store_true", help="print the rows and stop")
    parser.add_argument("--typo-check", action="store_true", help="compare typo rows' programs, no scenes")
    parser.add_argument(
        "--gen-seeds", type=int, default=5, help="draws of the generated set for --typo-check"
    )
    args = parser.parse_args()
    if args.typo_check:
        typo_check(args.gen_seeds)
        return
    if args.part == "generated":
        rows = generate(args.gen_seed)
        if args.limit is not None and args.limit < len(rows):
            step = len(rows) / args.limit
            rows = [rows[int(i * step)] for i in range(args.limit)]
        group = "typo"
        for r in rows:
            r["typo"] = "typo" if r["typo"] else "clean"
    else:
        rows = [json.loads(line) for line in PARTS[args.part].read_text().splitlines()]
        group = "form"
    if args.print:
        for r in rows:
            print(json.dumps(r))
        return
    everyday.score(rows, scene_for, english.judge, SENSORS, group, args.seed, f"# understanding {args.part}")


if __name__ == "__main__":
    main()
