"""The actions of a robot session: driving, going to an object, picking it up (checking that the right
object was lifted), putting it down or on another, pushing; `verify_actions` tries again where a new view
can mend a failure."""

from __future__ import annotations

from typing import ClassVar

from attribot.control.base import (
    RETRY_FROM_HERE,
    ControlError,
    Failure,
    Target,
)
from attribot.errors import UnsupportedAction
from attribot.skills.checks import check_number
from attribot.skills.errors import ApiArgumentError
from attribot.skills.preconditions import Verdict
from attribot.skills.robot_core import SessionCore, object_name
from attribot.skills.sighting import Sighting

__all__ = ["Acting"]


class Acting:
    """The actions of a robot session (see the module docstring): held by the session, they act on and
    keep its state through its `core`."""

    GRASP_TRIES: ClassVar[int] = 4
    APPROACH_TRIES: ClassVar[int] = 3

    def __init__(self, core: SessionCore) -> None:
        self.core = core

    def go_to_coords(self, x: float, y: float) -> None:
        """The session's side of `Robot.go_to_coords` (its docstring is the one programs read)."""
        fx, fy = check_number(x, "x", "go_to_coords"), check_number(y, "y", "go_to_coords")
        if self.core.capture is None or self.core.world is None:
            raise UnsupportedAction(
                "robot.go_to_coords() is not available here: "
                "there is no camera image of a world to navigate in",
                "run the query in a world (--layout) to use robot actions",
            )
        cam = self.core.capture.camera
        w, h = (cam.width, cam.height) if cam is not None else (None, None)
        if w is not None and h is not None and not (0 <= fx <= w and 0 <= fy <= h):
            raise ApiArgumentError(
                f"go_to_coords({fx:g}, {fy:g}) lies outside the {w}x{h} image",
                "pass a point inside the image, e.g. a patch's horizontal_center and vertical_center",
            )
        v = (h - fy) if h is not None else -fy  # y upward -> pixel row
        self.core.controller.go_to_coords(
            Target(box=(fx, v, fx, v), capture=self.core.capture, label="point")
        )
        self.core.near = self.core.aimed = None

    def go_to_object(self, patch: Sighting) -> None:
        """The session's side of `Robot.go_to_object` (its docstring is the one programs read)."""
        p, target = self.core.object_of_call(patch, "go_to_object")
        if self.core.arranging and self.core.held is not None and not self.core.held.same_object(p):
            # the paper's programs go on to the next object holding the last (their API has no put_down):
            # what they do there moves the robot itself (a pick-up puts the held object down first and
            # comes here, put_on reaches its receptacle), and driving with a load in view loses the target
            self.core.near = self.core.aimed = None
            self.core.note(
                f"did not drive yet, holding {self.core.held_name()}: the next call moves the robot"
            )
            return
        if self.core.check("go_to_object", p) is Verdict.ALREADY:
            self.core.note("already holds it: stayed where it is")
            return
        tries = self.core.safeguards.verify_actions.tries(self.APPROACH_TRIES)
        for attempt in range(tries):
            try:
                self.core.controller.approach(target)
                break
            except ControlError as exc:
                if attempt + 1 == tries or exc.reason not in RETRY_FROM_HERE:
                    raise
                call = f"go_to_object({p.label or 'patch'})"
                # from where it stopped, the robot sees the object anew: approach what it sees now
                fresh = self._seen_from_here(p, target)
                how = "from a new look at it" if fresh is not target else "again"
                self.core.safeguards.verify_actions.note(call, "caught", f"{exc.message}; trying {how}")
                target = fresh
        self.core.near = p
        self.core.aimed = None

    def _seen_from_here(self, p: Sighting, target: Target) -> Target:
        """The object of `p` as the camera sees it from where the robot stands now: centred on it, the
        detection of its name nearest the image centre; `target` itself when it cannot be seen again."""
        try:
            self.core.controller.focus_on(target)
            seen = self.core.reacquire(p, by_id=False)  # what the camera sees there, not what the id says
        except (ControlError, UnsupportedAction):
            return target
        if seen is None:
            return target
        return Target(
            box=seen.box, capture=seen.capture, object_id=p.object_id, label=p.label, find=target.find
        )

    def pick_up(self, patch: Sighting) -> None:
        """The session's side of `Robot.pick_up` (its docstring is the one programs read)."""
        p, target = self.core.object_of_call(patch, "pick_up")
        if self.core.arranging and self.core.held is not None and not self.core.held.same_object(p):
            self.core.note(f"put {self.core.held_name()} down first")
            self.put_down()
        if (
            self.core.arranging
            and self.core.held is None
            and (self.core.near is None or not self.core.near.same_object(p))
        ):
            self.core.note("went to it first")
            self.go_to_object(p)
        if self.core.check("pick_up", p) is Verdict.ALREADY:
            self.core.note("already holds it")
            return
        tries = self.core.safeguards.verify_actions.tries(self.GRASP_TRIES)
        seen_first = target
        for attempt in range(tries):
            if "force" in self.core.sensors:
                assert self.core.world is not None
                # zero with the gripper empty, so that a later reading is the load alone
                self.core.world.tare_force()
            try:
                self.core.controller.pick_up(target)
                self._check_held(p, target, seen_first)
                break
            except ControlError as exc:
                if attempt + 1 == tries or exc.reason is not Failure.GRASP_FAILED:
                    raise
                call = f"pick_up({p.label or 'patch'})"
                self.core.safeguards.verify_actions.note(call, "caught", f"{exc.message}; trying again")
                target = self._seen_from_here(p, target)  # a failed grasp may have moved it
                self.core.controller.approach(target)
        self.core.held = p
        self.core.aimed = None

    def _check_held(self, p: Sighting, target: Target, seen_first: Target) -> None:
        """With `verify_actions`, where the controller can look: the object lifted must be the one meant (its
        name is seen rising with the gripper). When another object was lifted, it is put back and the grasp
        counts as failed, to be tried again; when the camera cannot tell, the grasp stands."""
        check = getattr(self.core.controller, "check_held", None)
        call = f"pick_up({p.label or 'patch'})"
        verdict, detail = self.core.safeguards.verify_actions.held(check, target, seen_first, call)
        if verdict is not False:
            return
        self.core.controller.put_down()
        raise ControlError(
            f"grasp failed: it lifted another object than {target.describe()} and put it back: {detail}",
            "call robot.go_to_object(patch) again and retry",
            reason=Failure.GRASP_FAILED,
        )

    def put_down(self) -> None:
        """The session's side of `Robot.put_down` (its docstring is the one programs read)."""
        self.core.activity = "putting down " + (
            object_name(self.core.held.object_id, self.core.held.label)
            if self.core.held is not None
            else "nothing"
        )
        self.core.check("put_down", None)
        self.core.controller.put_down()
        self.core.held = self.core.aimed = None

    def put_on(self, patch: Sighting) -> None:
        """The session's side of `Robot.put_on` (its docstring is the one programs read)."""
        p, target = self.core.object_of_call(patch, "put_on")
        if self.core.check("put_on", p) is Verdict.PUT_BACK:
            # put_on(the object held): "put it back", as programs written from the authors' prompt, which
            # has no put_down, say it; putting an object on itself makes no sense
            self.core.note(f"{self.core.held_name()} is the object held: put it back where it was picked up")
            self.put_down()
            return
        try:
            self.core.controller.put_on(target)
        except ControlError:
            if (
                getattr(self.core.controller, "holding", self.core.held) is None
            ):  # let go before the failure showed
                self.core.held = self.core.aimed = None
            raise
        self.core.held = self.core.aimed = None

    def push(self, patch: Sighting) -> None:
        """The session's side of `Robot.push` (its docstring is the one programs read)."""
        p, target = self.core.object_of_call(patch, "push")
        self.core.check("push", p)
        self.core.controller.push(target)
        self.core.near = self.core.aimed = None
