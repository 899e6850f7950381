"""The real-room suite (`attribot.eval.tasks.realroom`): rooms whose query objects are COCO classes among
things no COCO class covers, and questions about objects the room does not hold. Every truth is read back
from the built world, not from the code that drew it."""

from __future__ import annotations

from attribot.embodiments.mujoco import MujocoWorld
from attribot.eval.datasets import build_items
from attribot.eval.suite import TASKS, suite_names
from attribot.eval.tasks.realroom import nameable_categories, unnameable_categories
from attribot.models.coco import COCO_CLASS_OF


def _objects(item):
    with MujocoWorld(item.scene()) as world:
        return world.scene_info().objects


def test_the_suite_and_its_categories():
    assert "realroom" in suite_names()
    assert {t for t, task in TASKS.items() if task.suite == "realroom"} == {
        "weight_realroom", "distance_realroom", "absent_realroom"
    }  # fmt: skip
    assert all(c in COCO_CLASS_OF for c in nameable_categories())
    assert not set(unnameable_categories()) & set(COCO_CLASS_OF)
    assert {"tomato", "dumbbell", "can", "toy block"} <= set(unnameable_categories())


def test_present_items_hold_unnameable_things_beside_the_query_objects_and_their_truth_is_the_worlds():
    items = build_items(["weight_realroom", "distance_realroom"], limit=1)
    assert len(items) == 2
    for item in items:
        objects = _objects(item)
        by_id = {o.id: o for o in objects}
        chosen = [by_id[i] for i in item.candidates]
        assert all(o.category in nameable_categories() for o in chosen)
        surfaces = {o.surface for o in chosen}
        beside = [o for o in objects if o.category not in COCO_CLASS_OF and o.surface in surfaces]
        assert len(beside) >= 2, item.id
        key = (lambda o: o.mass_kg) if item.task == "weight_realroom" else (lambda o: o.distance_m)
        assert item.true_id == min(chosen, key=key).id and item.true_box and not item.absent


def test_absent_items_name_an_object_the_room_does_not_hold():
    items = build_items(["absent_realroom"], limit=2)
    assert len(items) == 2 and len({i.query.split()[0] for i in items}) == 2  # its forms in turn
    for item in items:
        categories = {o.category for o in _objects(item)}
        assert item.absent and not set(item.absent) & categories
        assert all(name in item.query for name in item.absent)
        assert item.true_id == "" and item.true_box == []
