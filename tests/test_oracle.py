"""Ground-truth perception: the oracle detector and VQA on synthetic frames (and a rendered one)."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from attribot.config import Settings
from attribot.errors import ConfigError, InputError
from attribot.frame import Frame, ObjectTruth
from attribot.lexicon import singular_forms
from attribot.models.base import UNKNOWN, Detector, VisualQA, build_backend
from attribot.models.oracle import OracleDetector, OracleVQA, visible_objects

H, W = 80, 120

# key -> (truth, (x0, y0, x1, y1) of its rectangle); drawn in this order, later ones occlude earlier ones
LAYOUT = {
    0: (ObjectTruth("apple_0", "apple", "red", ("apple",)), (5, 40, 20, 60)),  # 300 px
    1: (ObjectTruth("mug_1", "mug", "blue", ("cup", "coffee mug")), (30, 30, 50, 60)),  # 600 px
    2: (ObjectTruth("laptop_2", "laptop", "gray", ("notebook computer",)), (60, 10, 100, 60)),  # 2000 px
    3: (ObjectTruth("apple_3", "apple", "green"), (105, 50, 115, 60)),  # 100 px
    4: (ObjectTruth("cell_phone_4", "cell_phone", "black", ("mobile phone",)), (5, 5, 11, 9)),  # 24 px
    5: (ObjectTruth("knife_5", "knife", "silver"), (25, 65, 55, 70)),  # 150 px
}


def make_frame(layout=LAYOUT, occluder: tuple[int, int, int, int] | None = None) -> Frame:
    seg = np.full((H, W), -1, np.int32)
    rgb = np.zeros((H, W, 3), np.uint8)
    for key, (_, (x0, y0, x1, y1)) in layout.items():
        seg[y0:y1, x0:x1] = key
        rgb[y0:y1, x0:x1] = (40 * key) % 255
    if occluder is not None:
        x0, y0, x1, y1 = occluder
        seg[y0:y1, x0:x1] = -1
    return Frame(rgb=rgb, segmentation=seg, objects={k: t for k, (t, _) in layout.items()})


@pytest.fixture(scope="module")
def frame() -> Frame:
    return make_frame()


def ids(dets) -> list[str]:
    return [d.object_id for d in dets]


# ---- detector ----------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("query", "expected"),
    [
        ("apple", ["apple_0", "apple_3"]),
        ("Apples", ["apple_0", "apple_3"]),
        ("APPLE", ["apple_0", "apple_3"]),
        ("the apple", ["apple_0", "apple_3"]),
        ("a photo of an apple", ["apple_0", "apple_3"]),
        ("an image of the apples.", ["apple_0", "apple_3"]),
        ("red apple", ["apple_0"]),
        ("green apples", ["apple_3"]),
        ("blue apple", []),
        ("the blue ones", ["mug_1"]),
        ("the red one", ["apple_0"]),
        ("red", ["apple_0"]),
        ("grey things", ["laptop_2"]),  # British spelling folds to the object's "gray"
        ("cup", ["mug_1"]),
        ("coffee mugs", ["mug_1"]),
        ("mug on the table", ["mug_1"]),
        ("computer", ["laptop_2"]),  # head noun of a multi-word synonym
        ("knives", ["knife_5"]),
        ("item", ["laptop_2", "mug_1", "apple_0", "knife_5", "apple_3"]),
        ("objects", ["laptop_2", "mug_1", "apple_0", "knife_5", "apple_3"]),
        ("a heavy object", ["laptop_2", "mug_1", "apple_0", "knife_5", "apple_3"]),  # modifier ignored
        ("all the things", ["laptop_2", "mug_1", "apple_0", "knife_5", "apple_3"]),
        ("dog", []),
        ("banana", []),
        ("cell phone", []),  # 24 px: below the 30 px threshold
        ("mug or laptop", ["laptop_2", "mug_1"]),
        ("t-shirt", []),
    ],
)
def test_detector_query_table(frame, query, expected):
    dets = OracleDetector().detect(frame, [query])
    assert sorted(ids(dets)) == sorted(expected)
    assert ids(dets) == ids(sorted(dets, key=lambda d: -d.score))  # best first


def test_detector_boxes_and_ranking_follow_visible_pixels(frame):
    dets = OracleDetector().detect(frame, ["item"])
    boxes = {d.object_id: d.box for d in dets}
    for truth, rect in LAYOUT.values():
        if truth.id in boxes:
            assert boxes[truth.id] == tuple(float(v) for v in rect)
    # bigger visible area ranks first: laptop 2000 px, mug 600, apple 300, knife 150, green apple 100
    assert ids(dets) == ["laptop_2", "mug_1", "apple_0", "knife_5", "apple_3"]
    assert all(0.0 < d.score < 1.0 for d in dets)
    assert all(d.label == "item" for d in dets)


def test_exact_names_outrank_loose_matches_of_equal_size():
    layout = {
        0: (ObjectTruth("a", "tennis_racket", "red"), (0, 0, 20, 20)),
        1: (ObjectTruth("b", "racket", "red"), (30, 0, 50, 20)),
    }
    dets = OracleDetector().detect(make_frame(layout), ["racket"])
    assert ids(dets) == ["b", "a"] and dets[0].score > dets[1].score


@pytest.mark.parametrize(
    ("query", "expected"),
    [
        ("orange", ["fruit"]),  # a category name first, a colour only when no object is called so
        ("oranges", ["fruit"]),
        ("orange mug", ["mug"]),
        ("orange things", ["fruit", "mug"]),
        ("wooden spoon", ["spoon"]),  # a material the oracle cannot check is ignored, not a filter
        ("teal", ["spoon"]),
    ],
)
def test_colour_words_that_are_also_names(query, expected):
    layout = {
        0: (ObjectTruth("fruit", "orange", "orange"), (0, 0, 20, 20)),
        1: (ObjectTruth("mug", "mug", "orange"), (30, 0, 50, 20)),
        2: (ObjectTruth("spoon", "spoon", "teal"), (60, 0, 80, 20)),
    }
    assert sorted(ids(OracleDetector().detect(make_frame(layout), [query]))) == sorted(expected)


def test_several_phrases_each_matched_and_deduplicated(frame):
    dets = OracleDetector().detect(frame, ["apple", "red thing", "mug"])
    assert sorted(ids(dets)) == ["apple_0", "apple_3", "mug_1"]  # apple_0 once, though two phrases name it
    assert {d.label for d in dets} <= {"apple", "red thing", "mug"}


def test_occlusion_shrinks_box_and_score():
    full = OracleDetector().detect(make_frame(), ["laptop"])[0]
    half = OracleDetector().detect(make_frame(occluder=(80, 0, 120, 80)), ["laptop"])[0]
    assert half.box == (60.0, 10.0, 80.0, 60.0)
    assert half.score < full.score


@pytest.mark.parametrize(("min_pixels", "seen"), [(1, True), (24, True), (25, False), (30, False)])
def test_small_object_threshold(frame, min_pixels, seen):
    dets = OracleDetector(min_pixels=min_pixels).detect(frame, ["phone"])
    assert (ids(dets) == ["cell_phone_4"]) is seen


def test_crop_boxes_are_in_crop_pixels(frame):
    crop = frame.crop((25.0, 20.0, 70.0, 75.0))  # the mug, a strip of the laptop, most of the knife
    dets = {d.object_id: d.box for d in OracleDetector().detect(crop, ["item"])}
    assert dets["mug_1"] == (5.0, 10.0, 25.0, 40.0)
    assert dets["laptop_2"] == (35.0, 0.0, 45.0, 40.0)
    assert dets["knife_5"] == (0.0, 45.0, 30.0, 50.0)
    assert "apple_0" not in dets and "apple_3" not in dets
    # boxes in crop pixels plus the crop's origin are the full frame's boxes (where not cut by the crop)
    ox, oy = crop.origin
    full = {d.object_id: d.box for d in OracleDetector().detect(frame, ["mug"])}
    x0, y0, x1, y1 = dets["mug_1"]
    assert (x0 + ox, y0 + oy, x1 + ox, y1 + oy) == full["mug_1"]


@pytest.mark.parametrize("queries", [[], [""], ["   "], ["?!"], ["apple", ""]])
def test_empty_queries_are_input_errors(frame, queries):
    with pytest.raises(InputError):
        OracleDetector().detect(frame, queries)


def test_plain_image_needs_a_real_detector():
    plain = Frame(rgb=np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(ConfigError, match="ground truth") as err:
        OracleDetector().detect(plain, ["apple"])
    assert "--detector hf:" in str(err.value) and "attribot backends" in str(err.value)
    with pytest.raises(ConfigError, match="ground truth") as err:
        OracleVQA().answer(plain, "What is this?")
    assert "--vqa hf:" in str(err.value)


def test_a_bare_string_query_is_one_phrase(frame):
    assert ids(OracleDetector().detect(frame, "mug")) == ["mug_1"]


def test_empty_scene_frame_detects_nothing():
    empty = Frame(rgb=np.zeros((10, 10, 3), np.uint8), segmentation=np.full((10, 10), -1, np.int32))
    assert OracleDetector().detect(empty, ["item"]) == []
    assert OracleVQA().answer(empty, "What is this?") == UNKNOWN
    assert OracleVQA().answer(empty, "How many items are there?") == "0"


# ---- VQA ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("question", "expected"),
    [
        ("What is this?", "laptop"),
        ("what's in the image", "laptop"),
        ("What is in this picture?", "laptop"),
        ("What is it?", "laptop"),
        ("What colour is it?", "gray"),
        ("What color is the mug?", "blue"),
        ("What color is this object?", "gray"),
        ("What is the colour of the green apple?", "green"),
        ("What is the mug's colour?", "blue"),
        ("What color is the dog?", UNKNOWN),
        ("Is this a laptop?", "yes"),
        ("Is this a computer?", "yes"),
        ("Is this an apple?", "no"),
        ("Is it gray?", "yes"),
        ("Is there a mug?", "yes"),
        ("Is there a red apple in the image?", "yes"),
        ("Are there any apples?", "yes"),
        ("Is there a dog?", "no"),
        ("Is there a cell phone?", "no"),  # below the pixel threshold
        ("Does the image contain a knife?", "yes"),
        ("Can you see a cup?", "yes"),
        ("Is the mug blue?", "yes"),
        ("Is the mug red?", "no"),
        ("What are the items in this image?", "apple, mug, knife, laptop, apple"),
        ("What objects are in the image?", "apple, mug, knife, laptop, apple"),
        ("Which objects are red?", "apple"),
        ("How many apples are there?", "2"),
        ("How many items are there in the image?", "5"),
        ("How many red apples are there?", "1"),
        ("How many dogs are there?", "0"),
        # not visual: must be measured or reasoned about
        ("Out of these items, which one is the heaviest?", UNKNOWN),
        ("How heavy is the laptop?", UNKNOWN),
        ("What is the weight of this?", UNKNOWN),
        ("Is this lightweight enough to pick up?", UNKNOWN),
        ("Is it light?", UNKNOWN),
        ("Which one is closer to me?", UNKNOWN),
        ("How far away is the mug?", UNKNOWN),
        ("Is the mug hot?", UNKNOWN),
        ("What is the temperature of the mug?", UNKNOWN),
        ("Is the box empty?", UNKNOWN),
        ("How many heavy items are there?", UNKNOWN),
        # anything else
        ("Where is the mug?", UNKNOWN),
        ("Why?", UNKNOWN),
        ("Tell me a joke", UNKNOWN),
        ("asdf qwer", UNKNOWN),
    ],
)
def test_vqa_question_table(frame, question, expected):
    assert OracleVQA().answer(frame, question) == expected


@pytest.mark.parametrize(
    ("box", "question", "expected"),
    [
        ((25, 25, 55, 62), "What is this?", "mug"),
        ((25, 25, 55, 62), "What colour is it?", "blue"),
        ((25, 25, 55, 62), "Is this a cup?", "yes"),
        ((25, 25, 55, 62), "Is there a laptop?", "no"),
        ((0, 35, 60, 80), "What are the items in this image?", "apple, mug, knife"),
        ((0, 35, 60, 80), "How many apples are there?", "1"),
        ((100, 0, 120, 80), "What is this?", "apple"),
        ((100, 0, 120, 80), "What colour is it?", "green"),
        ((0, 0, 4, 4), "What is this?", UNKNOWN),
        ((0, 0, 4, 4), "What are the items in this image?", "nothing"),
    ],
)
def test_vqa_on_crops(frame, box, question, expected):
    assert OracleVQA().answer(frame.crop(box), question) == expected


@pytest.mark.parametrize("question", ["", "   ", "?"])
def test_vqa_empty_question_is_an_error(frame, question):
    with pytest.raises(InputError):
        OracleVQA().answer(frame, question)


# ---- registration and helpers ------------------------------------------------------------------------


def test_registered_builders_and_protocols():
    settings = Settings()
    det = build_backend("detector", "oracle", settings)
    vqa = build_backend("vqa", "oracle:5", settings)
    assert isinstance(det, Detector) and det.name == "oracle" and det.min_pixels == 30
    assert isinstance(vqa, VisualQA) and vqa.name == "oracle" and vqa.min_pixels == 5
    assert build_backend("detector", "oracle:min_pixels=12", settings).min_pixels == 12
    with pytest.raises(ConfigError, match="pixel count"):
        build_backend("detector", "oracle:lots", settings)
    with pytest.raises(ConfigError):
        OracleDetector(min_pixels=0)
    for cls in (OracleDetector, OracleVQA):
        assert "honest stand-in" in (cls.__doc__ or "")


@pytest.mark.parametrize(
    ("word", "singular"),
    [("apples", "apple"), ("boxes", "box"), ("knives", "knife"), ("berries", "berry"), ("glass", "glass"),
     ("cacti", "cactus"), ("potatoes", "potato")],
)  # fmt: skip
def test_singular_forms(word, singular):
    assert singular in singular_forms(word)


def test_visible_objects_sorted_left_to_right(frame):
    xs = [o.center_x for o in visible_objects(frame)]
    assert xs == sorted(xs)


# ---- a rendered simulator frame ----------------------------------------------------------------------

_HAS_WORLD = importlib.util.find_spec("attribot.embodiments.mujoco") is not None


def _projected_box(world, key: int, frame: Frame) -> tuple[float, float, float, float]:
    """The image box of the corners of an object's world bounds: its pixels can only lie inside it."""
    pos, rot = world.sim.camera_pose()  # rotation columns: right, up, backward
    cam = frame.camera
    lo, hi = world.sim.object_bounds(key)
    us, vs = [], []
    for corner in np.array(np.meshgrid(*zip(lo, hi, strict=True))).T.reshape(-1, 3):
        x, y, z = rot.T @ (corner - pos)
        assert z < 0, "object behind the camera"
        us.append(cam.cx + cam.fx * x / -z)
        vs.append(cam.cy - cam.fy * y / -z)
    return min(us), min(vs), max(us), max(vs)


