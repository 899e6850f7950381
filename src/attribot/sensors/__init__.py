"""Sensor plug-ins: what a robot can be given (`--sensors`, `Robot(sensors=[...])`), as registered records.

A `Sensor` says what it is called (its name and the paper-style names it answers to: "distance sensor",
"force/torque sensor"), what it measures and in what unit, what a reading needs (nothing, the camera centred
on the object, the robot next to it, the object in the gripper) and how the layers above reach it:

- a world offers it in `Embodiment.sensors()` and reads it with `Embodiment.read_sensor(name)` (the camera,
  the rangefinder and the force sensor keep their own calls, named by `capability`);
- the bridge carries the names in the robot's hello and each reading with the `read` request;
- the API gives a program the sensor's `method` (e.g. `robot.measure_temperature(patch)`), documented by
  `doc`, checking what the reading needs before it reads; the prompt shows the method only when the robot
  has the sensor.

A lab adds its own sensor with one `register_sensor(Sensor(...))` and a world that reads it; nothing else
changes. This is the bottom layer: it imports nothing of attribot above the registry.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

from attribot.errors import BadPlugin, InputError
from attribot.registry import Registry

__all__ = [
    "Need",
    "Sensor",
    "SENSORS",
    "SENSOR_BUNDLES",
    "register_sensor",
    "sensor_names",
    "check_sensors",
    "sensor_of_method",
    "sensor_method_doc",
]


class Need(StrEnum):
    """What a reading needs before it can be taken."""

    NOTHING = "nothing"  # reads whenever it is asked
    AIM = "aim"  # the camera centred on the object (robot.focus_on_patch): a rangefinder, a thermometer
    REACH = "reach"  # the robot next to the object (robot.go_to_object): a contact probe
    GRASP = "grasp"  # the object in the gripper (robot.pick_up): a load cell, a squeeze


@dataclass(frozen=True)
class Sensor:
    """One kind of sensor a robot may carry (see the module docstring).

    name: what `--sensors` takes; measures: one line for the prompt ("an infrared thermometer ..."); quantity
    and unit: what a reading is ("temperature", "°C"); aliases: other names it answers to; needs: what a
    reading needs; method: the Robot method a program calls (None: the API defines its own methods for it,
    as for the camera, distance and force); doc: that method's docstring, written for the LLM, with its
    preconditions and a `>>> def execute_command(image, robot):` example (empty: one is written from the
    fields); readings: how many readings one measurement combines (with `remeasure`); resolution and
    relative: the least uncertainty a measurement claims, in `unit` and as a share of the value;
    capability: the `attribot.embodiments.base.Capability` of a world that reads it through its own call
    (None: through `read_sensor(name)`).
    """

    name: str
    measures: str
    quantity: str
    unit: str
    aliases: tuple[str, ...] = ()
    needs: Need = Need.NOTHING
    method: str | None = None
    doc: str = ""
    readings: int = 5
    resolution: float = 0.0
    relative: float = 0.0
    capability: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name or self.name != _key(self.name):
            raise BadPlugin(
                f"a sensor's name is lower-case words, got {self.name!r}", "e.g. name='spectrometer'"
            )
        if self.method is not None and (
            not isinstance(self.method, str) or not self.method.isidentifier() or self.method.startswith("_")
        ):
            raise BadPlugin(
                f"sensor {self.name!r}: {self.method!r} cannot be a method's name (a program may call no "
                "name that starts with _)",
                "name its method in lower-case words joined by _, e.g. method='measure_sugar'",
            )
        if not isinstance(self.aliases, tuple) or not all(
            isinstance(a, str) and _key(a) for a in self.aliases
        ):
            raise BadPlugin(
                f"sensor {self.name!r}: aliases must be a tuple of names", "e.g. aliases=('brix meter',)"
            )
        if self.readings < 1 or not self.resolution >= 0 or not 0 <= self.relative < 1:
            raise BadPlugin(
                f"sensor {self.name!r}: readings >= 1, resolution >= 0, 0 <= relative < 1",
                "give readings, resolution and relative within those bounds",
            )


SENSORS: Registry[Sensor] = Registry("sensor", ("attribot.sensors.builtin",))
"""Every sensor a robot can be given, under its name (and its aliases)."""

SENSOR_BUNDLES: dict[str, tuple[str, ...]] = {
    # a depth camera sees and measures how far what it sees is: both our camera and rangefinder
    **dict.fromkeys(("depth camera", "rgb-d camera", "rgbd camera", "rgb d camera"), ("camera", "distance")),
}
"""Names that stand for several sensors at once."""


def register_sensor(sensor: Sensor) -> Sensor:
    """Add `sensor` under its name and aliases (a name used twice is an error)."""
    aliases = tuple(dict.fromkeys(_key(a) for a in sensor.aliases if _key(a) != sensor.name))
    taken = [n for n in (sensor.name, *aliases) if n in SENSOR_BUNDLES]
    if (
        taken
    ):  # "depth camera" stands for the camera and the rangefinder: a sensor of that name is unreachable
        raise BadPlugin(
            f"sensor {sensor.name!r}: {', '.join(map(repr, taken))} names several built-in sensors at once",
            "give the sensor another name",
        )
    return SENSORS.register(sensor.name, aliases=aliases)(sensor)


def sensor_names() -> list[str]:
    """The registered sensors' names, in registration order (camera first)."""
    return SENSORS.names()


