"""`Robot`: the action half of the API that programs see (after the paper's Robot class).

The robot's sensors are chosen by the user (`--sensors camera,distance,force`); a method that needs a
sensor the robot was not given refuses and names it. Actions go to a `attribot.control.base.Controller`
bound to the world; what the world cannot do raises "not available in this world", never a fake value.
Docstrings of the names in `API_METHODS` are written for the LLM (the prompt renders them).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Sequence
from typing import Any, ClassVar, Literal

from pydantic import BaseModel, ConfigDict

from attribot.api.checks import check_number, check_patch
from attribot.api.errors import ActionFailed, ApiArgumentError, MissingSensor, PreconditionError
from attribot.api.patch import ImagePatch
from attribot.api.perception import Perception
from attribot.control.base import Capture, Controller, Target, build_controller
from attribot.embodiments.base import Capability, Embodiment
from attribot.errors import InputError, UnsupportedAction
from attribot.frame import CameraInfo

__all__ = ["Robot", "Measurement", "SENSORS", "SENSOR_ALIASES", "GRAVITY", "check_sensors"]

SENSORS: tuple[str, ...] = ("camera", "distance", "force")
"""The sensor names a robot can be given, as `--sensors` takes them."""

SENSOR_ALIASES: dict[str, tuple[str, ...]] = {
    **dict.fromkeys(("rgb camera", "color camera", "colour camera", "rgb"), ("camera",)),
    **dict.fromkeys(
        (
            "distance sensor",
            "proximity sensor",
            "range sensor",
            "rangefinder",
            "range finder",
            "infrared sensor",
            "infrared distance sensor",
            "ir sensor",
            "tof sensor",
            "time of flight sensor",
            "depth sensor",
        ),
        ("distance",),
    ),
    # a depth camera sees and measures how far what it sees is: both our camera and rangefinder
    **dict.fromkeys(("depth camera", "rgb-d camera", "rgbd camera"), ("camera", "distance")),
    **dict.fromkeys(
        (
            "force sensor",
            "force/torque sensor",
            "force torque sensor",
            "force-torque sensor",
            "f/t sensor",
            "ft sensor",
            "wrist force sensor",
            "load cell",
            "weight sensor",
        ),
        ("force",),
    ),
}
"""Other names of the sensors, the paper's among them ("distance sensor", "force/torque sensor")."""

GRAVITY = 9.81
"""m/s^2, as MuJoCo's default gravity; converts the measured weight (newtons) to mass (kilograms)."""

_CAPABILITY_OF = {"camera": Capability.CAMERA, "distance": Capability.DISTANCE, "force": Capability.FORCE}


class Measurement(BaseModel):
    """One sensor reading a program asked for, kept for the answer and the trace."""

    model_config = ConfigDict(frozen=True)

    kind: Literal["distance", "weight"]
    object_id: str | None
    label: str
    value: float  # metres or kilograms
    unit: Literal["m", "kg"]
    newtons: float | None = None  # the weight as the force sensor measured it
    samples: int = 1


