"""`Robot`: the action half of the API that programs see (after the paper's Robot class).

The robot's sensors are chosen by the user (`--sensors camera,distance,force`); a method that needs a
sensor the robot was not given refuses and names it. Actions go to a `attribot.control.base.Controller`
bound to the world; what the world cannot do raises "not available in this world", never a fake value.
Docstrings of the names in `API_METHODS` are written for the LLM (the prompt renders them).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Sequence
from typing import Any, ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict

from attribot.api.checks import check_number, check_patch
from attribot.api.errors import ActionFailed, ApiArgumentError, MissingSensor, PreconditionError
from attribot.api.harder import acting_find, carried_back
from attribot.api.looking import Survey, View, capture_now
from attribot.api.patch import ImagePatch
from attribot.api.perception import Perception
from attribot.api.safeguards import Safeguards
from attribot.boxes import iou, overlap_of_smaller
from attribot.control.base import (
    RETRY_FROM_HERE,
    Capture,
    ControlError,
    Controller,
    Failure,
    Target,
    build_controller,
)
from attribot.control.candidates import Candidate
from attribot.embodiments.base import Embodiment
from attribot.errors import ConfigError, UnsupportedAction
from attribot.frame import CameraInfo
from attribot.lexicon import GENERIC_NOUNS
from attribot.models.base import Detection
from attribot.sensors import (
    Need,
    Sense,
    Sensor,
    check_sensors,
    sense_of,
    sense_of_method,
    senses,
    sensor_method_doc,
    sensor_names,
)
from attribot.sim.catalog import categories, find_category

__all__ = ["Robot", "Measurement", "GRAVITY", "check_sensors", "sensor_names"]

GRAVITY = 9.81
"""m/s^2, as MuJoCo's default gravity; converts the measured weight (newtons) to mass (kilograms)."""


class Measurement(BaseModel):
    """One sensor reading a program asked for, kept for the answer and the trace."""

    model_config = ConfigDict(frozen=True)

    kind: str  # the quantity: distance, weight, temperature, stiffness, fullness, or a plug-in sensor's
    object_id: str | None
    label: str
    value: float  # in `unit`
    unit: str  # m, kg, °C, N/mm, "full" (a share of the container's capacity), or a plug-in sensor's
    newtons: float | None = None  # the weight as the force sensor measured it
    samples: int = 1
    uncertainty: float = 0.0  # one standard deviation, in `unit`
    method: str = ""  # the Robot method that measured it: how `settle` measures again

    def reading(self) -> str:
        """The value as a person reads it, as its sense shows it (`attribot.sensors.Sense.show`): "0.308 kg
        (3.02 N)", "1.211 m", "84.6 °C", "95% full"."""
        found = sense_of(self.kind)
        shown = found[1].show(self.value) if found is not None else f"{self.value:.3f} {self.unit}"
        return shown if self.newtons is None or self.kind != "weight" else f"{shown} ({self.newtons:.2f} N)"

    def describe(self) -> str:
        """The object and its value: "mug 0: 0.308 kg (3.02 N)"."""
        return f"{object_name(self.object_id, self.label)}: {self.reading()}"


def object_name(object_id: str | None, label: str | None) -> str:
    """What a caption calls an object: its detector id made readable ("computer mouse 1"), else its label."""
    if object_id:
        return object_id.replace("_", " ")
    return label or "the object"


def _own_sense(quantity: str) -> Sense:
    """The record of a sense whose methods Robot defines itself (distance, weight, fullness)."""
    found = sense_of(quantity)
    assert found is not None, f"the built-in {quantity} sense is registered (attribot.sensors.builtin)"
    return found[1]


FULL = _own_sense("fullness").unit
"""The unit of a fullness: the share of a container's capacity its contents fill (0 empty, 1 full)."""

_DOING = {
    "focus_on_patch": "turning the camera to",
    "go_to_object": "driving to",
    "pick_up": "picking up",
    "put_on": "putting the held object on",
    "push": "pushing",
}
"""What an episode video's caption says a robot method is doing, before the object's name (a sense's
method: its record's `doing`)."""


def _doing(method: str) -> str:
    found = sense_of_method(method)
    return found[1].doing or method if found is not None else _DOING.get(method, method)


