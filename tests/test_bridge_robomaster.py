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


class _Chassis:
    def __init__(self) -> None:
        self.speeds: list[dict[str, Any]] = []

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


class _Subscriptions:
    def __init__(self) -> None:
        self.callbacks: dict[str, Any] = {}

    def _sub(self, what: str, freq: int, callback: Any) -> bool:
        assert freq in (1, 5, 10, 20, 50)
        self.callbacks[what] = callback
        return True


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


def test_the_ep_over_the_bridge_in_the_sdks_units():
    ep = FakeEP()
    cell = LoadCell.calibrate(zero_adc=500, loaded_adc=600, mass_kg=0.2)  # 0.2 kg lifts the ADC by 100
    driver = _driver(ep, load_cell=cell)
    limits = Limits(max_accel=1000.0, max_turn_accel=1000.0, watchdog_s=5.0)
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

            world.set_arm(0.05, 0.12)
            assert ep.robotic_arm.moves[-1] == pytest.approx((120.0, 50.0))  # x forward, y up, mm

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
            assert ep.robotic_arm.moves[-1] == pytest.approx((120.0, 50.0))
    finally:
        server.close()
        thread.join(timeout=10)
        driver.close()
    assert ep.closed and ep.camera.streaming is None and not ep.sensor.callbacks


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
