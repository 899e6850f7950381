"""An AI2-THOR scene behind the `Embodiment` interface, registered as "ai2thor" (extra `attribot[ai2thor]`).

`Ai2ThorWorld` wraps any controller with `step(action=..., **kwargs)` returning an event (the real one is
`ai2thor.controller.Controller`, built here with depth and instance segmentation on). It gives frames
with depth and an instance segmentation whose objects carry AI2-THOR's `objectType`, and the paper's
simulated sensors: the distance of the object centred in the frame, read from the object metadata, and the
weight of the held object from its `mass`. AI2-THOR moves in discrete steps, so motion goes through
`act()` and the discrete controller `Ai2ThorController` ("ai2thor-discrete"), which names itself in every
answer: `MoveAhead`/`MoveBack`/`MoveLeft`/`MoveRight`, `RotateLeft`/`RotateRight`, `LookUp`/`LookDown`,
`PickupObject`, `PutObject`, `PushObject`, `DropHandObject`. Like the paper's, its manipulation addresses
objects by their AI2-THOR `objectId` (privileged), which the oracle detector gives.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from attribot.config import Ai2ThorConfig
from attribot.control.base import CONTROLLERS, ControlError, Target, not_available
from attribot.control.pointing import PointingController
from attribot.deps import install_line
from attribot.embodiments.base import EMBODIMENTS, Capability, Embodiment, Pose2D
from attribot.errors import AttribotError, MissingDependency, UnsupportedAction
from attribot.frame import CameraInfo, Frame, ObjectTruth
from attribot.sensors import GRAVITY

__all__ = ["Ai2ThorWorld", "Ai2ThorController", "Ai2ThorError"]

_ACTIONS = (
    "MoveAhead", "MoveBack", "MoveLeft", "MoveRight", "RotateLeft", "RotateRight", "LookUp", "LookDown",
    "PickupObject", "PutObject", "PushObject", "DropHandObject",
)  # fmt: skip


class Ai2ThorError(AttribotError):
    """An AI2-THOR action failed (`lastActionSuccess` false); the message carries its `errorMessage`."""


def _category(object_type: str) -> str:
    """AI2-THOR's CamelCase `objectType` as the catalogue's words: "CoffeeMachine" -> "coffee machine"."""
    return re.sub(r"(?<=[a-z])(?=[A-Z])", " ", object_type).lower()


@EMBODIMENTS.register("ai2thor")
class Ai2ThorWorld(Embodiment):
    """The AI2-THOR scene of an `Ai2ThorConfig` (default FloorPlan1), or the given `controller`."""

    name = "ai2thor"

    def __init__(
        self,
        config: Ai2ThorConfig | None = None,
        *,
        controller: Any = None,
        **fields: Any,
    ) -> None:
        """`fields`: Ai2ThorConfig fields instead of `config` (as every world takes its config's)."""
        self.config = config or Ai2ThorConfig.create(**fields)
        fov_deg = self.fov_deg = self.config.fov_deg
        if controller is None:
            try:
                from ai2thor.controller import Controller
            except ImportError:
                raise MissingDependency(
                    "the ai2thor world needs the ai2thor package",
                    f"{install_line('ai2thor')} (its first run downloads a Unity build, about 500 MB)",
                ) from None
            controller = Controller(
                scene=self.config.scene,
                width=self.config.width,
                height=self.config.height,
                fieldOfView=fov_deg,
                renderDepthImage=True,
                renderInstanceSegmentation=True,
            )
        self.controller = controller
        self.event = self.act("Pass")
        self.held_mass: float | None = None
        self._tare = 0.0

    # --- discrete actions ---------------------------------------------------------------------------
    def act(self, action: str, **kwargs: Any) -> Any:
        """Run one AI2-THOR action; `Ai2ThorError` with its errorMessage when it fails."""
        if action not in _ACTIONS and action != "Pass":
            raise UnsupportedAction(
                f"AI2-THOR action {action!r} is not used here", f"use one of {', '.join(_ACTIONS)}"
            )
        event = self.controller.step(action=action, **kwargs)
        self.event = event
        meta = event.metadata
        if not meta.get("lastActionSuccess", False):
            raise Ai2ThorError(
                f"AI2-THOR refused {action}: {meta.get('errorMessage') or 'no reason given'}",
                "choose a reachable, visible object, or move closer first",
            )
        return event

    def objects(self) -> list[dict[str, Any]]:
        """The scene's object metadata now (AI2-THOR's schema)."""
        return list(self.event.metadata.get("objects", []))

    def object_meta(self, object_id: str) -> dict[str, Any]:
        for obj in self.objects():
            if obj["objectId"] == object_id:
                return obj
        raise Ai2ThorError(f"no object {object_id!r} in this AI2-THOR scene", "use an id from the detector")

    # --- Embodiment ---------------------------------------------------------------------------------
    def capabilities(self) -> frozenset[Capability]:
        caps = {Capability.CAMERA, Capability.SEGMENTATION, Capability.DISTANCE, Capability.FORCE,
                Capability.GRIPPER, Capability.POSE}  # fmt: skip
        if getattr(self.event, "depth_frame", None) is not None:
            caps.add(Capability.DEPTH)
        return frozenset(caps)

    def camera_info(self) -> CameraInfo:
        h, w = np.asarray(self.event.frame).shape[:2]
        f = (h / 2.0) / math.tan(math.radians(self.fov_deg) / 2.0)  # fieldOfView is vertical; square pixels
        return CameraInfo(width=w, height=h, fx=f, fy=f, cx=w / 2.0, cy=h / 2.0)

    def observe(self) -> Frame:
        event = self.event
        rgb = np.ascontiguousarray(np.asarray(event.frame, dtype=np.uint8))
        depth = getattr(event, "depth_frame", None)
        masks: dict[str, np.ndarray] = dict(getattr(event, "instance_masks", None) or {})
        seg = np.full(rgb.shape[:2], -1, np.int32)
        objects: dict[int, ObjectTruth] = {}
        by_id = {o["objectId"]: o for o in self.objects()}
        for key, (object_id, mask) in enumerate(sorted(masks.items())):
            meta = by_id.get(object_id)
            if meta is None:
                continue  # structure (walls, floor) have masks and no object metadata
            seg[np.asarray(mask, bool)] = key
            objects[key] = ObjectTruth(id=object_id, category=_category(meta["objectType"]))
        return Frame(
            rgb=rgb,
            depth=None if depth is None else np.asarray(depth, np.float32),
            segmentation=seg,
            objects=objects,
            camera=self.camera_info(),
        )

    def centred_object(self) -> dict[str, Any] | None:
        """Metadata of the object whose instance mask covers the centre pixel (`visible` in AI2-THOR means
        within the interaction distance, which the rangefinder does not need)."""
        masks = dict(getattr(self.event, "instance_masks", None) or {})
        h, w = np.asarray(self.event.frame).shape[:2]
        by_id = {o["objectId"]: o for o in self.objects()}
        for object_id, mask in masks.items():
            if object_id in by_id and np.asarray(mask, bool)[h // 2, w // 2]:
                return by_id[object_id]
        return None

    def read_distance(self) -> float:
        """The paper's simulated rangefinder: the metadata `distance` of the object centred in the frame."""
        obj = self.centred_object()
        return math.inf if obj is None else float(obj["distance"])

    def step(self, seconds: float) -> None:
        """AI2-THOR has no continuous time: the scene holds still between actions."""

    def grasp(self) -> bool:
        raise not_available("grasp", self.name, "AI2-THOR picks objects by id: use Ai2ThorController.pick_up")

    def release(self) -> None:
        self.act("DropHandObject")
        self.held_mass = None

    def tare_force(self) -> None:
        self._tare = 0.0 if self.held_mass is None else self.held_mass * GRAVITY

    def read_force(self) -> np.ndarray:
        """The paper's simulated weight: the held (`isPickedUp`) object's `mass` times g, downwards."""
        held = [o for o in self.objects() if o.get("isPickedUp")]
        newtons = float(held[0]["mass"]) * GRAVITY if held else 0.0
        return np.array([0.0, 0.0, -(newtons - self._tare)])

    def base_pose(self) -> Pose2D:
        agent = self.event.metadata["agent"]
        pos, rot = agent["position"], agent["rotation"]
        # Unity: y up, rotation.y clockwise from +z seen from above; (x, z) from above is a right-handed plane
        return Pose2D(float(pos["x"]), float(pos["z"]), math.radians(90.0 - float(rot["y"])))

    def joint_states(self) -> dict[str, float]:
        horizon = float(self.event.metadata["agent"].get("cameraHorizon", 0.0))  # degrees, down positive
        return {"head_pan": 0.0, "head_tilt": -math.radians(horizon)}

    def close(self) -> None:
        stop = getattr(self.controller, "stop", None)
        if callable(stop):
            stop()


@dataclass
class Ai2ThorController(PointingController):
    """AI2-THOR's discrete actions: turn and look to centre a box, walk up to it, pick up, put down, push."""

    name: str = "ai2thor-discrete"
    reach_m: float = 1.0  # AI2-THOR's default visibilityDistance: PickupObject works within it
    max_moves: int = 40

    @property
    def thor(self) -> Ai2ThorWorld:
        world: Ai2ThorWorld = self.world
        return world

    def focus_on(self, target: Target) -> None:
        cam = target.capture.camera or self.thor.camera_info()
        u, v = target.center
        yaw = math.degrees(math.atan2(u - cam.cx, cam.fx))  # right positive
        pitch = math.degrees(math.atan2(v - cam.cy, cam.fy))  # down positive
        if abs(yaw) > 0.5:
            self.thor.act("RotateRight" if yaw > 0 else "RotateLeft", degrees=abs(yaw))
        if abs(pitch) > 0.5:
            self.thor.act("LookDown" if pitch > 0 else "LookUp", degrees=abs(pitch))

    def _id(self, target: Target, action: str) -> str:
        if not target.object_id:
            raise UnsupportedAction(
                f"robot action {action!r} in AI2-THOR needs the objectId of {target.describe()}",
                "use the oracle detector (--detector oracle) in AI2-THOR",
            )
        return target.object_id

    def approach(self, target: Target) -> None:
        object_id = self._id(target, "go_to_object")
        # face the object by its metadata position (privileged, as the paper's AI2-THOR actions were)
        agent = self.thor.event.metadata["agent"]
        pos = self.thor.object_meta(object_id)["position"]
        heading = math.degrees(
            math.atan2(pos["x"] - agent["position"]["x"], pos["z"] - agent["position"]["z"])
        )
        turn = (heading - float(agent["rotation"]["y"]) + 180.0) % 360.0 - 180.0
        if abs(turn) > 0.5:
            self.thor.act("RotateRight" if turn > 0 else "RotateLeft", degrees=abs(turn))
        for _ in range(self.max_moves):
            if float(self.thor.object_meta(object_id)["distance"]) <= self.reach_m:
                return
            try:
                self.thor.act("MoveAhead")
            except Ai2ThorError as exc:
                raise ControlError(
                    f"walking to {target.describe()} stopped: {exc.message}", "try from another side"
                ) from None
        raise ControlError(
            f"{target.describe()} is still out of reach after {self.max_moves} steps", "move closer first"
        )

    def pick_up(self, target: Target) -> None:
        object_id = self._id(target, "pick_up")
        self.thor.act("PickupObject", objectId=object_id)
        self.thor.held_mass = float(self.thor.object_meta(object_id)["mass"])

    def put_down(self) -> None:
        self.thor.release()

    def put_on(self, target: Target) -> None:
        self.thor.act("PutObject", objectId=self._id(target, "put_on"))
        self.thor.held_mass = None

    def push(self, target: Target) -> None:
        self.thor.act("PushObject", objectId=self._id(target, "push"), moveMagnitude=50.0)

    def go_to_coords(self, target: Target) -> None:
        raise not_available("go_to_coords", "ai2thor", "walking to image coordinates needs visual servoing")


@CONTROLLERS.register("ai2thor")
def _ai2thor(world: object) -> Ai2ThorController:
    return Ai2ThorController(world)
