"""The embedded MuJoCo world behind the `Embodiment` interface, registered as "mujoco".

`MujocoWorld` wraps `attribot.sim.world.SimWorld` (scene, physics, sensors, truth) and exposes what a
controller or the API may use: camera frames with depth, segmentation and object truth, base velocity,
head, arm, gripper, time, the rangefinder, the wrist force sensor, the infrared thermometer, the gripper's
squeeze (`attribot.sim.senses`) and poses. The privileged scripted
manipulation of `attribot.sim.scripted` takes a `MujocoWorld` too.

With the RoboMaster-EP-like robot (`SceneConfig(robot="ep")`) the world has what a real EP has: no camera
head and no depth camera (frames are RGB, with the simulator's segmentation for the oracle detector), the
ToF sensor on the gripper, and a force sensor standing for the EP's load cell; it states the EP's body as
the EP's bridge driver does.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from attribot.config import SceneConfig
from attribot.control.body import BodyGeometry
from attribot.embodiments import mujoco_control  # noqa: F401  (registers this world's controller)
from attribot.embodiments.base import EMBODIMENTS, Capability, Embodiment, Pose2D
from attribot.frame import CameraInfo, Frame
from attribot.sensors import register_reading
from attribot.sim.world import SceneInfo, SimWorld

__all__ = ["MujocoWorld"]


@EMBODIMENTS.register("mujoco", aliases=("sim",))
class MujocoWorld(Embodiment):
    """A seeded MuJoCo scene with the mobile manipulator in it, built from a `attribot.config.SceneConfig`
    (or from its fields: `MujocoWorld(layout="triplet", seed=3, width=320, height=240)`)."""

    name = "mujoco"

    def __init__(self, config: SceneConfig | None = None, **fields: Any) -> None:
        self.sim = SimWorld(config, **fields)
        self.config = self.sim.config
        self.layout = self.sim.plan.layout
        self.seed = self.sim.plan.seed

    def capabilities(self) -> frozenset[Capability]:
        body = self.sim.body
        lacks = {Capability.HEAD} if not body.head else set()
        return frozenset(Capability) - lacks - ({Capability.DEPTH} if not body.depth else set())

    # camera
    def observe(self) -> Frame:
        return self.sim.observe(depth=Capability.DEPTH in self.capabilities())

    def camera_info(self) -> CameraInfo:
        return self.sim.camera_info()

    # time and motion
    def step(self, seconds: float) -> None:
        self.sim.step(seconds)

    def world_time(self) -> float:
        return float(self.sim.data.time)

    def command_base(self, vx: float, vy: float, wz: float) -> None:
        self.sim.command_base(vx, vy, wz)

    def set_head(self, pan: float, tilt: float) -> None:
        self.require(Capability.HEAD, "move a camera head")
        self.sim.set_head(pan, tilt)

    def set_arm(self, lift: float, extension: float) -> None:
        self.sim.set_arm(lift, extension)

    def grasp(self) -> bool:
        return self.sim.grasp()

    def release(self) -> None:
        self.sim.release()

    # sensors
    def read_distance(self) -> float:
        return self.sim.read_distance()

    def tare_force(self) -> None:
        self.sim.tare_force()

    def read_force(self) -> np.ndarray:
        return self.sim.read_force()

    def body(self) -> BodyGeometry:
        return self.sim.body.geometry

    def base_pose(self) -> Pose2D:
        return Pose2D(*self.sim.odometry())  # what the wheels say, drift and all (truth: scene_info)

    def snapshot(self) -> Any:
        return self.sim.robot_state()

    def restore(self, snapshot: Any) -> None:
        self.sim.restore_robot(snapshot)

    def joint_states(self) -> dict[str, float]:
        return self.sim.joint_states()

    # truth (simulator only)
    def scene_info(self) -> SceneInfo:
        """The scene's truth now, with boxes from a fresh frame: what `attribot scene info` prints."""
        return self.sim.scene_info()

    def held_object(self) -> str | None:
        """Id of the object in the gripper, or None."""
        key = self.sim.held
        return None if key is None else self.sim.objects[key].id

    def close(self) -> None:
        self.sim.close()


# the sensors this world reads beyond its capabilities' own calls (`attribot.sensors`)
register_reading("temperature", MujocoWorld.name, lambda world: world.sim.read_temperature())
register_reading("grip", MujocoWorld.name, lambda world: world.sim.squeeze())  # NaN with an empty gripper
