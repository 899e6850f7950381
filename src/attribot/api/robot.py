"""`Robot`: the action half of the API that programs see (after the paper's Robot class).

The robot's sensors are chosen by the user (`--sensors camera,distance,force`); a method that needs a
sensor the robot was not given refuses and names it. Actions go to a `attribot.control.base.Controller`
bound to the world; what the world cannot do raises "not available in this world", never a fake value.

`Robot` is a facade: it holds the methods and docstrings a program reads (the prompt renders the
docstrings of the names in `API_METHODS`) and the host methods the session calls, and hands every call to
its `attribot.skills.robot_session.RobotSession`, which owns the state, the statistics and the error-catching
mechanisms. A program's `Robot(sensors=[...])` is another facade over the same session.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, ClassVar, cast

from attribot.api.patch import ImagePatch
from attribot.control.base import Capture, Controller
from attribot.embodiments.base import Embodiment
from attribot.errors import ConfigError
from attribot.sensors import Sense, Sensor, check_sensors, senses, sensor_method_doc, sensor_names
from attribot.skills.checks import check_facade
from attribot.skills.errors import MissingSensor
from attribot.skills.perception import Perception
from attribot.skills.robot_core import GRAVITY, OWN_REQUIRES, Measurement, object_name, required_sensors
from attribot.skills.robot_session import RobotSession
from attribot.skills.safeguards import Safeguards
from attribot.skills.sighting import Sighting

__all__ = ["Robot", "Measurement", "GRAVITY", "check_sensors", "sensor_names", "object_name"]


class _RobotApi(type):
    """The metaclass of `Robot`: a program's Robot methods are its own (`OWN_METHODS`, which include the
    senses of the camera's, the rangefinder's and the force sensor's records) and one per registered sense
    read through `read_sensor` (`attribot.sensors.Sense.method`), read from the registry whenever they are
    asked for, so that a sensor registered later (a lab's own) is offered like the built-in ones."""

    def __init__(cls, name: str, bases: tuple[type, ...], namespace: dict[str, Any]) -> None:
        super().__init__(name, bases, namespace)
        check_facade(cls, namespace)

    @property
    def API_METHODS(cls) -> tuple[str, ...]:
        """The methods a program may call, in the prompt's order: the sensors' methods after the
        measurements of the robot's own."""
        own = Robot.OWN_METHODS
        at = own.index("uncertainty")
        return (*own[:at], *_install_sensor_methods(), *own[at:])

    @property
    def PROGRAM_FUNCTIONS(cls) -> tuple[str, ...]:
        """The methods a program may also call as bare functions (`go_to_object("book")`) and on a patch
        (`book_patch.measure_weight("book")`), as the paper authors' prompt writes them: all of them, bound
        to the program's one Robot (`attribot.runner` offers them on the program's side)."""
        return cls.API_METHODS

    @property
    def REQUIRES(cls) -> dict[str, str]:
        """The sensor each method needs (methods not listed need none); the prompt offers a method only
        when the robot has its sensor."""
        _install_sensor_methods()
        return required_sensors()


class Robot(metaclass=_RobotApi):
    """The robot that carries the camera. It can move, act on objects, and measure what a camera cannot
    see. Its methods take ImagePatch objects returned by image.find(...).
    """

    API_KIND: ClassVar[str] = "action"  # what a failing call of this class counts as
    API_ATTRIBUTES: ClassVar[tuple[str, ...]] = ("sensors",)
    OWN_METHODS: ClassVar[tuple[str, ...]] = (
        "focus_on_patch",
        "measure_distance",
        "measure_weight",
        "measure_fullness",
        "uncertainty",
        "go_to_coords",
        "go_to_object",
        "pick_up",
        "put_down",
        "put_on",
        "push",
    )
    """The methods the class defines itself; `API_METHODS` adds the sensors' (see `_RobotApi`)."""
    OWN_REQUIRES: ClassVar[dict[str, str]] = OWN_REQUIRES
    """The sensor each of its own methods needs beyond the senses' (each sense's method needs its sensor)."""
    HOST_ATTRIBUTES: ClassVar[tuple[str, ...]] = (
        "world",
        "controller",
        "held",
        "measurements",
        "capture",
        "activity",
        "acting_on",
        "acting_on_id",
        "safeguards",
    )
    HOST_METHODS: ClassVar[tuple[str, ...]] = (
        "look",
        "backend_name",
        "from_program",
        "called_on",
        "settle",
        "as_named",
        "snapshot",
        "restore",
        "take_notes",
    )
    PROGRAM_CONSTRUCTOR: ClassVar[str] = "from_program"
    """What `Robot(...)` in a program calls on the session's robot (the paper's dialect)."""
    PROGRAM_FUNCTIONS_ON: ClassVar[tuple[str, ...]] = ("ImagePatch",)
    """The class whose objects take the robot's methods too (`PROGRAM_FUNCTIONS`): `patch.pick_up()`."""
    PROGRAM_CALLED_ON: ClassVar[str] = "called_on"
    """The host method the runner tells which patch such a call was made on."""
    PROGRAM_NOTES: ClassVar[str] = "take_notes"
    """The host method the runner asks, after a call, what the robot did beyond it, for the trace."""

    def __init__(
        self,
        sensors: Sequence[str] = ("camera",),
        world: Embodiment | None = None,
        controller: Controller | None = None,
        safeguards: Safeguards | None = None,
    ) -> None:
        """Host side: a robot with `sensors` in `world` (None: a still image, every action refused), acting
        through `controller` (default: the one registered for the world, see attribot.control.base), with
        the error-catching mechanisms of `safeguards` (default: all on)."""
        _install_sensor_methods()  # the methods of sensors registered since the class was last asked
        self._session = RobotSession(sensors, world, controller, safeguards, patch_type=ImagePatch)
        self._view: list[str] | None = None  # a program's Robot(sensors=...): the sensors it sees

    @classmethod
    def _seen_through(cls, session: RobotSession, sensors: list[str]) -> Robot:
        """Another facade over `session` that sees only `sensors` and arranges what a call needs first."""
        view = cls.__new__(cls)
        view._session, view._view = session, sensors
        return view

    def _do(self, method: str, *args: Any) -> Any:
        """`method` of the session, done as this facade sees the robot: with its sensors, and arranging what
        the call needs first when it is a program's `Robot(sensors=...)` (as the paper's robot did)."""
        session = self._session
        if self._view is None:
            return getattr(session, method)(*args)
        given, arranging = session._sensors, session.arranging
        session._sensors, session.arranging = self._view, True
        try:
            return getattr(session, method)(*args)
        finally:
            session._sensors, session.arranging = given, arranging

    @property
    def sensors(self) -> list[str]:
        """the robot's sensors, e.g. ["camera", "distance", "force"]"""
        return list(self._view if self._view is not None else self._session.sensors)

    # ---- host side: what the session reads and calls ------------------------------------------------
    @property
    def world(self) -> Embodiment | None:
        return self._session.world

    @property
    def controller(self) -> Controller:
        return self._session.controller

    @property
    def held(self) -> Sighting | None:
        return self._session.held

    @property
    def measurements(self) -> list[Measurement]:
        return self._session.measurements

    @property
    def capture(self) -> Capture | None:
        return self._session.capture

    @property
    def activity(self) -> str:
        return self._session.activity

    @property
    def acting_on(self) -> str:
        return self._session.acting_on

    @property
    def acting_on_id(self) -> str | None:
        return self._session.acting_on_id

    @property
    def safeguards(self) -> Safeguards:
        return self._session.safeguards

    def look(self, perception: Perception, survey: bool = True) -> ImagePatch:
        """Host side: take a camera frame now and return its whole-image patch (`RobotSession.look`)."""
        return cast(
            ImagePatch, self._session.look(perception, survey)
        )  # the session's patches are ImagePatch

    def settle(self, chosen: ImagePatch) -> str | None:
        """Host side, after a program chose `chosen`: measure again where the choice is not yet settled
        (`RobotSession.settle`); the sentence that says it cannot tell, or None."""
        return self._session.settle(chosen)

    def as_named(self, chosen: ImagePatch) -> tuple[ImagePatch, str] | None:
        """Host side, after a program chose `chosen`: the object the question's names choose where it is
        another (`Measuring.as_named`), with the sentence that says why; or None."""
        return cast(tuple[ImagePatch, str] | None, self._session.as_named(chosen))

    def snapshot(self) -> Any:
        """Host side: the robot's state now, or None where the world cannot put it back."""
        return self._session.snapshot()

    def restore(self, snapshot: Any, image: ImagePatch) -> None:
        """Host side: back to `snapshot` with `image` as the camera's last look (a retry's start)."""
        self._session.restore(snapshot, image)

    def called_on(self, patch: ImagePatch) -> None:
        """Host side: the program called one of this robot's methods on `patch` (`RobotSession.called_on`)."""
        self._session.called_on(patch)

    def take_notes(self) -> str | None:
        """Host side: what the last call did beyond itself ("put it back where it was picked up"), for its
        trace record (`RobotSession.take_notes`)."""
        return self._session.take_notes()

    def backend_name(self) -> str:
        """Host side: the controller's name."""
        return self._session.backend_name()

    def from_program(self, sensors: Sequence[str] | None = None) -> Robot:
        """Host side: `Robot(sensors=[...])` written in a program, as the paper's programs do: this robot,
        seen through only the named sensors (the paper's names are read too: "distance sensor",
        "force/torque sensor", "depth camera"; none named: all of its own). A sensor it was not given is
        refused. The paper's robot did what its methods needed itself (its prompt's programs weigh one
        object after another with no put_down), so this one arranges it: a reading turns to its object,
        goes to it or picks it up first, and a pick-up puts down what the gripper holds."""
        if sensors is None:
            return Robot._seen_through(self._session, self._session.sensors)
        names = check_sensors(sensors)
        missing = [n for n in names if n not in self._session.sensors]
        if missing:
            raise MissingSensor(
                f"Robot(sensors={list(sensors)!r}) asks for the {', '.join(missing)} sensor, and this robot "
                f"has only: {', '.join(self._session.sensors)}",
                f"add it with --sensors {','.join([*self._session.sensors, *missing])}, "
                "or leave it out of Robot(...)",
            )
        return Robot._seen_through(self._session, names)

    # ---- methods (for programs) --------------------------------------------------------------------
    def focus_on_patch(self, patch: ImagePatch) -> None:
        """Turns the camera so that the centre of the image looks at the centre of `patch`.

        >>> # look at the clock
        >>> def execute_command(image, robot):
        >>>     clock = image.find("clock")[0]
        >>>     robot.focus_on_patch(clock)
        >>>     return clock
        """
        return self._do("focus_on_patch", patch)

    def measure_distance(self, patch: ImagePatch) -> float:
        """Returns the distance in metres from the robot's camera to the object in `patch`, measured with the
        distance sensor after focusing the camera on it.

        >>> # which one is closer to me, the chair or the lamp?
        >>> def execute_command(image, robot):
        >>>     chair = image.find("chair")[0]
        >>>     lamp = image.find("lamp")[0]
        >>>     if robot.measure_distance(chair) < robot.measure_distance(lamp):
        >>>         return chair
        >>>     return lamp

        >>> # return the farthest bottle
        >>> def execute_command(image, robot):
        >>>     return max(image.find("bottle"), key=lambda bottle: robot.measure_distance(bottle))
        """
        return self._do("measure_distance", patch)

    def measure_weight(self, patch: ImagePatch) -> float:
        """Returns the mass in kilograms of the object in `patch`, measured with the force sensor in the
        gripper. The object must be held: call robot.go_to_object(patch) and robot.pick_up(patch) first,
        and robot.put_down() afterwards.

        >>> # return the lightest box
        >>> def execute_command(image, robot):
        >>>     lightest = None
        >>>     lightest_kg = 0.0
        >>>     for box in image.find("box"):
        >>>         robot.go_to_object(box)
        >>>         robot.pick_up(box)
        >>>         kg = robot.measure_weight(box)
        >>>         robot.put_down()
        >>>         if lightest is None or kg < lightest_kg:
        >>>             lightest = box
        >>>             lightest_kg = kg
        >>>     return lightest
        """
        return self._do("measure_weight", patch)

    def measure_fullness(self, patch: ImagePatch) -> float:
        """Returns how full the container in `patch` is, from 0 (empty) to 1 (full), found by weighing it with
        the force sensor and taking away the mass of such a container when empty (a bottle, a mug, a jar).
        An empty and a full bottle look the same: only weighing tells. The container must be held: call
        robot.go_to_object(patch) and robot.pick_up(patch) first, and robot.put_down() afterwards.

        >>> # which bottle is empty?
        >>> def execute_command(image, robot):
        >>>     emptiest, emptiest_fill = None, 0.0
        >>>     for bottle in image.find("bottle"):
        >>>         robot.go_to_object(bottle)
        >>>         robot.pick_up(bottle)
        >>>         fill = robot.measure_fullness(bottle)
        >>>         robot.put_down()
        >>>         if emptiest is None or fill < emptiest_fill:
        >>>             emptiest, emptiest_fill = bottle, fill
        >>>     return emptiest
        """
        return self._do("measure_fullness", patch)

    def uncertainty(self, patch: ImagePatch) -> float:
        """Returns the uncertainty (one standard deviation, in the same unit) of the last measurement of the
        object in `patch`. Two measured values whose difference is within twice their uncertainties cannot
        be told apart: measure again, or answer that you cannot tell.

        >>> # the closer of two balls, or "cannot tell" when their distances overlap
        >>> def execute_command(image, robot):
        >>>     first, second = image.find("ball")[:2]
        >>>     d1 = robot.measure_distance(first)
        >>>     d2 = robot.measure_distance(second)
        >>>     if abs(d1 - d2) <= 2 * (robot.uncertainty(first) + robot.uncertainty(second)):
        >>>         return "cannot tell"
        >>>     return first if d1 < d2 else second
        """
        return self._do("uncertainty", patch)

    def go_to_coords(self, x: float, y: float) -> None:
        """Drives the robot towards the point (x, y) of the image (pixels, y growing upward, like the
        patch attributes).

        >>> # drive to the middle of the rug
        >>> def execute_command(image, robot):
        >>>     rug = image.find("rug")[0]
        >>>     robot.go_to_coords(rug.horizontal_center, rug.vertical_center)
        >>>     return rug
        """
        return self._do("go_to_coords", x, y)

    def go_to_object(self, patch: ImagePatch) -> None:
        """Drives the robot next to the object in `patch`, close enough to pick it up.

        >>> # bring the robot to the fridge
        >>> def execute_command(image, robot):
        >>>     fridge = image.find("fridge")[0]
        >>>     robot.go_to_object(fridge)
        >>>     return fridge
        """
        return self._do("go_to_object", patch)

    def pick_up(self, patch: ImagePatch) -> None:
        """Grasps and lifts the object in `patch`. Call robot.go_to_object(patch) first; the gripper must be
        empty.

        >>> # pick up the apple
        >>> def execute_command(image, robot):
        >>>     apple = image.find("apple")[0]
        >>>     robot.go_to_object(apple)
        >>>     robot.pick_up(apple)
        >>>     return apple
        """
        return self._do("pick_up", patch)

    def put_down(self) -> None:
        """Puts the held object back down where it was picked up.

        >>> # lift the melon and put it back
        >>> def execute_command(image, robot):
        >>>     melon = image.find("melon")[0]
        >>>     robot.go_to_object(melon)
        >>>     robot.pick_up(melon)
        >>>     robot.put_down()
        >>>     return melon
        """
        return self._do("put_down")

    def put_on(self, patch: ImagePatch) -> None:
        """Places the held object on top of the object in `patch`; on a table, counter or shelf, at a
        free spot near the robot.

        >>> # put the cup on the tray
        >>> def execute_command(image, robot):
        >>>     cup = image.find("cup")[0]
        >>>     tray = image.find("tray")[0]
        >>>     robot.go_to_object(cup)
        >>>     robot.pick_up(cup)
        >>>     robot.put_on(tray)
        >>>     return tray
        """
        return self._do("put_on", patch)

    def push(self, patch: ImagePatch) -> None:
        """Pushes the object in `patch` away from the robot.

        >>> # push the ball
        >>> def execute_command(image, robot):
        >>>     ball = image.find("ball")[0]
        >>>     robot.push(ball)
        >>>     return ball
        """
        return self._do("push", patch)


def _sensor_method(sensor: Sensor, sense: Sense) -> Callable[..., float]:
    """The Robot method a program calls to read `sense` (`robot.measure_temperature(patch)`), documented by
    the sense's own docstring; what it does is `RobotSession._sense`."""

    def method(self: Robot, patch: ImagePatch) -> float:
        return float(self._do("_sense", sensor, sense, patch))

    method.__name__ = method.__qualname__ = sense.method
    method.__doc__ = sensor_method_doc(sensor, sense)
    method.__annotations__ = {"patch": "ImagePatch", "return": "float"}
    method.sensor_name = sensor.name  # type: ignore[attr-defined]
    method.sense = sense  # type: ignore[attr-defined]
    return method


def _install_sensor_methods() -> list[str]:
    """Give Robot a method for each registered sense read through `read_sensor` (the senses of a sensor
    with a `capability` have Robot's own methods), once; the names, in the registry's order. A sense whose
    method name Robot has already (a method, an attribute) is a `ConfigError`."""
    names = []
    current = {sense.method: sense for sensor, sense in senses() if sensor.capability is None}
    for name, value in list(vars(Robot).items()):  # a sensor taken out of the registry takes its method along
        if getattr(value, "sensor_name", None) is not None and current.get(name) is not value.sense:
            delattr(Robot, name)
    for sensor, sense in senses():
        if sensor.capability is not None:
            continue
        have = Robot.__dict__.get(sense.method)
        # a robot's own attribute (robot.held) or anything the class has by inheritance is taken too
        taken = sense.method in (*Robot.HOST_ATTRIBUTES, *Robot.API_ATTRIBUTES) or (
            have is None and hasattr(Robot, sense.method)
        )
        if have is None and not taken:
            setattr(Robot, sense.method, _sensor_method(sensor, sense))
        elif taken or getattr(have, "sensor_name", None) != sensor.name:
            raise ConfigError(
                f"the {sensor.name} sensor names its method robot.{sense.method}, which Robot has already",
                "give the sense another method name (Sense(method=...))",
            )
        names.append(sense.method)
    return names
