"""Sensor plug-ins: what a robot can be given (`--sensors`, `Robot(sensors=[...])`), as registered records.

A `Sensor` says what it is called (its name and the paper-style names it answers to: "distance sensor",
"force/torque sensor") and what it settles: one `Sense` per quantity it measures (the force sensor settles
weight and, weighing a container, fullness). A sense is the one record of everything attribot knows of a
quantity:

- what a reading is (its unit, how many readings one measurement combines, the least uncertainty it
  claims) and what it needs (nothing, the camera centred on the object, the robot next to it, the object in
  the gripper);
- the Robot method a program calls (`robot.measure_temperature(patch)`), documented by `doc`; the prompt
  shows the method only when the robot has the sensor;
- the words people say it with, read by every planner and backend through `attribot.lexicon`: adjectives
  each way ("hot", "hotter", "hottest"), the states they name with their thresholds ("hot" is 40 °C or
  more), the nouns of the quantity ("the temperature of the mug"), why the camera cannot settle it, and
  how a caption says a robot is taking it.

Each world registers how it reads a sensor (`register_reading(sensor, world, read)`): it then offers the
sensor (`Embodiment.sensors()`) and reads it (`Embodiment.read_sensor(name)`); the camera, the rangefinder
and the force sensor are read through the world's own calls, named by `capability`. The bridge carries the
names in the robot's hello and each reading with the `read` request.

A lab adds its own sensor with one `register_sensor(Sensor(...))` and one `register_reading(...)` per world;
nothing else changes. This is the bottom layer: it imports nothing of attribot above the registry.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from attribot.errors import BadPlugin, InputError
from attribot.registry import Registry

__all__ = [
    "GRAVITY",
    "Need",
    "State",
    "Sense",
    "Sensor",
    "SENSORS",
    "SENSOR_BUNDLES",
    "register_sensor",
    "register_reading",
    "reading_in",
    "sensors_read_in",
    "sensor_names",
    "check_sensors",
    "senses",
    "sense_of",
    "sense_of_method",
    "sensor_method_doc",
    "program_steps",
    "vocabulary",
    "ABSOLUTE",
    "COMPARATIVE",
    "SUPERLATIVE",
]


ABSOLUTE, COMPARATIVE, SUPERLATIVE = "absolute", "comparative", "superlative"
"""The forms of a sense's words ("hot", "hotter", "hottest"), as `Sense.words` names them."""

GRAVITY = 9.81
"""m/s^2, as MuJoCo's default gravity: what turns a force sensor's newtons into the kilograms of a weight."""


class Need(StrEnum):
    """What a reading needs before it can be taken."""

    NOTHING = "nothing"  # reads whenever it is asked
    AIM = "aim"  # the camera centred on the object (robot.focus_on_patch): a rangefinder, a thermometer
    REACH = "reach"  # the robot next to the object (robot.go_to_object): a contact probe
    GRASP = "grasp"  # the object in the gripper (robot.pick_up): a load cell, a squeeze


_COMPARISONS: dict[str, Callable[[float, float], bool]] = {
    ">=": operator.ge,
    ">": operator.gt,
    "<=": operator.le,
    "<": operator.lt,
}


@dataclass(frozen=True)
class State:
    """What a state word means: a value (in the sense's unit) is in the state `word` when it passes
    `comparison` against `threshold` ("hot": >= 40.0 °C)."""

    word: str
    threshold: float
    comparison: str

    def __post_init__(self) -> None:
        if self.comparison not in _COMPARISONS or not isinstance(self.word, str) or not _key(self.word):
            raise BadPlugin(
                f"state {self.word!r}: a word and one of {', '.join(_COMPARISONS)}",
                "e.g. State('hot', 40.0, '>=')",
            )

    def holds(self, value: float) -> bool:
        """Whether `value` is in this state."""
        return bool(_COMPARISONS[self.comparison](value, self.threshold))


