"""The suite as registered records (issue 19): every task and method found through one registry, the truth of
location and size from the arrangement's own rows, columns and sizes with no planner involved, the error
category from the trace, the report's files (SVG and 2x PNG figures, Table I in LaTeX, the hypotheses), and
the size limits of the evaluation's code."""

from __future__ import annotations

import ast
import io
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from types import SimpleNamespace

import pytest
from PIL import Image

from attribot.config import SceneConfig, load_settings
from attribot.errors import InputError
from attribot.eval.corpus import paper_queries, released_families
from attribot.eval.datasets import build_items, item_count, scene_info
from attribot.eval.figures import Bar, Group, bar_figure
from attribot.eval.methods import PROGRAM_METHODS, _category, paper_methods
from attribot.eval.report import write_report
from attribot.eval.run import EvalPlan, run_eval
from attribot.eval.suite import METHODS, TASKS, tagged, task_names
from attribot.eval.tasks import still
from attribot.eval.tasks.still import Place, _in_scene, paper_extremes, paper_places, place_truth
from attribot.sim.table_layouts import NoRoomOnTable
from attribot.sim.world import ObjectInfo

EVAL = Path(__file__).resolve().parents[1] / "src" / "attribot" / "eval"


# ---- the registry ----------------------------------------------------------------------------------------


def test_every_task_is_a_registered_record_with_known_methods_and_the_papers_numbers():
    assert task_names() == ["location", "size", "weight_image", "distance_embodied", "weight_embodied"]
    assert tagged("embodied") == ["distance_embodied", "weight_embodied"]
    seeds = [TASKS.get(t).seed_base for t in task_names()]
    assert len(set(seeds)) == len(seeds), "two tasks would draw the same scenes"
    for name, task in TASKS.items():
        assert task.name == name and task.size > 0 and task.why
        assert set(task.methods) <= set(METHODS.names()) and paper_methods(name) == task.methods
        assert set(task.paper) <= set(task.methods), (
            f"{name}: the paper's numbers of a method it does not run"
        )
        assert all(0 < v <= 1 for published in task.paper.values() for _, v in published)
    assert item_count("size", 3) == 6 and item_count("location", 500) == 100
    assert PROGRAM_METHODS == ("attr-api", "pa-api")
    assert all(METHODS.get(m).why for m in METHODS.names())


def test_an_unknown_task_or_method_is_refused_naming_the_known_ones():
    with pytest.raises(Exception, match="choose from: location, size"):
        build_items(["juggling"])
    with pytest.raises(Exception, match="unknown method"):
        EvalPlan(methods=("telepathy",))


def test_the_released_families_are_read_from_the_data_not_a_second_task_tuple():
    assert released_families()[:3] == ["location", "size", "weight_image"]
    assert "ai2thor_distance" in released_families() and "ai2thor_distance" not in task_names()


# ---- truth from the world, not from a planner ------------------------------------------------------------


def _grid(rows: int, cols: int) -> list[ObjectInfo]:
    return [
        ObjectInfo(
            id=f"mug_{r}{c}",
            key=r * cols + c,
            category="mug",
            color="blue",
            mass_kg=0.3,
            position=[0, 0, 0],
            box=[c * 10.0, r * 10.0, c * 10.0 + 8, r * 10.0 + 8],
            visible_pixels=64,
            pickable=True,
            size_m=0.1,
            distance_m=1.0,
            row=r,
            col=c,
        )  # fmt: skip
        for r in range(rows)
        for c in range(cols)
    ]


