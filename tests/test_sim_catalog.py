"""The object catalog and the shapes built from it (no rendering, no physics)."""

from __future__ import annotations

import pytest

from attribot.errors import UnknownName
from attribot.sim.catalog import COLORS, categories, category_names, find_category, get_category
from attribot.sim.shapes import SHAPES, build_shape

PAPER = [
    "laptop",
    "vase",
    "cactus",
    "pencil",
    "lamp",
    "book",
    "broom",
    "cd",
    "cell phone",
    "basketball",
    "apple",
    "mug",
    "pot",
    "pan",
    "knife",
    "fork",
    "ladle",
    "toaster",
    "remote control",
    "pillow",
    "box",
    "tennis racket",
    "painting",
    "plate",
    "bowl",
    "bottle",
    "can",
    "candle",
    "teapot",
    "egg",
    "tomato",
    "potato",
    "carrot",
]


def test_at_least_forty_categories_covering_the_papers_scenes():
    names = category_names()
    assert len(names) >= 40
    assert len(set(names)) == len(names)
    missing = [n for n in PAPER if n not in names]
    assert not missing


@pytest.mark.parametrize("cat", categories(), ids=lambda c: c.name)
def test_category_fields_are_sane_and_its_shape_builds(cat):
    lo, hi = cat.size_range_m
    assert 0 < lo <= hi < 2.0
    mlo, mhi = cat.mass_range_kg
    assert 0 < mlo <= mhi < 50
    assert cat.colors and all(c in COLORS for c in cat.colors)
    assert cat.placement in ("surface", "floor")
    assert cat.shape in SHAPES
    for size in (lo, hi):
        shape = build_shape(cat.shape, size)
        assert shape.lo[2] >= -1e-3, "a shape must not reach below its base (stripes may stand out < 1 mm)"
        extent = max(h - l_ for h, l_ in zip(shape.hi, shape.lo, strict=True))
        assert 0.5 * size <= extent <= 1.35 * size, f"longest dimension {extent:.3f} for size {size:.3f}"
        assert shape.visible_volume > 0
    if cat.deceptive:
        assert len(cat.mass_variants) >= 2
        ranges = sorted(r for _, r in cat.mass_variants)
        assert ranges[0][1] * 3 < ranges[-1][0], "the hidden states must differ clearly in weight"


def test_deceptive_objects_exist_for_box_and_ball():
    for name in ("box", "ball"):
        cat = get_category(name)
        assert cat.deceptive and cat.pickable
        assert {v for v, _ in cat.mass_variants} >= (
            {"empty", "full"} if name == "box" else {"hollow", "solid"}
        )


@pytest.mark.parametrize(
    ("word", "expected"),
    [
        ("mug", "mug"),
        ("Coffee Cups", "mug"),
        ("cell phones", "cell phone"),
        ("the red smartphone", "cell phone"),
        ("knives", "knife"),
        ("tomatoes", "tomato"),
        ("boxes", "box"),
        ("cardboard box", "box"),
        ("ball", "ball"),
        ("basketballs", "basketball"),
        ("tennis racket", "tennis racket"),
        ("racquets", "tennis racket"),
        ("weight", None),
        ("heaviest", None),
        ("", None),
        ("item", None),
    ],
)
def test_find_category_names_synonyms_plurals(word, expected):
    found = find_category(word)
    assert (found.name if found else None) == expected


def test_get_category_unknown_lists_the_names():
    with pytest.raises(UnknownName, match="unicorn") as exc:
        get_category("unicorn")
    assert "mug" in (exc.value.fix or "")
