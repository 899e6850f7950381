"""The perception priors of our own (`attribot.priors`): the shipped table validates, its ranges are sound, a
bad file is refused with a clear error, names and classes are found, and scaling scales every length."""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path

import pytest

from attribot.config import Settings
from attribot.errors import ConfigError, InvalidSetting
from attribot.priors import PLACES, SCALE_RANGE, load_priors, priors

SHIPPED = tomllib.loads(
    resources.files("attribot").joinpath("data", "priors.toml").read_text(encoding="utf-8")
)
COCO_CLASSES = [
    word.replace("_", " ")
    for word in """
person bicycle car motorbike aeroplane bus train truck boat traffic_light fire_hydrant stop_sign
parking_meter bench bird cat dog horse sheep cow elephant bear zebra giraffe backpack umbrella handbag tie
suitcase frisbee skis snowboard sports_ball kite baseball_bat baseball_glove skateboard surfboard
tennis_racket bottle wine_glass cup fork knife spoon bowl banana apple sandwich orange broccoli carrot
hot_dog pizza donut cake chair sofa pottedplant bed diningtable toilet tvmonitor laptop mouse remote
keyboard cell_phone microwave oven toaster sink refrigerator book clock vase scissors teddy_bear
hair_drier toothbrush
""".split()
]
"""Darknet's coco.names, the classes the coco detector names."""


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "priors.toml"
    path.write_text(text, encoding="utf-8")
    return path


GOOD_KIND = """
[colours]
red = [200, 30, 30]

[kinds.mug]
coco = "cup"
also = ["cup"]
size_m = [0.06, 0.18]
height_m = [0.05, 0.18]
across_m = [0.05, 0.15]
places = ["table"]
colours = ["red"]
"""


def test_the_shipped_table_validates_and_covers_every_coco_class():
    assert len(COCO_CLASSES) == 80
    table = priors()
    covered = {k.coco for k in table.kinds.values()} - {None}
    assert covered == set(COCO_CLASSES)
    assert table.scale == 1.0


def test_every_range_is_positive_and_ordered_and_fits_within_the_largest_extent():
    for kind in priors().kinds.values():
        ranges = [kind.size_m, kind.height_m, kind.across_m]
        ranges += [r for r in (kind.empty_kg, kind.holds_kg) if r is not None]
        for low, high in ranges:
            assert 0 < low <= high, kind.name
        assert kind.height_m[1] <= kind.size_m[1] * 1.001 and kind.across_m[1] <= kind.size_m[1] * 1.001
        assert set(kind.places) <= set(PLACES) and kind.places


def test_the_file_says_where_its_values_come_from_in_its_first_line():
    first = (
        resources.files("attribot")
        .joinpath("data", "priors.toml")
        .read_text(encoding="utf-8")
        .splitlines()[0]
    )
    assert first.startswith("# Source of every value: common knowledge")


@pytest.mark.parametrize(
    ("phrase", "kind", "coco"),
    [
        ("mug", "mug", "cup"),
        ("the red coffee mugs", "mug", "cup"),
        ("teacups", "cup", "cup"),
        ("alarm clock", "clock", "clock"),
        ("cactus", "cactus", "pottedplant"),
        ("tennis balls", "tennis ball", "sports ball"),
        ("basketball", "basketball", "sports ball"),
        ("remote control", "remote", "remote"),
        ("cell phones", "cell phone", "cell phone"),
        ("cutting board", "cutting board", None),  # not the surfboard's "board"
        ("kettle", "kettle", None),
    ],
)
def test_names_synonyms_and_plurals_find_their_kind(phrase, kind, coco):
    found = priors().find(phrase)
    assert found is not None and found.name == kind and found.coco == coco


def test_a_name_the_table_does_not_know_finds_nothing():
    assert priors().find("flux capacitor") is None
    assert priors().find("") is None


def test_a_class_covers_its_kinds_sizes():
    table = priors()
    low, high = table.class_sizes("sports ball") or (0.0, 0.0)
    for name in ("tennis ball", "basketball", "foam ball"):
        kind = table.find(name)
        assert kind is not None and low <= kind.size_m[0] and kind.size_m[1] <= high
    assert table.class_sizes("no such class") is None


def test_places_say_where_a_kind_is_put():
    table = priors()
    assert table.find("basketball").placement == "floor"  # type: ignore[union-attr]
    assert table.find("knife").placement == "surface"  # type: ignore[union-attr]
    assert table.find("box").placement is None  # type: ignore[union-attr]  # either


