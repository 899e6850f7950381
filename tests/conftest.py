"""Helpers and fixtures shared by several test files, in sections. Import the helpers by name
(`from conftest import wait_for`); pytest finds the fixtures by itself. Add new shared fakes to the
section they belong to (or a new one), not to a test file."""

from __future__ import annotations

import json
import math
import os
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from attribot.api import Perception
from attribot.control.base import Target
from attribot.control.body import BodyGeometry
from attribot.control.pointing import PointingController
from attribot.embodiments.base import Capability, Embodiment, Pose2D
from attribot.errors import InputError
from attribot.frame import CameraInfo, Frame
from attribot.models.base import UNKNOWN, Detection

ARTIFACTS = Path(__file__).parent / "artifacts"
EMPTY_SETTINGS = ARTIFACTS / "empty-settings.toml"
"""A settings file with no settings: point ATTRIBOT_CONFIG here so that no ./attribot.toml is read."""


# ---- settings -----------------------------------------------------------------------------------------


def cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """`attribot ARGS...` in a fresh process with the empty settings file, its output captured."""
    env = {**os.environ, "ATTRIBOT_CONFIG": str(EMPTY_SETTINGS)}
    return subprocess.run(
        [sys.executable, "-m", "attribot.cli", *args],
        capture_output=True,
        text=True,
        env=env,
        cwd=cwd,
        timeout=120,
    )


@pytest.fixture
def empty_settings(monkeypatch: pytest.MonkeyPatch) -> Path:
    """The defaults, whatever ./attribot.toml or ATTRIBOT_CONFIG the machine has."""
    monkeypatch.setenv("ATTRIBOT_CONFIG", str(EMPTY_SETTINGS))
    return EMPTY_SETTINGS


# ---- processes, ports and waiting -----------------------------------------------------------------------


def alive(pid: int) -> bool:
    """Whether process `pid` runs (a zombie, exited but not yet reaped, counts as gone)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def wait_for(predicate: Callable[[], bool], timeout: float = 10.0) -> bool:
    """Poll `predicate` until it holds or `timeout` seconds pass; its last value."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.05)
    return predicate()


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on (just now)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# ---- frames ---------------------------------------------------------------------------------------------


def random_frame(h: int, w: int, seed: int = 0) -> Frame:
    """A frame of uniform random pixels."""
    return Frame(rgb=np.random.default_rng(seed).integers(0, 256, (h, w, 3), dtype=np.uint8))


def frame_with_box(h: int, w: int, box: tuple[int, int, int, int]) -> Frame:
    """A black frame with one bright rectangle (x0, y0, x1, y1): what `bright_box` finds again."""
    rgb = np.zeros((h, w, 3), np.uint8)
    x0, y0, x1, y1 = box
    rgb[y0:y1, x0:x1] = 200
    return Frame(rgb=rgb)


def bright_box(rgb: np.ndarray) -> tuple[float, float, float, float]:
    """The box of the bright pixels: stand-in detectors answer with it, so a frame that crossed a pipe or
    a wire can be checked against the one that was sent."""
    ys, xs = np.nonzero(rgb.max(axis=2) > 40)
    return float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1)


# ---- stand-in backends ----------------------------------------------------------------------------------


def mean_colour(rgb: np.ndarray) -> str:
    """The mean colour of an image as "r,g,b": what `MeanColourVQA` answers, so that an answer that
    crossed a wire can be checked against the image that was sent."""
    return ",".join(str(int(round(v))) for v in rgb.reshape(-1, 3).mean(axis=0))


class MeanColourVQA:
    """Answers with the mean colour of the image; the question "fail" raises a model error."""

    name = "test:mean-colour"

    def answer(self, frame: Frame, question: str) -> str:
        if question == "fail":
            raise ValueError("CUDA out of memory (simulated)")
        return mean_colour(frame.rgb)


class WholeImageDetector:
    """Finds every query as the whole image, score 0.5."""

    name = "test:whole-image"

    def detect(self, frame: Frame, queries: list[str]) -> list[Detection]:
        return [
            Detection(box=(0.0, 0.0, float(frame.width), float(frame.height)), score=0.5, label=q)
            for q in queries
        ]


class EchoLanguage:
    """Answers a question with the question in capitals."""

    name = "test:echo"

    def complete(self, question: str) -> str:
        return question.upper()


class BrightBoxDetector:
    """Box of the bright pixels, labelled with the first query and the child's process id. The first
    query can ask for trouble: "bad-input" raises an InputError, "crash" a RuntimeError, "exit" ends the
    process, as a CUDA fault or the out-of-memory killer would, "hang" never returns."""

    name = "test:bright-box"

    def detect(self, frame: Frame, queries):
        return self.detect_batch([frame], [queries])[0]

    def detect_batch(self, frames, queries):
        out = []
        for f, q in zip(frames, queries, strict=True):
            if q[0] == "bad-input":
                raise InputError("this image is not acceptable", "send another one")
            if q[0] == "crash":
                raise RuntimeError("the model crashed on purpose")
            if q[0] == "exit":
                os._exit(3)
            if q[0] == "hang":  # a model call that never ends
                time.sleep(3600)
            out.append([Detection(box=bright_box(f.rgb), score=0.9, label=f"{q[0]}@{os.getpid()}")])
        return out


