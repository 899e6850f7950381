"""A small geometric world for the API's tests.

The world is an honest miniature: spheres at known 3D positions, a pinhole camera on a pan/tilt head that
moves with first-order dynamics and stops at its limits, a rangefinder that intersects the optical axis
with the spheres, a force sensor that feels what the gripper holds, an infrared thermometer along the optical
axis that reads the temperature of the sphere it hits (the room's when it hits none) and a gripper that
reads the stiffness of the sphere it holds. Its detector projects the spheres
through the camera as it was when the frame was taken, so boxes and distances agree the way they would on
a robot. tests/test_api_fakes.py checks the fakes themselves."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from attribot.api import Perception
from attribot.control.base import Target
from attribot.control.pointing import PointingController
from attribot.embodiments.base import Capability, Embodiment, Pose2D
from attribot.frame import CameraInfo, Frame
from attribot.models.base import Detection
from fakes.backends import FakeDetector, FakeLanguage, FakeVQA, Thing

__all__ = [
    "Ball",
    "CAM",
    "CAM_HEIGHT",
    "BallWorld",
    "WorldDetector",
    "BallController",
    "BALLS",
    "world_perception",
]


@dataclass
class Ball:
    id: str
    label: str
    center: tuple[float, float, float]  # world metres
    radius: float
    mass: float  # kg
    celsius: float = 21.0  # its surface temperature
    n_per_mm: float = 30.0  # its stiffness under the gripper


CAM = CameraInfo(width=320, height=240, fx=200.0, fy=200.0, cx=160.0, cy=120.0)
CAM_HEIGHT = 1.0
ROOM_C = 21.0


def _rot_head_to_world(pan: float, tilt: float, v: np.ndarray) -> np.ndarray:
    f, left, up = v
    f1, u1 = f * math.cos(tilt) - up * math.sin(tilt), f * math.sin(tilt) + up * math.cos(tilt)
    return np.array(
        [f1 * math.cos(pan) - left * math.sin(pan), f1 * math.sin(pan) + left * math.cos(pan), u1]
    )


def _rot_world_to_head(pan: float, tilt: float, v: np.ndarray) -> np.ndarray:
    x, y, z = v
    f1, left = x * math.cos(pan) + y * math.sin(pan), -x * math.sin(pan) + y * math.cos(pan)
    return np.array(
        [f1 * math.cos(tilt) + z * math.sin(tilt), left, -f1 * math.sin(tilt) + z * math.cos(tilt)]
    )


class BallWorld(Embodiment):
    """Spheres, a pan/tilt head with axes at (0, 0, CAM_HEIGHT) on a fixed base carrying a camera (at
    `cam_offset` from the axes: parallax), a rangefinder along its optical axis and a force sensor."""

    name = "balls"

    def __init__(
        self,
        balls: Sequence[Ball],
        *,
        tilt_limit: float = 0.9,
        force_bias: float = 0.3,
        cam_offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
        tilt_sag: float = 0.0,
    ) -> None:
        self.tilt_sag = tilt_sag  # the tilt servo settles this far below its command (carrying the head)
        self.balls = {b.id: b for b in balls}
        self.cam_offset = np.asarray(cam_offset)  # optical centre from the pan/tilt axes, head frame
        self.pan = self.tilt = 0.0
        self.target = (0.0, 0.0)
        self.tilt_limit = tilt_limit
        self.base = Pose2D(0.0, 0.0, 0.0)
        self.held: str | None = None
        self.force_bias = force_bias  # what the sensor reads with an empty gripper, before a tare
        self.tare = 0.0
        self.time = 0.0

    def capabilities(self) -> frozenset[Capability]:
        c = Capability
        return frozenset({c.CAMERA, c.HEAD, c.POSE, c.DISTANCE, c.FORCE, c.GRIPPER, c.BASE})

    def sensors(self) -> frozenset[str]:
        return super().sensors() | {"temperature", "grip"}

    def read_sensor(self, name: str) -> float:
        if name == "temperature":
            hit = self._on_axis()
            return hit.celsius if hit is not None else ROOM_C
        if name == "grip":
            return self.balls[self.held].n_per_mm if self.held else math.nan
        return super().read_sensor(name)

    def camera_position(self) -> np.ndarray:
        axes = np.array([self.base.x, self.base.y, CAM_HEIGHT])
        return axes + _rot_head_to_world(self.pan, self.tilt, self.cam_offset)

    def boxes(self) -> list[Detection]:
        """Each visible ball's projected bounding box at the current head pose."""
        out = []
        for b in self.balls.values():
            h = _rot_world_to_head(self.pan, self.tilt, np.asarray(b.center) - self.camera_position())
            if h[0] <= b.radius:
                continue
            u, v = CAM.cx - CAM.fx * h[1] / h[0], CAM.cy - CAM.fy * h[2] / h[0]
            r = CAM.fx * b.radius / h[0]
            box = (max(u - r, 0.0), max(v - r, 0.0), min(u + r, CAM.width), min(v + r, CAM.height))
            if box[2] > box[0] and box[3] > box[1]:
                out.append(Detection(box=box, score=0.9, label=b.label, object_id=b.id))
        return out

    def observe(self) -> Frame:
        rgb = np.zeros((CAM.height, CAM.width, 3), np.uint8)
        frame = Frame(rgb=rgb, camera=CAM)
        object.__setattr__(frame, "_detections", self.boxes())  # what the world's detector will report
        return frame

    def camera_info(self) -> CameraInfo:
        return CAM

    def step(self, seconds: float) -> None:
        k = min(1.0, 8.0 * seconds)
        self.pan += (self.target[0] - self.pan) * k
        command = max(-self.tilt_limit, min(self.tilt_limit, self.target[1]))
        self.tilt += (command - self.tilt_sag - self.tilt) * k
        self.time += seconds

    def set_head(self, pan: float, tilt: float) -> None:
        self.target = (pan, tilt)

    def joint_states(self) -> dict[str, float]:
        return {"head_pan": self.pan, "head_tilt": self.tilt, "lift": 0.5, "arm": 0.0}

    def base_pose(self) -> Pose2D:
        return self.base

    def read_distance(self) -> float:
        hit = self._on_axis()
        best = self._hit_at(hit) if hit is not None else math.inf
        return best if best < 8.0 else math.inf

    def _hit_at(self, b: Ball) -> float:
        o, d = self.camera_position(), _rot_head_to_world(self.pan, self.tilt, np.array([1.0, 0.0, 0.0]))
        oc = o - np.asarray(b.center)
        half_b = float(d @ oc)
        disc = half_b**2 - (float(oc @ oc) - b.radius**2)
        return -half_b - math.sqrt(disc) if disc >= 0 else math.inf

    def _on_axis(self) -> Ball | None:
        """The first sphere the optical axis meets, or None."""
        hits = [(self._hit_at(b), b.id) for b in self.balls.values()]
        near = [(t, i) for t, i in hits if 0 < t < math.inf]
        return self.balls[min(near)[1]] if near else None

    def tare_force(self) -> None:
        self.tare = self._raw_force()

    def _raw_force(self) -> float:
        load = self.balls[self.held].mass if self.held else 0.0
        return -9.81 * load - self.force_bias

    def read_force(self) -> np.ndarray:
        return np.array([0.0, 0.0, self._raw_force() - self.tare])


