"""The AI2-THOR world against a fake controller whose events follow AI2-THOR's documented metadata schema."""

from __future__ import annotations

import math
import sys
import types
from typing import Any

import numpy as np
import pytest

from attribot.config import Ai2ThorConfig, load_settings
from attribot.control.base import Capture, Target, build_controller
from attribot.embodiments.ai2thor import Ai2ThorController, Ai2ThorError, Ai2ThorWorld
from attribot.embodiments.base import EMBODIMENTS, Capability
from attribot.errors import MissingDependency

W, H, FOV, EYE = 160, 160, 90.0, 0.9


class FakeEvent:
    """`ai2thor.server.Event`: frame, depth_frame, instance_masks, metadata."""

    def __init__(
        self, frame: np.ndarray, depth: np.ndarray, masks: dict[str, np.ndarray], metadata: dict
    ) -> None:
        self.frame = frame
        self.depth_frame = depth
        self.instance_masks = masks
        self.metadata = metadata


def _obj(
    object_id: str, kind: str, x: float, y: float, z: float, size: float, mass: float, pick: bool
) -> dict:
    return {
        "objectId": object_id,
        "objectType": kind,
        "mass": mass,
        "position": {"x": x, "y": y, "z": z},
        "axisAlignedBoundingBox": {
            "center": {"x": x, "y": y, "z": z},
            "size": {"x": size, "y": size, "z": size},
        },
        "pickupable": pick,
        "isPickedUp": False,
        "visible": False,
        "distance": 0.0,
    }


class FakeThor:
    """A tiny AI2-THOR: an agent on a plane, cube-ish objects rendered as squares by a pinhole camera."""

    def __init__(self, scene: str = "FloorPlan1", **kwargs: Any) -> None:
        self.scene, self.kwargs, self.actions = scene, kwargs, []
        self.agent = {"position": {"x": 0.0, "y": 0.9, "z": 0.0}, "rotation": {"x": 0.0, "y": 0.0, "z": 0.0},
                      "cameraHorizon": 0.0}  # fmt: skip
        self.objects = [
            _obj("Apple|+00.30|+00.90|+02.00", "Apple", 0.3, 0.9, 2.0, 0.12, 0.2, True),
            _obj("Mug|-00.40|+00.90|+02.50", "Mug", -0.4, 0.9, 2.5, 0.12, 0.35, True),
            _obj("SaltShaker|+00.00|+00.90|+04.00", "SaltShaker", 0.0, 0.9, 4.0, 0.3, 0.5, True),
        ]
        self.stopped = False

    def _project(self, p: dict) -> tuple[float, float, float]:
        th, ph = math.radians(self.agent["rotation"]["y"]), math.radians(self.agent["cameraHorizon"])
        dx, dz = p["x"] - self.agent["position"]["x"], p["z"] - self.agent["position"]["z"]
        fwd, right, up = (
            dx * math.sin(th) + dz * math.cos(th),
            dx * math.cos(th) - dz * math.sin(th),
            p["y"] - EYE,
        )
        fwd, up = fwd * math.cos(ph) - up * math.sin(ph), up * math.cos(ph) + fwd * math.sin(ph)
        f = (H / 2) / math.tan(math.radians(FOV) / 2)
        if fwd <= 0.05:  # behind the camera: not drawn
            return math.nan, math.nan, fwd
        return W / 2 + f * right / fwd, H / 2 - f * up / fwd, fwd

    def _event(self, ok: bool = True, error: str = "") -> FakeEvent:
        frame = np.full((H, W, 3), 90, np.uint8)
        depth = np.full((H, W), 5.0, np.float32)
        masks: dict[str, np.ndarray] = {}
        f = (H / 2) / math.tan(math.radians(FOV) / 2)
        for o in sorted(self.objects, key=lambda o: -self._project(o["position"])[2]):
            ax, az = self.agent["position"]["x"], self.agent["position"]["z"]
            o["distance"] = math.dist(
                (ax, EYE, az), (o["position"]["x"], o["position"]["y"], o["position"]["z"])
            )
            u, v, fwd = self._project(o["position"])
            o["visible"] = False
            if o["isPickedUp"] or fwd <= 0.05:
                continue
            r = f * o["axisAlignedBoundingBox"]["size"]["x"] / 2 / fwd
            mask = np.zeros((H, W), bool)
            mask[max(0, int(v - r)) : max(0, int(v + r) + 1), max(0, int(u - r)) : max(0, int(u + r) + 1)] = (
                True
            )
            if mask.any():
                for m in masks.values():
                    m &= ~mask
                masks[o["objectId"]] = mask
                frame[mask] = (200, 40 + 60 * len(masks), 40)
                depth[mask] = fwd
                o["visible"] = o["distance"] <= 1.5
        agent = {k: (dict(v) if isinstance(v, dict) else v) for k, v in self.agent.items()}
        meta = {"lastActionSuccess": ok, "errorMessage": error, "objects": [dict(o) for o in self.objects],
                "agent": agent}  # fmt: skip
        return FakeEvent(frame, depth, masks, meta)

    def step(self, action: str, **kwargs: Any) -> FakeEvent:
        self.actions.append((action, kwargs))
        a = self.agent
        if action in ("RotateRight", "RotateLeft"):
            a["rotation"]["y"] += kwargs.get("degrees", 90.0) * (1 if action == "RotateRight" else -1)
        elif action in ("LookDown", "LookUp"):
            a["cameraHorizon"] += kwargs.get("degrees", 30.0) * (1 if action == "LookDown" else -1)
        elif action == "MoveAhead":
            th = math.radians(a["rotation"]["y"])
            a["position"]["x"] += 0.25 * math.sin(th)
            a["position"]["z"] += 0.25 * math.cos(th)
        elif action == "PickupObject":
            o = next(o for o in self.objects if o["objectId"] == kwargs["objectId"])
            if not o["pickupable"] or o["distance"] > 1.5:
                return self._event(False, f"{o['objectId']} is not interactable")
            o["isPickedUp"] = True
        elif action == "DropHandObject":
            for o in self.objects:
                o["isPickedUp"] = False
        return self._event()

    def stop(self) -> None:
        self.stopped = True