@pytest.mark.parametrize(
    ("line", "pick", "expected"),
    [
        (None, "left 2", None),  # three in every column: "second from the left" names no one object
        ("row 1", "left 2", "mug_01"),  # row 1 is the top row
        ("row -1", "right 1", "mug_22"),  # bottom right
        ("row -2", "left 1", "mug_10"),  # the second row from the bottom
        ("middle row", "right 2", "mug_11"),
        ("column 1", "middle", "mug_10"),  # the middle of the first column
        ("column -1", "top 1", "mug_02"),
        (None, "centre", "mug_11"),
        ("row 4", "left 1", None),  # no fourth row
    ],
)
def test_a_place_is_read_off_the_arrangements_rows_and_columns(line, pick, expected):
    truth = place_truth(Place(noun="mug", pick=pick, line=line), _grid(3, 3))
    assert (truth.id if truth else None) == expected


def test_an_even_arrangement_has_no_middle():
    assert place_truth(Place(noun=None, pick="middle", line="row 1"), _grid(2, 4)) is None
    assert place_truth(Place(noun=None, pick="centre"), _grid(2, 2)) is None


def test_an_arrangement_with_no_room_for_its_pattern_is_passed_over_for_the_next_seed(monkeypatch):
    """Root seed 7's location items reach scene seed 7010048, whose three bowls do not fit in a column:
    generation takes the next seed instead of stopping the whole evaluation."""
    config = SceneConfig(layout="arrangement", seed=7010048, options={"pattern": "column", "odd": "size"})
    with pytest.raises(NoRoomOnTable, match="do not fit on the table") as refused:
        scene_info(config)
    assert isinstance(refused.value, InputError) and "--option pattern=row" in str(refused.value.fix)
    assert still._arrangement(7010048, "column") is None
    drawn = still._arrangement
    seen: list[int] = []

    def first_has_no_room(seed: int, pattern: str):
        seen.append(seed)
        return None if len(seen) == 1 else drawn(seed, pattern)

    monkeypatch.setattr(still, "_arrangement", first_has_no_room)
    for make in (still._location_items, still._size_items):
        seen.clear()
        item = next(make(1, 20008))  # size: scene seed 20010 carries an item
        assert seen[0] == 20009 and item.seed > 20009


def test_every_released_location_and_size_phrasing_has_a_written_meaning():
    assert [q for q, _ in paper_places()] == [q.query for q in paper_queries("location")]
    superlatives = [q.query for q in paper_queries("size") if q.form == "superlative"]
    assert [q for q, _, _ in paper_extremes()] == superlatives
    places = dict(paper_places())
    assert places["second letter from the right on the third line from the bottom"] == Place(
        noun="letter", pick="right 2", line="row -3"
    )
    extremes = {q: e for q, _, e in paper_extremes()}
    assert extremes["third tallest item"].rank == 3 and extremes["least wide item"].largest is False


def test_a_released_colour_is_swapped_for_the_scenes_so_the_query_names_objects_that_exist():
    mug = _grid(1, 1)[0]
    assert _in_scene("rightmost black book", "book", ("black",), mug) == "rightmost blue mug"
    assert _in_scene("the second dog from the right", "dog", (), mug) == "the second mug from the right"
    assert _in_scene("the first item from the left", None, (), mug) == "the first item from the left"