class WorldDetector(FakeDetector):
    """Reports the boxes the BallWorld projected when the frame was taken."""

    name = "world-detector"

    relabel = False  # True: report every ball under whatever name is asked for

    def detect(self, frame: Frame, queries: Sequence[str]) -> list[Detection]:
        # a crop of a frame carries no detections of its own: use those of the last whole frame
        if "_detections" in frame.__dict__:
            self.root = list(frame.__dict__["_detections"])
        found = getattr(self, "root", [])
        self.things = [
            Thing(queries[0] if self.relabel else d.label, d.box, d.score, d.object_id) for d in found
        ]
        return super().detect(frame, queries)


@dataclass
class BallController(PointingController):
    """Pointing by geometry, plus a test-only "teleport" approach and grasp on the BallWorld."""

    name: str = "ball-test"

    def approach(self, target: Target) -> None:
        self.world.approached = target.object_id

    def pick_up(self, target: Target) -> None:
        self.world.held = target.object_id

    def put_down(self) -> None:
        self.world.held = None


BALLS = [
    Ball("b1", "ball", (2.0, 0.6, 0.5), 0.15, 0.4),
    Ball("b2", "ball", (3.0, -0.9, 0.3), 0.2, 1.7),
    Ball("b3", "ball", (1.5, 0.1, 1.3), 0.1, 0.05),
]


def world_perception(relabel: bool = False) -> Perception:
    detector = WorldDetector()
    detector.relabel = relabel
    return Perception(detector, FakeVQA(), FakeLanguage())
