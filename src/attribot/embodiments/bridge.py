"""The host side of the robot bridge: a robot served by `attribot bridge serve`, as an `Embodiment`.

`BridgeWorld` connects to `tcp://HOST:PORT`, says hello with the protocol version and the shared token
(`ATTRIBOT_BRIDGE_TOKEN`), and takes its capabilities from the robot's hello: any controller that acts
only through the `Embodiment` interface drives it unchanged. `EmbodimentDriver` is the other direction:
it serves any local `Embodiment` (the embedded MuJoCo world for `--driver mujoco`) as a bridge driver.
The protocol is in docs/bridge-protocol.md; the robot side in `attribot.bridge`.
"""

from __future__ import annotations

import dataclasses
import os
import socket
import time
import zlib
from typing import Any
from urllib.parse import urlparse

import numpy as np

from attribot.bridge.driver import CameraFrame, Driver
from attribot.bridge.protocol import PROTOCOL_VERSION, ProtocolError, recv_message, send_message
from attribot.config import BridgeConfig
from attribot.control.base import CONTROLLERS
from attribot.control.body import BodyGeometry
from attribot.control.servo import ServoController
from attribot.embodiments.base import EMBODIMENTS, Capability, Embodiment, Pose2D
from attribot.errors import AttribotError, ConfigError, UnsupportedAction
from attribot.frame import CameraInfo, Frame, ObjectTruth
from attribot.sensors import SENSORS

__all__ = ["BridgeError", "BridgeWorld", "EmbodimentDriver", "TOKEN_ENV", "URL_ENV"]

TOKEN_ENV = "ATTRIBOT_BRIDGE_TOKEN"
URL_ENV = "ATTRIBOT_BRIDGE_URL"  # the robot's address when neither the config nor `url` gives one


class BridgeError(AttribotError):
    """The robot bridge refused a request, or the connection to it failed."""


def _parse_url(url: str) -> tuple[str, int]:
    parsed = urlparse(url)
    if parsed.scheme != "tcp" or not parsed.hostname or parsed.port is None:
        raise ConfigError(
            f"bridge URL {url!r} is not tcp://HOST:PORT",
            "give the robot's address, e.g. --bridge-url tcp://192.168.2.1:7777",
        )
    return parsed.hostname, parsed.port


def _body_geometry(fields: dict[str, Any]) -> BodyGeometry:
    """The hello's `body` as a BodyGeometry (JSON lists become tuples); a malformed one is the robot's bug."""
    try:
        return BodyGeometry.from_dict(fields)
    except (TypeError, ValueError, AttributeError) as exc:
        raise BridgeError(
            f"the robot's hello gives a body geometry this client cannot read ({exc})",
            "check the robot driver's body(): the fields of attribot.control.body.BodyGeometry",
        ) from None


