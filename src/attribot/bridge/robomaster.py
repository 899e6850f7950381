"""The DJI RoboMaster EP as a bridge driver, through the RoboMaster SDK's documented calls.

Calls and units (SDK 0.1.1, `src/robomaster/*.py` of dji-sdk/RoboMaster-SDK):
- `chassis.drive_speed(x, y, z, timeout)`: x forward and y rightward in m/s, z clockwise in degrees/s
  (the EP's chassis frame points x forward, y right, z down); the bridge speaks forward / left /
  counter-clockwise radians, so y and z change sign here. `timeout` makes the EP itself stop when no new
  speed arrives: a second watchdog below the bridge's.
- `camera.start_video_stream(display=False, resolution=...)` and `camera.read_cv2_image(strategy="newest")`:
  BGR frames, encoded to JPEG here with OpenCV (the SDK's own dependency).
- `sensor.sub_distance(freq, callback)`: the callback gets the four ToF readings in millimetres.
- `robotic_arm.moveto(x, y)`: absolute end-point position in millimetres, x forward, y up;
  `robotic_arm.sub_position(freq, callback)` reports (x, y) in millimetres. The bridge's `arm` request
  (the grip point's height above the floor and its extension) is turned into these by the EP's body
  (`attribot.bridge.robomaster_body`: the end point is the forearm's tip, measured from the shoulder).
- `chassis.sub_position(cs=1, freq, callback)`: odometry (x forward, y right, metres) from where the EP
  was switched on; `chassis.sub_attitude(freq, callback)`: (yaw, pitch, roll) in degrees, yaw clockwise.
- `gripper.open(power)` / `gripper.close(power)` and `gripper.sub_status(freq, callback)` ("opened",
  "closed", "normal"; "normal" after closing means the fingers stopped on something).
- `sensor_adaptor.get_adc(id, port)`: 10-bit ADC value (0 to 1023) of a sensor adaptor port.

The EP has no force sensor. Weight comes from an optional load cell on the gripper, read through the sensor
adaptor's ADC; its wiring and calibration are in docs/bridge-protocol.md ("RoboMaster EP load cell"). With
no `LoadCell` configured the driver leaves the force capability out and the planner never asks for weight.

The driver states the EP's body in its hello (`body()`, from `attribot.bridge.robomaster_body`): where the
camera on the arm is for each pose of the arm, how far the gripper reaches, the chassis's size. With it and
the pose capability (odometry and the arm's position), the host's servo controller drives to objects,
picks them up and puts them back by perception (docs/bridge-protocol.md, "The RoboMaster EP's body").

Optional sensors (`sensors()` in the hello, read with `read`), through the sensor adaptor's ADC as well
(docs/bridge-protocol.md, "RoboMaster EP optional sensors"):
- `temperature`: an infrared thermometer with an analog output (a thermopile module, e.g. a Melexis
  MLX90614 in its PWM/analog mode behind an RC filter, or an MLX90614-to-voltage board), mounted beside
  the ToF sensor between the fingers and aimed along its beam, on an adaptor port: celsius = offset +
  adc * slope (`AnalogThermometer`, calibrated against two known temperatures).
- `grip` (not driven here): a squeeze needs the fingers' force and their closure. The EP's gripper reports
  only opened / closed / stalled, so it would take a force-sensing resistor on a finger pad on one ADC port
  and a linear potentiometer on the finger linkage on the other port of the same adaptor, closed step by
  step with `gripper.close(power)`; the driver states no `grip` sensor until both are fitted.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Any

from attribot.bridge.driver import CameraFrame, Driver
from attribot.bridge.robomaster_body import EP_BODY, from_sdk_mm, to_sdk_mm

__all__ = [
    "LoadCell",
    "AnalogThermometer",
    "RoboMasterDriver",
    "CALIBRATION_RANGES",
    "SDK_MISSING",
    "SdkMissing",
    "require_sdk",
    "checked",
]

_GRAVITY = 9.80665

CALIBRATION_RANGES = {
    "hfov_deg": (20.0, 170.0, "degrees"),  # the EP's camera sees 96 (video) to 120 (photo) degrees
    "load_cell_newtons_per_count": (1e-6, 10.0, "N per count, either sign"),
    "load_cell_zero": (0.0, 1023.0, "ADC counts"),  # the sensor adaptor's ADC is 10-bit
    "load_cell_board": (1, 8, ""),
    "load_cell_port": (1, 2, ""),
    "thermometer_celsius_per_count": (1e-6, 10.0, "degC per count, either sign"),
    "thermometer_offset": (-100.0, 500.0, "degC"),
    "thermometer_board": (1, 8, ""),
    "thermometer_port": (1, 2, ""),
    "tof_index": (0, 3, ""),
    "gripper_power": (1, 100, ""),
    "speed_timeout_s": (0.05, 5.0, "s"),
    "jpeg_quality": (1, 100, ""),
    "gripper_settle_s": (0.0, 10.0, "s"),
}
"""Each calibration value's physical range (low, high, unit), both ends included; a scale factor
(`..._per_count`) may be negative, its magnitude lies in the range. A value outside, or not a finite number
(NaN, an infinity), is refused: the controller would drive by it."""


def checked(name: str, value: Any, integer: bool = False) -> float:
    """`value` as a finite number within `CALIBRATION_RANGES[name]`; a `ValueError` naming the range
    otherwise."""
    low, high, unit = CALIBRATION_RANGES[name]
    what = "{} must be {} from {:g} to {:g}{}".format(
        name, "a whole number" if integer else "a finite number", low, high, " " + unit if unit else ""
    )
    number = None
    if isinstance(value, str):
        try:
            number = int(value.strip()) if integer else float(value.strip())
        except ValueError:
            number = None
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        number = value
    if integer and isinstance(number, float):
        number = int(number) if number.is_integer() else None
    size = None if number is None else abs(number) if name.endswith("_per_count") else number
    if number is None or size is None or not math.isfinite(size) or not low <= size <= high:
        raise ValueError(f"{what} (got {str(value)[:40] if isinstance(value, str) else value!r})")
    return number


def _signed(value: Any) -> float:
    """A reported arm coordinate as a signed number: the SDK unpacks them as unsigned 32-bit integers
    (`struct.unpack('<II', ...)` in robotic_arm.py), so a point below the shoulder comes out near 2**32."""
    v = float(value)
    return v - 2.0**32 if v >= 2.0**31 else v


SDK_MISSING = (
    "the RoboMaster SDK is not installed here: install it on the robot's computer with "
    "`python3.8 -m pip install robomaster` (it runs on Python 3.6 to 3.8), or serve --driver mujoco"
)


class SdkMissing(RuntimeError):
    """The RoboMaster SDK cannot be imported; the message is the one line to show (`SDK_MISSING`)."""


def require_sdk() -> Any:
    """The SDK's `robomaster.robot` module, or `SdkMissing` saying how to install it."""
    try:
        from robomaster import robot as rm_robot  # the SDK: only on the robot's computer
    except ImportError as exc:
        raise SdkMissing(f"{SDK_MISSING} ({exc})") from None
    return rm_robot


