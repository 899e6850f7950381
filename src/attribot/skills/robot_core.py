"""The host side of a robot session, its core: the state a program's robot acts on (the world, the
controller, what it holds, its measurements, its last look), how a call's patch or name becomes the object
acted on, what a call needs from the robot's sensors, looking (and looking harder), and focusing the camera
on an object. `attribot.skills.robot_session.RobotSession` is a core that holds its readings
(`attribot.skills.measuring.Measuring`) and its actions (`attribot.skills.acting.Acting`) as objects of
their own; `attribot.api.robot.Robot` is what programs see.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict

from attribot.boxes import iou, overlap_of_smaller
from attribot.control.base import (
    Capture,
    ControlError,
    Controller,
    Target,
    build_controller,
)
from attribot.control.candidates import Candidate
from attribot.control.focus import correct_aim
from attribot.control.sighting import Box, capture_now, reacquire
from attribot.embodiments.base import Embodiment
from attribot.errors import UnsupportedAction
from attribot.frame import Frame
from attribot.lexicon import GENERIC_NOUNS
from attribot.models.base import SURE_SCORE, Detection
from attribot.sensors import (
    GRAVITY,
    Sense,
    check_sensors,
    sense_of,
    sense_of_method,
    senses,
)
from attribot.skills.checks import check_patch, patch_named
from attribot.skills.errors import ApiArgumentError, MissingSensor
from attribot.skills.harder import acting_find, carried_back
from attribot.skills.looking import View
from attribot.skills.params import LOOK_HARDER
from attribot.skills.perception import Perception
from attribot.skills.preconditions import Dialect, State, Verdict, check_action
from attribot.skills.safeguards import Safeguards
from attribot.skills.sighting import Sighting

__all__ = ["SessionCore", "Measurement", "GRAVITY", "FULL", "OWN_REQUIRES", "object_name", "required_sensors"]


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
    box: tuple[float, float, float, float] | None = None  # the object's box when measured (pixels, y down)
    evidence: str | None = None  # what the object measured rests on (`attribot.models.base.Evidence`)

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


OWN_REQUIRES: dict[str, str] = {"focus_on_patch": "camera"}
"""The sensor each of the robot's own methods needs beyond the senses' (a sense's method needs its sensor)."""


def required_sensors() -> dict[str, str]:
    """The sensor each robot method needs (methods not listed need none): the robot's own, and each
    registered sense's method its sensor. What the prompt offers and what a call checks both read it."""
    return {**OWN_REQUIRES, **{sense.method: sensor.name for sensor, sense in senses()}}


class SessionCore:
    """The state and the core of a robot session (see the module docstring)."""

    FOCUS_CORRECTIONS: ClassVar[int] = 3
    FOCUS_TOL_PX: ClassVar[float] = 1.5
    GRIPPER_EMPTY_M: ClassVar[float] = 0.0003  # fingers closer than this hold nothing

    def __init__(
        self,
        sensors: Sequence[str] = ("camera",),
        world: Embodiment | None = None,
        controller: Controller | None = None,
        safeguards: Safeguards | None = None,
        patch_type: type[Sighting] = Sighting,
    ) -> None:
        """A robot session with `sensors` in `world` (None: a still image, every action refused), acting
        through `controller` (default: the one registered for the world, see attribot.control.base), with
        the error-catching mechanisms of `safeguards` (default: all on). Its looks are `patch_type`'s
        (`attribot.api.ImagePatch` for the robot programs see), and so are the patches its calls take."""
        self.patch_type = patch_type
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
        self.held: Sighting | None = None
        self.safeguards = safeguards if safeguards is not None else Safeguards()
        self.measurements: list[Measurement] = []
        self.measured: list[tuple[Measurement, Sighting]] = []
        self.capture: Capture | None = None
        self.near: Sighting | None = None  # what the robot stands next to, since it last drove
        self.aimed: Sighting | None = None  # what the camera was last centred on, since the robot moved
        self._captures = 0
        self._image: Sighting | None = None  # the last look: where an object's name is looked up
        self.activity = ""  # the action under way, naming its object ("weighing mug 0"): videos show it
        self.acting_on = ""  # the name of the object of that action
        self.acting_on_id: str | None = None  # and its detector id, when the detector gives one
        self._acted_on: list[Sighting] = []  # patches the program acted on, for names (paper dialect)
        # a call through the robot a program made (the paper's dialect): it arranges what an action or a
        # reading needs (turning to the object, going to it, picking it up) where this robot would refuse
        self.arranging = False
        self._notes: list[str] = []  # what the session did beyond the call itself (put back, arranged)

    @property
    def sensors(self) -> list[str]:
        """the robot's sensors, e.g. ["camera", "distance", "force"]"""
        return list(self._sensors)

    # ---- host side ---------------------------------------------------------------------------------
    def look(self, perception: Perception, survey: bool = True) -> Sighting:
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
            self.capture = Capture(index=self._captures, camera=camera, depth=frame.scene_depth)
        self._captures += 1
        self._image = self.patch_type(frame, perception, capture=self.capture)
        self._image.safeguards = self.safeguards
        if {"base", "pose"} <= caps and frame.depth is not None:
            self._image.nearer = self.safeguards.look_harder.nearer(self._nearer)
        if survey and {"head", "pose"} <= caps and frame.depth is not None:
            self._image.survey = self.safeguards.look_again.survey(self.world, View(frame, self.capture))
        self._acted_on = []
        self.aimed = None
        return self._image

    def _nearer(self, name: str, candidates: list[Candidate]) -> tuple[list[Detection], int]:
        """Host side, for `look_harder`: drive nearer to each candidate of the image in turn (at most its
        params' `nearer_visits`, stopping `nearer_m` from each), look for `name` there until it is seen on
        the candidate (carried back into the image): the candidate's box is then its box in the image; then
        drive back to where the robot was. Returns the detections in the image and the places visited."""
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
        params = getattr(self.safeguards.look_harder, "params", LOOK_HARDER)  # a plug-in may hold none
        try:
            for cand in candidates[: params.nearer_visits]:
                try:
                    look(Target(box=cand.box, capture=first), params.nearer_m)
                except (ControlError, UnsupportedAction):
                    continue  # no way there, or stopped on the way: the next place, and back from there
                visits += 1
                frame = world.observe()
                seen = capture_now(world, frame, -1, frame.camera or first.camera)
                here = [
                    det
                    for det in acting_find(detector, frame, name)
                    if (box := carried_back(det.box, frame, seen, first)) is not None
                    and overlap_of_smaller(box, cand.box) >= 0.3
                ]
                if here:
                    # the object is the candidate: what depth sees of it whole in the image (carried back,
                    # the detector's box is only the surface in its middle, a part of the object)
                    best = max(here, key=lambda d: d.score)
                    # a box seen nearer under the sure score is as faint as one in the image: in a room of
                    # things the detector cannot name, a feather seen nearer as a spoon at 0.13
                    seen_as = "seen nearer" if best.score >= SURE_SCORE else "faint box"
                    found.append(
                        Detection(box=cand.box, score=best.score, label=best.label, evidence=seen_as)
                    )
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

    def snapshot(self) -> Any:
        """Host side: the robot's state now (pose, head, arm, gripper), or None where the world cannot
        put it back."""
        return None if self.world is None else self.world.snapshot()

    def restore(self, snapshot: Any, image: Sighting) -> None:
        """Host side: back to `snapshot` with `image` as the camera's last look: how a retry starts from
        the state the first try started from."""
        assert self.world is not None
        self.world.restore(snapshot)
        self.held = None
        self.near = None
        self.aimed = None
        self._image = image
        self.capture = image.capture
        self._acted_on = []

    def called_on(self, patch: Sighting) -> None:
        """Host side: the program called one of this robot's methods on `patch` (`book_patch.pick_up("book")`,
        `apple_patch.measure_distance("desk")`), or named an object right after looking at `patch` (a loop
        over patches that asks each a question, then `go_to_object("object")`): a name in that call stands
        for it when it answers to the name (see `_named`), as for the latest object the program acted on."""
        if (
            isinstance(patch, self.patch_type)
            and patch.label
            and (not self._acted_on or self._acted_on[-1] is not patch)
        ):
            self._acted_on.append(patch)

    def take_notes(self) -> str | None:
        """Host side: what the session did beyond the last call itself ("put it back where it was picked
        up", "went to it first"), for the call's trace record; None when nothing. Emptied as it is read."""
        notes, self._notes = self._notes, []
        return "; ".join(notes) or None

    def note(self, text: str) -> None:
        """Keep what the session did beyond the call itself, for the call's trace record (`take_notes`)."""
        self._notes.append(text)

    @property
    def dialect(self) -> Dialect:
        """How the program calls this robot: its methods on the robot it was given (`robot.put_down()`), or
        as bare functions or on a `Robot(sensors=[...])` it made (`put_down()`), as the paper's prompt
        writes them. Refusals name the fix in these words."""
        return "paper" if self.arranging else "attribot"

    def check(self, method: str, p: Sighting | None, reading: str = "grasp") -> Verdict:
        """What `method` on `p` needs of the robot's state, checked before anything moves
        (`attribot.skills.preconditions.check_action`)."""
        state = State(held=self.held, near=self.near, dialect=self.dialect, aimed=self.aimed)
        return check_action(method, p, state, reading)

    def held_name(self) -> str:
        """What the gripper holds, as a caption names it ("nothing" when empty)."""
        held = self.held
        return "nothing" if held is None else object_name(held.object_id, held.label)

    def backend_name(self) -> str:
        """Host side: the controller's name, reported as the "robot" backend of an answer."""
        return str(getattr(self.controller, "name", type(self.controller).__name__))

    def need(self, method: str) -> None:
        """Refuse `method` (`MissingSensor`) when the robot, as the program sees it, lacks its sensor."""
        sensor = required_sensors().get(method)
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

    def _named(self, name: str, method: str) -> Sighting:
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
            seen = ", ".join(patch_named(p) for p in found[:4]) + (", ..." if len(found) > 4 else "")
            raise ApiArgumentError(
                f"robot.{method}({name!r}) is ambiguous: the robot's camera sees {len(found)} of them "
                f"({seen})",
                f"pass the patch you mean instead of its name, e.g. for patch in image.find({name!r}): ... "
                f"{method}(patch)",
            )
        return found[0]

    def object_of_call(self, patch: object, method: str) -> tuple[Sighting, Target]:
        """The object a call of `method` acts on (a patch, a name, the list `find` returned) and what a
        controller needs to act on it; noted as the action under way. Refused outside a world."""
        if isinstance(patch, str):
            patch = self._named(patch, method)
        elif isinstance(patch, list | tuple) and all(isinstance(p, self.patch_type) for p in patch):
            patch = _one_of(patch, method)  # the list find returned, as the paper's prompt passes it
        p = check_patch(patch, self.patch_type, "patch", method)
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

    def focus(self, patch: Sighting, target: Target) -> None:
        """Point the camera at `target`, then centre the object by what fresh images show
        (`attribot.control.focus.correct_aim`, up to FOCUS_CORRECTIONS times)."""
        self.controller.focus_on(target)
        self.aimed = patch
        assert self.world is not None  # _target checked it
        headless = "head" not in {str(c) for c in self.world.capabilities()}
        correct_aim(
            self.controller,
            lambda: self.reacquire(patch),
            self.FOCUS_CORRECTIONS,
            self.FOCUS_TOL_PX,
            headless=headless,
        )

    def reacquire(self, patch: Sighting, by_id: bool = True) -> Target | None:
        """The object of `patch` in a new camera image (`attribot.control.sighting.reacquire`): by world id
        when known (and `by_id`), else the detection of its name nearest the image centre. The camera has
        been aimed at it, so it is looked for as a controller looks (`acting_find`: the middle half first),
        not in every tile of the image."""
        label, world = patch.label, self.world
        if not label or world is None or "pose" not in {str(c) for c in world.capabilities()}:
            return None
        detector = patch.perception.detector

        def sightings(frame: Frame) -> list[tuple[Box, str | None]]:
            return [(d.box, d.object_id) for d in acting_find(detector, frame, label)]

        self._captures += 1
        return reacquire(world, sightings, label, patch.object_id, self._captures - 1, by_id)

    def focus_on_patch(self, patch: Sighting) -> None:
        """The session's side of `Robot.focus_on_patch` (its docstring is the one programs read)."""
        self.need("focus_on_patch")
        p, target = self.object_of_call(patch, "focus_on_patch")
        self.focus(p, target)

    def gripper_empty(self) -> bool:
        """The fingers have closed (almost) all the way: nothing is between them."""
        assert self.world is not None
        try:
            opening = self.world.joint_states().get("gripper")
        except UnsupportedAction:
            return False
        return opening is not None and float(opening) < self.GRIPPER_EMPTY_M

    def record(self, p: Sighting, **reading: Any) -> None:
        """Keep a reading of `p` (Measurement's fields) for the answer, and with its patch for `settle`."""
        m = Measurement(
            object_id=p.object_id, label=p.label, box=tuple(p.box), evidence=p.evidence, **reading
        )
        self.measurements.append(m)
        self.measured.append((m, p))


_SAME_BOX = 0.5
"""Two boxes of one image that overlap this much (IoU) show one object: a name and a patch found under
another word meet there when the detector gives no ids."""


def _one_of(patches: Sequence[Sighting], method: str) -> Sighting:
    """The one patch of a list `image.find` returned, passed where a patch belongs; none or several are
    refused, naming them."""
    if len(patches) == 1:
        return patches[0]
    if not patches:
        raise ApiArgumentError(
            f"robot.{method}() got an empty list: image.find found nothing there",
            "check the list before acting (if patches: ...), or find the object under another name",
        )
    seen = ", ".join(patch_named(p) for p in patches[:4]) + (", ..." if len(patches) > 4 else "")
    raise ApiArgumentError(
        f"robot.{method}() got a list of {len(patches)} patches ({seen}) and acts on one object",
        f"pass the one you mean: patches[0], max(patches, key=...), or {method}(patch) in a loop over them",
    )


def _camera_info(world: Embodiment) -> Any:
    try:
        return world.camera_info()
    except UnsupportedAction:
        return None


def _name_key(name: str) -> str:
    """An object's name as compared: lower case, no article, singular ("the Books" -> "book")."""
    text = _without_article(name.lower())
    return text[:-1] if text.endswith("s") and not text.endswith("ss") else text


def _without_article(name: str) -> str:
    """An object's name without the articles it opens with ("the red mug" -> "red mug"), as written."""
    words = name.split()
    while words and words[0].lower() in ("the", "a", "an"):
        words = words[1:]
    return " ".join(words)
