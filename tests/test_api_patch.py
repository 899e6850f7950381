"""ImagePatch semantics: coordinates (y up), find on crops mapped back, queries, crop, helpers, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from attribot.api import ApiArgumentError, ImagePatch, Perception
from attribot.boxes import to_upward
from attribot.errors import AttribotError, BackendError, ConfigError
from attribot.frame import Frame
from conftest import FakeDetector, Thing, perception_for

W, H = 200, 100


def frame() -> Frame:
    rgb = np.zeros((H, W, 3), np.uint8)
    rgb[:, :, 0] = np.arange(W, dtype=np.uint8)[None, :]  # a gradient, so crops can be told apart
    return Frame(rgb=rgb)


THINGS = [
    Thing("cup", (10, 60, 30, 90), 0.5, "cup_1"),  # bottom left
    Thing("cup", (150, 5, 170, 25), 0.9, "cup_2"),  # top right
    Thing("cup", (90, 40, 110, 60), 0.7, None),  # middle, a detector that knows no ids
    Thing("plate", (80, 45, 130, 70), 0.8, "plate_1"),
]


@pytest.fixture
def image() -> ImagePatch:
    return ImagePatch(frame(), perception_for(THINGS, {"which is heavier, a cup or a plate?": "plate"}))


def test_whole_image_coordinates_grow_upward(image):
    assert (image.left, image.lower, image.right, image.upper) == (0, 0, W, H)
    assert (image.width, image.height, image.area) == (W, H, W * H)
    assert (image.horizontal_center, image.vertical_center) == (W / 2, H / 2)


def test_find_best_first_with_ids_and_upward_boxes(image):
    cups = image.find("cup")
    assert [c.score for c in cups] == [0.9, 0.7, 0.5]
    assert [c.object_id for c in cups] == ["cup_2", None, "cup_1"]
    top_right, _, bottom_left = cups
    assert top_right.box == (150, 5, 170, 25)
    assert (top_right.left, top_right.lower, top_right.right, top_right.upper) == to_upward(
        (150, 5, 170, 25), H
    )
    # y grows upward: the cup at the top of the image has the larger vertical_center
    assert top_right.vertical_center > bottom_left.vertical_center
    assert top_right.upper > top_right.lower
    assert all(c.label == "cup" for c in cups)
    assert image.find("giraffe") == []


def test_find_on_a_patch_searches_only_its_pixels_and_maps_back(image):
    detector: FakeDetector = image.perception.detector
    plate = image.find("plate")[0]
    cups_on_plate = plate.find("cup")
    # only the middle cup overlaps the plate; its box is back in whole-frame pixels, clipped to the crop
    assert len(cups_on_plate) == 1
    assert cups_on_plate[0].box == (90, 45, 110, 60)
    origin_and_size, queries = detector.calls[-1]
    assert origin_and_size == (80, 45, 50, 25) and queries == ["cup"]
    # a patch of a patch keeps the coordinates of the whole image
    assert cups_on_plate[0].left == 90 and cups_on_plate[0].upper == H - 45


def test_exists(image):
    assert image.exists("plate") is True
    assert image.exists("giraffe") is False
    plate = image.find("plate")[0]
    assert plate.exists("cup") and not plate.crop(120, 31, 130, 55).exists("cup")


def test_visual_query_sees_the_patch_pixels_and_language_query_the_text(image):
    plate = image.find("plate")[0]
    assert image.visual_query("What is this?") == f"{W}x{H}@0,0"
    assert plate.visual_query("  What is this? ") == "50x25@80,45"
    assert image.perception.vqa.questions[-1] == "What is this?"  # stripped
    assert image.language_query("which is heavier, a cup or a plate?") == "plate"
    assert image.language_query("what is a flumph?") == "unknown"


def test_crop_takes_upward_coordinates_and_intersects_the_patch(image):
    top_half = image.crop(0, H / 2, W, H)
    assert top_half.box == (0, 0, W, H / 2)
    in_top = top_half.find("cup")
    assert [c.object_id for c in in_top] == ["cup_2", None]  # the middle cup straddles the line: clipped
    assert in_top[1].box == (90, 40, 110, 50)
    plate = image.find("plate")[0]
    part = plate.crop(0, 0, 100, H)  # reaches beyond the plate: keeps the plate's part
    assert (part.left, part.right, part.lower, part.upper) == (80, 100, plate.lower, plate.upper)
    assert part.capture is plate.capture and part.object_id is None


def test_overlaps_and_distance_to(image):
    plate = image.find("plate")[0]
    middle_cup, *_ = [c for c in image.find("cup") if c.object_id is None]
    far_cup = [c for c in image.find("cup") if c.object_id == "cup_2"][0]
    assert plate.overlaps(middle_cup) and middle_cup.overlaps(plate)
    assert not plate.overlaps(far_cup)
    touching = image.crop(130, 0, 140, 10)
    assert not plate.overlaps(touching)  # shares only the edge x=130
    assert middle_cup.distance_to(middle_cup) == 0
    assert far_cup.distance_to(middle_cup) == pytest.approx(np.hypot(160 - 100, 85 - 50))


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda p: p.find(""), "find\\(\\) got an empty object_name"),
        (lambda p: p.find("   "), "empty object_name"),
        (lambda p: p.find(3), "find\\(\\) needs object_name as text, got int"),
        (lambda p: p.find(["cup"]), "as text, got list"),
        (lambda p: p.exists(None), "exists\\(\\) needs object_name as text"),
        (lambda p: p.visual_query(""), "visual_query\\(\\) got an empty question"),
        (lambda p: p.language_query(b"hi"), "language_query\\(\\) needs question as text, got bytes"),
        (lambda p: p.language_query("x" * 5000), "more than 2000"),
        # a length cap per role (issue 22 item 1): names for the detector, questions for VQA
        (lambda p: p.find("x" * 301), "object_name of 301 characters, more than 300"),
        (lambda p: p.exists("x" * 400), "more than 300"),
        (lambda p: p.visual_query("x" * 1001), "question of 1001 characters, more than 1000"),
        (lambda p: p.crop(10, 10, 5, 20), "is empty: it needs right > left"),
        (lambda p: p.crop(10, 20, 30, 20), "is empty"),
        (lambda p: p.crop(-5, 0, 10, 10), "reaches outside the image"),
        (lambda p: p.crop(0, 0, 10, H + 1), "reaches outside the image"),
        (lambda p: p.crop(0, 0, "10", 10), "crop\\(\\) needs right as a number, got str"),
        (lambda p: p.crop(0, 0, True, 10), "needs right as a number, got bool"),
        (lambda p: p.crop(0, 0, float("nan"), 10), "not finite"),
        (lambda p: p.find("plate")[0].crop(0, 0, 10, 10), "does not overlap this patch"),
        (lambda p: p.overlaps("cup"), "overlaps\\(\\) needs other as an ImagePatch, got str"),
        (lambda p: p.distance_to(None), "distance_to\\(\\) needs other as an ImagePatch"),
    ],
)
def test_bad_arguments_are_api_errors_with_a_fix(image, call, match):
    with pytest.raises(ApiArgumentError, match=match) as info:
        call(image)
    assert isinstance(info.value, AttribotError) and info.value.fix


@pytest.mark.parametrize(
    ("box", "match"),
    [
        ((0, 0, W + 5, 10), "lies outside the 200x100 image"),
        ((-1, 0, 5, 5), "lies outside"),
        ((5, 5, 1, 8), "x1 >= x0"),
        ((0, 0, float("inf"), 5), "finite"),
        ((0, 0, 5), "four numbers"),
    ],
)
def test_bad_boxes_rejected_at_construction(box, match):
    with pytest.raises(ApiArgumentError, match=match):
        ImagePatch(frame(), perception_for(), box)


def test_backends_that_break_their_protocol_are_named():
    class BadDetector(FakeDetector):
        def detect(self, frame, queries):
            return [((0, 0, 1, 1), 0.5)]

    class BadVQA:
        name = "bad-vqa"

        def answer(self, frame, question):
            return None

    p = perception_for()
    patch = ImagePatch(frame(), Perception(BadDetector(), BadVQA(), p.language))
    with pytest.raises(BackendError, match="fake-detector"):
        patch.find("cup")
    with pytest.raises(BackendError, match="'bad-vqa' answered a NoneType"):
        patch.visual_query("what?")
    with pytest.raises(ConfigError, match="does not follow the VisualQA protocol"):
        Perception(BadDetector(), object(), p.language)


def test_from_image_file_and_summary(tmp_path, image):
    from PIL import Image

    path = tmp_path / "img.png"
    Image.fromarray(frame().rgb).save(path)
    patch = ImagePatch.from_image(path, image.perception)
    assert (patch.width, patch.height) == (W, H) and patch.capture is None and patch.target() is None
    cup = image.find("cup")[0]
    assert cup.summary() == {
        "label": "cup", "object_id": "cup_2", "box": [150, 5, 170, 25], "score": 0.9, "evidence": "sure box"
    }  # fmt: skip
    assert cup.same_object(image.find("cup")[0]) and not cup.same_object(image.find("cup")[2])
    assert "ImagePatch('cup' left=150" in repr(cup)


def test_real_offline_backends_through_settings():
    """The oracle detector/VQA and catalog language model, built from default settings, behind ImagePatch."""
    from attribot.config import Settings
    from attribot.frame import ObjectTruth

    seg = np.full((H, W), -1, np.int32)
    seg[60:90, 10:30] = 0  # a mug at the bottom left (y down: rows 60..89)
    seg[5:25, 150:170] = 1  # a mug at the top right
    seg[40:70, 80:130] = 2  # a plate in the middle
    objects = {
        0: ObjectTruth("mug_0", "mug", "red"),
        1: ObjectTruth("mug_1", "mug", "blue"),
        2: ObjectTruth("plate_0", "plate", "white"),
    }
    f = Frame(rgb=np.zeros((H, W, 3), np.uint8), segmentation=seg, objects=objects)
    perception = Perception.from_settings(Settings(_env_file=None))
    assert perception.names() == {"detector": "oracle", "vqa": "oracle", "language": "catalog"}
    image = ImagePatch(f, perception)
    mugs = sorted(image.find("mug"), key=lambda m: m.vertical_center)
    assert [m.object_id for m in mugs] == ["mug_0", "mug_1"]  # bottom one first: y grows upward
    assert mugs[1].box == (150, 5, 170, 25) and mugs[1].upper == H - 5
    plate = image.find("plate")[0]
    # a find inside the plate's patch sees only the pixels there: no mug; boxes map back to the frame
    assert plate.find("mug") == [] and plate.find("plate")[0].box == plate.box
    # the VQA sees only the patch's pixels: each mug answers with its own colour
    assert [m.visual_query("What color is this?") for m in mugs] == ["red", "blue"]
    assert image.language_query("Which is heavier, a mug or a plate?") in {"mug", "plate"}