def _jpeg(rgb: np.ndarray, quality: int) -> bytes:
    import cv2

    ok, buf = cv2.imencode(".jpg", rgb[:, :, ::-1], [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise BridgeError("a camera frame could not be encoded as JPEG", "check the camera's image")
    return bytes(buf.tobytes())


@EMBODIMENTS.register("bridge")
class BridgeWorld(Embodiment):
    """A robot behind `attribot bridge serve` at `url` (or its `BridgeConfig`'s, or $ATTRIBOT_BRIDGE_URL)."""

    name = "bridge"

    def __init__(
        self,
        config: BridgeConfig | None = None,
        *,
        url: str | None = None,
        token: str | None = None,
        timeout_s: float | None = None,
    ) -> None:
        """`url` and `timeout_s` instead of a `config`; the token from $ATTRIBOT_BRIDGE_TOKEN if not given."""
        url = url or (config.url if config is not None else os.environ.get(URL_ENV, ""))
        timeout_s = timeout_s or (config.timeout_s if config is not None else 10.0)
        if not url:
            raise ConfigError(
                "the bridge world needs the robot's address",
                "give --bridge-url tcp://HOST:PORT (where `attribot bridge serve` listens)",
            )
        token = token if token is not None else os.environ.get(TOKEN_ENV, "")
        if not token:
            raise ConfigError(
                f"the bridge world needs the robot's shared token and {TOKEN_ENV} is not set",
                f"export {TOKEN_ENV}=<the --token given to `attribot bridge serve`>",
            )
        self.url = url
        host, port = _parse_url(url)
        try:
            self._sock: socket.socket | None = socket.create_connection((host, port), timeout=timeout_s)
        except OSError as exc:
            raise BridgeError(
                f"cannot reach the robot bridge at {url} ({exc.strerror or exc})",
                "start `attribot bridge serve` on the robot and check the address and port",
            ) from None
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        hello = self._call({"op": "hello", "version": PROTOCOL_VERSION, "token": token})[0]
        self.robot = str(hello.get("robot", "robot"))
        self.limits: dict[str, float] = dict(hello.get("limits", {}))
        self._caps = frozenset(Capability(c) for c in hello.get("capabilities", []) if c in set(Capability))
        cam = hello.get("camera")
        self._camera = (
            None if cam is None else CameraInfo(**{k: cam[k] for k in CameraInfo.__dataclass_fields__})
        )
        body = hello.get("body")
        self._body = None if body is None else _body_geometry(body)
        # optional sensors the robot reads (absent from the hello of robots without any); one this side does
        # not know cannot be asked for, so it is left out
        stated = hello.get("sensors", [])
        named = stated if isinstance(stated, list) else []
        self._sensors = frozenset(s for s in named if isinstance(s, str) and s in SENSORS)
        self.last_timestamp: float | None = None

    # --- transport --------------------------------------------------------------------------------
    def _call(self, request: dict[str, Any]) -> tuple[dict[str, Any], bytes]:
        if self._sock is None:
            raise BridgeError("the bridge connection is closed", "build a new BridgeWorld")
        try:
            send_message(self._sock, request)
            reply, payload = recv_message(self._sock)
        except (OSError, ProtocolError) as exc:
            self._drop()
            raise BridgeError(
                f"the robot bridge at {self.url} stopped answering during {request.get('op')!r} ({exc})",
                "check the robot's `attribot bridge serve` log; the robot's watchdog has stopped it",
            ) from None
        if not reply.get("ok"):
            error_type = UnsupportedAction if reply.get("code") == "unsupported" else BridgeError
            if reply.get("code") in ("auth", "version", "hello", "busy"):
                self._drop()
            raise error_type(str(reply.get("error")), str(reply.get("fix") or "") or None)
        return reply, payload

    def _drop(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None

    # --- Embodiment -------------------------------------------------------------------------------
    def capabilities(self) -> frozenset[Capability]:
        return self._caps

    def sensors(self) -> frozenset[str]:
        return super().sensors() | self._sensors

    def read_sensor(self, name: str) -> float:
        if name not in self._sensors:
            return super().read_sensor(name)
        value = self._call({"op": "read", "sensor": name})[0].get("value")
        return float("nan") if value is None else float(value)

    def camera_info(self) -> CameraInfo:
        if self._camera is None:
            raise self._unsupported(Capability.CAMERA, "describe its camera")
        return self._camera

    def observe(self) -> Frame:
        import cv2

        self.require(Capability.CAMERA, "take a camera frame")
        head, payload = self._call({"op": "observe"})
        parts: dict[str, bytes] = {}
        at = 0
        for name, size in head["parts"]:
            parts[name] = payload[at : at + size]
            at += size
        bgr = cv2.imdecode(np.frombuffer(parts["jpeg"], np.uint8), cv2.IMREAD_COLOR)
        if bgr is None:
            raise BridgeError("the robot sent a frame that is not a JPEG image", "check the robot's camera")
        rgb = np.ascontiguousarray(bgr[:, :, ::-1])
        size = rgb.shape[:2]
        depth = None
        if "depth" in parts:
            depth = _image_part(parts, head, "depth", size, "<f4").astype(np.float32)
        own = None
        if "own_body" in parts:  # packed bits, row-major: the robot's own pixels
            bits = _image_part(parts, head, "own_body", size, "u1", compressed=True, packed_bits=True)
            own = np.unpackbits(bits)[: size[0] * size[1]].reshape(size).astype(bool)
        seg = None
        objects: dict[int, ObjectTruth] = {}
        if "segmentation" in parts:
            seg = _image_part(parts, head, "segmentation", size, "<i4", compressed=True).astype(np.int32)
            for item in head.get("objects", []):
                objects[int(item["key"])] = ObjectTruth(
                    id=item["id"],
                    category=item["category"],
                    color=item.get("color", ""),
                    synonyms=tuple(item.get("synonyms", ())),
                )
        cam = head.get("camera")
        camera = (
            self._camera
            if cam is None
            else CameraInfo(**{k: cam[k] for k in CameraInfo.__dataclass_fields__})
        )
        self.last_timestamp = float(head.get("timestamp", time.time()))
        return Frame(rgb=rgb, depth=depth, segmentation=seg, objects=objects, camera=camera, own_body=own)

    def body(self) -> BodyGeometry:
        if self._body is None:
            raise UnsupportedAction(
                f"the robot behind the bridge ({self.robot}) does not state its body geometry",
                "give its driver a body() (camera position, arm reach; see docs/bridge-protocol.md)",
            )
        return self._body

    def step(self, seconds: float) -> None:
        self._call({"op": "step", "seconds": float(seconds)})

    def command_base(self, vx: float, vy: float, wz: float) -> None:
        self._call({"op": "base", "vx": float(vx), "vy": float(vy), "wz": float(wz)})

    def stop(self) -> None:
        """Stop the base and hold the arm now."""
        self._call({"op": "stop"})

    def set_head(self, pan: float, tilt: float) -> None:
        self._call({"op": "head", "pan": float(pan), "tilt": float(tilt)})

    def set_arm(self, lift: float, extension: float) -> None:
        self._call({"op": "arm", "lift": float(lift), "extension": float(extension)})

    def grasp(self) -> bool:
        return bool(self._call({"op": "grasp"})[0]["held"])

    def release(self) -> None:
        self._call({"op": "release"})

    def read_distance(self) -> float:
        value = self._call({"op": "distance"})[0]["metres"]
        return float("inf") if value is None else float(value)

    def tare_force(self) -> None:
        self._call({"op": "tare"})

    def read_force(self) -> np.ndarray:
        return np.asarray(self._call({"op": "force"})[0]["newtons"], dtype=float)

    def base_pose(self) -> Pose2D:
        reply = self._call({"op": "pose"})[0]
        return Pose2D(reply["x"], reply["y"], reply["yaw"])

    def joint_states(self) -> dict[str, float]:
        return {k: float(v) for k, v in self._call({"op": "joints"})[0]["joints"].items()}

    def close(self) -> None:
        if self._sock is not None:
            try:
                send_message(self._sock, {"op": "bye"})
                recv_message(self._sock)
            except (OSError, ProtocolError):
                pass
            self._drop()


class EmbodimentDriver(Driver):
    """Serve a local `Embodiment` over the bridge (`--driver mujoco` serves the embedded world)."""

    realtime = False

    def __init__(self, world: Embodiment, jpeg_quality: int = 90) -> None:
        self.world = world
        self.name = world.name
        self.jpeg_quality = jpeg_quality
        self._clock = 0.0
        self.commanded = (0.0, 0.0, 0.0)  # the base velocity the world was last given

    def capabilities(self) -> list[str]:
        return [str(c) for c in self.world.capabilities()]

    def camera(self) -> dict[str, float]:
        info = self.world.camera_info()
        return {k: getattr(info, k) for k in CameraInfo.__dataclass_fields__}

    def body(self) -> dict[str, Any] | None:
        try:
            return dataclasses.asdict(self.world.body())
        except UnsupportedAction:
            return None

    def frame(self) -> CameraFrame:
        frame = self.world.observe()
        objects = [
            {"key": k, "id": o.id, "category": o.category, "color": o.color, "synonyms": list(o.synonyms)}
            for k, o in frame.objects.items()
        ]
        return CameraFrame(
            jpeg=_jpeg(frame.rgb, self.jpeg_quality),
            timestamp=self._clock,
            depth=frame.depth,
            segmentation=frame.segmentation,
            objects=objects if frame.segmentation is not None else None,
            own_body=frame.own_body,
        )

    def clock(self) -> float:
        return self._clock

    def step(self, seconds: float) -> None:
        self.world.step(seconds)
        self._clock += seconds

    def drive(self, vx: float, vy: float, wz: float) -> None:
        self.commanded = (vx, vy, wz)
        self.world.command_base(vx, vy, wz)

    def stop(self) -> None:
        self.drive(0.0, 0.0, 0.0)
        if Capability.ARM in self.world.capabilities():
            joints = self.world.joint_states()
            if "lift" in joints and "arm" in joints:
                self.world.set_arm(joints["lift"], joints["arm"])  # hold where it is

    def set_head(self, pan: float, tilt: float) -> None:
        self.world.set_head(pan, tilt)

    def set_arm(self, lift: float, extension: float) -> None:
        self.world.set_arm(lift, extension)

    def grasp(self) -> bool:
        return self.world.grasp()

    def release(self) -> None:
        self.world.release()

    def distance(self) -> float:
        return self.world.read_distance()

    def tare_force(self) -> None:
        self.world.tare_force()

    def force(self) -> list[float]:
        return [float(v) for v in self.world.read_force()]

    def pose(self) -> list[float]:
        p = self.world.base_pose()
        return [p.x, p.y, p.yaw]

    def joints(self) -> dict[str, float]:
        return self.world.joint_states()

    def sensors(self) -> list[str]:
        # the sensors read through `read_sensor`: those no capability's own call reads
        return sorted(s for s in self.world.sensors() if s in SENSORS and SENSORS.get(s).capability is None)

    def read_sensor(self, name: str) -> float:
        return self.world.read_sensor(name)

    def close(self) -> None:
        self.world.close()


@CONTROLLERS.register("bridge")
def _bridge_controller(world: object) -> ServoController:
    """A robot behind the bridge is driven by what it perceives: the servo controller, by default."""
    return ServoController(world)


def _image_part(
    parts: dict[str, bytes],
    head: dict[str, Any],
    name: str,
    size: tuple[int, int],
    dtype: str,
    compressed: bool = False,
    packed_bits: bool = False,
) -> np.ndarray:
    """A per-pixel part of an `observe` reply (`depth`, `segmentation`, `own_body`) as an [H, W] array (with
    `packed_bits`: its bytes, one bit a pixel, row-major). A `compressed` part (zlib) is never inflated past
    the frame's size. Its stated shape must be the frame's [H, W] and its bytes exactly that many values,
    else a BridgeError naming the part."""
    shape = head.get(f"{name}_shape")
    if shape != list(size):
        raise BridgeError(
            f"the robot sent a {name} part of shape {str(shape)[:40]} for a frame of {size[0]}x{size[1]}",
            "send depth, segmentation and own_body at the camera frame's size (see docs/bridge-protocol.md)",
        )
    pixels = size[0] * size[1]
    want = (pixels + 7) // 8 if packed_bits else pixels * np.dtype(dtype).itemsize
    data = parts[name]
    if compressed:
        inflate = zlib.decompressobj()
        try:
            data = inflate.decompress(data, want + 1)
        except zlib.error:
            data = b""
    if len(data) != want:
        raise BridgeError(
            f"the robot's {name} part holds {len(data)} bytes where {want} were due",
            "send the part as docs/bridge-protocol.md describes",
        )
    if packed_bits:
        return np.frombuffer(data, np.uint8)
    return np.frombuffer(data, dtype).reshape(size)
