"""The evaluation with a closed-set detector (the real coco one, YOLOv3-tiny on the CPU): the run keeps the
items whose objects the detector can find and says so, its records name the detector, and a report sets its
rows beside an oracle run's on the same items. Four location items: two are arrangements of candles (no COCO
class), two of remote controls and scissors."""

from __future__ import annotations

import json
import re
from collections import Counter
from dataclasses import replace

import pytest

from attribot.config import load_settings
from attribot.errors import InputError
from attribot.eval.datasets import Item
from attribot.eval.report import summarize, write_report
from attribot.eval.run import EvalPlan, read_records, run_eval
from attribot.eval.subset import closed_set_detector, findable_items
from attribot.models.base import can_find
from conftest import cli

PLAN = EvalPlan(tasks=("location",), methods=("ovd", "attr-api"), limit=4)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A coco run, an oracle run on the coco run's items, and an oracle run on every item."""
    root = tmp_path_factory.mktemp("runs")
    notes: list[str] = []
    coco = run_eval(PLAN, load_settings(detector="coco"), root / "coco", note=notes.append)
    oracle = load_settings(detector="oracle")
    run_eval(replace(PLAN, findable_by="coco"), oracle, root / "oracle-subset", dataset=root / "coco")
    run_eval(PLAN, oracle, root / "oracle-all", dataset=root / "coco")
    return root, coco, notes


def _item(categories: list[str]) -> Item:
    return Item(id="x", task="location", query="q", form="n/a", phrasing="template", layout="arrangement",
                seed=1, sensors=["camera"], embodied=False, true_id="a", true_box=[0, 0, 1, 1],
                object_categories=categories)  # fmt: skip


def test_the_detector_is_asked_what_it_can_find():
    settings = load_settings()
    coco = closed_set_detector("coco", settings)
    assert coco is not None and closed_set_detector("oracle", settings) is None
    assert can_find(coco, "mug") and can_find(coco, "cactus") and not can_find(coco, "kettle")
    items = [_item(["mug", "apple"]), _item(["mug", "kettle"]), _item([])]
    kept, subset = findable_items(items, "coco", coco)
    assert [i.object_categories for i in kept] == [["mug", "apple"]]
    assert subset.kept == {"location": (1, 3)}
    assert subset.says("location").startswith("1 of 3 items kept; 2 left out")
    assert "kettle 1" in subset.says("location") and "(no categories recorded) 1" in subset.says("location")


def test_a_coco_run_keeps_the_items_it_can_find_says_so_and_its_records_name_it(runs):
    root, summary, notes = runs
    assert summary.subset is not None and summary.subset.kept == {"location": (2, 4)}
    assert any(n == "location: 2 of 4 items kept; 2 left out, with objects coco cannot find (candle 2)"
               for n in notes)  # fmt: skip
    about = json.loads((root / "coco" / "run.json").read_text())
    assert about["detector"] == "coco" and about["subset"] == "coco"
    assert about["items"]["location"].startswith("2 of 4 items kept")
    assert "coco:yolov3-tiny" in about["items"]["rule"]
    records = read_records(root / "coco")
    assert Counter(r.method for r in records) == {"ovd": 2, "attr-api": 2}
    assert {r.detector for r in records} == {"coco"}
    assert {r.id for r in records} == {"location-001", "location-003"}  # remote controls, scissors
    # the dataset keeps every item (a resumed or longer run finds them), the records only the subset's
    assert len((root / "coco" / "dataset" / "manifest.jsonl").read_text().splitlines()) == 4
    program = next(r for r in records if r.method == "attr-api")
    assert any(t["call"].endswith("find") for t in program.trace)  # the program asked the real detector


def test_the_oracle_runs_on_the_coco_subset_or_on_every_item(runs):
    root, _, _ = runs
    subset = read_records(root / "oracle-subset")
    assert {r.id for r in subset} == {"location-001", "location-003"}
    assert {r.detector for r in subset} == {"oracle"}
    assert json.loads((root / "oracle-subset" / "run.json").read_text())["subset"] == "coco"
    everything = read_records(root / "oracle-all")
    assert len({r.id for r in everything}) == 4
    assert json.loads((root / "oracle-all" / "run.json").read_text())["subset"] is None


def test_a_report_sets_the_coco_rows_beside_the_oracle_rows_on_the_same_items(runs):
    root, _, _ = runs
    page = write_report([root / "oracle-all", root / "coco"], root / "side" / "report.html").read_text()
    records = read_records(root / "oracle-all") + read_records(root / "coco")
    shared = [r for r in records if r.id in {"location-001", "location-003"}]
    rows = summarize(shared)
    assert {(r["method"], r["series"], r["n"]) for r in rows} == {
        (m, f"clean, {d}", 2) for m in ("ovd", "attr-api") for d in ("oracle", "coco")
    }
    for row in rows:  # each row, labelled with its detector, shows the accuracy of the shared items only
        key = f"location|{row['method']}|{row['series']}"
        shown = re.findall(rf'data-key="{re.escape(key)}">(.*?)</td>', page)
        assert shown == [f"{row['accuracy']:.2f} [{row['low']:.2f}, {row['high']:.2f}] (n=2)"]
    assert "every run counted on the 2 items all of them hold" in page
    assert "<th>detector</th><td>oracle</td><td>coco</td>" in page
    assert (root / "side" / "report-location.png").is_file()
    assert "attr-api (coco)" in page and "attr-api (oracle)" in page  # the gallery's boxes say whose


def test_the_report_command_takes_several_runs_and_refuses_runs_that_differ_in_more_than_the_detector(runs):
    root, _, _ = runs
    done = cli("report", str(root / "oracle-subset"), str(root / "coco"))
    assert done.returncode == 0, done.stderr
    assert (root / "oracle-subset" / "compared.html").is_file()
    assert not (root / "oracle-subset" / "report.html").exists()  # a run's own report is not overwritten
    with pytest.raises(InputError, match="same detector"):
        write_report([root / "oracle-all", root / "oracle-subset"])
    other = root / "no-checks"
    run_eval(EvalPlan(tasks=("location",), methods=("ovd",), limit=1), load_settings(checks="none"), other,
             dataset=root / "coco")  # fmt: skip
    with pytest.raises(InputError, match=r"differ in checks .*differ only in their detector"):
        write_report([root / "coco", other])
