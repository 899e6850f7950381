"""`attribot scene render` and `scene info`: files, JSON truth, clear errors with a non-zero exit."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from attribot.cli import app

runner = CliRunner()


def _run(*args: str):
    return runner.invoke(app, list(args))


def test_render_writes_the_camera_view_and_boxes_change_it(tmp_path):
    plain, boxed = tmp_path / "scene.png", tmp_path / "boxed.png"
    common = ["--layout", "triplet", "--seed", "7", "--width", "160", "--height", "120"]
    r1 = _run("scene", "render", *common, "--out", str(plain))
    r2 = _run("scene", "render", *common, "--out", str(boxed), "--boxes")
    assert r1.exit_code == 0, r1.output
    assert r2.exit_code == 0, r2.output
    a, b = np.asarray(Image.open(plain)), np.asarray(Image.open(boxed))
    assert a.shape == (120, 160, 3) and a.std() > 5
    changed = np.any(a != b, axis=2)
    assert 0.005 < changed.mean() < 0.5, "boxes and labels are drawn over the image, not instead of it"


def test_info_prints_the_scene_truth_as_json():
    r = _run("scene", "info", "--layout", "household", "--seed", "7", "--width", "160", "--height", "120")
    assert r.exit_code == 0, r.output
    info = json.loads(r.output)
    assert info["layout"] == "household" and info["seed"] == 7 and info["image_size"] == [160, 120]
    assert 2 <= len(info["objects"]) <= 6
    for o in info["objects"]:
        assert {"id", "category", "color", "mass_kg", "position", "box", "pickable"} <= set(o)
        assert len(o["position"]) == 3 and o["mass_kg"] > 0
        if o["box"] is not None:
            x0, y0, x1, y1 = o["box"]
            assert 0 <= x0 < x1 <= 160 and 0 <= y0 < y1 <= 120
    assert len(info["robot"]["base"]) == 3 and len(info["robot"]["camera_position"]) == 3
    again = _run("scene", "info", "--layout", "household", "--seed", "7", "--width", "160", "--height", "120")
    assert again.output == r.output


def test_info_options_and_categories_reach_the_layout():
    r = _run(
        "scene",
        "info",
        "--layout",
        "arrangement",
        "--seed",
        "1",
        "--categories",
        "mug,apple",
        "--objects",
        "4",
        "--option",
        "pattern=row",
        "--option",
        "odd=category",
        "--width",
        "96",
        "--height",
        "72",
    )
    assert r.exit_code == 0, r.output
    objs = json.loads(r.output)["objects"]
    assert sorted(o["category"] for o in objs) == ["apple", "mug", "mug", "mug"]
    assert {o["row"] for o in objs} == {0} and sorted(o["col"] for o in objs) == [0, 1, 2, 3]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--layout", "castle"], "unknown layout 'castle'"),
        (["--categories", "unicorn"], "unknown object category 'unicorn'"),
        (["--seed", "-4"], "seed (--seed) = -4 is not valid"),
        (["--objects", "40"], "objects"),
        (["--layout", "arrangement", "--objects", "20", "--categories", "pot"], "do not fit"),
        (["--layout", "triplet", "--objects", "5"], "triplet takes exactly 3"),
        (["--option", "pattern"], "KEY=VALUE"),
        (["--layout", "arrangement", "--option", "pattern=spiral"], "pattern='spiral'"),
    ],
)
def test_bad_requests_fail_clearly(args, message):
    r = _run("scene", "info", *args, "--width", "64", "--height", "48")
    assert r.exit_code != 0
    assert message in r.output.replace("\n", " ")


def test_render_refuses_a_bad_output_path(tmp_path):
    r = _run("scene", "render", "--out", str(tmp_path / "missing" / "x.png"))
    assert r.exit_code != 0 and "does not exist" in " ".join(r.output.split())
    r = _run("scene", "render", "--out", str(tmp_path / "x.gif"))
    assert r.exit_code != 0 and ".png" in " ".join(r.output.split())


@pytest.mark.parametrize("command", [["scene", "info"], ["ask", "Which object is the heaviest?"]])
def test_a_million_objects_is_refused_before_any_work_naming_the_range(command):
    # issue 49: --objects 1000000 hung `scene info` and `ask`
    result = CliRunner().invoke(app, [*command, "--objects", "1000000"])
    said = " ".join(result.output.split())
    assert result.exit_code == 2 and "1 to 30 objects" in said and "Traceback" not in said