@dataclass(frozen=True)
class Sense:
    """One quantity a sensor settles, and how people speak of it (see the module docstring).

    quantity and unit: what a reading is ("temperature", "°C"); method: the Robot method a program calls
    (default `measure_<quantity>`); needs: what a reading needs; doc: that method's docstring, written for
    the LLM, with its preconditions and a `>>> def execute_command(image, robot):` example (empty: one is
    written from the fields); readings: how many readings one measurement combines (with `remeasure`);
    resolution and relative: the least uncertainty a measurement claims, in `unit` and as a share of the
    value.

    The words: more and less, the adjectives asking for more or less of it, each "absolute/comparative/
    superlative" ("hot/hotter/hottest"; a form may be left empty, "/closer/closest"; one word alone is an
    absolute only, "chilled"); states, what its absolute words mean as thresholds; grades, the state words a
    value is named by on its own, tried in order (ungraded: the word when none holds, "room"); nouns, the
    quantity's nouns ("temperature"); why, why the camera cannot settle it; doing, what a caption says a
    robot measuring it is doing, before the object's name. digits, scale and suffix: how a value is shown
    (`show`).

    How a planner ranks and says it: most, the end its choices lead with, "the most" of a ranking (True:
    more of it, the heaviest; False: less, the nearest: distances rank from the robot out); written, the
    words a program says it with (more and less as comparatives, then as superlatives: `comparative`,
    `superlative`; empty: the first of each that `more` and `less` list).
    """

    quantity: str
    unit: str
    method: str = ""
    needs: Need = Need.NOTHING
    doc: str = ""
    readings: int = 5
    resolution: float = 0.0
    relative: float = 0.0
    more: tuple[str, ...] = ()
    less: tuple[str, ...] = ()
    states: tuple[State, ...] = ()
    grades: tuple[str, ...] = ()
    ungraded: str = ""
    nouns: tuple[str, ...] = ()
    why: str = ""
    doing: str = ""
    digits: int = 3
    scale: float = 1.0
    suffix: str | None = None  # None: a space and the unit
    most: bool = True
    written: tuple[str, ...] = ()
    words: dict[str, tuple[bool, str]] = field(init=False, repr=False, compare=False, hash=False)

    def __post_init__(self) -> None:
        if not isinstance(self.quantity, str) or not _key(self.quantity) or not isinstance(self.unit, str):
            raise BadPlugin(
                f"a sense needs a quantity and a unit, got {self.quantity!r} in {self.unit!r}",
                "e.g. Sense(quantity='sugar content', unit='°Bx')",
            )
        if not self.method:
            object.__setattr__(self, "method", "measure_" + "_".join(_key(self.quantity).split()))
        if not isinstance(self.method, str) or not self.method.isidentifier() or self.method.startswith("_"):
            raise BadPlugin(
                f"sense {self.quantity!r}: {self.method!r} cannot be a method's name (a program may call no "
                "name that starts with _)",
                "name its method in lower-case words joined by _, e.g. method='measure_sugar'",
            )
        if self.readings < 1 or not self.resolution >= 0 or not 0 <= self.relative < 1 or self.digits < 0:
            raise BadPlugin(
                f"sense {self.quantity!r}: readings >= 1, resolution >= 0, 0 <= relative < 1, digits >= 0",
                "give readings, resolution, relative and digits within those bounds",
            )
        for group in ("more", "less", "nouns", "grades"):
            value = getattr(self, group)
            if not isinstance(value, tuple) or not all(isinstance(w, str) and w.strip() for w in value):
                raise BadPlugin(
                    f"sense {self.quantity!r}: {group} must be a tuple of words",
                    "e.g. more=('hot/hotter/hottest',)",
                )
        states = {s.word for s in self.states if isinstance(s, State)}
        if len(states) != len(self.states) or not set(self.grades) <= states:
            raise BadPlugin(
                f"sense {self.quantity!r}: states must be State records with distinct words, and grades "
                "words among them",
                "e.g. states=(State('hot', 40.0, '>='),), grades=('hot',)",
            )
        words = {**_degrees(self.more, True), **_degrees(self.less, False)}
        if not states <= {w for w, (_, form) in words.items() if form == "absolute"}:
            raise BadPlugin(
                f"sense {self.quantity!r}: a state is said with one of its absolute words (more or less)",
                "add the state's word to more or less",
            )
        if self.written and (
            len(self.written) != 4
            or [words.get(w) for w in self.written]
            != [(True, "comparative"), (False, "comparative"), (True, "superlative"), (False, "superlative")]
        ):
            raise BadPlugin(
                f"sense {self.quantity!r}: written is its comparatives for more and less, then its "
                "superlatives, each one of its words",
                "e.g. written=('hotter', 'colder', 'hottest', 'coldest'), or leave it out",
            )
        object.__setattr__(self, "words", words)

    def comparative(self, more: bool) -> str:
        """The comparative a program says asking for more (or less) of it: "heavier", "closer"; empty when
        the sense has none."""
        return self._said(more, 1)

    def superlative(self, more: bool) -> str:
        """The superlative a program says asking for more (or less) of it: "heaviest", "nearest"; empty when
        the sense has none."""
        return self._said(more, 2)

    def _said(self, more: bool, place: int) -> str:
        if self.written:
            return self.written[(0 if more else 1) + 2 * (place - 1)]
        for entry in self.more if more else self.less:
            forms = [" ".join(f.split()) for f in entry.lower().split("/")]
            if len(forms) == 3 and forms[place]:
                return forms[place]
        return ""

    def state(self, word: str) -> State | None:
        """The state `word` names, or None."""
        return next((s for s in self.states if s.word == word), None)

    def grade(self, value: float) -> str:
        """The word for `value` on its own: the first of `grades` whose state holds, else `ungraded`."""
        for word in self.grades:
            state = self.state(word)
            if state is not None and state.holds(value):
                return word
        return self.ungraded

    def show(self, value: float) -> str:
        """`value` as a person reads it: "84.6 °C", "0.25 N/mm", "95% full"."""
        suffix = f" {self.unit}" if self.suffix is None else self.suffix
        return f"{self.scale * value:.{self.digits}f}{suffix}"


