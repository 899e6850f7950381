"""Objects' looks: drawn over unchanged bodies, so physics, sensing and scenes are those of the old looks."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from attribot.errors import InputError
from attribot.sim.catalog import categories
from attribot.sim.looks import LOOKS, look_of, variant_of
from attribot.sim.meshes import lathe, tube
from attribot.sim.model import build_model
from attribot.sim.scene import plan_scene
from attribot.sim.scene_plan import SceneRequest
from attribot.sim.shapes import SHAPES, Part, Shape, build_shape
from attribot.sim.world import SimWorld


@pytest.mark.parametrize(("layout", "seed"), [("household", 0), ("household", 7), ("triplet", 2)])
def test_looks_change_no_mass_inertia_placement_or_settled_pose(layout, seed):
    new = SimWorld(layout=layout, seed=seed, width=64, height=48)
    old = SimWorld(layout=layout, seed=seed, width=64, height=48, looks="primitive")
    try:
        for field in ("body_mass", "body_inertia", "body_ipos", "body_iquat", "body_pos"):
            assert np.array_equal(getattr(new.model, field), getattr(old.model, field)), field
        assert np.array_equal(new.data.qpos, old.data.qpos)
        assert new.read_distance() == old.read_distance()
        for key in new.objects:
            assert np.array_equal(new.object_bounds(key), old.object_bounds(key))
        assert new.model.ngeom > old.model.ngeom  # the looks are there, as extra geoms
    finally:
        new.close()
        old.close()


def test_every_category_builds_with_its_look_in_a_scene():
    built = 0
    for category in categories():  # a few big ones (a pan, a suitcase) fit no one-object household
        for seed in range(5):
            try:
                plan = plan_scene("household", seed, SceneRequest(n_objects=1, categories=(category,)))
            except InputError:
                continue
            model = build_model(plan)
            assert model.ngeom > build_model(plan, looks="primitive").ngeom, category.name
            built += 1
            break
    assert built >= 0.8 * len(categories())


@pytest.mark.parametrize("shape", sorted(LOOKS.names()))
def test_each_look_has_the_size_of_its_body(shape):
    size = 0.2
    body = build_shape(shape, size)
    for variant in range(3):
        looks = look_of(shape, body, size, variant)
        assert looks
        pts = []
        for look in looks:
            if look.mesh is not None:
                assert look.mesh.faces.max() < len(look.mesh.vertices)
                pts.append(look.mesh.vertices)
            else:
                pts.append(np.asarray([look.pos]))
        pts = np.vstack(pts)
        extent = pts.max(axis=0) - pts.min(axis=0)
        assert extent.max() < 1.6 * size, (shape, extent)


def _bounds(looks: list) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for look in looks:
        if look.mesh is not None:
            pts = look.mesh.vertices
        else:
            part = Part(look.kind, look.size, (0, 0, 0), look.quat)
            if look.kind in ("sphere", "ellipsoid"):  # a turned ellipsoid's own extent, not its box's
                rot = np.zeros(9)
                mujoco.mju_quat2Mat(rot, np.asarray(look.quat, float))
                reach = np.sqrt(((rot.reshape(3, 3) * part.half_extents()) ** 2).sum(axis=1))
            else:
                reach = np.abs(Shape((part,)).hi)
            pts = np.asarray([np.asarray(look.pos) - reach, np.asarray(look.pos) + reach])
        lo, hi = np.minimum(lo, pts.min(axis=0)), np.maximum(hi, pts.max(axis=0))
    return lo, hi


@pytest.mark.parametrize(
    "category", [c for c in categories() if c.shape in LOOKS.names()], ids=lambda c: c.name
)
def test_a_look_keeps_to_its_body_at_real_world_sizes(category):
    """A look is drawn over its body, at its category's sizes: no part of it reaches more than a tenth of the
    object's size (2 cm at least: a toaster's toast, a backpack's straps) beyond the body's bounds, which
    the truth's boxes, the rangefinder and the grasps read."""
    for size in category.size_range_m:
        body = build_shape(category.shape, size)
        for variant in range(3):
            lo, hi = _bounds(look_of(category.shape, body, size, variant))
            beyond = np.maximum(np.asarray(body.lo) - lo, hi - np.asarray(body.hi)).max()
            assert beyond <= max(0.1 * size, 0.02), (category.name, size, variant, beyond)


def test_every_look_names_a_shape_and_variants_come_from_the_id_not_the_scene():
    assert set(LOOKS.names()) <= set(SHAPES.names())
    assert variant_of("mug_3", 3) == variant_of("mug_3", 3)
    assert {variant_of(f"mug_{i}", 3) for i in range(30)} == {0, 1, 2}


def test_meshes_are_closed_where_they_should_be():
    cup = lathe([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)], 12)
    assert len(cup.vertices) == 4 * 12 and len(cup.faces) == 2 * 3 * 12
    rod = tube(np.array([[0.0, 0, 0], [0, 0, 1.0]]), 0.1, 8)
    assert len(rod.faces) == 2 * 8 + 2 * 8  # side and two caps
    normals = np.cross(*(rod.vertices[rod.faces[:, k]] - rod.vertices[rod.faces[:, 0]] for k in (1, 2)))
    centres = rod.vertices[rod.faces].mean(axis=1)
    side = slice(0, 16)
    outward = np.einsum("ij,ij->i", normals[side], centres[side] - [0, 0, centres[side][:, 2].mean()])
    assert (outward > 0).all()


def test_unknown_looks_are_refused():
    with pytest.raises(InputError, match="looks"):
        SimWorld(layout="triplet", seed=0, width=64, height=48, looks="photoreal")
