"""The RoboMaster EP driver against a fake SDK robot that follows the SDK's documented calls and units."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from attribot.bridge.robomaster import AnalogThermometer, LoadCell, RoboMasterDriver, driver_options
from attribot.bridge.server import Limits, RobotServer
from attribot.embodiments.base import Capability
from attribot.embodiments.bridge import BridgeWorld

TOKEN = "ep-secret"
_RESOLUTIONS = {"360p": (640, 360), "540p": (960, 540), "720p": (1280, 720)}


class _Subscriptions:
    def __init__(self) -> None:
        self.callbacks: dict[str, Any] = {}

    def _sub(self, what: str, freq: int, callback: Any) -> bool:
        assert freq in (1, 5, 10, 20, 50)
        self.callbacks[what] = callback
        return True


class _Chassis(_Subscriptions):
    def __init__(self) -> None:
        super().__init__()
        self.speeds: list[dict[str, Any]] = []

    def sub_position(self, cs: int = 0, freq: int = 5, callback: Any = None, *args: Any, **kw: Any) -> bool:
        assert cs in (0, 1)
        return self._sub("position", freq, callback)  # (x forward, y right, z) metres

    def unsub_position(self) -> bool:
        return self.callbacks.pop("position", None) is not None

    def sub_attitude(self, freq: int = 5, callback: Any = None, *args: Any, **kw: Any) -> bool:
        return self._sub("attitude", freq, callback)  # (yaw, pitch, roll) degrees, yaw clockwise

    def unsub_attitude(self) -> bool:
        return self.callbacks.pop("attitude", None) is not None

    def drive_speed(
        self, x: float = 0.0, y: float = 0.0, z: float = 0.0, timeout: float | None = None
    ) -> bool:
        # the SDK's checkers: x, y in [-3.5, 3.5] m/s, z in [-600, 600] degrees/s
        assert -3.5 <= x <= 3.5 and -3.5 <= y <= 3.5 and -600 <= z <= 600
        self.speeds.append({"x": x, "y": y, "z": z, "timeout": timeout})
        return True


class _Camera:
    def __init__(self) -> None:
        self.streaming: str | None = None

    def start_video_stream(self, display: bool = True, resolution: str = "720p") -> bool:
        assert display is False and resolution in _RESOLUTIONS
        self.streaming = resolution
        return True

    def stop_video_stream(self) -> bool:
        self.streaming = None
        return True

    def read_cv2_image(self, timeout: float = 3, strategy: str = "pipeline") -> np.ndarray | None:
        if self.streaming is None:
            return None
        w, h = _RESOLUTIONS[self.streaming]
        bgr = np.zeros((h, w, 3), np.uint8)
        bgr[:, :, 2] = 220  # red in BGR order
        return bgr


class _Sensor(_Subscriptions):
    def sub_distance(self, freq: int = 5, callback: Any = None, *args: Any, **kw: Any) -> bool:
        return self._sub("distance", freq, callback)

    def unsub_distance(self) -> bool:
        return self.callbacks.pop("distance", None) is not None


class _Arm(_Subscriptions):
    def __init__(self) -> None:
        super().__init__()
        self.moves: list[tuple[float, float]] = []

    def moveto(self, x: float = 0, y: float = 0) -> object:
        self.moves.append((x, y))  # millimetres: x forward, y up
        if "position" in self.callbacks:
            self.callbacks["position"]((x, y))
        return object()

    def sub_position(self, freq: int = 5, callback: Any = None, *args: Any, **kw: Any) -> bool:
        return self._sub("position", freq, callback)

    def unsub_position(self) -> bool:
        return self.callbacks.pop("position", None) is not None


class _Gripper(_Subscriptions):
    def __init__(self) -> None:
        super().__init__()
        self.object_between_fingers = False
        self.calls: list[tuple[str, int]] = []

    def open(self, power: int = 50) -> bool:
        self.calls.append(("open", power))
        self.callbacks["status"]("opened")
        return True

    def close(self, power: int = 50) -> bool:
        self.calls.append(("close", power))
        self.callbacks["status"]("normal" if self.object_between_fingers else "closed")
        return True

    def sub_status(self, freq: int = 5, callback: Any = None, *args: Any, **kw: Any) -> bool:
        return self._sub("status", freq, callback)

    def unsub_status(self) -> bool:
        return self.callbacks.pop("status", None) is not None


class _SensorAdaptor:
    def __init__(self) -> None:
        self.adc = {(1, 1): 500}

    def get_adc(self, id: int = 1, port: int = 1) -> int | None:  # noqa: A002 (the SDK's name)
        value = self.adc.get((id, port))
        return None if value is None else max(0, min(1023, int(value)))


class FakeEP:
    """An initialised `robomaster.robot.Robot`, as far as the driver uses it."""

    def __init__(self) -> None:
        self.chassis = _Chassis()
        self.camera = _Camera()
        self.sensor = _Sensor()
        self.robotic_arm = _Arm()
        self.gripper = _Gripper()
        self.sensor_adaptor = _SensorAdaptor()
        self.closed = False

    def close(self) -> None:
        self.closed = True


def _driver(ep: FakeEP, **kw: Any) -> RoboMasterDriver:
    return RoboMasterDriver(ep, gripper_settle_s=0.0, **kw)


def test_without_a_load_cell_the_force_capability_is_left_out():
    ep = FakeEP()
    assert "force" not in _driver(ep).capabilities()
    assert "force" in _driver(FakeEP(), load_cell=LoadCell(0.02)).capabilities()
    assert ep.camera.streaming == "360p" and set(ep.sensor.callbacks) == {"distance"}
    assert set(ep.chassis.callbacks) == {"position", "attitude"}


def test_the_ep_over_the_bridge_in_the_sdks_units():
    ep = FakeEP()
    cell = LoadCell.calibrate(zero_adc=500, loaded_adc=600, mass_kg=0.2)  # 0.2 kg lifts the ADC by 100
    driver = _driver(ep, load_cell=cell)
    limits = Limits(max_accel=1000.0, max_turn_accel=1000.0, watchdog_s=5.0, simulated=True)
    server = RobotServer(driver, TOKEN, limits=limits)
    import threading

    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        with BridgeWorld(url=f"tcp://127.0.0.1:{server.address[1]}", token=TOKEN) as world:
            assert Capability.FORCE in world.capabilities() and Capability.HEAD not in world.capabilities()
            info = world.camera_info()
            assert (info.width, info.height) == (640, 360)
            assert info.fx == pytest.approx(320 / math.tan(math.radians(48)))

            frame = world.observe()
            assert frame.rgb.shape == (360, 640, 3) and frame.rgb[0, 0, 0] > 200 and frame.rgb[0, 0, 2] < 30

            world.command_base(0.3, 0.1, 0.5)  # forward, left, counter-clockwise rad/s
            last = ep.chassis.speeds[-1]
            assert last["x"] == pytest.approx(0.3) and last["y"] == pytest.approx(-0.1)  # y right
            assert last["z"] == pytest.approx(-math.degrees(0.5))  # z clockwise, degrees/s
            assert last["timeout"] == 1.0  # the EP's own stop when speeds stop coming

            ep.sensor.callbacks["distance"]([350, 0, 0, 0])  # millimetres
            assert world.read_distance() == pytest.approx(0.35)
            ep.sensor.callbacks["distance"]([0, 0, 0, 0])
            assert world.read_distance() == math.inf

            # the arm's rest pose is the SDK's zero pose: both servos at 0, the forearm's tip 109.6 mm ahead
            # of the shoulder and 62.7 mm above it (two 0.12 m links at 88.0 and -28.5 degrees: the
            # forward kinematics of the RoboMaster simulator, jeguzzi/robomaster_sim src/robot/arm.cpp)
            zero = (120 * (math.cos(1.5359) - math.cos(2.6442)), 120 * (math.sin(1.5359) - math.sin(2.6442)))
            world.set_arm(*world.body().rest)
            assert ep.robotic_arm.moves[-1] == pytest.approx(zero, abs=0.5)  # x forward, y up, mm
            world.set_arm(0.05, 0.03)  # down to 5 cm from 17.87 cm, 3 cm further out: the end point too
            lowered = (zero[0] + 30, zero[1] - (178.7 - 50))
            assert ep.robotic_arm.moves[-1] == pytest.approx(lowered, abs=0.5)

            assert world.grasp() is False  # the fingers closed fully: nothing between them
            ep.gripper.object_between_fingers = True
            world.release()
            world.tare_force()
            ep.sensor_adaptor.adc[(1, 1)] = 550  # a 0.1 kg object
            assert world.grasp() is True
            force = world.read_force()
            assert force[2] == pytest.approx(-0.1 * 9.80665, rel=1e-6)

            world.stop()  # base zero, arm held where it is
            assert ep.chassis.speeds[-1] == {"x": 0.0, "y": 0.0, "z": 0.0, "timeout": None}
            assert ep.robotic_arm.moves[-1] == pytest.approx(lowered, abs=0.5)
    finally:
        server.close()
        thread.join(timeout=10)
        driver.close()
    assert ep.closed and ep.camera.streaming is None and not ep.sensor.callbacks and not ep.chassis.callbacks


def test_robomaster_options_parse_and_refuse_unknown_keys():
    kwargs = driver_options(
        {"load_cell_newtons_per_count": "0.02", "load_cell_zero": "511", "resolution": "720p"}
    )
    assert kwargs["resolution"] == "720p" and kwargs["load_cell"].zero_adc == 511.0
    with pytest.raises(ValueError, match="unknown robomaster option"):
        driver_options({"colour": "red"})
    with pytest.raises(ValueError, match="needs load_cell_newtons_per_count"):
        driver_options({"load_cell_zero": "3"})
    with pytest.raises(ValueError, match="check the wiring"):
        LoadCell.calibrate(500, 500, 0.1)


def test_the_ep_states_its_body_and_reports_its_pose_and_arm_in_the_bridges_frames():
    ep = FakeEP()
    driver = _driver(ep)
    server = RobotServer(driver, TOKEN, limits=Limits(watchdog_s=5.0))
    import threading

    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        with BridgeWorld(url=f"tcp://127.0.0.1:{server.address[1]}", token=TOKEN) as world:
            body = world.body()  # no longer refused: the servo controller can drive and grasp by it
            assert body.arm is not None and body.arm.links == (0.12, 0.12)
            assert body.base_half == (0.16, 0.12)  # the EP's 320 x 240 mm chassis
            assert body.finger_open == pytest.approx(0.05)  # the gripper opens about 10 cm
            # 220 mm of horizontal travel, 150 mm of vertical: the box the controller uses lies inside
            assert (
                body.arm_range[1] - body.arm_range[0] < 0.22
                and body.lift_range[1] - body.lift_range[0] < 0.25
            )
            assert {Capability.POSE, Capability.ARM, Capability.DISTANCE} <= world.capabilities()
            ep.chassis.callbacks["position"]((1.5, 0.25, 0.0))  # 1.5 m forward, 0.25 m to the right
            ep.chassis.callbacks["attitude"]((30.0, 0.0, 0.0))  # turned 30 degrees clockwise
            pose = world.base_pose()
            assert (pose.x, pose.y, pose.yaw) == pytest.approx((1.5, -0.25, -math.radians(30)))
            ep.robotic_arm.callbacks["position"]((110, 63))  # the zero pose, as the EP reports it
            joints = world.joint_states()
            assert (joints["lift"], joints["arm"]) == pytest.approx(body.rest, abs=0.002)
            assert joints["gripper"] == pytest.approx(0.05)
            ep.robotic_arm.callbacks["position"]((150, 2**32 - 80))  # 80 mm below the shoulder
            assert world.joint_states()["lift"] == pytest.approx(0.156 - 0.08 - 0.04, abs=0.002)
            # the camera rides on the arm: lowering the arm lowers it and tilts it down
            high = body.camera_pose({"lift": body.rest[0], "arm": body.rest[1]})
            low = body.camera_pose(world.joint_states())
            assert low.xyz[2] < high.xyz[2] - 0.05 and low.tilt < high.tilt - 0.3 and low.pan == 0.0
    finally:
        server.close()
        thread.join(timeout=10)
        driver.close()


def test_an_analog_thermometer_on_a_sensor_adaptor_is_stated_in_hello_and_read_over_the_bridge():
    ep = FakeEP()
    probe = AnalogThermometer.calibrate(
        adc_a=100, celsius_a=0.0, adc_b=600, celsius_b=100.0
    )  # 0.2 degC a count
    assert _driver(FakeEP()).sensors() == []  # none fitted: the hello states none
    driver = _driver(ep, thermometer=probe)
    assert driver.sensors() == ["temperature"]
    ep.sensor_adaptor.adc[(1, 2)] = 400  # port 2 of adaptor 1, the thermometer's by default
    server = RobotServer(driver, TOKEN, limits=Limits(watchdog_s=5.0))
    import threading

    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        with BridgeWorld(url=f"tcp://127.0.0.1:{server.address[1]}", token=TOKEN) as world:
            assert "temperature" in world.sensors() and "grip" not in world.sensors()
            assert world.read_sensor("temperature") == pytest.approx(60.0)
    finally:
        server.close()
        thread.join(timeout=10)
        driver.close()
    kwargs = driver_options({"thermometer_celsius_per_count": "0.2", "thermometer_offset": "-20"})
    assert kwargs["thermometer"].celsius_per_count == 0.2 and kwargs["thermometer"].port == 2
    with pytest.raises(ValueError, match="needs thermometer_celsius_per_count"):
        driver_options({"thermometer_offset": "3"})


def test_arm_targets_beyond_the_eps_travel_never_reach_the_sdk():
    # issue 28: `lift=1e6` reached the SDK as moveto(x=-1e9, ...)
    from attribot.bridge.robomaster_body import EP_BODY, to_sdk_mm
    from attribot.embodiments.bridge import BridgeError

    ep = FakeEP()
    driver = _driver(ep)
    server = RobotServer(driver, TOKEN, limits=Limits(watchdog_s=5.0))
    import threading

    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        with BridgeWorld(url=f"tcp://127.0.0.1:{server.address[1]}", token=TOKEN) as world:
            for lift, extension in ((1e6, 0.0), (0.1, 1e6), (-1e6, -1e6), (0.5, 0.0)):
                with pytest.raises(BridgeError, match="outside its travel"):
                    world.set_arm(lift, extension)
            world.set_arm(0.23, 0.07)  # a hair beyond the box the body states: clipped into it
    finally:
        server.close()
        thread.join(timeout=10)
        driver.close()
    (low, high), (near, far) = EP_BODY["lift_range"], EP_BODY["arm_range"]
    corners = [to_sdk_mm(lift, ext) for lift in (low, high) for ext in (near, far)]
    xs, ys = [c[0] for c in corners], [c[1] for c in corners]
    assert to_sdk_mm(high, far) in ep.robotic_arm.moves  # the clipped target was sent
    for x, y in ep.robotic_arm.moves:  # and every move (a refusal's stop holds the arm) within the box
        assert min(xs) - 1e-6 <= x <= max(xs) + 1e-6 and min(ys) - 1e-6 <= y <= max(ys) + 1e-6


# --- calibration is checked (issue 49) -----------------------------------------------------------------


@pytest.mark.parametrize(
    ("options", "named"),
    [
        ({"hfov_deg": "nan"}, "hfov_deg must be a finite number from 20 to 170"),
        ({"hfov_deg": "0"}, "hfov_deg"),
        ({"hfov_deg": "-5"}, "hfov_deg"),
        ({"hfov_deg": "1e9"}, "hfov_deg"),
        ({"load_cell_newtons_per_count": "0.02", "load_cell_zero": "inf"}, "load_cell_zero"),
        ({"load_cell_newtons_per_count": "nan"}, "load_cell_newtons_per_count"),
        ({"load_cell_newtons_per_count": "0.02", "load_cell_board": "x"}, "load_cell_board"),
        ({"thermometer_celsius_per_count": "0.1", "thermometer_offset": "-inf"}, "thermometer_offset"),
        ({"conn_type": "usb"}, "conn_type"),
    ],
)
def test_calibration_outside_physical_values_is_refused_naming_its_range(options, named):
    with pytest.raises(ValueError, match=named):
        driver_options(options)


@pytest.mark.parametrize("hfov", [math.nan, 0.0, -5.0, 1e9, math.inf])
def test_the_driver_itself_refuses_a_field_of_view_it_cannot_have(hfov):
    with pytest.raises(ValueError, match="hfov_deg"):
        RoboMasterDriver(FakeEP(), hfov_deg=hfov)
    with pytest.raises(ValueError, match="load_cell_zero"):
        LoadCell(0.02, zero_adc=math.inf)
