"""The weight and distance family of the rules planner reads its words from the senses' records alone: a
word a lab adds to a record (tests/fakes/senses.py) is read in every form the family reads, with no edit to
`attribot.planning`, where without it the same word is only a misspelling of a built-in one."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent
SRC = TESTS.parent / "src"

QUERIES = (
    "the heftiest mug",
    "is the kettle heftier than the mug?",
    "the lightest of the two heftiest objects",
    "the heaviest of the two nighest objects",
    "is the mug nigher than the plate?",
)

_READ = """
import json, sys
if sys.argv[1] == "with":
    import fakes.senses  # the lab's words, registered before the planner loads
from attribot.planning.rules import parse_query, write_program
from attribot.planning.rules.forms import Understood, UnsupportedQuery
out = []
for query in json.loads(sys.argv[2]):
    try:
        parsed = parse_query(query)
    except UnsupportedQuery as refused:
        out.append(["refused", str(refused), False, ""])
        continue
    program = write_program(parsed, query, ["camera", "distance", "force"], True)
    out.append([type(parsed).__name__, repr(parsed), isinstance(parsed, Understood), program])
print(json.dumps(out))
"""


def _read(words: str) -> list[list]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), str(TESTS)])}
    done = subprocess.run(
        [sys.executable, "-c", _READ, words, json.dumps(QUERIES)],
        capture_output=True, text=True, env=env, timeout=240, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.fixture(scope="module")
def with_words() -> list[list]:
    return _read("with")


def test_a_word_added_to_a_sense_record_is_read_as_that_sense(with_words):
    kinds = [kind for kind, _, understood, _ in with_words]
    assert not any(understood for _, _, understood, _ in with_words), with_words  # read, not corrected
    assert kinds == ["WeightQuery", "YesNoQuery", "Request", "Request", "YesNoQuery"]
    heftiest, heftier, lightest_of, heaviest_of, nigher = (r for _, r, _, _ in with_words)
    assert "heaviest=True" in heftiest
    assert "attribute='weight', more=True, word='heftier'" in heftier
    assert "among=Among(attribute='weight', most=True, k=2)" in lightest_of
    assert "among=Among(attribute='distance', most=True, k=2)" in heaviest_of  # the two nearest
    assert "attribute='distance', more=False, word='nigher'" in nigher
    # the programs measure what the record's sensor settles, and say it in the record's words
    assert "robot.measure_weight(patch)" in with_words[1][3] and "is heavier than" in with_words[1][3]
    assert "robot.measure_distance(patch)" in with_words[3][3] and "# first the 2 nearest" in with_words[3][3]


def test_without_the_record_the_same_words_are_only_misspellings():
    without = _read("without")
    assert all(understood for _, _, understood, _ in without[:3]), without  # 'heftiest' read as 'heaviest'
    assert without[4][0] == "refused", without  # 'nigher' is no word of the planner's
