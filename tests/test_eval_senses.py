"""The suite `senses`: a task per sense, registered like the paper's, with truth from the world's own state;
the baselines cannot see what only a sensor settles, pa-api measures, and the report shows the tasks."""

from __future__ import annotations

from pathlib import Path

import pytest

from attribot.config import load_settings
from attribot.eval.datasets import build_items
from attribot.eval.methods import run_method
from attribot.eval.report import write_report
from attribot.eval.run import EvalPlan, read_records, run_eval
from attribot.eval.suite import TASKS, suite_names, tagged, task_names
from attribot.session import Scene

SENSES = ["temperature_embodied", "softness_embodied", "fullness_embodied"]
FIELD = {"temperature_embodied": "temperature_c", "softness_embodied": "stiffness_n_per_mm"}


def test_the_senses_are_a_suite_of_their_own_beside_the_papers():
    assert suite_names() == ["paper", "senses", "realroom"]
    assert task_names("senses") == SENSES == tagged("senses")
    assert not set(SENSES) & set(task_names())  # the paper's suite stays the paper's five
    for name in SENSES:
        task = TASKS.get(name)
        assert task.size == 50 and "pa-api" in task.methods and {"ovd", "vqa", "vqa+llm"} <= set(task.methods)
    assert len({TASKS.get(t).seed_base for t in task_names(None)}) == len(task_names(None))


@pytest.fixture(scope="module")
def items():
    return build_items(SENSES, limit=4)


def test_items_take_their_truth_from_the_worlds_state_and_look_alike(items):
    assert {i.task for i in items} == set(SENSES) and len(items) == 12
    for item in items:
        truth = {o.id: o for o in Scene(item.scene()).truth().objects}
        assert set(item.candidates) <= set(truth) and item.true_id in item.candidates
        assert len({truth[c].category for c in item.candidates}) == 1  # no look or prior tells them apart
        field = FIELD.get(item.task, "fill")
        values = {c: getattr(truth[c], field) for c in item.candidates}
        most = "hot" in item.query or "hardest" in item.query or "full" in item.query
        end = (max if most else min)(values, key=values.get)
        assert item.true_id == end, (item.query, values)
        assert item.sensors in (["camera", "temperature"], ["camera", "grip"], ["camera", "force"])
    assert build_items(SENSES, limit=4) == items  # the same seeds, the same items


def test_vqa_cannot_see_and_pa_api_measures(items):
    settings = load_settings()
    for item in items[::4]:  # one of each task
        assert run_method(item, "vqa", settings).right is False
        record = run_method(item, "pa-api", settings)
        assert record.right, (item.query, record.error)
        assert record.measured and all(m["call"].startswith("Robot.measure_") for m in record.measured)
        refused = run_method(item, "attr-api", settings)
        assert not refused.right and refused.error_category == "planner" and "sensor" in (refused.error or "")


def test_a_run_of_the_senses_is_reported_in_a_table_of_its_own(tmp_path: Path, empty_settings):
    plan = EvalPlan(tasks=("temperature_embodied",), methods=("vqa+llm", "pa-api"), limit=2)
    run_eval(plan, load_settings(), tmp_path)
    assert {(r.task, r.method) for r in read_records(tmp_path)} == {
        ("temperature_embodied", "vqa+llm"),
        ("temperature_embodied", "pa-api"),
    }
    page = write_report(tmp_path).read_text()
    assert 'id="senses"' in page and "Beyond the paper's senses" in page
    assert (tmp_path / "report-temperature_embodied.png").is_file()
