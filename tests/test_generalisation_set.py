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


FORMS = {"contraction", "filler", "measure", "place", "yesno", "odd", "other"}
SENSES = {"temperature", "stiffness", "fullness"}
STATES = {"hot", "warm", "cold", "soft", "firm", "hard", "full", "empty"}
SCOPES = {"table", "counter", "shelf", "floor", "top shelf", "bottom shelf"}


def test_english_parts_are_the_seeded_split_of_the_whole_set():
    rows = _rows("generalisation_english.jsonl")
    order = list(range(len(rows)))
    random.Random(30).shuffle(order)
    half = len(rows) // 2
    assert _rows("generalisation_english_tuning.jsonl") == [rows[i] for i in sorted(order[:half])]
    assert _rows("generalisation_english_test.jsonl") == [rows[i] for i in sorted(order[half:])]


def test_english_rows_state_their_meaning():
    queries = set()
    for line in _rows("generalisation_english.jsonl"):
        row = json.loads(line)
        assert row["form"] in FORMS and row["query"] not in queries
        assert row["kind"] in KINDS | {"state"}
        queries.add(row["query"])
        if row["kind"] in ("extreme", "compare", "yesno"):
            assert row["attr"] in ATTRS | SENSES and row["dir"] in ("max", "min")
        if row["kind"] in ("compare", "yesno"):
            assert len(row["named"]) >= 2
        if row["kind"] in ("measure", "state"):
            assert row["attr"] in {"weight", "distance", "size"} | SENSES and row["noun"]
        if row["kind"] == "state":
            assert row["attr"] in SENSES and row["state"] in STATES
        assert row.get("scope", "table") in SCOPES
        if "region" in row:
            assert row["kind"] == "ground" and row["region"][0] in ("top", "bottom")
            assert row["region"][1] in ("left", "right")