class LoadCell:
    """A load cell (strain-gauge bridge and an instrumentation amplifier) on a sensor adaptor ADC port.

    newtons = (adc - zero_adc) * newtons_per_count, with `zero_adc` the reading with nothing held and
    `newtons_per_count` from one known mass: (m * 9.80665) / (adc_with_mass - zero_adc). `tare()` takes the
    current reading as the new zero (what `tare_force` does before a grasp).
    """

    def __init__(
        self, newtons_per_count: float, zero_adc: float = 0.0, board_id: int = 1, port: int = 1
    ) -> None:
        self.newtons_per_count = float(checked("load_cell_newtons_per_count", newtons_per_count))
        self.zero_adc = float(checked("load_cell_zero", zero_adc))
        self.board_id = int(checked("load_cell_board", board_id, integer=True))
        self.port = int(checked("load_cell_port", port, integer=True))

    @staticmethod
    def calibrate(
        zero_adc: float, loaded_adc: float, mass_kg: float, board_id: int = 1, port: int = 1
    ) -> LoadCell:
        """The load cell whose readings were `zero_adc` empty and `loaded_adc` holding `mass_kg`."""
        if loaded_adc == zero_adc:
            raise ValueError(
                "the loaded reading equals the empty one: check the wiring and the amplifier gain"
            )
        return LoadCell(mass_kg * _GRAVITY / (loaded_adc - zero_adc), zero_adc, board_id, port)


