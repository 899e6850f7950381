"""A world seen as a real robot sees it: the truth-blind wrapper around a simulated world."""

from __future__ import annotations

import numpy as np

from attribot.control.body import BodyGeometry
from attribot.embodiments.base import Capability, Embodiment, Pose2D
from attribot.frame import CameraInfo, Frame

__all__ = ["TruthBlindWorld"]


class TruthBlindWorld(Embodiment):
    """A world as a real robot would see it: frames with RGB and depth only (no segmentation, no object
    truth), only the `Embodiment` interface, and no way through to the simulator behind it."""

    name = "truth-blind"

    def __init__(self, inner: Embodiment) -> None:
        self._inner = inner

    def capabilities(self) -> frozenset[Capability]:
        return self._inner.capabilities() - {Capability.SEGMENTATION}

    def observe(self) -> Frame:
        f = self._inner.observe()
        return Frame(rgb=f.rgb, depth=f.depth, camera=f.camera)

    def camera_info(self) -> CameraInfo:
        return self._inner.camera_info()

    def body(self) -> BodyGeometry:
        return self._inner.body()

    def step(self, seconds: float) -> None:
        self._inner.step(seconds)

    def command_base(self, vx: float, vy: float, wz: float) -> None:
        self._inner.command_base(vx, vy, wz)

    def set_head(self, pan: float, tilt: float) -> None:
        self._inner.set_head(pan, tilt)

    def set_arm(self, lift: float, extension: float) -> None:
        self._inner.set_arm(lift, extension)

    def grasp(self) -> bool:
        return self._inner.grasp()

    def release(self) -> None:
        self._inner.release()

    def read_distance(self) -> float:
        return self._inner.read_distance()

    def tare_force(self) -> None:
        self._inner.tare_force()

    def read_force(self) -> np.ndarray:
        return self._inner.read_force()

    def joint_states(self) -> dict[str, float]:
        return self._inner.joint_states()

    def base_pose(self) -> Pose2D:
        return self._inner.base_pose()
