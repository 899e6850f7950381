"""The plan -> run -> feedback loop, the planner registry, and program extraction from model replies."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from attribot.config import Settings
from attribot.errors import BackendError, InputError
from attribot.planning import (
    PLANNERS,
    Attempt,
    NoProgram,
    Plan,
    Planner,
    PlanRequest,
    RunError,
    build_planner,
    solve,
)
from attribot.planning.extract import extract_program

REQUEST = PlanRequest(query="the heaviest item", sensors=["camera"], embodied=False)
GOOD = "def execute_command(image, robot):\n    return 1\n"


@dataclass
class Result:  # what the runner's RunResult offers the loop: ok and a structured error
    ok: bool
    error: object = None


def failing(message: str, line: int | None = 2) -> Result:
    return Result(
        False, RunError(category="runtime", message=message, line=line, snippet="x = y[3]", output="")
    )


class ScriptedPlanner:
    """Returns scripted programs (or raises NoProgram for None) and records the feedback it was given."""

    name = "scripted"

    def __init__(self, programs):
        self.programs = list(programs)
        self.seen: list[tuple[Attempt, ...]] = []

    def plan(self, request, feedback=()):
        self.seen.append(tuple(feedback))
        program = self.programs.pop(0)
        if program is None:
            raise NoProgram("no code in the reply (the reply starts: 'Sorry')", reply="Sorry, I cannot.")
        return Plan(program=program, reply=f"```python\n{program}```")


def test_first_success_stops_the_loop():
    planner = ScriptedPlanner([GOOD, "unused"])
    runs = []
    outcome = solve(planner, REQUEST, lambda p: runs.append(p) or Result(True), max_tries=3)
    assert outcome.ok and runs == [GOOD] and len(outcome.attempts) == 1
    assert outcome.error is None and outcome.program == GOOD


def test_errors_are_fed_back_until_success():
    programs = [GOOD.replace("1", str(i)) for i in range(3)]
    planner = ScriptedPlanner(programs)
    results = iter([failing("IndexError: list index out of range"), failing("NameError: y"), Result(True)])
    outcome = solve(planner, REQUEST, lambda p: next(results), max_tries=5)
    assert outcome.ok and len(outcome.attempts) == 3
    assert [len(f) for f in planner.seen] == [0, 1, 2]
    assert planner.seen[1][0].error.message == "IndexError: list index out of range"
    assert planner.seen[2][1].program == programs[1]


def test_max_tries_is_respected():
    planner = ScriptedPlanner([GOOD.replace("1", str(i)) for i in range(10)])
    calls = []
    outcome = solve(planner, REQUEST, lambda p: calls.append(p) or failing("boom"), max_tries=3)
    assert not outcome.ok and len(calls) == 3 and len(outcome.attempts) == 3
    assert outcome.error.message == "boom"


def test_a_repeated_program_is_not_run_again():
    planner = ScriptedPlanner([GOOD, GOOD, GOOD])
    calls = []
    outcome = solve(planner, REQUEST, lambda p: calls.append(p) or failing("boom"), max_tries=3)
    assert len(calls) == 1 and len(outcome.attempts) == 1 and not outcome.ok


def test_rules_planner_runs_once_however_many_tries():
    planner = build_planner("rules", Settings())
    calls = []
    outcome = solve(planner, REQUEST, lambda p: calls.append(p) or failing("no item found"), max_tries=4)
    assert len(calls) == 1 and outcome.attempts[0].program == calls[0]


def test_a_reply_without_code_is_a_try_and_goes_back_as_feedback():
    planner = ScriptedPlanner([None, GOOD])
    outcome = solve(planner, REQUEST, lambda p: Result(True), max_tries=3)
    assert outcome.ok and len(outcome.attempts) == 2
    first = outcome.attempts[0]
    assert first.program == "" and first.reply == "Sorry, I cannot." and "no code" in first.error.message
    assert planner.seen[1] == (first,)


def test_no_program_ever_leaves_no_result_and_names_the_error():
    outcome = solve(
        ScriptedPlanner([None, None]), REQUEST, lambda p: pytest.fail("nothing to run"), max_tries=2
    )
    assert outcome.result is None and not outcome.ok and outcome.program is None
    assert "no code" in outcome.error.message


def test_planner_failures_propagate_and_bad_tries_are_refused():
    class Down:
        name = "down"

        def plan(self, request, feedback=()):
            raise BackendError("cannot reach http://127.0.0.1:1")

    with pytest.raises(BackendError):
        solve(Down(), REQUEST, lambda p: Result(True), max_tries=2)
    with pytest.raises(InputError, match="max_tries"):
        solve(ScriptedPlanner([GOOD]), REQUEST, lambda p: Result(True), max_tries=0)


@pytest.mark.parametrize("name", PLANNERS.names())
def test_every_registered_planner_builds_and_speaks_the_protocol(name, tmp_path):
    planner = build_planner(name, Settings(cache_dir=tmp_path))
    assert isinstance(planner, Planner) and planner.name == name
    assert set(PLANNERS.names()) == {"rules", "llm"}


# ---- extraction ------------------------------------------------------------------------------------


ENTRY = "def execute_command(image, robot):\n    return image.find('cup')[0]\n"


@pytest.mark.parametrize(
    ("reply", "expected"),
    [
        (f"```python\n{ENTRY}```", ENTRY),
        (f"Here you go:\n\n```py\n{ENTRY}```\nThis returns the first cup.", ENTRY),
        (f"```\n{ENTRY}```", ENTRY),
        (f"~~~python\n{ENTRY}~~~", ENTRY),
        (f"```Python3\n{ENTRY}```", ENTRY),
        (f"```python\n{ENTRY}", ENTRY),  # cut off before the closing fence
        (ENTRY, ENTRY),  # bare code
        (f"Sure! The program is:\n{ENTRY}\nIt finds the cup and returns it.", ENTRY),
        (f"import math\n{ENTRY}", f"import math\n{ENTRY}"),
        # a draft, then the fix: the last block that defines the entry point and parses wins
        (
            "```python\ndef execute_command(image, robot):\n    return 0\n```\n"
            f"Better:\n```python\n{ENTRY}```",
            ENTRY,
        ),
        # a broken block after a good one: the good one
        (f"```python\n{ENTRY}```\n```python\ndef execute_command(image, robot):\n    return (\n```", ENTRY),
        # a usage example in another language is ignored
        (f"```python\n{ENTRY}```\n```bash\nattribot ask 'the cup'\n```", ENTRY),
        # example calls for a reader are dropped
        (
            f"```python\n{ENTRY}\nprint(execute_command(image, robot))\n"
            "if __name__ == '__main__':\n    execute_command(1, 2)\n```",
            ENTRY,
        ),
    ],
)
def test_extraction_reads_the_usual_shapes(reply, expected):
    assert extract_program(reply) == expected


def test_helpers_from_another_block_come_along():
    reply = (
        "First a helper:\n```python\ndef leftmost(patches):\n"
        "    return min(patches, key=lambda p: p.left)\n```\n"
        "Then:\n```python\ndef execute_command(image, robot):\n    return leftmost(image.find('cup'))\n```"
    )
    program = extract_program(reply)
    assert program.index("def leftmost") < program.index("def execute_command")
    namespace: dict = {}
    exec(program, namespace)
    assert "leftmost" in namespace


@pytest.mark.parametrize(
    ("reply", "match"),
    [
        ("", "the reply is empty"),
        ("   \n ", "the reply is empty"),
        (
            "I am sorry, I cannot see the image.\nPlease send it.",
            "no code in the reply.*I am sorry, I cannot see the image",
        ),
        ("```python\ndef solve(image):\n    return 1\n```", "does not define execute_command"),
        ("```python\ndef execute_command():\n    return 1\n```", "takes 0 argument"),
        (
            "```python\ndef execute_command(image, robot, extra):\n    return 1\n```",
            r"takes 3 argument\(s\) \(3 required",
        ),
        ("```python\nif True:\n    def execute_command(image, robot):\n        return 1\n```", "top level"),
    ],
)
def test_extraction_refusals_are_messages_for_the_model(reply, match):
    """(`execute_command(image)` alone is the paper's dialect and is accepted: tests/test_paper_dialect.py)"""
    with pytest.raises(NoProgram, match=match) as info:
        extract_program(reply)
    assert info.value.error.category == "reply" and info.value.error.message == info.value.message
    assert "```python" in info.value.fix


def test_a_syntax_error_is_left_for_the_runner_to_point_at():
    broken = "```python\ndef execute_command(image, robot):\n    return (\n```"
    assert extract_program(broken).startswith("def execute_command")


def test_a_finished_run_that_is_no_answer_is_retried_with_its_output_and_calls():
    """Issue 18: a program that prints its answer and returns None goes back to the planner."""
    from attribot.planning.answer import result_problem
    from attribot.planning.llm import feedback_message
    from attribot.runner.records import RunResult, TraceRecord

    printed = "def execute_command(image, robot):\n    print('the mug')\n"
    planner = ScriptedPlanner([printed, GOOD])
    call = TraceRecord(call="ImagePatch.find", args=["mug"], result=[{"type": "ImagePatch", "label": "mug",
                       "object_id": "mug_1"}], ms=1.0, line=2)  # fmt: skip
    results = {
        printed: RunResult(ok=True, value=None, value_object=None, output="the mug\n", trace=[call]),
        GOOD: RunResult(ok=True, value=1, value_object=1),
    }
    outcome = solve(
        planner, REQUEST, results.__getitem__, max_tries=3, check=lambda r: result_problem(r, False)
    )
    assert outcome.ok and [a.program for a in outcome.attempts] == [printed, GOOD]
    first = outcome.attempts[0]
    assert first.error.category == "runtime" and first.error.output == "the mug\n"
    assert "returned None (it printed its answer" in first.error.message
    assert first.did == ['ImagePatch.find("mug") -> [mug mug_1]']
    said = feedback_message(first.error, first.did, same_start=True)
    assert "Its output so far:\nthe mug" in said and "- ImagePatch.find" in said and "same state" in said
    # a query asking which object: a number returned chooses none, and is no answer either
    assert "chooses none" in result_problem(RunResult(ok=True, value=3, value_object=3), wants_object=True)
