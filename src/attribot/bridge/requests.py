"""The requests a client may send the robot: one function per op, and their value checks.

`RobotServer._handle` calls these with the server's lock held: each returns the reply's header and payload,
or raises `Refused`. A table (`REQUESTS`), not a lookup by name: a client's op string reaches nothing but
these. A value that is not a finite number, or a target beyond an actuator's travel, is refused.
"""

from __future__ import annotations

import math
import zlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from attribot.bridge.driver import CameraFrame, Driver
    from attribot.bridge.server import RobotServer

__all__ = ["MAX_STEP_S", "REQUESTS", "TRAVEL_TOLERANCE", "Refused", "shown"]

MAX_STEP_S = 10.0
"""The longest `step` one request may ask for (a simulator runs it at once; a real robot waits it out)."""
TRAVEL_TOLERANCE = 0.02
"""How far (m or rad) beyond an actuator's travel a target is clipped into it; further out it is refused."""


class Refused(Exception):
    def __init__(self, code: str, message: str, fix: str = "") -> None:
        Exception.__init__(self, message)
        self.code = code
        self.message = message
        self.fix = fix


def _clip(value: float, bound: float) -> float:
    return max(-bound, min(bound, value))


def shown(value: Any, limit: int = 40) -> str:
    """A short repr of what a client sent, for an error message (a huge string is not echoed back)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def finite(h: dict[str, Any], key: str, op: str) -> float:
    """`h[key]` as a finite float; anything else (missing, text, a bool, NaN, an infinity, a number too
    large for a float: clipping a NaN gives the limit, so NaN would drive the base at full speed) is refused
    with code `value`."""
    value = h.get(key)
    number = None
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        try:
            number = float(value)
        except OverflowError:  # an integer of hundreds of digits
            number = None
    if number is None or not math.isfinite(number):
        raise Refused(
            "value",
            f"{op} needs {key} as a finite number, got {shown(value)}",
            "send finite numbers (no NaN or infinity, nothing beyond a float's range; JSON has none)",
        )
    return number


def within(value: float, travel: tuple[float, float], what: str, unit: str) -> float:
    """`value` clipped into `travel`; refused (code `value`) when it lies further out than the tolerance:
    a target that far off is a client's bug, not a robot's reach."""
    low, high = travel
    if not low - TRAVEL_TOLERANCE <= value <= high + TRAVEL_TOLERANCE:
        raise Refused(
            "value",
            f"{what} {value:g} {unit} is outside its travel, {low:g} to {high:g} {unit}",
            "command targets within the travel the robot states in its hello (`travel`)",
        )
    return min(high, max(low, value))


def _need(driver: Driver, capability: str, op: str) -> None:
    if capability not in driver.capabilities():
        raise Refused(
            "unsupported",
            f"{driver.name} cannot {op}: it has no {capability} capability",
            "available here: {}".format(", ".join(sorted(driver.capabilities()))),
        )


def _frame(driver: Driver, frame: CameraFrame) -> tuple[dict[str, Any], bytes]:
    parts = [("jpeg", frame.jpeg)]
    header: dict[str, Any] = {"timestamp": frame.timestamp, "camera": dict(driver.camera())}
    if frame.depth is not None:
        import numpy as np  # only a robot with depth or segmentation needs it

        depth = np.ascontiguousarray(frame.depth, dtype="<f4")
        parts.append(("depth", depth.tobytes()))
        header["depth_shape"] = list(depth.shape)
    if frame.segmentation is not None:
        import numpy as np

        seg = np.ascontiguousarray(frame.segmentation, dtype="<i4")
        parts.append(("segmentation", zlib.compress(seg.tobytes(), 1)))
        header["segmentation_shape"] = list(seg.shape)
        header["objects"] = frame.objects or []
    if frame.own_body is not None:
        import numpy as np

        own = np.asarray(frame.own_body, dtype=bool)
        parts.append(("own_body", zlib.compress(np.packbits(own).tobytes(), 1)))
        header["own_body_shape"] = list(own.shape)
    header["parts"] = [[name, len(data)] for name, data in parts]
    return header, b"".join(data for _, data in parts)


def _op_observe(
    server: RobotServer, op: str, h: dict[str, Any], received: float
) -> tuple[dict[str, Any], bytes]:
    _need(server.driver, "camera", op)
    return _frame(server.driver, server.driver.frame())


def _op_base(
    server: RobotServer, op: str, h: dict[str, Any], received: float
) -> tuple[dict[str, Any], bytes]:
    _need(server.driver, "base", "drive its base")
    lim = server.limits
    server._target = (
        _clip(finite(h, "vx", op), lim.max_speed),
        _clip(finite(h, "vy", op), lim.max_speed),
        _clip(finite(h, "wz", op), lim.max_turn),
    )
    server._armed = True
    server._last_command = max(server._last_command, received)
    if server.driver.realtime:
        server._ramp(server.RAMP_TICK)
    return {"commanded": list(server._target)}, b""


def _op_step(
    server: RobotServer, op: str, h: dict[str, Any], received: float
) -> tuple[dict[str, Any], bytes]:
    seconds = finite(h, "seconds", op)
    if not 0.0 <= seconds <= MAX_STEP_S:
        raise Refused(
            "value",
            f"step needs seconds from 0 to {MAX_STEP_S:g}, got {seconds:g}",
            "step in shorter pieces",
        )
    server._step(seconds)
    return {"clock": server.driver.clock()}, b""


def _op_stop(
    server: RobotServer, op: str, h: dict[str, Any], received: float
) -> tuple[dict[str, Any], bytes]:
    server._target = (0.0, 0.0, 0.0)
    server._applied = (0.0, 0.0, 0.0)
    server._armed = False
    server.driver.stop()
    return {}, b""


def _op_head(
    server: RobotServer, op: str, h: dict[str, Any], received: float
) -> tuple[dict[str, Any], bytes]:
    _need(server.driver, "head", "move a camera head")
    pan, tilt = finite(h, "pan", op), finite(h, "tilt", op)
    if abs(pan) > 2 * math.pi:
        raise Refused("value", f"head pan {pan:g} rad is more than a turn", "send an angle")
    pan = within(math.remainder(pan, 2 * math.pi), server.travel["pan"], "head pan", "rad")
    tilt = within(tilt, server.travel["tilt"], "head tilt", "rad")
    server.driver.set_head(pan, tilt)
    return {"commanded": [pan, tilt]}, b""


def _op_arm(server: RobotServer, op: str, h: dict[str, Any], received: float) -> tuple[dict[str, Any], bytes]:
    _need(server.driver, "arm", "move an arm")
    travel = server.travel
    lift = within(finite(h, "lift", op), travel["lift"], "arm lift", "m")
    extension = within(finite(h, "extension", op), travel["extension"], "arm extension", "m")
    server._armed = True
    server._last_command = max(server._last_command, received)
    server.driver.set_arm(lift, extension)
    return {"commanded": [lift, extension]}, b""


def _op_grasp(
    server: RobotServer, op: str, h: dict[str, Any], received: float
) -> tuple[dict[str, Any], bytes]:
    _need(server.driver, "gripper", op)
    return {"held": bool(server.driver.grasp())}, b""


def _op_release(
    server: RobotServer, op: str, h: dict[str, Any], received: float
) -> tuple[dict[str, Any], bytes]:
    _need(server.driver, "gripper", op)
    server.driver.release()
    return {}, b""


def _op_distance(
    server: RobotServer, op: str, h: dict[str, Any], received: float
) -> tuple[dict[str, Any], bytes]:
    _need(server.driver, "distance", "measure distance")
    value = float(server.driver.distance())
    return {"metres": value if math.isfinite(value) else None}, b""


def _op_tare(
    server: RobotServer, op: str, h: dict[str, Any], received: float
) -> tuple[dict[str, Any], bytes]:
    _need(server.driver, "force", "tare a force sensor")
    server.driver.tare_force()
    return {}, b""


def _op_force(
    server: RobotServer, op: str, h: dict[str, Any], received: float
) -> tuple[dict[str, Any], bytes]:
    _need(server.driver, "force", "measure force")
    return {"newtons": [float(v) for v in server.driver.force()]}, b""


def _op_read(
    server: RobotServer, op: str, h: dict[str, Any], received: float
) -> tuple[dict[str, Any], bytes]:
    d = server.driver
    name = h.get("sensor")
    offered = [str(s) for s in d.sensors()]
    if not isinstance(name, str) or name not in offered:
        raise Refused(
            "unsupported",
            f"{d.name} has no {name!r} sensor",
            "its sensors: {}".format(", ".join(offered) or "none beyond its capabilities"),
        )
    value = float(d.read_sensor(name))
    return {"value": value if math.isfinite(value) else None}, b""


def _op_pose(
    server: RobotServer, op: str, h: dict[str, Any], received: float
) -> tuple[dict[str, Any], bytes]:
    _need(server.driver, "pose", "report its pose")
    x, y, yaw = server.driver.pose()
    return {"x": float(x), "y": float(y), "yaw": float(yaw)}, b""


def _op_joints(
    server: RobotServer, op: str, h: dict[str, Any], received: float
) -> tuple[dict[str, Any], bytes]:
    _need(server.driver, "pose", "report joint states")
    return {"joints": {k: float(v) for k, v in server.driver.joints().items()}}, b""


REQUESTS = {
    "observe": _op_observe,
    "base": _op_base,
    "step": _op_step,
    "stop": _op_stop,
    "head": _op_head,
    "arm": _op_arm,
    "grasp": _op_grasp,
    "release": _op_release,
    "distance": _op_distance,
    "tare": _op_tare,
    "force": _op_force,
    "read": _op_read,
    "pose": _op_pose,
    "joints": _op_joints,
}
