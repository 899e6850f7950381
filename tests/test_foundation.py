"""Box maths, the registry, configuration and frames: the shared bottom layer."""

from __future__ import annotations

import numpy as np
import pytest

from attribot import boxes
from attribot.config import load_settings
from attribot.errors import ConfigError, InputError, UnknownName
from attribot.frame import Frame, load_image
from attribot.models.base import Detection, parse_spec
from attribot.registry import Registry


@pytest.mark.parametrize(
    ("a", "b", "expected"),
    [
        ((0, 0, 2, 2), (0, 0, 2, 2), 1.0),
        ((0, 0, 2, 2), (2, 2, 4, 4), 0.0),
        ((0, 0, 2, 2), (1, 0, 3, 2), 1 / 3),
        ((0, 0, 0, 0), (0, 0, 0, 0), 0.0),
    ],
)
def test_iou_table(a, b, expected):
    assert boxes.iou(a, b) == pytest.approx(expected)


def test_nms_keeps_best_of_overlapping_and_all_disjoint():
    bx = np.array([[0, 0, 10, 10], [1, 1, 10, 10], [20, 20, 30, 30]])
    keep = boxes.nms(bx, np.array([0.5, 0.9, 0.1]), 0.5)
    assert keep.tolist() == [1, 2]


def test_upward_round_trip_and_orientation():
    up = boxes.to_upward((10, 0, 20, 5), image_height=100)
    assert up[3] > up[1]  # upper > lower: y grows upward
    assert boxes.from_upward(*up, image_height=100) == (10.0, 0.0, 20.0, 5.0)


def test_clip_and_crop_never_empty():
    assert boxes.clip(np.array([[-5, -5, 200, 50]]), 100, 40).tolist() == [[0, 0, 100, 40]]
    img = np.zeros((10, 10, 3), np.uint8)
    assert boxes.crop_array(img, (9.5, 9.5, 9.6, 9.6)).shape == (1, 1, 3)


def test_bad_boxes_rejected():
    with pytest.raises(ValueError):
        boxes.as_boxes([[5, 0, 1, 1]])
    with pytest.raises(ValueError):
        Detection(box=(0, 0, float("nan"), 1), score=0.5, label="x")
    with pytest.raises(ValueError):
        Detection(box=(0, 0, 1, 1), score=1.5, label="x")


def test_registry_unknown_lists_known_and_rejects_duplicates():
    reg: Registry[int] = Registry("layout")
    reg.register("grid", aliases=("rows",))(1)
    assert reg.get("rows") == 1
    with pytest.raises(UnknownName, match="choose one of: grid"):
        reg.get("nope")
    with pytest.raises(ValueError, match="twice"):
        reg.register("grid")(2)


@pytest.mark.parametrize(
    ("spec", "expected"),
    [
        ("oracle", ("oracle", None)),
        ("hf:a/b", ("hf", "a/b")),
        ("remote:http://h:1", ("remote", "http://h:1")),
    ],
)
def test_parse_spec(spec, expected):
    assert parse_spec(spec) == expected


@pytest.mark.parametrize("spec", ["", ":x", "hf:", "  "])
def test_parse_spec_malformed(spec):
    with pytest.raises(ConfigError):
        parse_spec(spec)


def test_settings_env_file_and_flags(tmp_path, monkeypatch):
    cfg = tmp_path / "a.toml"
    cfg.write_text('detector = "hf:owl"\nvqa = "openai:gpt-4o"\n')
    monkeypatch.setenv("ATTRIBOT_CONFIG", str(cfg))
    monkeypatch.setenv("ATTRIBOT_VQA", "remote:http://127.0.0.1:1")
    monkeypatch.setenv("ATTRIBOT_LLM_API_KEY", "sk-secret")
    s = load_settings(planner="llm")
    assert (s.detector, s.vqa, s.planner) == ("hf:owl", "remote:http://127.0.0.1:1", "llm")
    assert s.public_dict()["llm_api_key"] == "***"


def test_frame_crop_keeps_layers_aligned():
    rgb = np.zeros((20, 30, 3), np.uint8)
    seg = np.full((20, 30), -1, np.int32)
    seg[5:10, 10:20] = 3
    f = Frame(rgb=rgb, segmentation=seg)
    c = f.crop((10, 5, 20, 10))
    assert c.origin == (10, 5) and c.rgb.shape == (5, 10, 3) and (c.segmentation == 3).all()
    with pytest.raises(ValueError, match="uint8"):
        Frame(rgb=np.zeros((2, 2, 3), np.float32))


def test_load_image_errors(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        load_image(tmp_path / "missing.png")
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"\x89PNG not really")
    with pytest.raises(InputError, match="cannot be read"):
        load_image(bad)


def test_draw_boxes_marks_pixels_and_keeps_input():
    from attribot.draw import draw_boxes

    rgb = np.zeros((40, 60, 3), np.uint8)
    out = draw_boxes(rgb, [((10, 15, 30, 35), "mug")])
    assert out.shape == rgb.shape and rgb.max() == 0  # input untouched
    assert out[34, 20].any() and out[25, 10].any()  # bottom and left edges drawn
    assert not out[25, 20].any()  # inside stays clear