def test_scaling_scales_every_length_and_keeps_masses():
    plain, small = priors(), priors(0.5)
    assert small.scale == 0.5 and priors(0.5) is small  # read once
    for name, kind in plain.kinds.items():
        other = small.kinds[name]
        for a, b in (
            (kind.size_m, other.size_m),
            (kind.height_m, other.height_m),
            (kind.across_m, other.across_m),
        ):
            assert b == pytest.approx((a[0] * 0.5, a[1] * 0.5))
        assert other.empty_kg == kind.empty_kg and other.holds_kg == kind.holds_kg
    assert small.find("mug") == small.kinds["mug"]  # names find the scaled kinds
    assert small.class_sizes("cup") == pytest.approx(tuple(v * 0.5 for v in plain.class_sizes("cup") or ()))


@pytest.mark.parametrize("scale", [0.0, 0.2, 4.5, -1.0])
def test_a_scale_out_of_range_is_refused(scale):
    with pytest.raises(ConfigError, match="scale must be within"):
        priors(scale)
    with pytest.raises(InvalidSetting, match="priors_scale"):
        Settings(priors_scale=scale)


def test_the_setting_takes_the_documented_range():
    assert Settings().priors_scale == 1.0
    assert Settings(priors_scale=SCALE_RANGE[0]).priors_scale == SCALE_RANGE[0]
    assert Settings(priors_scale=SCALE_RANGE[1]).priors_scale == SCALE_RANGE[1]


def test_a_good_small_file_loads(tmp_path):
    table = load_priors(_write(tmp_path, GOOD_KIND))
    assert table.find("cups").name == "mug"  # type: ignore[union-attr]


@pytest.mark.parametrize(
    ("change", "problem"),
    [
        (("size_m = [0.06, 0.18]", "size_m = [-0.06, 0.18]"), "must be positive"),
        (("size_m = [0.06, 0.18]", "size_m = [0.18, 0.06]"), "[smallest, largest]"),
        (('places = ["table"]', 'places = ["table"]\nweight_kg = [0.1, 0.2]'), "weight_kg"),
        (('places = ["table"]', 'places = ["ceiling"]'), "places"),
        (('places = ["table"]', "places = []"), "places"),
        (('colours = ["red"]', 'colours = ["mauve"]'), "does not define"),
        (("red = [200, 30, 30]", "red = [300, 30, 30]"), "colours.red"),
        (("height_m = [0.05, 0.18]", "height_m = [0.05, 0.5]"), "past the largest size"),
        (('places = ["table"]', 'places = ["table"]\nempty_kg = [0.1, 0.3]'), "both empty_kg and holds_kg"),
        (("[kinds.mug]", "[kinds.mug]\nsize = 3"), "size"),
        (("[colours]", "[colors]"), "colors"),
    ],
)
def test_a_bad_file_is_refused_naming_the_kind_and_the_field(tmp_path, change, problem):
    with pytest.raises(ConfigError) as err:
        load_priors(_write(tmp_path, GOOD_KIND.replace(*change)))
    assert problem in err.value.message and str(tmp_path) in err.value.message


def test_a_name_given_to_two_kinds_is_refused(tmp_path):
    two = GOOD_KIND + GOOD_KIND.split("[kinds.mug]")[1].join(["\n[kinds.teacup]", ""])
    with pytest.raises(ConfigError, match="given to two kinds"):
        load_priors(_write(tmp_path, two))


def test_a_file_that_is_no_toml_is_refused(tmp_path):
    with pytest.raises(ConfigError, match="cannot read the perception priors"):
        load_priors(_write(tmp_path, "[kinds.mug\nsize_m = ["))
    with pytest.raises(ConfigError, match="cannot read"):
        load_priors(tmp_path / "missing.toml")


def test_the_shipped_file_holds_only_its_two_tables():
    assert set(SHIPPED) == {"colours", "kinds"}


def test_the_flag_is_on_ask_and_a_condition_on_eval():
    from conftest import cli

    ask = cli("ask", "--help")
    assert "--priors-scale" in ask.stdout
    evaluate = cli("eval", "--help")
    assert "--priors-scale" not in evaluate.stdout and "priorsFACTOR" in evaluate.stdout
    bad = cli("ask", "--priors-scale", "9", "Where is the mug?")
    assert bad.returncode == 2 and "priors_scale" in bad.stderr


def test_the_mechanisms_of_a_session_hold_the_scaled_table():
    from attribot.skills.safeguards import Safeguards

    assert Safeguards().priors is priors()
    assert Safeguards("all", None, priors(0.7)).priors.scale == 0.7