class AnalogThermometer:
    """An infrared thermometer with an analog output on a sensor adaptor ADC port: celsius = offset_c +
    adc * celsius_per_count (`calibrate` from two readings at known temperatures)."""

    def __init__(
        self, celsius_per_count: float, offset_c: float = 0.0, board_id: int = 1, port: int = 2
    ) -> None:
        self.celsius_per_count = float(checked("thermometer_celsius_per_count", celsius_per_count))
        self.offset_c = float(checked("thermometer_offset", offset_c))
        self.board_id = int(checked("thermometer_board", board_id, integer=True))
        self.port = int(checked("thermometer_port", port, integer=True))

    @staticmethod
    def calibrate(
        adc_a: float, celsius_a: float, adc_b: float, celsius_b: float, board_id: int = 1, port: int = 2
    ) -> AnalogThermometer:
        """The thermometer that read `adc_a` aimed at something at `celsius_a` and `adc_b` at `celsius_b`
        (e.g. iced water and boiled water in matt black mugs)."""
        if adc_a == adc_b:
            raise ValueError("both readings are equal: check the wiring and the two temperatures")
        slope = (celsius_b - celsius_a) / (adc_b - adc_a)
        return AnalogThermometer(slope, celsius_a - adc_a * slope, board_id, port)


class RoboMasterDriver(Driver):
    """A RoboMaster EP (engineering version: chassis, arm, gripper, camera, ToF) behind the bridge."""

    name = "robomaster-ep"
    realtime = True

    def __init__(
        self,
        robot: Any,
        *,
        load_cell: LoadCell | None = None,
        thermometer: AnalogThermometer | None = None,
        resolution: str = "360p",
        hfov_deg: float = 96.0,
        tof_index: int = 0,
        gripper_power: int = 50,
        speed_timeout_s: float = 1.0,
        jpeg_quality: int = 85,
        gripper_settle_s: float = 1.0,
    ) -> None:
        """`robot`: an initialised `robomaster.robot.Robot` (or anything with its modules and calls).
        hfov_deg: the camera's horizontal field of view after calibration (the intrinsics sent in hello)."""
        sizes = {"360p": (640, 360), "540p": (960, 540), "720p": (1280, 720)}
        if resolution not in sizes:
            raise ValueError(f"resolution must be one of {sorted(sizes)}, got {resolution!r}")
        hfov_deg = float(checked("hfov_deg", hfov_deg))
        tof_index = int(checked("tof_index", tof_index, integer=True))
        gripper_power = int(checked("gripper_power", gripper_power, integer=True))
        speed_timeout_s = float(checked("speed_timeout_s", speed_timeout_s))
        jpeg_quality = int(checked("jpeg_quality", jpeg_quality, integer=True))
        gripper_settle_s = float(checked("gripper_settle_s", gripper_settle_s))
        self.robot = robot
        self.load_cell = load_cell
        self.thermometer = thermometer
        self.resolution = resolution
        self.width, self.height = sizes[resolution]
        self.fx = (self.width / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
        self.tof_index = tof_index
        self.gripper_power = gripper_power
        self.speed_timeout_s = speed_timeout_s
        self.jpeg_quality = jpeg_quality
        self.gripper_settle_s = gripper_settle_s
        self._lock = threading.Lock()
        self._tof_mm: float | None = None
        self._arm_mm = to_sdk_mm(*EP_BODY["rest"])  # the zero pose, until the arm reports
        self._gripper = "opened"
        self._position = (0.0, 0.0)  # odometry, the SDK's frame: x forward, y right, metres
        self._yaw_deg = 0.0  # clockwise
        robot.camera.start_video_stream(display=False, resolution=resolution)
        robot.sensor.sub_distance(freq=20, callback=self._on_distance)
        robot.robotic_arm.sub_position(freq=20, callback=self._on_arm)
        robot.gripper.sub_status(freq=20, callback=self._on_gripper)
        robot.chassis.sub_position(cs=1, freq=20, callback=self._on_position)
        robot.chassis.sub_attitude(freq=20, callback=self._on_attitude)

    @classmethod
    def connect(cls, conn_type: str = "ap", **options: Any) -> RoboMasterDriver:
        """Connect to the EP over wifi (`ap`: the robot's own access point; `sta`: the lab's network).
        Without the RoboMaster SDK: `SdkMissing`, whose message says how to install it."""
        rm_robot = require_sdk()

        ep = rm_robot.Robot()
        ep.initialize(conn_type=conn_type)
        return cls(ep, **options)

    # --- subscriptions ----------------------------------------------------------------------------
    def _on_distance(self, distances: Any) -> None:
        with self._lock:
            self._tof_mm = float(distances[self.tof_index])

    def _on_arm(self, position: Any) -> None:
        with self._lock:
            self._arm_mm = (_signed(position[0]), _signed(position[1]))

    def _on_gripper(self, status: Any) -> None:
        with self._lock:
            self._gripper = str(status)

    def _on_position(self, position: Any) -> None:
        with self._lock:
            self._position = (float(position[0]), float(position[1]))

    def _on_attitude(self, attitude: Any) -> None:
        with self._lock:
            self._yaw_deg = float(attitude[0])

    # --- Driver -----------------------------------------------------------------------------------
    def capabilities(self) -> list[str]:
        caps = ["camera", "base", "arm", "gripper", "distance", "pose"]
        if self.load_cell is not None:
            caps.append("force")
        return caps

    def camera(self) -> dict[str, float]:
        return {
            "width": self.width,
            "height": self.height,
            "fx": self.fx,
            "fy": self.fx,
            "cx": self.width / 2.0,
            "cy": self.height / 2.0,
        }

    def frame(self) -> CameraFrame:
        import cv2  # installed with the RoboMaster SDK

        bgr = self.robot.camera.read_cv2_image(timeout=3, strategy="newest")
        stamp = time.time()
        if bgr is None:
            raise RuntimeError("the EP's video stream gave no frame within 3 s")
        ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality])
        if not ok:
            raise RuntimeError("the EP's frame could not be encoded as JPEG")
        return CameraFrame(bytes(buf.tobytes()), timestamp=stamp)

    def drive(self, vx: float, vy: float, wz: float) -> None:
        self.robot.chassis.drive_speed(
            x=float(vx), y=-float(vy), z=-math.degrees(float(wz)), timeout=self.speed_timeout_s
        )

    def stop(self) -> None:
        self.robot.chassis.drive_speed(x=0.0, y=0.0, z=0.0)
        with self._lock:
            x, y = self._arm_mm
        self.robot.robotic_arm.moveto(x=x, y=y)  # hold the arm where it is

    def body(self) -> dict[str, Any]:
        return dict(EP_BODY)

    def set_arm(self, lift: float, extension: float) -> None:
        """The grip point's height and extension in metres -> the arm's end point, x forward and y up in
        millimetres."""
        x, y = to_sdk_mm(float(lift), float(extension))
        self.robot.robotic_arm.moveto(x=x, y=y)

    def pose(self) -> list[float]:
        """Odometry as the bridge speaks it: x forward and y left in metres, yaw counter-clockwise in
        radians, from where the EP was switched on."""
        with self._lock:
            (x, y), yaw = self._position, self._yaw_deg
        return [x, -y, math.remainder(-math.radians(yaw), math.tau)]

    def joints(self) -> dict[str, float]:
        """The arm's grip point (lift, arm: metres) from its reported end point, and the gripper's opening:
        open, closed, or stopped on something (half open) as its status says."""
        with self._lock:
            arm_mm, status = self._arm_mm, self._gripper
        lift, extension = from_sdk_mm(*arm_mm)
        open_ = float(EP_BODY["finger_open"])
        opening = {"opened": open_, "closed": 0.0}.get(status, open_ / 2)
        return {"lift": lift, "arm": extension, "gripper": opening}

    def grasp(self) -> bool:
        self.robot.gripper.close(power=self.gripper_power)
        time.sleep(self.gripper_settle_s)  # the fingers take about a second to close or stall on an object
        with self._lock:
            return self._gripper == "normal"  # stopped between open and closed: holding something

    def release(self) -> None:
        self.robot.gripper.open(power=self.gripper_power)
        time.sleep(self.gripper_settle_s)

    def distance(self) -> float:
        with self._lock:
            mm = self._tof_mm
        return math.inf if mm is None or mm <= 0 else mm / 1000.0

    def _adc(self, board_id: int | None = None, port: int | None = None) -> float:
        """An ADC reading of a sensor adaptor port (the load cell's, unless another is named)."""
        if board_id is None or port is None:
            cell = self.load_cell
            if cell is None:
                raise RuntimeError("no load cell is configured")
            board_id, port = cell.board_id, cell.port
        value = self.robot.sensor_adaptor.get_adc(id=board_id, port=port)
        if value is None:
            raise RuntimeError(f"sensor adaptor {board_id} port {port} gave no ADC reading")
        return float(value)

    def sensors(self) -> list[str]:
        return ["temperature"] if self.thermometer is not None else []

    def read_sensor(self, name: str) -> float:
        probe = self.thermometer
        if name != "temperature" or probe is None:
            raise RuntimeError(f"no {name} sensor is configured")
        return probe.offset_c + self._adc(probe.board_id, probe.port) * probe.celsius_per_count

    def tare_force(self) -> None:
        cell = self.load_cell
        if cell is None:
            raise RuntimeError("no load cell is configured")
        cell.zero_adc = self._adc()

    def force(self) -> list[float]:
        cell = self.load_cell
        if cell is None:
            raise RuntimeError("no load cell is configured")
        newtons = (self._adc() - cell.zero_adc) * cell.newtons_per_count
        return [0.0, 0.0, -newtons]  # the held object's weight pulls down (world -z)

    def close(self) -> None:
        for call in (
            lambda: self.robot.chassis.drive_speed(x=0.0, y=0.0, z=0.0),
            self.robot.sensor.unsub_distance,
            self.robot.robotic_arm.unsub_position,
            self.robot.gripper.unsub_status,
            self.robot.chassis.unsub_position,
            self.robot.chassis.unsub_attitude,
            self.robot.camera.stop_video_stream,
            self.robot.close,
        ):
            try:
                call()
            except Exception:  # close everything that still can be closed
                pass