@pytest.mark.skipif(not _HAS_WORLD, reason="the MuJoCo world (embodiments/mujoco.py) is not in this tree yet")
@pytest.mark.parametrize(("layout", "seed"), [("triplet", 3), ("household", 7)])
def test_oracle_on_a_rendered_world_frame(layout, seed):
    from attribot.embodiments.mujoco import MujocoWorld

    world = MujocoWorld(layout=layout, seed=seed, width=320, height=240)
    try:
        frame = world.observe()
        info = world.scene_info()
        assert frame.has_truth
        seg = frame.segmentation
        dets = OracleDetector().detect(frame, ["item"])
        by_id = {t.id: k for k, t in frame.objects.items()}
        listed = {o.id: o for o in info.objects}
        for det in dets:
            key = by_id[det.object_id]
            mask = seg == key
            ys, xs = np.nonzero(mask)
            # the box is the segmentation's, and the scene listing's box for the same object
            assert det.box == (xs.min(), ys.min(), xs.max() + 1.0, ys.max() + 1.0)
            assert mask.sum() >= 30
            assert listed[det.object_id].box is not None
            assert tuple(listed[det.object_id].box) == det.box
            # ... and it lies inside the projection of the object's 3D bounds (visible pixels can be fewer)
            px0, py0, px1, py1 = _projected_box(world, key, frame)
            x0, y0, x1, y1 = det.box
            assert x0 >= max(px0, 0) - 2 and y0 >= max(py0, 0) - 2, (det, (px0, py0, px1, py1))
            assert x1 <= min(px1, frame.width) + 2 and y1 <= min(py1, frame.height) + 2, (
                det,
                (px0, py0, px1, py1),
            )
        # every object the scene lists as seen with enough pixels is detected, also by its own name
        seen = [o for o in info.objects if o.box is not None and o.visible_pixels >= 30]
        assert seen
        assert {o.id for o in seen} == set(ids(dets))
        for obj in seen:
            assert obj.id in ids(OracleDetector().detect(frame, [obj.category]))
            assert obj.id in ids(OracleDetector().detect(frame, [f"the {obj.color} {obj.category}s"]))
        items = OracleVQA().answer(frame, "What are the items in this image?").split(", ")
        left_to_right = sorted(seen, key=lambda o: (o.box[0] + o.box[2]) / 2)
        assert items == [o.category for o in left_to_right]
        # a crop around one object: the VQA names it, the detector boxes it in the crop's pixels
        target = max(seen, key=lambda o: o.visible_pixels)
        crop = frame.crop(tuple(target.box))
        assert OracleVQA().answer(crop, "What is this?") == target.category
        assert OracleVQA().answer(crop, "What colour is it?") == target.color
        (inside,) = [d for d in OracleDetector().detect(crop, [target.category]) if d.object_id == target.id]
        w, h = target.box[2] - target.box[0], target.box[3] - target.box[1]
        assert inside.box == (0.0, 0.0, w, h)
    finally:
        world.close()