class _RobotApi(type):
    """The metaclass of `Robot`: a program's Robot methods are its own (`OWN_METHODS`, which include the
    senses of the camera's, the rangefinder's and the force sensor's records) and one per registered sense
    read through `read_sensor` (`attribot.sensors.Sense.method`), read from the registry whenever they are
    asked for, so that a sensor registered later (a lab's own) is offered like the built-in ones."""

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
        return {**Robot.OWN_REQUIRES, **{sense.method: sensor.name for sensor, sense in senses()}}


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
    OWN_REQUIRES: ClassVar[dict[str, str]] = {"focus_on_patch": "camera"}
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
        "snapshot",
        "restore",
    )
    PROGRAM_CONSTRUCTOR: ClassVar[str] = "from_program"
    """What `Robot(...)` in a program calls on the session's robot (the paper's dialect)."""
    PROGRAM_FUNCTIONS_ON: ClassVar[tuple[str, ...]] = ("ImagePatch",)
    """The class whose objects take the robot's methods too (`PROGRAM_FUNCTIONS`): `patch.pick_up()`."""
    PROGRAM_CALLED_ON: ClassVar[str] = "called_on"
    """The host method the runner tells which patch such a call was made on."""

    FOCUS_CORRECTIONS: ClassVar[int] = 3
    FOCUS_TOL_PX: ClassVar[float] = 1.5
    # the readings a measurement combines and the least uncertainty it claims: the senses' records
    FORCE_SAMPLES: ClassVar[int] = _own_sense("weight").readings
    FORCE_SAMPLE_S: ClassVar[float] = 0.05
    FORCE_MAX_SAMPLES: ClassVar[int] = 40  # re-measuring: until the standard error is small, at most this
    FORCE_RESOLUTION_N: ClassVar[float] = round(_own_sense("weight").resolution * GRAVITY, 9)
    RANGE_READINGS: ClassVar[int] = _own_sense("distance").readings
    NEARER_VISITS: ClassVar[int] = 2  # look_harder: places driven nearer to for one find, at most
    NEARER_M: ClassVar[float] = 0.9  # ...and how far from them it stops to look
    RANGE_RESOLUTION_M: ClassVar[float] = _own_sense("distance").resolution
    BEAM_TOLERANCE: ClassVar[float] = 0.06  # the beam agrees with depth within this fraction (or 4 cm)
    GRASP_TRIES: ClassVar[int] = 4
    GRIPPER_EMPTY_M: ClassVar[float] = 0.0003  # fingers closer than this hold nothing
    APPROACH_TRIES: ClassVar[int] = 3
    SETTLE_ROUNDS: ClassVar[int] = 3
    SETTLE_Z: ClassVar[float] = 2.0  # a margin of this many standard deviations settles a comparison

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
        self._sensors: list[str] = check_sensors(sensors)
        self._given = list(self._sensors)  # what the user gave; a program's Robot(sensors=...) may see fewer
        if world is not None and not isinstance(world, Embodiment):
            raise TypeError(
                f"Robot needs an attribot.embodiments.base.Embodiment, got {type(world).__name__}"
            )
        if world is not None:
            have = world.sensors()
            for sensor in self.sensors:
                if sensor not in have:
                    raise UnsupportedAction(
                        f"the world {world.name!r} has no {sensor} sensor",
                        f"leave {sensor!r} out of --sensors; this world offers: "
                        f"{', '.join(sorted(have)) or 'nothing'}",
                    )
        self.world = world
        self.controller: Controller = controller if controller is not None else build_controller(world)
        self.held: ImagePatch | None = None
        self.safeguards = safeguards if safeguards is not None else Safeguards()
        self.measurements: list[Measurement] = []
        self._measured: list[tuple[Measurement, ImagePatch]] = []
        self.capture: Capture | None = None
        self._near: ImagePatch | None = None
        self._aimed: ImagePatch | None = None  # what the camera was last centred on, since the robot moved
        self._captures = 0
        self._image: ImagePatch | None = None  # the last look: where an object's name is looked up
        self.activity = ""  # the action under way, naming its object ("weighing mug 0"): videos show it
        self.acting_on = ""  # the name of the object of that action
        self.acting_on_id: str | None = None  # and its detector id, when the detector gives one
        self._acted_on: list[ImagePatch] = []  # patches the program acted on, for names (paper dialect)
        # a call through the robot a program made (the paper's dialect): it arranges what an action or a
        # reading needs (turning to the object, going to it, picking it up) where this robot would refuse
        self._arranging = False

    @property
    def sensors(self) -> list[str]:
        """the robot's sensors, e.g. ["camera", "distance", "force"]"""
        return list(self._sensors)

    # ---- host side ---------------------------------------------------------------------------------
    def look(self, perception: Perception, survey: bool = True) -> ImagePatch:
        """Host side: take a camera frame now and return its whole-image patch, remembering the head
        angles and base pose so that boxes in it can be acted on later. With `look_again` on and `survey`,
        the head also turns around it to take the views that finds are checked against; without `survey`
        (the image is all a program may see) finds are checked on the image itself."""
        if self.world is None:
            raise UnsupportedAction(
                "a robot without a world has no camera to look with", "build Robot(world=...)"
            )
        frame = self.world.observe()
        caps = {str(c) for c in self.world.capabilities()}
        camera = frame.camera if frame.camera is not None else _camera_info(self.world)
        if "pose" in caps:
            self.capture = capture_now(self.world, frame, self._captures, camera)
        else:
            self.capture = Capture(index=self._captures, camera=camera, depth=frame.depth)
        self._captures += 1
        self._image = ImagePatch(frame, perception, capture=self.capture)
        if self.safeguards.on("look_again") or self.safeguards.on("look_harder"):
            self._image.safeguards = self.safeguards
        if self.safeguards.on("look_harder") and {"base", "pose"} <= caps and frame.depth is not None:
            self._image.nearer = self._nearer
        if self.safeguards.on("look_again"):
            if survey and {"head", "pose"} <= caps and frame.depth is not None:
                try:
                    body = self.world.body()
                except UnsupportedAction:  # a robot that does not state where its camera sits
                    body = None
                if body is not None:
                    self._image.survey = Survey.take(self.world, View(frame, self.capture), body)
        self._acted_on = []
        self._aimed = None
        return self._image

    def _nearer(self, name: str, candidates: list[Candidate]) -> tuple[list[Detection], int]:
        """Host side, for `look_harder`: drive nearer to each candidate of the image in turn (at most
        `NEARER_VISITS`), look for `name` there and carry what is seen back into the image; then drive back
        to where the robot was. Returns the detections in the image and the places visited."""
        image, world = self._image, self.world
        look, back = (
            getattr(self.controller, "look_nearer", None),
            getattr(self.controller, "return_to", None),
        )
        if image is None or image.capture is None or world is None or look is None or back is None:
            return [], 0
        if self.held is not None:
            return [], 0  # it does not drive about with something in the gripper to look
        first, detector = image.capture, image.perception.detector
        found: list[Detection] = []
        visits = 0
        try:
            for cand in candidates[: self.NEARER_VISITS]:
                try:
                    look(Target(box=cand.box, capture=first), self.NEARER_M)
                except (ControlError, UnsupportedAction):
                    continue  # no way there, or stopped on the way: the next place, and back from there
                visits += 1
                frame = world.observe()
                seen = capture_now(world, frame, -1, frame.camera or first.camera)
                for det in acting_find(detector, frame, name):
                    box = carried_back(det.box, frame, seen, first)
                    if box is not None and overlap_of_smaller(box, cand.box) >= 0.3:
                        found.append(Detection(box=box, score=det.score, label=det.label))
                if found:
                    break
        finally:
            try:
                back()
            except ControlError as exc:
                raise ControlError(
                    f"looking harder for {name!r}, the robot drove nearer to look and could not drive back "
                    f"to where it took the image: {exc.message}",
                    "take a new image (robot.look) where it stands, or switch the mechanism off "
                    "(--checks all,-look_harder)",
                ) from exc
        return found, visits

    def settle(self, chosen: ImagePatch) -> str | None:
        """Host side, after a program chose `chosen`: with `confidence`, when the choice rests on measured
        values (the chosen object's is the largest or smallest of its kind, or lies between two) and the
        margin to the next one lies inside their uncertainty, measure both again (up to SETTLE_ROUNDS),
        combining the readings. None when settled (or nothing to settle); otherwise the sentence that says
        it cannot tell, naming both values."""
        if not self.safeguards.on("confidence"):
            return None
        mine = [(m, p) for m, p in self._measured if p.same_object(chosen) or p is chosen]
        if not mine:
            return None
        last = mine[-1][0]
        kind, unit = last.kind, last.unit
        for round_ in range(self.SETTLE_ROUNDS + 1):
            values = self._combined(kind)
            me = next((v for v in values if v[2].same_object(chosen) or v[2] is chosen), None)
            if me is None or len(values) < 2:
                return None
            rivals = _neighbours(values, me)
            close = [r for r in rivals if abs(r[0] - me[0]) <= self.SETTLE_Z * math.hypot(r[1], me[1])]
            call = f"answer({chosen.label or 'patch'})"
            if not close:
                if round_ > 0:
                    self.safeguards.note("confidence", call, "caught", "settled after measuring again")
                return None
            if round_ == self.SETTLE_ROUNDS:
                rival = close[0]
                text = (
                    f"cannot tell {_named(chosen)} ({me[0]:.3f} +/- {me[1]:.3f} {unit}) from "
                    f"{_named(rival[2])} ({rival[0]:.3f} +/- {rival[1]:.3f} {unit}): "
                    "the difference lies inside the measurements' uncertainty"
                )
                self.safeguards.note("confidence", call, "unsettled", text)
                return text
            for _value, _error, patch in [me, *close]:
                self._measure_again(last.method or _own_sense(kind).method, patch)
        return None

    def _combined(self, kind: str) -> list[tuple[float, float, ImagePatch]]:
        """Each measured object's readings of `kind` combined (inverse-variance mean): (value, sd, patch)."""
        groups: list[list[tuple[Measurement, ImagePatch]]] = []
        for m, p in self._measured:
            if m.kind != kind:
                continue
            home = next((g for g in groups if g[0][1].same_object(p) or g[0][1] is p), None)
            if home is None:
                groups.append([(m, p)])
            else:
                home.append((m, p))
        out = []
        for g in groups:
            weights = [1.0 / max(m.uncertainty, 1e-6) ** 2 for m, _ in g]
            value = sum(w * m.value for w, (m, _) in zip(weights, g, strict=True)) / sum(weights)
            out.append((value, 1.0 / math.sqrt(sum(weights)), g[0][1]))
        return out

    def _measure_again(self, method: str, patch: ImagePatch) -> None:
        """Measure `patch` again with `method`, arranging first what its reading needs."""
        found = sense_of_method(method)
        needs = found[1].needs if found is not None else Need.NOTHING
        measure = getattr(self, method)
        if needs is Need.GRASP:
            if self.held is not None:
                self.put_down()
            self.go_to_object(patch)
            self.pick_up(patch)
            measure(patch)
            self.put_down()
            return
        if needs is Need.REACH:
            self.go_to_object(patch)
        elif needs is Need.AIM and method != "measure_distance":  # which centres the camera itself
            self.focus_on_patch(patch)
        measure(patch)

    def snapshot(self) -> Any:
        """Host side: the robot's state now (pose, head, arm, gripper), or None where the world cannot
        put it back."""
        return None if self.world is None else self.world.snapshot()

    def restore(self, snapshot: Any, image: ImagePatch) -> None:
        """Host side: back to `snapshot` with `image` as the camera's last look: how a retry starts from
        the state the first try started from."""
        assert self.world is not None
        self.world.restore(snapshot)
        self.held = None
        self._near = None
        self._aimed = None
        self._image = image
        self.capture = image.capture
        self._acted_on = []

    def from_program(self, sensors: Sequence[str] | None = None) -> Robot:
        """Host side: `Robot(sensors=[...])` written in a program, as the paper's programs do: this robot,
        seen through only the named sensors (the paper's names are read too: "distance sensor",
        "force/torque sensor", "depth camera"; none named: all of its own). A sensor it was not given is
        refused. The paper's robot did what its methods needed itself (its prompt's programs weigh one
        object after another with no put_down), so this one arranges it: a reading turns to its object,
        goes to it or picks it up first, and a pick-up puts down what the gripper holds."""
        if sensors is None:
            return _RobotWithSensors(self, list(self._sensors))
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

    def called_on(self, patch: ImagePatch) -> None:
        """Host side: the program called one of this robot's methods on `patch` (`book_patch.pick_up("book")`,
        `apple_patch.measure_distance("desk")`), or named an object right after looking at `patch` (a loop
        over patches that asks each a question, then `go_to_object("object")`): a name in that call stands
        for it when it answers to the name (see `_named`), as for the latest object the program acted on."""
        if (
            isinstance(patch, ImagePatch)
            and patch.label
            and (not self._acted_on or self._acted_on[-1] is not patch)
        ):
            self._acted_on.append(patch)

    def backend_name(self) -> str:
        """Host side: the controller's name, reported as the "robot" backend of an answer."""
        return str(getattr(self.controller, "name", type(self.controller).__name__))

    def _need(self, method: str) -> None:
        sensor = type(self).REQUIRES.get(method)
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
        the last patch the program acted on with that name (or any name, for a generic noun such as
        "object"), else the very last one when the camera finds it under that name, else the one such
        object in the camera image. Several in view is ambiguous: refused, naming them."""
        key = _name_key(name)
        if not key:
            raise ApiArgumentError(
                f"robot.{method}({name!r}) names no object",
                f'pass a patch or a name, e.g. robot.{method}("cup")',
            )
        for done in reversed(self._acted_on):
            if key in GENERIC_NOUNS or _name_key(done.label) == key:  # "object": the one acted on last
                return done
        last = self._acted_on[-1] if self._acted_on else None  # found as "object", named now as a "jar"
        if last is not None and any(
            f.same_object(last) or iou(f.box, last.box) >= _SAME_BOX for f in last.find(name)
        ):
            return last
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
            seen = ", ".join(_named(p) for p in found[:4]) + (", ..." if len(found) > 4 else "")
            raise ApiArgumentError(
                f"robot.{method}({name!r}) is ambiguous: the robot's camera sees {len(found)} of them "
                f"({seen})",
                f"pass the patch you mean instead of its name, e.g. for patch in image.find({name!r}): ... "
                f"{method}(patch)",
            )
        return found[0]

    def _target(self, patch: object, method: str) -> tuple[ImagePatch, Target]:
        if isinstance(patch, str):
            patch = self._named(patch, method)
        elif isinstance(patch, list | tuple) and all(isinstance(p, ImagePatch) for p in patch):
            patch = _one_of(patch, method)  # the list find returned, as the paper's prompt passes it
        p = check_patch(patch, ImagePatch, "patch", method)
        self.acting_on, self.acting_on_id = object_name(p.object_id, p.label), p.object_id
        self.activity = f"{_doing(method)} {self.acting_on}"
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
        self._aimed = patch
        for _ in range(self.FOCUS_CORRECTIONS):
            seen = self._reacquire(patch)
            if seen is None:
                return  # the detector cannot find it again (or it has no name): keep the geometric aim
            cam = seen.capture.camera
            if cam is None:
                return  # no intrinsics to check the aim against: keep the geometric aim
            u, v = seen.center
            # without a camera head only the base turns it: left-right is all a focus can centre
            assert self.world is not None  # _target checked it
            headless = "head" not in {str(c) for c in self.world.capabilities()}
            off = abs(u - cam.cx) if headless else math.hypot(u - cam.cx, v - cam.cy)
            if off <= self.FOCUS_TOL_PX:
                return
            self.controller.focus_on(seen)

    def _reacquire(self, patch: ImagePatch, by_id: bool = True) -> Target | None:
        """The object of `patch` in a new camera image: by world id when known (and `by_id`), else the
        detection of the same name nearest the image centre (where the aim put it), within a quarter of
        the image."""
        if not patch.label or self.world is None or "pose" not in {str(c) for c in self.world.capabilities()}:
            return None
        frame = self.world.observe()
        cam = frame.camera or _camera_info(self.world)
        if cam is None:
            return None
        capture = capture_now(self.world, frame, self._captures, cam)
        self._captures += 1
        detections = patch.perception.detector.detect(frame, [patch.label])
        if by_id and patch.object_id is not None:
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
        metres, spread, samples = self._read_range(p)
        self._record(
            p,
            kind="distance",
            value=metres,
            unit="m",
            samples=samples,
            uncertainty=spread,
            method="measure_distance",
        )
        return metres

    def _read_range(self, p: ImagePatch) -> tuple[float, float, int]:
        """The rangefinder's reading of the object the camera is centred on: (metres, one standard
        deviation, readings used). With `remeasure`, several readings are combined (dropouts left out);
        with `verify_actions`, readings where the beam did not hit the object (it disagrees with the depth
        in the object's middle: an edge, the wall behind) are left out, re-aiming once if none is left."""
        assert self.world is not None
        guards = self.safeguards
        count = self.RANGE_READINGS if guards.on("remeasure") else 1
        call = f"measure_distance({p.label or 'patch'})"
        for aim in range(2):
            readings = []
            for _ in range(count):
                r = float(self.world.read_distance())
                if math.isfinite(r) and r >= 0:
                    readings.append(r)
                if count > 1:
                    self.world.step(0.02)
            if count > 1:
                empty = count - len(readings)
                detail = f"{count} readings, {empty} empty"
                guards.note("remeasure", call, "caught" if empty else "confirmed", detail)
            depth = self._centre_depth() if guards.on("verify_actions") else None
            if depth is not None and readings:
                tol = max(0.04, self.BEAM_TOLERANCE * depth)
                hits = [r for r in readings if abs(r - depth) <= tol]
                if len(hits) < len(readings):
                    guards.note(
                        "verify_actions",
                        call,
                        "caught",
                        f"{len(readings) - len(hits)} beam readings off the object "
                        f"(depth there {depth:.3f} m)",
                    )
                readings = hits
            if readings:
                break
            if aim == 0 and (guards.on("verify_actions") or guards.on("remeasure")):
                self._focus(p, p.target() or self._target(p, "measure_distance")[1])  # aim again, read again
                continue
            break
        if not readings:
            raise ActionFailed(
                f"the distance sensor saw nothing within range when pointed at {p.label or 'the object'}",
                "the object may be too far away or hidden; compare the objects another way",
            )
        values = sorted(readings)
        metres = values[len(values) // 2] if len(values) % 2 else sum(values[len(values) // 2 - 1 :][:2]) / 2
        spread = _std(values) / math.sqrt(len(values)) if len(values) > 1 else 0.0
        floor = self.RANGE_RESOLUTION_M + (0.01 * metres if len(values) == 1 else 0.0)
        return metres, max(spread, floor), len(values)

    def _gripper_empty(self) -> bool:
        """The fingers have closed (almost) all the way: nothing is between them."""
        assert self.world is not None
        try:
            opening = self.world.joint_states().get("gripper")
        except UnsupportedAction:
            return False
        return opening is not None and float(opening) < self.GRIPPER_EMPTY_M

    def _centre_depth(self) -> float | None:
        """The depth camera's distance to the surface at the image centre (where the object is, once
        focused): the nearest surface in a small window, along the optical axis. None without depth."""
        assert self.world is not None
        frame = self.world.observe()
        if frame.depth is None:
            return None
        h, w = frame.depth.shape
        win = frame.depth[h // 2 - 2 : h // 2 + 3, w // 2 - 2 : w // 2 + 3]
        finite = win[np.isfinite(win) & (win > 0.05)]
        # the nearest surface, not the middle one: a thin object (a lamp's pole) fills a few pixels of the
        # window, and the wall behind the rest
        return float(np.percentile(finite, 10)) if finite.size else None

    def _record(self, p: ImagePatch, **reading: Any) -> None:
        """Keep a reading of `p` (Measurement's fields) for the answer, and with its patch for `settle`."""
        m = Measurement(object_id=p.object_id, label=p.label, **reading)
        self.measurements.append(m)
        self._measured.append((m, p))

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
        self._held_for(p, target, "measure_weight")
        assert self.world is not None
        newtons, error, samples = self._weigh(p)
        kg = newtons / GRAVITY
        self._record(
            p,
            kind="weight",
            value=kg,
            unit="kg",
            newtons=newtons,
            samples=samples,
            uncertainty=error / GRAVITY,
            method="measure_weight",
        )
        return kg

    def _held_for(self, p: ImagePatch, target: Target, method: str) -> None:
        """Refuse a reading that needs `p` in the gripper when it is not there, saying what to call; the
        robot a program made picks it up instead."""
        if self.held is not None and self.held.same_object(p):
            return
        if self._arranging:
            self.pick_up(p)
            return
        holding = (
            f"the robot holds {self.held.label or 'another object'}"
            if self.held
            else "the robot holds nothing"
        )
        raise PreconditionError(
            f"robot.{method}() needs {target.describe()} in the gripper, and {holding}",
            ("call robot.put_down() first, then " if self.held else "call ")
            + f"robot.go_to_object(patch) and robot.pick_up(patch) before robot.{method}(patch)",
        )

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
        self._need("measure_fullness")
        p, target = self._target(patch, "measure_fullness")
        kind = find_category(p.label or "")
        if kind is None or not kind.container or kind.empty_kg is None:
            known = ", ".join(c.name for c in categories() if c.container)
            raise ApiArgumentError(
                f"robot.measure_fullness() knows how much an empty {known} weighs, and not a "
                f"{p.label or 'patch without a name'}",
                "weigh it with robot.measure_weight(patch) and compare it with others of its kind",
            )
        self._held_for(p, target, "measure_fullness")
        newtons, error, samples = self._weigh(p)
        lo, hi = kind.empty_kg
        empty_sd = (hi - lo) / math.sqrt(12.0)  # the empty mass of one such container, uniform in its range
        fill = (newtons / GRAVITY - (lo + hi) / 2.0) / kind.capacity_kg
        spread = math.hypot(error / GRAVITY, empty_sd) / kind.capacity_kg
        value = min(max(fill, 0.0), 1.0)
        self._record(
            p,
            kind="fullness",
            value=value,
            unit=FULL,
            newtons=newtons,
            samples=samples,
            uncertainty=spread,
            method="measure_fullness",
        )
        return value

    def _sense(self, sensor: Sensor, sense: Sense, patch: ImagePatch) -> float:
        """A reading of a registered sensor through its method: checks the sensor, the object and what the
        reading needs, then reads (several readings with `remeasure`) and records the measurement."""
        method = sense.method
        self._need(method)
        p, target = self._target(patch, method)
        assert self.world is not None  # _target checked it
        arrange = self._arranging
        if sense.needs is Need.AIM and (self._aimed is None or not self._aimed.same_object(p)) and arrange:
            self._focus(p, target)
        elif sense.needs is Need.REACH and (self._near is None or not self._near.same_object(p)) and arrange:
            self.go_to_object(p)
        if sense.needs is Need.AIM and (self._aimed is None or not self._aimed.same_object(p)):
            raise PreconditionError(
                f"robot.{method}() reads whatever the camera is centred on, and it is not centred on "
                f"{target.describe()}",
                f"call robot.focus_on_patch(patch) right before robot.{method}(patch)",
            )
        if sense.needs is Need.REACH and (self._near is None or not self._near.same_object(p)):
            raise PreconditionError(
                f"robot.{method}() needs the robot next to {target.describe()}",
                f"call robot.go_to_object(patch) right before robot.{method}(patch)",
            )
        if sense.needs is Need.GRASP:
            self._held_for(p, target, method)
        value, spread, count = self._read_sensor(sensor, sense, p)
        self._record(
            p,
            kind=sense.quantity,
            value=value,
            unit=sense.unit,
            samples=count,
            uncertainty=spread,
            method=method,
        )
        return value

    def _read_sensor(self, sensor: Sensor, sense: Sense, p: ImagePatch) -> tuple[float, float, int]:
        """The sensor's reading of `p`: (value, one standard deviation, readings used). With `remeasure`,
        `sense.readings` readings are combined (the ones that read nothing left out)."""
        assert self.world is not None
        guards = self.safeguards
        count = sense.readings if guards.on("remeasure") else 1
        call = f"{sense.method}({p.label or 'patch'})"
        readings = []
        for i in range(count):
            value = float(self.world.read_sensor(sensor.name))
            if math.isfinite(value):
                readings.append(value)
            if count > 1 and i + 1 < count and sense.needs is not Need.GRASP:
                self.world.step(0.02)
        if count > 1:
            empty = count - len(readings)
            guards.note(
                "remeasure", call, "caught" if empty else "confirmed", f"{count} readings, {empty} empty"
            )
        if not readings:
            raise ActionFailed(
                f"the {sensor.name} sensor read nothing from {p.label or 'the object'}",
                "check what the reading needs (" + str(sense.needs) + "), or compare the objects another way",
            )
        mean = sum(readings) / len(readings)
        spread = _std(readings) / math.sqrt(len(readings)) if len(readings) > 1 else 0.0
        return mean, max(spread, sense.resolution, sense.relative * abs(mean)), len(readings)

    def _weigh(self, p: ImagePatch) -> tuple[float, float, int]:
        """The held load in newtons, its standard error and the readings used. A short window is averaged
        (the reading sways while the arm settles and carries sensor noise); with `remeasure`, readings are
        added until the standard error is small or FORCE_MAX_SAMPLES are taken; with `verify_actions`, a
        load too small to be an object means it slipped out: it is picked up again and weighed again."""
        assert self.world is not None
        guards = self.safeguards
        call = f"measure_weight({p.label or 'patch'})"
        for attempt in range(2):
            readings = []
            while True:
                for _ in range(self.FORCE_SAMPLES):
                    self.world.step(self.FORCE_SAMPLE_S)
                    # signed: a held load pulls down (world -z); folding each noisy reading about zero
                    # would bias a light object upward by as much as the noise
                    readings.append(-float(self.world.read_force()[2]))
                mean = sum(readings) / len(readings)
                error = _std(readings) / math.sqrt(len(readings))
                small = error <= max(self.FORCE_RESOLUTION_N, 0.01 * mean)
                if not guards.on("remeasure") or small or len(readings) >= self.FORCE_MAX_SAMPLES:
                    break
            if guards.on("remeasure") and len(readings) > self.FORCE_SAMPLES:
                guards.note("remeasure", call, "caught", f"{len(readings)} force readings for {mean:.3f} N")
            empty = self._gripper_empty()
            if not guards.on("verify_actions") or (mean > 0.05 and not empty) or attempt == 1:
                # a weight is never negative: a mean below zero is zero within its error
                return max(mean, 0.0), max(error, self.FORCE_RESOLUTION_N), len(readings)
            why = "the gripper has closed on nothing" if empty else f"no load ({mean:.3f} N)"
            guards.note("verify_actions", call, "caught", f"{why}: it slipped; lifting it again")
            self.put_down()
            self.go_to_object(p)
            self.pick_up(p)
        raise AssertionError("unreachable")

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
        p = check_patch(patch, ImagePatch, "patch", "uncertainty")
        m = next((m for m, q in reversed(self._measured) if q is p or q.same_object(p)), None)
        if m is None:
            raise PreconditionError(
                f"robot.uncertainty() has no measurement of {p.label or 'this patch'} yet",
                "call robot.measure_distance(patch) or robot.measure_weight(patch) first",
            )
        return m.uncertainty

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
        self._near = self._aimed = None

    def go_to_object(self, patch: ImagePatch) -> None:
        """Drives the robot next to the object in `patch`, close enough to pick it up.

        >>> # bring the robot to the fridge
        >>> def execute_command(image, robot):
        >>>     fridge = image.find("fridge")[0]
        >>>     robot.go_to_object(fridge)
        >>>     return fridge
        """
        p, target = self._target(patch, "go_to_object")
        if self._arranging and self.held is not None and not self.held.same_object(p):
            # the paper's programs go on to the next object holding the last (their API has no put_down):
            # what they do there moves the robot itself (a pick-up puts the held object down first and
            # comes here, put_on reaches its receptacle), and driving with a load in view loses the target
            self._near = self._aimed = None
            return
        tries = self.APPROACH_TRIES if self.safeguards.on("verify_actions") else 1
        for attempt in range(tries):
            try:
                self.controller.approach(target)
                break
            except ControlError as exc:
                if attempt + 1 == tries or exc.reason not in RETRY_FROM_HERE:
                    raise
                call = f"go_to_object({p.label or 'patch'})"
                # from where it stopped, the robot sees the object anew: approach what it sees now
                fresh = self._seen_from_here(p, target)
                how = "from a new look at it" if fresh is not target else "again"
                self.safeguards.note("verify_actions", call, "caught", f"{exc.message}; trying {how}")
                target = fresh
        self._near = p
        self._aimed = None

    def _seen_from_here(self, p: ImagePatch, target: Target) -> Target:
        """The object of `p` as the camera sees it from where the robot stands now: centred on it, the
        detection of its name nearest the image centre; `target` itself when it cannot be seen again."""
        try:
            self.controller.focus_on(target)
            seen = self._reacquire(p, by_id=False)  # what the camera sees there, not what the id says
        except (ControlError, UnsupportedAction):
            return target
        if seen is None:
            return target
        return Target(
            box=seen.box, capture=seen.capture, object_id=p.object_id, label=p.label, find=target.find
        )

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
        if self.held is not None and self._arranging:
            if self.held.same_object(p):
                return
            self.put_down()
        if self.held is not None:
            raise PreconditionError(
                "robot.pick_up() needs an empty gripper, and the robot holds "
                f"{self.held.label or 'an object'}",
                "call robot.put_down() first",
            )
        if (self._near is None or not self._near.same_object(p)) and self._arranging:
            self.go_to_object(p)
        if self._near is None or not self._near.same_object(p):
            raise PreconditionError(
                f"robot.pick_up() needs the robot next to {target.describe()}",
                "call robot.go_to_object(patch) right before robot.pick_up(patch)",
            )
        tries = self.GRASP_TRIES if self.safeguards.on("verify_actions") else 1
        seen_first = target
        for attempt in range(tries):
            if "force" in self.sensors:
                assert self.world is not None
                self.world.tare_force()  # zero with the gripper empty, so a later reading is the load alone
            try:
                self.controller.pick_up(target)
                self._check_held(p, target, seen_first)
                break
            except ControlError as exc:
                if attempt + 1 == tries or exc.reason is not Failure.GRASP_FAILED:
                    raise
                call = f"pick_up({p.label or 'patch'})"
                self.safeguards.note("verify_actions", call, "caught", f"{exc.message}; trying again")
                target = self._seen_from_here(p, target)  # a failed grasp may have moved it
                self.controller.approach(target)
        self.held = p
        self._aimed = None

    def _check_held(self, p: ImagePatch, target: Target, seen_first: Target) -> None:
        """With `verify_actions`, where the controller can look: the object lifted must be the one meant (its
        name is seen rising with the gripper). When another object was lifted, it is put back and the grasp
        counts as failed, to be tried again; when the camera cannot tell, the grasp stands."""
        check = getattr(self.controller, "check_held", None)
        if check is None or not self.safeguards.on("verify_actions"):
            return
        verdict, detail = check(target, seen_first)
        call = f"pick_up({p.label or 'patch'})"
        if verdict is True:
            self.safeguards.note("verify_actions", call, "confirmed", detail)
        if verdict is not False:
            return
        self.controller.put_down()
        raise ControlError(
            f"grasp failed: it lifted another object than {target.describe()} and put it back: {detail}",
            "call robot.go_to_object(patch) again and retry",
            reason=Failure.GRASP_FAILED,
        )

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
        self.activity = "putting down " + (
            object_name(self.held.object_id, self.held.label) if self.held is not None else "nothing"
        )
        if self.held is None:
            raise PreconditionError(
                "robot.put_down() needs an object in the gripper, and it is empty",
                "call robot.pick_up(patch) before robot.put_down()",
            )
        self.controller.put_down()
        self.held = self._aimed = None

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
        _, target = self._target(patch, "put_on")
        if self.held is None:
            raise PreconditionError(
                "robot.put_on() needs an object in the gripper, and it is empty",
                "call robot.go_to_object(obj) and robot.pick_up(obj) first",
            )
        try:
            self.controller.put_on(target)
        except ControlError:
            if getattr(self.controller, "holding", self.held) is None:  # let go before the failure showed
                self.held = self._aimed = None
            raise
        self.held = self._aimed = None

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
        self._near = self._aimed = None


class _RobotWithSensors(Robot):
    """The session's robot as a program's `Robot(sensors=[...])` sees it: every action and measurement is
    the session robot's own (its state, its measurements), checked against the fewer sensors, and arranges
    what it needs first (see `Robot.from_program`)."""

    def __init__(self, robot: Robot, sensors: list[str]) -> None:  # noqa: D107 (no Robot.__init__: a view)
        self._robot = robot
        self._sensors = sensors

    def from_program(self, sensors: Sequence[str] | None = None) -> Robot:
        return self._robot.from_program(sensors)

    def called_on(self, patch: ImagePatch) -> None:
        self._robot.called_on(patch)


def _through_view(name: str) -> Any:
    robot_method = getattr(Robot, name)

    def method(self: _RobotWithSensors, *args: Any, **kwargs: Any) -> Any:
        robot = self._robot
        given, arranging = robot._sensors, robot._arranging
        robot._sensors = self._sensors  # the session robot checks the view's sensors for this call
        robot._arranging = True  # and does what the call needs first, as the paper's robot did
        try:
            return getattr(robot, name)(*args, **kwargs)
        finally:
            robot._sensors, robot._arranging = given, arranging

    method.__name__ = name
    method.__doc__ = robot_method.__doc__
    method.__signature__ = inspect.signature(robot_method)  # type: ignore[attr-defined]
    return method


for _name in Robot.OWN_METHODS:
    setattr(_RobotWithSensors, _name, _through_view(_name))


def _sensor_method(sensor: Sensor, sense: Sense) -> Callable[..., float]:
    """The Robot method a program calls to read `sense` (`robot.measure_temperature(patch)`), documented by
    the sense's own docstring; what it does is `Robot._sense`."""

    def method(self: Robot, patch: ImagePatch) -> float:
        return self._sense(sensor, sense, patch)

    method.__name__ = method.__qualname__ = sense.method
    method.__doc__ = sensor_method_doc(sensor, sense)
    method.__annotations__ = {"patch": "ImagePatch", "return": "float"}
    method.sensor_name = sensor.name  # type: ignore[attr-defined]
    method.sense = sense  # type: ignore[attr-defined]
    return method


def _install_sensor_methods() -> list[str]:
    """Give Robot (and the view a program's `Robot(sensors=...)` makes) a method for each registered sense
    read through `read_sensor` (the senses of a sensor with a `capability` have Robot's own methods), once;
    the names, in the registry's order. A sense whose method name Robot has already (a method, an
    attribute) is a `ConfigError`."""
    names = []
    current = {sense.method: sense for sensor, sense in senses() if sensor.capability is None}
    for cls in (Robot, _RobotWithSensors):  # a sensor taken out of the registry takes its method along
        for name, value in list(vars(cls).items()):
            if getattr(value, "sensor_name", None) is not None and current.get(name) is not value.sense:
                delattr(cls, name)
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
            view = _through_view(sense.method)
            view.sensor_name, view.sense = sensor.name, sense
            setattr(_RobotWithSensors, sense.method, view)
        elif taken or getattr(have, "sensor_name", None) != sensor.name:
            raise ConfigError(
                f"the {sensor.name} sensor names its method robot.{sense.method}, which Robot has already",
                "give the sense another method name (Sense(method=...))",
            )
        names.append(sense.method)
    return names


_SAME_BOX = 0.5
"""Two boxes of one image that overlap this much (IoU) show one object: a name and a patch found under
another word meet there when the detector gives no ids."""


def _one_of(patches: Sequence[ImagePatch], method: str) -> ImagePatch:
    """The one patch of a list `image.find` returned, passed where a patch belongs; none or several are
    refused, naming them."""
    if len(patches) == 1:
        return patches[0]
    if not patches:
        raise ApiArgumentError(
            f"robot.{method}() got an empty list: image.find found nothing there",
            "check the list before acting (if patches: ...), or find the object under another name",
        )
    seen = ", ".join(_named(p) for p in patches[:4]) + (", ..." if len(patches) > 4 else "")
    raise ApiArgumentError(
        f"robot.{method}() got a list of {len(patches)} patches ({seen}) and acts on one object",
        f"pass the one you mean: patches[0], max(patches, key=...), or {method}(patch) in a loop over them",
    )


def _named(patch: ImagePatch) -> str:
    """A patch as an answer names it: its label, its id where the detector gives one, and its box (two
    objects found under one word, "object", are told apart by where they are)."""
    ident = f" ({patch.object_id})" if patch.object_id else ""
    box = ", ".join(str(round(v)) for v in patch.box)
    return f"the {patch.label or 'object'}{ident} at [{box}]"


def _neighbours(
    values: list[tuple[float, float, ImagePatch]], me: tuple[float, float, ImagePatch]
) -> list[tuple[float, float, ImagePatch]]:
    """The measured objects next to `me` in order of value: the one the choice was made against."""
    ranked = sorted(values, key=lambda v: v[0])
    i = next(k for k, v in enumerate(ranked) if v is me)
    return [ranked[k] for k in (i - 1, i + 1) if 0 <= k < len(ranked)]


def _std(values: Sequence[float]) -> float:
    if len(values) < 2:
        return 0.0
    mean = sum(values) / len(values)
    return math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1))


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