OPTIONS = {
    "conn_type": "wifi mode: ap (the robot's access point, default) or sta (the lab's network)",
    "resolution": "video stream: 360p (default), 540p or 720p",
    "hfov_deg": "calibrated horizontal field of view of the camera, degrees (default 96)",
    "load_cell_newtons_per_count": "N per ADC count from the calibration; no load cell: leave out",
    "load_cell_zero": "load cell ADC reading with nothing held (default 0; tare_force re-zeroes it)",
    "load_cell_board": "sensor adaptor id of the load cell, 1 to 8 (default 1)",
    "load_cell_port": "sensor adaptor port of the load cell, 1 or 2 (default 1)",
    "thermometer_celsius_per_count": "degC per ADC count of an analog infrared thermometer; none: leave out",
    "thermometer_offset": "degC at ADC count 0, from the thermometer's two-point calibration (default 0)",
    "thermometer_board": "sensor adaptor id of the thermometer, 1 to 8 (default 1)",
    "thermometer_port": "sensor adaptor port of the thermometer, 1 or 2 (default 2)",
}


def driver_options(options: dict[str, Any]) -> dict[str, Any]:
    """`RoboMasterDriver.connect` keyword arguments from KEY=VALUE options (`--option` given on the CLI)."""
    unknown = sorted(set(options) - set(OPTIONS))
    if unknown:
        raise ValueError(f"unknown robomaster option(s) {', '.join(unknown)}; known: {', '.join(OPTIONS)}")
    out: dict[str, Any] = {}
    if "conn_type" in options:
        out["conn_type"] = str(options["conn_type"])
    if "resolution" in options:
        out["resolution"] = str(options["resolution"])
    if "conn_type" in out and out["conn_type"] not in ("ap", "sta"):
        raise ValueError("conn_type must be ap or sta, got {!r}".format(out["conn_type"][:40]))
    if "hfov_deg" in options:
        out["hfov_deg"] = float(checked("hfov_deg", options["hfov_deg"]))
    if "load_cell_newtons_per_count" in options:
        out["load_cell"] = LoadCell(
            checked("load_cell_newtons_per_count", options["load_cell_newtons_per_count"]),
            checked("load_cell_zero", options.get("load_cell_zero", 0.0)),
            int(checked("load_cell_board", options.get("load_cell_board", 1), integer=True)),
            int(checked("load_cell_port", options.get("load_cell_port", 1), integer=True)),
        )
    elif any(k.startswith("load_cell_") for k in options):
        raise ValueError("a load cell needs load_cell_newtons_per_count (see docs/bridge-protocol.md)")
    if "thermometer_celsius_per_count" in options:
        out["thermometer"] = AnalogThermometer(
            checked("thermometer_celsius_per_count", options["thermometer_celsius_per_count"]),
            checked("thermometer_offset", options.get("thermometer_offset", 0.0)),
            int(checked("thermometer_board", options.get("thermometer_board", 1), integer=True)),
            int(checked("thermometer_port", options.get("thermometer_port", 2), integer=True)),
        )
    elif any(k.startswith("thermometer_") for k in options):
        raise ValueError("a thermometer needs thermometer_celsius_per_count (see docs/bridge-protocol.md)")
    return out
