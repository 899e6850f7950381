"""The robot's own body in its camera's frames (`Frame.own_body`): the simulator marks its own geoms' pixels,
and no detector's box on them is taken for an object (YOLOv3-tiny boxes the gripper's orange fingertips at
the image's foot as a carrot). Truth comes from the world: its segmentation of the objects, and the depth of
where furniture and the floor are."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from attribot.config import SceneConfig
from attribot.frame import Frame
from attribot.models.base import Detection, detect_in_views, findable_categories, off_own_body
from attribot.sim.world import SimWorld


@pytest.mark.parametrize(
    "config",
    [SceneConfig(layout="triplet", seed=1), SceneConfig(layout="household", seed=3, robot="ep")],
    ids=["mast-gripper", "ep-arm"],
)
def test_the_simulator_marks_the_robots_own_pixels_and_never_an_objects(config):
    world = SimWorld(config)
    try:
        frame = world.observe()
    finally:
        world.close()
    own = frame.own_body
    assert own is not None and own.dtype == bool and own.shape == frame.depth.shape
    assert own.any()
    # no object's pixel is the robot's, nor any of the furniture's or the floor's
    assert not (own & (frame.segmentation >= 0)).any()
    assert not (own & (frame.surfaces >= 0)).any()
    # a crop keeps the layer aligned with its pixels
    box = (100.0, 200.0, 500.0, 480.0)
    assert np.array_equal(frame.crop(box).own_body, own[200:480, 100:500])


def test_a_box_on_the_robots_body_is_set_aside_and_an_object_held_by_it_is_kept():
    own = np.zeros((480, 640), bool)
    own[455:480, 360:376] = True  # a fingertip at the image's foot
    frame = Frame(rgb=np.zeros((480, 640, 3), np.uint8), own_body=own)
    fingertip = Detection(box=(358, 452, 378, 480), score=0.14, label="carrot")  # loose by a few pixels
    carrot = Detection(box=(310, 248, 342, 281), score=0.12, label="carrot")
    held = Detection(box=(340, 400, 400, 470), score=0.5, label="cup")  # the fingers hold its foot
    assert off_own_body([fingertip, carrot, held], frame) == [carrot, held]
    # a frame that does not say where the body is keeps every box
    assert off_own_body([fingertip, carrot], dataclasses.replace(frame, own_body=None)) == [fingertip, carrot]
    with pytest.raises(ValueError, match="own_body"):
        Frame(rgb=np.zeros((480, 640, 3), np.uint8), own_body=np.zeros((10, 10), bool))


def test_the_coco_detector_takes_no_box_on_the_grippers_fingertips():
    """A household scene drawn for coco (seed 50004, the eval's weight item 3): zoomed in at the image's
    foot, YOLOv3-tiny calls a fingertip a carrot; with the frame's own body it sets that box aside."""
    from attribot.models.coco import CocoDetector

    detector = CocoDetector()
    vocabulary = findable_categories(detector)
    world = SimWorld(SceneConfig(layout="household", seed=50004, vocabulary=vocabulary))
    try:
        frame = world.observe()
    finally:
        world.close()
    view = [(282, 368, 394, 480)]
    bare = detect_in_views(detector, dataclasses.replace(frame, own_body=None), ["carrot"], view)
    assert bare, "the fingertip is no longer seen as a carrot: pick another view"
    assert all(frame.own_body[int(d.box[1]) :, int(d.box[0]) : int(d.box[2])].any() for d in bare)
    assert detect_in_views(detector, frame, ["carrot"], view) == []