class Robot:
    """The robot that carries the camera. It can move, act on objects, and measure what a camera cannot
    see. Its methods take ImagePatch objects returned by image.find(...).
    """

    API_ATTRIBUTES: ClassVar[tuple[str, ...]] = ("sensors",)
    API_METHODS: ClassVar[tuple[str, ...]] = (
        "focus_on_patch",
        "measure_distance",
        "measure_weight",
        "go_to_coords",
        "go_to_object",
        "pick_up",
        "put_down",
        "put_on",
        "push",
    )
    REQUIRES: ClassVar[dict[str, str]] = {
        "focus_on_patch": "camera",
        "measure_distance": "distance",
        "measure_weight": "force",
    }
    """The sensor each method needs (methods not listed need none); the prompt offers a method only when
    the robot has its sensor."""
    HOST_ATTRIBUTES: ClassVar[tuple[str, ...]] = (
        "world",
        "controller",
        "held",
        "measurements",
        "capture",
        "activity",
    )
    HOST_METHODS: ClassVar[tuple[str, ...]] = ("for_world", "look", "backend_name", "from_program")
    PROGRAM_CONSTRUCTOR: ClassVar[str] = "from_program"
    """What `Robot(...)` in a program calls on the session's robot (the paper's dialect)."""

    FOCUS_CORRECTIONS: ClassVar[int] = 3
    FOCUS_TOL_PX: ClassVar[float] = 1.5
    FORCE_SAMPLES: ClassVar[int] = 10
    FORCE_SAMPLE_S: ClassVar[float] = 0.05

    def __init__(
        self,
        sensors: Sequence[str] = ("camera",),
        world: Embodiment | None = None,
        controller: Controller | None = None,
    ) -> None:
        """Host side: a robot with `sensors` in `world` (None: a still image, every action refused), acting
        through `controller` (default: the one registered for the world, see attribot.control.base)."""
        self._sensors: list[str] = check_sensors(sensors)
        self._given = list(self._sensors)  # what the user gave; a program's Robot(sensors=...) may see fewer
        if world is not None and not isinstance(world, Embodiment):
            raise TypeError(
                f"Robot needs an attribot.embodiments.base.Embodiment, got {type(world).__name__}"
            )
        if world is not None:
            have = {str(c) for c in world.capabilities()}
            for sensor in self.sensors:
                if str(_CAPABILITY_OF[sensor]) not in have:
                    raise UnsupportedAction(
                        f"the world {world.name!r} has no {sensor} sensor",
                        f"leave {sensor!r} out of --sensors; this world offers: "
                        f"{', '.join(sorted(have)) or 'nothing'}",
                    )
        self.world = world
        self.controller: Controller = controller if controller is not None else build_controller(world)
        self.held: ImagePatch | None = None
        self.measurements: list[Measurement] = []
        self.capture: Capture | None = None
        self._near: ImagePatch | None = None
        self._captures = 0
        self._image: ImagePatch | None = None  # the last look: where an object's name is looked up
        self.activity = ""  # the action under way, as a program wrote it (episode videos show it)
        self._acted_on: list[ImagePatch] = []  # patches the program acted on, for names (paper dialect)

    @property
    def sensors(self) -> list[str]:
        """the robot's sensors, e.g. ["camera", "distance", "force"]"""
        return list(self._sensors)

    # ---- host side ---------------------------------------------------------------------------------
    @classmethod
    def for_world(cls, world: Embodiment, sensors: Sequence[str] = ("camera",)) -> Robot:
        """Host side: the robot in `world` with the controller registered for it."""
        return cls(sensors=sensors, world=world)

    def look(self, perception: Perception) -> ImagePatch:
        """Host side: take a camera frame now and return its whole-image patch, remembering the head
        angles and base pose so that boxes in it can be acted on later."""
        if self.world is None:
            raise UnsupportedAction(
                "a robot without a world has no camera to look with", "build Robot(world=...)"
            )
        frame = self.world.observe()
        caps = {str(c) for c in self.world.capabilities()}
        head = base = None
        if "pose" in caps:
            js = self.world.joint_states()
            if "head_pan" in js and "head_tilt" in js:
                head = (float(js["head_pan"]), float(js["head_tilt"]))
            pose = self.world.base_pose()
            base = (float(pose.x), float(pose.y), float(pose.yaw))
        camera = frame.camera if frame.camera is not None else _camera_info(self.world)
        self.capture = Capture(index=self._captures, camera=camera, head=head, base=base, depth=frame.depth)
        self._captures += 1
        self._image = ImagePatch(frame, perception, capture=self.capture)
        self._acted_on = []
        return self._image

    def from_program(self, sensors: Sequence[str] | None = None) -> Robot:
        """Host side: `Robot(sensors=[...])` written in a program, as the paper's programs do: this robot,
        seen through only the named sensors (the paper's names are read too: "distance sensor",
        "force/torque sensor", "depth camera"). A sensor it was not given is refused."""
        if sensors is None:
            return self
        names = check_sensors(sensors)
        missing = [n for n in names if n not in self._sensors]
        if missing:
            raise MissingSensor(
                f"Robot(sensors={list(sensors)!r}) asks for the {', '.join(missing)} sensor, and this robot "
                f"has only: {', '.join(self._sensors)}",
                f"add it with --sensors {','.join([*self._sensors, *missing])}, "
                "or leave it out of Robot(...)",
            )
        return _RobotWithSensors(self, names)

    def backend_name(self) -> str:
        """Host side: the controller's name, reported as the "robot" backend of an answer."""
        return str(getattr(self.controller, "name", type(self.controller).__name__))

    def _need(self, method: str) -> None:
        sensor = self.REQUIRES.get(method)
        if sensor is not None and sensor not in self.sensors:
            if sensor in self._given:  # the program's Robot(sensors=[...]) left it out
                wanted = [*self.sensors, sensor]
                fix = f"name it in the program's Robot(sensors=[...]), e.g. Robot(sensors={wanted})"
            else:
                fix = (
                    f"add it with --sensors {','.join([*self.sensors, sensor])}, "
                    f"or answer without robot.{method}"
                )
            raise MissingSensor(
                f"robot.{method}() needs the {sensor!r} sensor, and this robot has only: "
                f"{', '.join(self.sensors)}",
                fix,
            )

    def _named(self, name: str, method: str) -> ImagePatch:
        """The patch an object's name stands for, as the paper's Robot took names (`robot.pick_up("book")`):
        the last patch the program acted on with that name, else the one such object in the camera image."""
        key = _name_key(name)
        if not key:
            raise ApiArgumentError(
                f"robot.{method}({name!r}) names no object",
                f'pass a patch or a name, e.g. robot.{method}("cup")',
            )
        for done in reversed(self._acted_on):
            if _name_key(done.label) == key:
                return done
        if self._image is None:
            raise UnsupportedAction(
                f"robot.{method}({name!r}) is not available here: there is no camera image of a world",
                "run the query in a world (--layout) to use robot actions",
            )
        found = self._image.find(name)
        if not found:
            raise ApiArgumentError(
                f"robot.{method}({name!r}): the robot's camera sees no {name!r}",
                f'find it first: patches = image.find("{name}")',
            )
        if len(found) > 1:
            raise ApiArgumentError(
                f"robot.{method}({name!r}) is ambiguous: the robot's camera sees {len(found)} of them",
                f'pass the patch itself, e.g. robot.{method}(image.find("{name}")[0])',
            )
        return found[0]

    def _target(self, patch: object, method: str) -> tuple[ImagePatch, Target]:
        if isinstance(patch, str):
            patch = self._named(patch, method)
        p = check_patch(patch, ImagePatch, "patch", method)
        self.activity = f"robot.{method}({p.label or 'patch'})"
        if p.label and (not self._acted_on or self._acted_on[-1] is not p):
            self._acted_on.append(p)
        target = p.target()
        if target is None or self.world is None:
            raise UnsupportedAction(
                f"robot.{method}() is not available here: the patch comes from a still image, not from the "
                "robot's camera",
                "run the query in a world (--layout) to use robot actions, or answer from the image alone",
            )
        return p, target

    def _focus(self, patch: ImagePatch, target: Target) -> None:
        """Point the camera at `target`, then check in fresh images that the object sits at the image
        centre and correct up to FOCUS_CORRECTIONS times: this absorbs what the controller's geometry
        ignores (the camera's offset from the head axes, head tracking error)."""
        self.controller.focus_on(target)
        for _ in range(self.FOCUS_CORRECTIONS):
            seen = self._reacquire(patch)
            if seen is None:
                return  # the detector cannot find it again (or it has no name): keep the geometric aim
            cam = seen.capture.camera
            if cam is None:
                return  # no intrinsics to check the aim against: keep the geometric aim
            u, v = seen.center
            if math.hypot(u - cam.cx, v - cam.cy) <= self.FOCUS_TOL_PX:
                return
            self.controller.focus_on(seen)

    def _reacquire(self, patch: ImagePatch) -> Target | None:
        """The object of `patch` in a new camera image: by world id when known, else the detection of
        the same name nearest the image centre (where the aim put it), within a quarter of the image."""
        if not patch.label or self.world is None or "pose" not in {str(c) for c in self.world.capabilities()}:
            return None
        frame = self.world.observe()
        cam = frame.camera or _camera_info(self.world)
        if cam is None:
            return None
        js = self.world.joint_states()
        pose = self.world.base_pose()
        capture = Capture(
            index=self._captures,
            camera=cam,
            head=(float(js["head_pan"]), float(js["head_tilt"])),
            base=(float(pose.x), float(pose.y), float(pose.yaw)),
            depth=frame.depth,
        )
        self._captures += 1
        detections = patch.perception.detector.detect(frame, [patch.label])
        if patch.object_id is not None:
            same = [d for d in detections if d.object_id == patch.object_id]
        else:
            radius = min(cam.width, cam.height) / 4.0
            same = sorted(
                (d for d in detections if _dist_to_center(d.box, cam) <= radius),
                key=lambda d: _dist_to_center(d.box, cam),
            )
        if not same:
            return None
        d = same[0]
        return Target(box=d.box, capture=capture, object_id=patch.object_id, label=patch.label)

    # ---- methods (for programs) --------------------------------------------------------------------
    def focus_on_patch(self, patch: ImagePatch) -> None:
        """Turns the camera so that the centre of the image looks at the centre of `patch`.

        >>> # look at the clock
        >>> def execute_command(image, robot):
        >>>     clock = image.find("clock")[0]
        >>>     robot.focus_on_patch(clock)
        >>>     return clock
        """
        self._need("focus_on_patch")
        p, target = self._target(patch, "focus_on_patch")
        self._focus(p, target)

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
        self._need("measure_distance")
        p, target = self._target(patch, "measure_distance")
        self._focus(p, target)
        assert self.world is not None  # _target checked it
        metres = float(self.world.read_distance())
        if not math.isfinite(metres) or metres < 0:
            raise ActionFailed(
                f"the distance sensor saw nothing within range when pointed at {target.describe()}",
                "the object may be too far away or hidden; compare the objects another way",
            )
        self.measurements.append(
            Measurement(kind="distance", object_id=p.object_id, label=p.label, value=metres, unit="m")
        )
        return metres

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
        self._need("measure_weight")
        p, target = self._target(patch, "measure_weight")
        if self.held is None or not self.held.same_object(p):
            holding = (
                f"the robot holds {self.held.label or 'another object'}"
                if self.held
                else "the robot holds nothing"
            )
            raise PreconditionError(
                f"robot.measure_weight() needs {target.describe()} in the gripper, and {holding}",
                ("call robot.put_down() first, then " if self.held else "call ")
                + "robot.go_to_object(patch) and robot.pick_up(patch) before robot.measure_weight(patch)",
            )
        assert self.world is not None
        # average a short window: the reading sways while the arm settles and carries sensor noise
        total = 0.0
        for _ in range(self.FORCE_SAMPLES):
            self.world.step(self.FORCE_SAMPLE_S)
            total += abs(float(self.world.read_force()[2]))
        newtons = total / self.FORCE_SAMPLES
        kg = newtons / GRAVITY
        self.measurements.append(
            Measurement(
                kind="weight",
                object_id=p.object_id,
                label=p.label,
                value=kg,
                unit="kg",
                newtons=newtons,
                samples=self.FORCE_SAMPLES,
            )
        )
        return kg

    def go_to_coords(self, x: float, y: float) -> None:
        """Drives the robot towards the point (x, y) of the image (pixels, y growing upward, like the
        patch attributes).

        >>> # drive to the middle of the rug
        >>> def execute_command(image, robot):
        >>>     rug = image.find("rug")[0]
        >>>     robot.go_to_coords(rug.horizontal_center, rug.vertical_center)
        >>>     return rug
        """
        fx, fy = check_number(x, "x", "go_to_coords"), check_number(y, "y", "go_to_coords")
        if self.capture is None or self.world is None:
            raise UnsupportedAction(
                "robot.go_to_coords() is not available here: "
                "there is no camera image of a world to navigate in",
                "run the query in a world (--layout) to use robot actions",
            )
        cam = self.capture.camera
        w, h = (cam.width, cam.height) if cam is not None else (None, None)
        if w is not None and h is not None and not (0 <= fx <= w and 0 <= fy <= h):
            raise ApiArgumentError(
                f"go_to_coords({fx:g}, {fy:g}) lies outside the {w}x{h} image",
                "pass a point inside the image, e.g. a patch's horizontal_center and vertical_center",
            )
        v = (h - fy) if h is not None else -fy  # y upward -> pixel row
        self.controller.go_to_coords(Target(box=(fx, v, fx, v), capture=self.capture, label="point"))
        self._near = None

    def go_to_object(self, patch: ImagePatch) -> None:
        """Drives the robot next to the object in `patch`, close enough to pick it up.

        >>> # bring the robot to the fridge
        >>> def execute_command(image, robot):
        >>>     fridge = image.find("fridge")[0]
        >>>     robot.go_to_object(fridge)
        >>>     return fridge
        """
        p, target = self._target(patch, "go_to_object")
        self.controller.approach(target)
        self._near = p

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
        p, target = self._target(patch, "pick_up")
        if self.held is not None:
            raise PreconditionError(
                "robot.pick_up() needs an empty gripper, and the robot holds "
                f"{self.held.label or 'an object'}",
                "call robot.put_down() first",
            )
        if self._near is None or not self._near.same_object(p):
            raise PreconditionError(
                f"robot.pick_up() needs the robot next to {target.describe()}",
                "call robot.go_to_object(patch) right before robot.pick_up(patch)",
            )
        if "force" in self.sensors:
            assert self.world is not None
            self.world.tare_force()  # zero with the gripper empty, so a later reading is the load alone
        self.controller.pick_up(target)
        self.held = p

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
        self.activity = "robot.put_down()"
        if self.held is None:
            raise PreconditionError(
                "robot.put_down() needs an object in the gripper, and it is empty",
                "call robot.pick_up(patch) before robot.put_down()",
            )
        self.controller.put_down()
        self.held = None

    def put_on(self, patch: ImagePatch) -> None:
        """Places the held object on top of the object in `patch`.

        >>> # put the cup on the tray
        >>> def execute_command(image, robot):
        >>>     cup = image.find("cup")[0]
        >>>     tray = image.find("tray")[0]
        >>>     robot.go_to_object(cup)
        >>>     robot.pick_up(cup)
        >>>     robot.put_on(tray)
        >>>     return tray
        """
        _, target = self._target(patch, "put_on")
        if self.held is None:
            raise PreconditionError(
                "robot.put_on() needs an object in the gripper, and it is empty",
                "call robot.go_to_object(obj) and robot.pick_up(obj) first",
            )
        self.controller.put_on(target)
        self.held = None

    def push(self, patch: ImagePatch) -> None:
        """Pushes the object in `patch` away from the robot.

        >>> # push the ball
        >>> def execute_command(image, robot):
        >>>     ball = image.find("ball")[0]
        >>>     robot.push(ball)
        >>>     return ball
        """
        _, target = self._target(patch, "push")
        self.controller.push(target)
        self._near = None