def _degrees(entries: tuple[str, ...], more: bool) -> dict[str, tuple[bool, str]]:
    """The words of `entries` ("hot/hotter/hottest", "chilled") with (asks for more, form); an adjective
    with all three forms also takes "more", "most", "less" and "least" ("the least hot" is the coldest)."""
    out: dict[str, tuple[bool, str]] = {}
    for entry in entries:
        forms = [" ".join(f.split()) for f in entry.lower().split("/")]
        if len(forms) not in (1, 3):
            raise BadPlugin(
                f"{entry!r}: one word, or its three forms 'absolute/comparative/superlative'",
                "e.g. 'hot/hotter/hottest', '/closer/closest' or 'chilled'",
            )
        for word, form in zip(forms, ("absolute", "comparative", "superlative"), strict=False):
            if word:
                out[word] = (more, form)
        absolute = forms[0]
        if len(forms) == 3 and absolute:
            for modifier, form, way in (
                ("more", "comparative", more),
                ("most", "superlative", more),
                ("less", "comparative", not more),
                ("least", "superlative", not more),
            ):
                out.setdefault(f"{modifier} {absolute}", (way, form))
    return out


@dataclass(frozen=True)
class Sensor:
    """One kind of sensor a robot may carry (see the module docstring).

    name: what `--sensors` takes; measures: one line for the prompt ("an infrared thermometer ...");
    aliases: other names it answers to; senses: the quantities it settles; capability: the
    `attribot.embodiments.base.Capability` of a world that reads it through its own call (the API defines
    its senses' methods itself), None: through `read_sensor(name)` and a registered reading.
    """

    name: str
    measures: str
    aliases: tuple[str, ...] = ()
    senses: tuple[Sense, ...] = ()
    capability: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name or self.name != _key(self.name):
            raise BadPlugin(
                f"a sensor's name is lower-case words, got {self.name!r}", "e.g. name='spectrometer'"
            )
        if not isinstance(self.aliases, tuple) or not all(
            isinstance(a, str) and _key(a) for a in self.aliases
        ):
            raise BadPlugin(
                f"sensor {self.name!r}: aliases must be a tuple of names", "e.g. aliases=('brix meter',)"
            )
        if not isinstance(self.senses, tuple) or not all(isinstance(s, Sense) for s in self.senses):
            raise BadPlugin(
                f"sensor {self.name!r}: senses must be a tuple of Sense records",
                "e.g. senses=(Sense(quantity='sugar content', unit='°Bx', needs=Need.AIM),)",
            )