def _key(name: str) -> str:
    return " ".join(name.strip().lower().replace("_", " ").split())


def check_sensors(sensors: Sequence[str]) -> list[str]:
    """Sensor names as registered: lower-cased, aliases resolved, deduplicated, "camera" first (every robot
    sees through its camera: the image is the program's input); an unknown name raises `InputError`."""
    if not isinstance(sensors, list | tuple) or not all(isinstance(s, str) for s in sensors):
        raise InputError(
            f"sensors must be a list of names, got {sensors!r}",
            f"e.g. Robot(sensors=['camera', 'distance']); known: {', '.join(sensor_names())}",
        )
    out: list[str] = []
    for given in sensors:
        name = _key(given)
        if name in SENSOR_BUNDLES:
            found = list(SENSOR_BUNDLES[name])
        elif name in SENSORS:
            found = [SENSORS.get(name).name]
        else:
            raise InputError(
                f"unknown sensor {given!r}: this robot has no such sensor",
                f"choose from: {', '.join(sensor_names())} (e.g. --sensors camera,distance); the paper's "
                "names work too: 'distance sensor', 'force/torque sensor', 'depth camera'",
            )
        out += [s for s in found if s not in out]
    if "camera" not in out:
        out.insert(0, "camera")
    return out


def sensor_of_method(method: str) -> Sensor | None:
    """The registered sensor whose Robot method is `method`, or None."""
    return next((s for _, s in SENSORS.items() if s.method == method), None)


_PRECONDITION = {
    Need.NOTHING: "",
    Need.AIM: "The reading is of whatever the camera is centred on: call robot.focus_on_patch(patch) first "
    "(again after the robot has moved).",
    Need.REACH: "The robot must stand next to the object: call robot.go_to_object(patch) first.",
    Need.GRASP: "The object must be held: call robot.go_to_object(patch) and robot.pick_up(patch) first, "
    "and robot.put_down() afterwards.",
}
_STEPS = {
    Need.NOTHING: [],
    Need.AIM: ["robot.focus_on_patch(patch)"],
    Need.REACH: ["robot.go_to_object(patch)"],
    Need.GRASP: ["robot.go_to_object(patch)", "robot.pick_up(patch)"],
}


def sensor_method_doc(sensor: Sensor) -> str:
    """The docstring of a sensor's Robot method: its own `doc`, else one written from its fields (what it
    returns, what the reading needs, an example program)."""
    if sensor.doc:
        return sensor.doc
    method = sensor.method or f"measure_{sensor.quantity.replace(' ', '_')}"
    lines = [
        f"Returns the {sensor.quantity} of the object in `patch`, in {sensor.unit}, read with the "
        f"{sensor.name} sensor. {_PRECONDITION[sensor.needs]}".rstrip(),
        "",
        f">>> # the object with the highest {sensor.quantity}",
        ">>> def execute_command(image, robot):",
        ">>>     best, best_value = None, 0.0",
        '>>>     for patch in image.find("object"):',
        *(f">>>         {step}" for step in _STEPS[sensor.needs]),
        f">>>         value = robot.{method}(patch)",
    ]
    if sensor.needs is Need.GRASP:
        lines.append(">>>         robot.put_down()")
    lines += [
        ">>>         if best is None or value > best_value:",
        ">>>             best, best_value = patch, value",
        ">>>     return best",
    ]
    return "\n".join(lines)
