"""The API in the embedded MuJoCo world: the default (servo) controller's focus + rangefinder, and the
privileged controller's scripted manipulation + force sensor (the perception-driven manipulation has its
own tests in test_servo_actions.py)."""

from __future__ import annotations

import pytest

pytest.importorskip("attribot.embodiments.mujoco")
pytest.importorskip("attribot.sim.scripted")

from attribot.api import ImagePatch, Perception, PreconditionError, Robot  # noqa: E402
from attribot.config import Settings  # noqa: E402
from attribot.control.base import ControlError, build_controller  # noqa: E402
from attribot.embodiments.mujoco import MujocoWorld  # noqa: E402
from attribot.embodiments.mujoco_control import SimController  # noqa: E402
from attribot.errors import UnsupportedAction  # noqa: E402

ALL = ["camera", "distance", "force"]


@pytest.fixture(scope="module")
def perception() -> Perception:
    return Perception.from_settings(Settings(detector="oracle", vqa="oracle", language="catalog"))


def open_world(seed: int = 0, **kw) -> MujocoWorld:
    return MujocoWorld(layout="household", seed=seed, width=320, height=240, **kw)


def patches_by_id(image: ImagePatch, infos) -> dict[str, ImagePatch]:
    out = {}
    for info in infos:
        found = [p for p in image.find(info.category) if p.object_id == info.id]
        if found:
            out[info.id] = found[0]
    return out


@pytest.mark.parametrize("seed", [0, 3])
def test_measure_distance_reads_the_object_at_the_patch(perception, seed):
    with open_world(seed) as world:
        robot = Robot(ALL, world=world)
        assert robot.backend_name() == "servo"
        infos = [o for o in world.scene_info().objects if o.box is not None]
        image = robot.look(perception)
        patches = patches_by_id(image, infos)
        assert len(patches) >= 2
        for info in infos:
            if info.id not in patches:
                continue
            metres = robot.measure_distance(patches[info.id])
            # the rangefinder now looks at this object: the pixel at the image centre belongs to it
            frame = world.observe()
            cam = frame.camera
            key = int(frame.segmentation[int(cam.cy), int(cam.cx)])
            assert key >= 0 and frame.objects[key].id == info.id
            # it reads the near surface: within half the object's size of the distance to its centre
            assert info.distance_m - info.size_m / 2 - 0.02 <= metres <= info.distance_m + 0.02
        assert [m.object_id for m in robot.measurements] == [i.id for i in infos if i.id in patches]


def test_weighing_with_privileged_manipulation_returns_the_mass(perception):
    with open_world(0, force_noise_std=0.05) as world:
        robot = Robot(ALL, world=world, controller=build_controller(world, "privileged"))
        assert isinstance(robot.controller, SimController) and robot.backend_name() == "sim-privileged"
        infos = [o for o in world.scene_info().objects if o.box is not None and o.pickable]
        image = robot.look(perception)
        patches = patches_by_id(image, infos)
        assert len(patches) >= 2
        for info in infos:
            patch = patches[info.id]
            with pytest.raises(PreconditionError, match="holds nothing"):
                robot.measure_weight(patch)
            robot.go_to_object(patch)
            robot.pick_up(patch)
            assert world.held_object() == info.id
            kg = robot.measure_weight(patch)
            assert kg == pytest.approx(info.mass_kg, rel=0.03)
            assert robot.measurements[-1].newtons == pytest.approx(kg * 9.81)
            robot.put_down()
            assert world.held_object() is None
        # boxes of the first image no longer say where to look once the robot has driven
        with pytest.raises(ControlError, match="has moved"):
            robot.measure_distance(patches[infos[0].id])


def test_unscripted_actions_and_id_less_patches_are_refused(perception):
    with open_world(0) as world:
        robot = Robot(ALL, world=world, controller=build_controller(world, "privileged"))
        image = robot.look(perception)
        info = next(o for o in world.scene_info().objects if o.box is not None)
        patch = patches_by_id(image, [info])[info.id]
        for call, name in [
            (lambda: robot.push(patch), "push"),
            (lambda: robot.go_to_coords(patch.horizontal_center, patch.vertical_center), "go_to_coords"),
        ]:
            with pytest.raises(
                UnsupportedAction, match=f"'{name}' is not available in this world \\(mujoco\\)"
            ):
                call()
        anonymous = ImagePatch(image.frame, perception, patch.box, capture=patch.capture, label=patch.label)
        with pytest.raises(UnsupportedAction, match="needs the world's id") as exc:
            robot.go_to_object(anonymous)
        assert "--detector oracle" in exc.value.fix


# a household scene whose bowl, on a low table 1.3 m away, the camera sees into from above
BOWL_SCENE = dict(layout="household", seed=40005, width=640, height=480)
BOWL_VOCABULARY = (
    "apple", "carrot", "banana", "orange", "mug", "bowl", "knife", "fork", "spoon", "toaster", "bottle",
    "laptop", "book", "cell phone", "remote control", "vase", "cactus", "alarm clock", "scissors",
    "computer mouse", "keyboard", "basketball", "tennis racket", "suitcase", "backpack",
)  # fmt: skip


def test_the_beam_on_a_bowls_rim_is_the_bowl_though_the_camera_sees_into_it(perception):
    """The camera's centre looks into a bowl, past its rim, where the beam meets the rim: nearer than the
    depth there, by less than the bowl's own width. That reading is the bowl's, not one set aside as the
    beam missing it (only a reading farther than the depth, or nearer than the object's front, is)."""
    with MujocoWorld(**BOWL_SCENE, vocabulary=BOWL_VOCABULARY) as world:
        robot = Robot(ALL, world=world)
        bowl = next(o for o in world.scene_info().objects if o.category == "bowl")
        image = robot.look(perception)
        patch = next(p for p in image.find("bowl") if p.object_id == bowl.id)
        metres = robot.measure_distance(patch)
    assert bowl.distance_m - bowl.size_m / 2 - 0.02 <= metres <= bowl.distance_m + 0.02