SENSORS: Registry[Sensor] = Registry("sensor", ("attribot.sensors.builtin",))
"""Every sensor a robot can be given, under its name (and its aliases)."""

SENSOR_BUNDLES: dict[str, tuple[str, ...]] = {
    # a depth camera sees and measures how far what it sees is: both our camera and rangefinder
    **dict.fromkeys(("depth camera", "rgb-d camera", "rgbd camera", "rgb d camera"), ("camera", "distance")),
}
"""Names that stand for several sensors at once."""


def register_sensor(sensor: Sensor) -> Sensor:
    """Add `sensor` under its name and aliases (a name used twice is an error, and so is a quantity or a
    method another sensor's sense has)."""
    aliases = tuple(dict.fromkeys(_key(a) for a in sensor.aliases if _key(a) != sensor.name))
    taken = [n for n in (sensor.name, *aliases) if n in SENSOR_BUNDLES]
    if (
        taken
    ):  # "depth camera" stands for the camera and the rangefinder: a sensor of that name is unreachable
        raise BadPlugin(
            f"sensor {sensor.name!r}: {', '.join(map(repr, taken))} names several built-in sensors at once",
            "give the sensor another name",
        )
    mine = [(s.quantity, s.method) for s in sensor.senses]
    words = {w: s.quantity for s in sensor.senses for w in s.words}
    for other, sense in senses():
        if other.name == sensor.name:
            continue
        clash = [x for pair in mine for x in pair if x in (sense.quantity, sense.method)]
        if clash:
            raise BadPlugin(
                f"sensor {sensor.name!r}: the {other.name} sensor settles {clash[0]!r} already",
                "name the sense's quantity and method otherwise",
            )
        said = sorted(set(words) & set(sense.words))
        if said:  # one word, two meanings: a question would be read as the first sense's
            raise BadPlugin(
                f"sensor {sensor.name!r}: {', '.join(map(repr, said[:3]))} already says the "
                f"{sense.quantity} of the {other.name} sensor",
                f"give the {words[said[0]]} sense other words",
            )
    if len({q for q, _ in mine}) < len(mine) or len({m for _, m in mine}) < len(mine):
        raise BadPlugin(
            f"sensor {sensor.name!r}: two of its senses share a quantity or a method", "name each one apart"
        )
    return SENSORS.register(sensor.name, aliases=aliases)(sensor)


_READINGS: dict[str, dict[str, Callable[[Any], float]]] = {}
"""How each world reads each sensor: sensor name -> world name -> read(world)."""


def register_reading(sensor: str, world: str, read: Callable[[Any], float]) -> None:
    """Say how the world `world` (an `Embodiment.name`: "mujoco") reads `sensor`: `read(embodiment)` returns
    one reading in the sense's unit (NaN: nothing read). The world then offers the sensor. Registering a
    world's reading of a sensor twice replaces it."""
    if sensor not in SENSORS or not callable(read) or not isinstance(world, str) or not world:
        raise BadPlugin(
            f"a reading of {sensor!r} in {world!r}: the sensor must be registered first, and read callable",
            f"register_sensor(Sensor(name={sensor!r}, ...)) before register_reading; registered: "
            + ", ".join(sensor_names()),
        )
    _READINGS.setdefault(SENSORS.get(sensor).name, {})[world] = read