# ---- API fakes: perception backends following the protocols, and a small geometric world ---------------
# The world is an honest miniature: spheres at known 3D positions, a pinhole camera on a pan/tilt head that
# moves with first-order dynamics and stops at its limits, a rangefinder that intersects the optical axis
# with the spheres, and a force sensor that feels what the gripper holds. Its detector projects the spheres
# through the camera as it was when the frame was taken, so boxes and distances agree the way they would on
# a robot. tests/test_api_fakes.py checks the fakes themselves.


@dataclass(frozen=True)
class Thing:
    """A labelled box in full-frame pixels (y down), for the 2D detector."""

    label: str
    box: tuple[float, float, float, float]
    score: float = 0.9
    object_id: str | None = None


class FakeDetector:
    """Returns the things whose label is queried and whose box overlaps the frame given, in its pixels."""

    name = "fake-detector"

    def __init__(self, things: Sequence[Thing] = ()) -> None:
        self.things = list(things)
        self.calls: list[tuple[tuple[int, int, int, int], list[str]]] = []

    def detect(self, frame: Frame, queries: Sequence[str]) -> list[Detection]:
        ox, oy = frame.origin
        self.calls.append(((ox, oy, frame.width, frame.height), list(queries)))
        out = []
        for t in self.things:
            if t.label not in queries:
                continue
            x0, y0, x1, y1 = t.box[0] - ox, t.box[1] - oy, t.box[2] - ox, t.box[3] - oy
            x0, y0 = max(x0, 0.0), max(y0, 0.0)
            x1, y1 = min(x1, frame.width), min(y1, frame.height)
            if x1 > x0 and y1 > y0:
                out.append(
                    Detection(box=(x0, y0, x1, y1), score=t.score, label=t.label, object_id=t.object_id)
                )
        return out


class FakeVQA:
    """Answers with the size and origin of the pixels it was given, so tests can see what it saw."""

    name = "fake-vqa"

    def __init__(self) -> None:
        self.questions: list[str] = []

    def answer(self, frame: Frame, question: str) -> str:
        self.questions.append(question)
        return f"{frame.width}x{frame.height}@{frame.origin[0]},{frame.origin[1]}"


class FakeLanguage:
    name = "fake-language"

    def __init__(self, answers: dict[str, str] | None = None) -> None:
        self.answers = answers or {}

    def complete(self, question: str) -> str:
        return self.answers.get(question, UNKNOWN)


def perception_for(things: Sequence[Thing] = (), answers: dict[str, str] | None = None) -> Perception:
    return Perception(FakeDetector(things), FakeVQA(), FakeLanguage(answers))


# ---- a small geometric world -------------------------------------------------------------------------


@dataclass
class Ball:
    id: str
    label: str
    center: tuple[float, float, float]  # world metres
    radius: float
    mass: float  # kg


CAM = CameraInfo(width=320, height=240, fx=200.0, fy=200.0, cx=160.0, cy=120.0)
CAM_HEIGHT = 1.0


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
        o, d = self.camera_position(), _rot_head_to_world(self.pan, self.tilt, np.array([1.0, 0.0, 0.0]))
        best = math.inf
        for b in self.balls.values():
            oc = o - np.asarray(b.center)
            half_b = float(d @ oc)
            disc = half_b**2 - (float(oc @ oc) - b.radius**2)
            if disc >= 0:
                t = -half_b - math.sqrt(disc)
                if 0 < t < best:
                    best = t
        return best if best < 8.0 else math.inf

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


# ---- a loopback OpenAI-compatible chat endpoint ---------------------------------------------------------


def serve_chat_replies(httpserver, contents: list[str]) -> list[dict]:
    """A loopback OpenAI-compatible endpoint answering `contents` in turn (the last one repeats);
    returns the list that collects the request bodies."""
    from werkzeug import Response

    requests: list[dict] = []

    def handler(request):
        body = json.loads(request.data)
        requests.append(body)
        content = contents[min(len(requests), len(contents)) - 1]
        reply = {
            "id": "x",
            "object": "chat.completion",
            "created": 0,
            "model": body["model"],
            "choices": [
                {"index": 0, "finish_reason": "stop", "message": {"role": "assistant", "content": content}}
            ],
        }
        return Response(json.dumps(reply), content_type="application/json")

    httpserver.expect_request("/v1/chat/completions", method="POST").respond_with_handler(handler)
    return requests


# ---- a world seen as a real robot sees it -------------------------------------------------------------


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