def _target(world: Ai2ThorWorld, object_id: str) -> Target:
    frame = world.observe()
    key = next(k for k, o in frame.objects.items() if o.id == object_id)
    ys, xs = np.nonzero(frame.segmentation == key)
    return Target(box=(xs.min(), ys.min(), xs.max() + 1, ys.max() + 1), capture=Capture(0, frame.camera),
                  object_id=object_id)  # fmt: skip


def test_frames_carry_depth_and_instance_segmentation_with_object_types():
    world = Ai2ThorWorld(controller=FakeThor())
    assert {
        Capability.CAMERA,
        Capability.DEPTH,
        Capability.DISTANCE,
        Capability.FORCE,
    } <= world.capabilities()
    assert Capability.BASE not in world.capabilities()  # discrete actions only, through the controller
    frame = world.observe()
    cats = sorted(o.category for o in frame.objects.values())
    assert cats == ["apple", "mug", "salt shaker"]
    apple = next(k for k, o in frame.objects.items() if o.category == "apple")
    assert frame.depth is not None and float(
        frame.depth[frame.segmentation == apple].mean()
    ) == pytest.approx(2.0)
    assert world.base_pose().yaw == pytest.approx(math.pi / 2)  # rotation.y 0 faces +z
    world.close()
    assert world.controller.stopped


def test_focus_centres_the_object_and_the_rangefinder_reads_its_metadata_distance():
    world = Ai2ThorWorld(controller=FakeThor())
    controller = build_controller(world)
    assert isinstance(controller, Ai2ThorController) and controller.name == "ai2thor-discrete"
    mug = "Mug|-00.40|+00.90|+02.50"
    assert world.read_distance() != pytest.approx(world.object_meta(mug)["distance"])
    controller.focus_on(_target(world, mug))
    assert world.controller.actions[-1][0] == "RotateLeft"  # the mug is left of centre
    assert world.read_distance() == pytest.approx(math.hypot(0.4, 2.5), rel=1e-6)


def test_approach_pick_up_weigh_and_put_down_with_discrete_actions():
    world = Ai2ThorWorld(controller=FakeThor())
    controller = Ai2ThorController(world)
    apple = "Apple|+00.30|+00.90|+02.00"
    far = "SaltShaker|+00.00|+00.90|+04.00"
    with pytest.raises(Ai2ThorError, match="AI2-THOR refused PickupObject: .* is not interactable"):
        controller.pick_up(_target(world, far))  # 4 m away
    world.tare_force()
    controller.approach(_target(world, apple))
    assert world.object_meta(apple)["distance"] <= controller.reach_m
    assert ("MoveAhead", {}) in world.controller.actions
    controller.pick_up(_target(world, apple))
    assert -world.read_force()[2] == pytest.approx(0.2 * 9.81)
    controller.put_down()
    assert world.read_force()[2] == 0.0 and world.controller.actions[-1][0] == "DropHandObject"


def test_the_world_is_built_from_the_registry_with_the_scene_option(monkeypatch):
    fake = types.ModuleType("ai2thor.controller")
    fake.Controller = FakeThor  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "ai2thor", types.ModuleType("ai2thor"))
    monkeypatch.setitem(sys.modules, "ai2thor.controller", fake)
    world = EMBODIMENTS.get("ai2thor")(Ai2ThorConfig(scene="FloorPlan7"))
    assert world.controller.scene == "FloorPlan7"
    assert (
        world.controller.kwargs["renderDepthImage"] and world.controller.kwargs["renderInstanceSegmentation"]
    )


def test_without_the_package_the_error_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "ai2thor", None)
    with pytest.raises(MissingDependency, match="ai2thor package") as info:
        Ai2ThorWorld()
    assert "pip install -e '.[ai2thor]'" in (info.value.fix or "")


def test_an_embodied_query_runs_in_the_ai2thor_world(monkeypatch):
    from attribot.session import Scene, ask

    fake = types.ModuleType("ai2thor.controller")
    fake.Controller = FakeThor  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "ai2thor", types.ModuleType("ai2thor"))
    monkeypatch.setitem(sys.modules, "ai2thor.controller", fake)
    scene = Scene(
        world="ai2thor", config=Ai2ThorConfig(width=W, height=H), sensors=["camera", "distance", "force"]
    )
    answer = ask("Which object is the heaviest?", scene, load_settings())
    assert answer.error is None, answer.error
    assert answer.backends.get("robot") == "ai2thor-discrete"
    assert "salt shaker" in answer.answer  # 0.5 kg, against 0.35 and 0.2
    assert answer.value == pytest.approx(0.5, rel=1e-6) and answer.unit == "kg"