class _RobotWithSensors(Robot):
    """The session's robot as a program's `Robot(sensors=[...])` sees it: every action and measurement is
    the session robot's own (its state, its measurements), checked against the fewer sensors."""

    def __init__(self, robot: Robot, sensors: list[str]) -> None:  # noqa: D107 (no Robot.__init__: a view)
        self._robot = robot
        self._sensors = sensors

    def from_program(self, sensors: Sequence[str] | None = None) -> Robot:
        return self._robot.from_program(sensors)


def _through_view(name: str) -> Any:
    robot_method = getattr(Robot, name)

    def method(self: _RobotWithSensors, *args: Any, **kwargs: Any) -> Any:
        robot = self._robot
        given = robot._sensors
        robot._sensors = self._sensors  # the session robot checks the view's sensors for this call
        try:
            return getattr(robot, name)(*args, **kwargs)
        finally:
            robot._sensors = given

    method.__name__ = name
    method.__doc__ = robot_method.__doc__
    method.__signature__ = inspect.signature(robot_method)  # type: ignore[attr-defined]
    return method


for _name in Robot.API_METHODS:
    setattr(_RobotWithSensors, _name, _through_view(_name))


def check_sensors(sensors: Sequence[str]) -> list[str]:
    """Sensor names lower-cased, deduplicated, "camera" first (always present); unknown names raise."""
    if not isinstance(sensors, list | tuple) or not all(isinstance(s, str) for s in sensors):
        raise InputError(
            f"sensors must be a list of names, got {sensors!r}",
            f"e.g. Robot(sensors=['camera', 'distance']); known: {', '.join(SENSORS)}",
        )
    out: list[str] = []
    for s in sensors:
        name = " ".join(s.strip().lower().replace("_", " ").split())
        if name not in SENSORS and name not in SENSOR_ALIASES:
            raise InputError(
                f"unknown sensor {s!r}: this robot has no such sensor",
                f"choose from: {', '.join(SENSORS)} (e.g. --sensors camera,distance); the paper's names "
                "work too: 'distance sensor', 'force/torque sensor', 'depth camera'",
            )
        for sensor in SENSOR_ALIASES.get(name, (name,)):
            if sensor not in out:
                out.append(sensor)
    if "camera" not in out:
        out.insert(0, "camera")  # every robot here sees through its camera: the image is the program's input
    return out


def _dist_to_center(box: tuple[float, float, float, float], cam: CameraInfo) -> float:
    return math.hypot((box[0] + box[2]) / 2.0 - cam.cx, (box[1] + box[3]) / 2.0 - cam.cy)


def _camera_info(world: Embodiment) -> Any:
    try:
        return world.camera_info()
    except UnsupportedAction:
        return None


def _name_key(name: str) -> str:
    """An object's name as compared: lower case, no article, singular ("the Books" -> "book")."""
    words = name.lower().split()
    while words and words[0] in ("the", "a", "an"):
        words = words[1:]
    text = " ".join(words)
    return text[:-1] if text.endswith("s") and not text.endswith("ss") else text