def test_generating_items_imports_no_planner():
    # the truth of an item never comes from the code that is measured on it
    code = (
        "import sys\n"
        "from attribot.eval.datasets import build_items\n"
        "build_items(['location', 'size'], limit=1)\n"
        "print(sorted(m for m in sys.modules if m.startswith(('attribot.planning', 'attribot.api'))))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


# ---- records ---------------------------------------------------------------------------------------------


def test_the_error_category_is_the_kind_of_the_failing_call_in_the_trace():
    def answer(*trace: dict[str, object], category: str = "api") -> SimpleNamespace:
        return SimpleNamespace(error=SimpleNamespace(category=category), program="...", trace=list(trace))

    robot = {"call": "Robot.pick_up", "error": "no grasp", "kind": "action"}
    looked = {"call": "ImagePatch.find", "error": None, "kind": "perception"}
    missed = {"call": "ImagePatch.find", "error": "nothing", "kind": "perception"}
    assert _category(answer(looked, robot)) == "action"
    assert _category(answer(robot | {"error": None}, missed)) == "perception"
    assert _category(answer(looked | {"result": [{"label": "mug"}]})) == "runner"  # failed on its own
    # a program that raised because a find came back empty failed for what was not perceived
    assert _category(answer(robot | {"error": None}, looked | {"result": []})) == "perception"
    assert _category(answer(looked | {"result": []}, robot | {"error": None})) == "runner"
    assert _category(answer(category="uncertain")) == "uncertain"
    assert _category(SimpleNamespace(error=None)) is None


def test_a_programs_trace_names_the_kind_of_each_call():
    item = build_items(["weight_embodied"], limit=1)[0]
    from attribot.eval.methods import run_method

    record = run_method(item, "pa-api", load_settings(detector="oracle", vqa="oracle", language="catalog"))
    kinds = {t["call"].split(".")[0]: t["kind"] for t in record.trace}
    assert kinds == {"ImagePatch": "perception", "Robot": "action"}
    assert record.form == "comparative"


# ---- the report ------------------------------------------------------------------------------------------


def test_a_figure_is_svg_and_a_png_at_twice_its_size_with_no_slot_for_a_method_not_run():
    groups = [
        Group("ovd", (Bar("clean", 0.3, 0.2, 0.4, 100), Bar("paper", 0.35))),
        Group("vlm", ()),
        Group("attr-api", (Bar("clean", 0.9, 0.83, 0.94, 100),)),
    ]
    svg, png = bar_figure("location", groups)
    root = ET.fromstring(svg)
    texts = [t.text for t in root.iter("{http://www.w3.org/2000/svg}text")]
    assert "vlm" not in texts and {"ovd", "attr-api", "n=100", "paper", "ours, clean"} <= set(texts)
    assert min(float(t.get("font-size") or 0) for t in root.iter("{http://www.w3.org/2000/svg}text")) >= 10
    lines = list(root.iter("{http://www.w3.org/2000/svg}line"))
    assert len(lines) >= 5 + 2 + 2 * 3  # grid, axes, and an interval (bar and two caps) per bar of ours
    with Image.open(io.BytesIO(png)) as image:
        assert image.size == (2 * int(root.get("width") or 0), 2 * int(root.get("height") or 0))


def test_the_report_has_its_files_a_settings_table_the_hypotheses_and_no_orphan_not_run_lines(tmp_path):
    settings = load_settings(detector="oracle", vqa="oracle", language="catalog")
    run = tmp_path / "run"
    run_eval(
        EvalPlan(tasks=("size", "weight_embodied"), methods=("ovd", "attr-api", "vlm"), limit=2),
        settings,
        run,
    )
    page = write_report(run).read_text(encoding="utf-8")
    for task in ("size", "weight_embodied"):
        assert (run / f"report-{task}.svg").is_file() and (run / f"report-{task}.png").is_file()
    latex = (run / "report-table1.tex").read_text()
    assert latex.startswith("\\begin{tabular}") and "Attribute API" in latex and "\\bottomrule" in latex
    assert "<th>planner</th><td>rules</td>" in page and '"dataset_version"' not in page
    for name in ("H1", "H2", "H3", "H4"):
        assert f'<h3 id="{name}">' in page
    assert "superlative" in page and "absolute" in page  # H3's table: the size task asks both forms
    assert ">: no vision-chat" not in page and page.count("not run: vlm") == 6  # one line per card


# ---- the code --------------------------------------------------------------------------------------------


def test_no_function_over_60_lines_and_no_class_over_400_in_eval():
    long = []
    for path in sorted(EVAL.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            limit = 400 if isinstance(node, ast.ClassDef) else 60
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                lines = (node.end_lineno or node.lineno) - node.lineno + 1
                if lines > limit:
                    long.append(f"{path.relative_to(EVAL)}:{node.name} ({lines} lines)")
    assert not long, long