def reading_in(world: str, sensor: str) -> Callable[[Any], float] | None:
    """How `world` reads `sensor` (a registered sensor's name), or None."""
    if sensor not in SENSORS:
        return None
    return _READINGS.get(SENSORS.get(sensor).name, {}).get(world)


def sensors_read_in(world: str) -> frozenset[str]:
    """The registered sensors `world` has a reading of."""
    return frozenset(name for name, by_world in _READINGS.items() if world in by_world and name in SENSORS)


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


def senses() -> list[tuple[Sensor, Sense]]:
    """Every registered sense with its sensor, in the registry's order."""
    return [(sensor, sense) for _, sensor in SENSORS.items() for sense in sensor.senses]


def sense_of(quantity: str) -> tuple[Sensor, Sense] | None:
    """The sense of `quantity` ("temperature") with its sensor, or None."""
    return next(((s, q) for s, q in senses() if q.quantity == quantity), None)


def sense_of_method(method: str) -> tuple[Sensor, Sense] | None:
    """The sense whose Robot method is `method`, with its sensor, or None."""
    return next(((s, q) for s, q in senses() if q.method == method), None)


_PRECONDITION = {
    Need.NOTHING: "",
    Need.AIM: "The reading is of whatever the camera is centred on: call robot.focus_on_patch(patch) first "
    "(again after the robot has moved).",
    Need.REACH: "The robot must stand next to the object: call robot.go_to_object(patch) first.",
    Need.GRASP: "The object must be held: call robot.go_to_object(patch) and robot.pick_up(patch) first, "
    "and robot.put_down() afterwards.",
}
_STEPS = {
    Need.NOTHING: (),
    Need.AIM: ("robot.focus_on_patch({})",),
    Need.REACH: ("robot.go_to_object({})",),
    Need.GRASP: ("robot.go_to_object({})", "robot.pick_up({})"),
}


def program_steps(needs: Need, patch: str) -> tuple[list[str], list[str]]:
    """The lines a program writes around a reading that `needs` it, on the patch named `patch`: before it
    (turning to the object, going to it, picking it up) and after it (putting it down)."""
    after = ["robot.put_down()"] if needs is Need.GRASP else []
    return [step.format(patch) for step in _STEPS[needs]], after


def sensor_method_doc(sensor: Sensor, sense: Sense) -> str:
    """The docstring of a sense's Robot method: its own `doc`, else one written from its fields (what it
    returns, what the reading needs, an example program)."""
    if sense.doc:
        return sense.doc
    before, after = program_steps(sense.needs, "patch")
    lines = [
        f"Returns the {sense.quantity} of the object in `patch`, in {sense.unit}, read with the "
        f"{sensor.name} sensor. {_PRECONDITION[sense.needs]}".rstrip(),
        "",
        f">>> # the object with the highest {sense.quantity}",
        ">>> def execute_command(image, robot):",
        ">>>     best, best_value = None, 0.0",
        '>>>     for patch in image.find("object"):',
        *(f">>>         {step}" for step in before),
        f">>>         value = robot.{sense.method}(patch)",
        *(f">>>         {step}" for step in after),
    ]
    lines += [
        ">>>         if best is None or value > best_value:",
        ">>>             best, best_value = patch, value",
        ">>>     return best",
    ]
    return "\n".join(lines)


@functools.lru_cache(maxsize=8)
def _vocabulary(all_senses: tuple[Sense, ...]) -> tuple[dict[str, tuple[str, bool, str]], dict[str, State]]:
    words: dict[str, tuple[str, bool, str]] = {}
    states: dict[str, State] = {}
    for sense in all_senses:
        for word, (more, form) in sense.words.items():
            words.setdefault(word, (sense.quantity, more, form))
        for state in sense.states:
            states.setdefault(state.word, state)
    return words, states


def vocabulary() -> tuple[dict[str, tuple[str, bool, str]], dict[str, State]]:
    """Every registered sense's words, word -> (quantity, asks for more, form), and its state words, word
    -> `State`; the first sense to register a word keeps it. Read through `attribot.lexicon`."""
    return _vocabulary(tuple(sense for _, sense in senses()))
