"""The generalisation protocol's phrasings: the two parts are the whole set dealt with the fixed seed, and
every row states its meaning in the world's terms (benchmarks/accuracy_generalisation.py scores them)."""

from __future__ import annotations

import json
import random
from pathlib import Path

DATA = Path(__file__).parent / "data"
KINDS = {"extreme", "compare", "yesno", "measure", "ground", "odd"}
ATTRS = {"weight", "distance", "size", "x"}


def _rows(name: str) -> list[str]:
    return (DATA / name).read_text().splitlines()


def test_parts_are_the_seeded_split_of_the_whole_set():
    rows = _rows("generalisation.jsonl")
    order = list(range(len(rows)))
    random.Random(17).shuffle(order)
    half = len(rows) // 2
    assert _rows("generalisation_tuning.jsonl") == [rows[i] for i in sorted(order[:half])]
    assert _rows("generalisation_test.jsonl") == [rows[i] for i in sorted(order[half:])]


def test_rows_state_their_meaning():
    queries = set()
    for line in _rows("generalisation.jsonl"):
        row = json.loads(line)
        assert row["kind"] in KINDS and row["query"] not in queries
        queries.add(row["query"])
        if row["kind"] in ("extreme", "compare", "yesno"):
            assert row["attr"] in ATTRS and row["dir"] in ("max", "min")
        if row["kind"] in ("compare", "yesno"):
            assert len(row["named"]) >= 2
        if row["kind"] == "measure":
            assert row["attr"] in ("weight", "distance", "size") and row["noun"]
