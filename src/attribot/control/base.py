"""The controller interface that `attribot.api.Robot` delegates its actions to.

A controller is bound to one world or robot and turns a high-level action on a target seen in a camera
image ("focus on this box", "go to this object") into motion. It knows nothing of perception models or
programs: it receives a `Target`, i.e. a box in the pixels of one camera capture plus what was known when
that image was taken (intrinsics, head angles, base pose, the world's object id).

What a controller cannot do honestly it refuses with `UnsupportedAction` naming the action; it never
returns a made-up value. `UnsupportedController` refuses everything and is the base of the others.

This module sits in the `control` layer, below `embodiments`: the world is passed in as any object with
the methods of `attribot.embodiments.base.Embodiment` that a controller uses (duck-typed on purpose).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, Protocol, runtime_checkable

from attribot.control.body import CameraPose
from attribot.errors import AttribotError, UnsupportedAction
from attribot.frame import CameraInfo
from attribot.registry import Registry

__all__ = [
    "Capture",
    "Target",
    "Controller",
    "ControlError",
    "Failure",
    "RETRY_FROM_HERE",
    "UnsupportedController",
    "CONTROLLERS",
    "build_controller",
    "not_available",
    "angle_close",
]


class Failure(StrEnum):
    """Why a motion failed, typed, so that the caller decides what to do next without reading the message."""

    TARGET_LOST = "target lost"  # the camera no longer sees what it was heading for
    NOT_REACHABLE = "not reachable"  # no free way there, or out of the arm's reach from here
    NOT_CONVERGED = "did not converge"  # the base did not arrive in time
    BLOCKED = "blocked"  # something stopped the base on its way
    GRASP_FAILED = "grasp failed"  # the gripper closed on nothing, or lost what it lifted
    OTHER = "other"


RETRY_FROM_HERE = frozenset(
    {Failure.TARGET_LOST, Failure.NOT_REACHABLE, Failure.NOT_CONVERGED, Failure.BLOCKED}
)
"""Approach failures another try from where the robot now stands can mend (a new view, another path)."""


class ControlError(AttribotError):
    """A motion was attempted and did not succeed (a joint did not settle, a grasp closed on nothing);
    `reason` says why, typed (`Failure`)."""

    recoverable = True  # a program may catch it as ActionFailed and go on with the next object

    def __init__(self, message: str, fix: str | None = None, *, reason: Failure = Failure.OTHER) -> None:
        super().__init__(message, fix)
        self.reason = reason


@dataclass(frozen=True)
class Capture:
    """What was known when one camera image was taken, so that a box in it can be acted on later.

    index: a counter of captures of one robot (0, 1, ...). camera: the pinhole intrinsics, or None for a
    still image with unknown optics. head: `(pan, tilt)` radians of the camera head at capture, or None
    (no head). base: `(x, y, yaw)` world pose of the base at capture, metres and radians, or None. view:
    where the camera was and looked in the base frame, or None where the robot does not state its body.
    arm: the arm's `(lift, extension)` at capture, or None: where a camera riding on the arm was put.
    """

    index: int
    camera: CameraInfo | None = None
    head: tuple[float, float] | None = None
    base: tuple[float, float, float] | None = None
    depth: Any = field(default=None, compare=False, repr=False)
    """The frame's depth image (float32 metres along the optical axis), or None: where a box's object is."""
    view: CameraPose | None = None
    arm: tuple[float, float] | None = None


@dataclass(frozen=True)
class Target:
    """A box to act on: xyxy pixels (origin top-left, y down) of the capture it was seen in.

    object_id is the world's id of the detected object when the detector knew it (simulator oracle); only
    the privileged controller may use it.
    """

    box: tuple[float, float, float, float]
    capture: Capture
    object_id: str | None = None
    label: str = ""
    find: Callable[[Any], list[tuple[float, float, float, float]]] | None = field(
        default=None, compare=False, repr=False
    )
    """Finds the target's kind in a new frame with the configured detector (xyxy boxes): how a
    perception-driven controller sees it again. None when the target has no name to look for."""
    by_depth: bool = False
    """Taken where the detector did not see its name surely (a faint box, elimination: depth saw it stand):
    a controller that does not see it again acts on where depth placed it."""

    @property
    def center(self) -> tuple[float, float]:
        """Centre pixel `(u, v)` of the box, y down."""
        x0, y0, x1, y1 = self.box
        return (x0 + x1) / 2.0, (y0 + y1) / 2.0

    def describe(self) -> str:
        """A short name for messages: the label and the id when known."""
        name = self.label or "object"
        return f"{name} ({self.object_id})" if self.object_id else name


@runtime_checkable
class Controller(Protocol):
    """Turns the Robot's actions into motion of one world or robot.

    Every method either completes the action (returning once the world has settled) or raises an
    `AttribotError`: `UnsupportedAction` when this controller cannot do it in this world, `ControlError`
    when it tried and failed.
    """

    name: str

    def focus_on(self, target: Target) -> None:
        """Turn the camera so that the centre of the image falls on the target's centre."""

    def go_to_coords(self, target: Target) -> None:
        """Drive towards the point of the image at the target's centre (a zero-size box)."""

    def approach(self, target: Target) -> None:
        """Drive to within reach of the target object."""

    def pick_up(self, target: Target) -> None:
        """Grasp and lift the target object, which must be within reach."""

    def put_down(self) -> None:
        """Put the held object back down where it was picked up."""

    def put_on(self, target: Target) -> None:
        """Place the held object on top of the target object."""

    def push(self, target: Target) -> None:
        """Push the target object away from the robot."""


def not_available(action: str, world: str, why: str = "") -> UnsupportedAction:
    """The one wording of "this world cannot do that yet", with the reason when there is one."""
    reason = f": {why}" if why else ""
    return UnsupportedAction(
        f"robot action {action!r} is not available in this world ({world}){reason}",
        "write the program without it, or run with a controller that supports it (--controller servo, "
        "in a world that gives depth or a distance sensor, a base and an arm)",
    )


@dataclass
class UnsupportedController:
    """A controller that can do nothing: every action raises `UnsupportedAction` naming it.

    Used for still images (no world at all) and as the base class of partial controllers.
    """

    world: Any = None
    name: str = "none"
    why: str = ""
    _world_name: str = field(init=False, default="")

    def __post_init__(self) -> None:
        self._world_name = getattr(self.world, "name", None) or "a still image, no robot"

    def _refuse(self, action: str) -> UnsupportedAction:
        return not_available(action, self._world_name, self.why)

    def focus_on(self, target: Target) -> None:
        raise self._refuse("focus_on_patch")

    def go_to_coords(self, target: Target) -> None:
        raise self._refuse("go_to_coords")

    def approach(self, target: Target) -> None:
        raise self._refuse("go_to_object")

    def pick_up(self, target: Target) -> None:
        raise self._refuse("pick_up")

    def put_down(self) -> None:
        raise self._refuse("put_down")

    def put_on(self, target: Target) -> None:
        raise self._refuse("put_on")

    def push(self, target: Target) -> None:
        raise self._refuse("push")


ControllerFactory = Callable[[Any], Controller]

CONTROLLERS: Registry[ControllerFactory] = Registry(
    "controller", homes={"default": "attribot.control.pointing", "servo": "attribot.control.servo"}
)
"""Controller factories: under an embodiment's name (`Embodiment.name`) its default controller, "default"
for the others, and by their own names the controllers a user can choose (`--controller servo`). A world's
own controller registers from the world's package (e.g. `attribot.embodiments.mujoco_control`), since this
layer knows no world."""


def build_controller(world: Any, choice: str | None = None) -> Controller:
    """The controller for `world`: `choice` when given (a registered name), else the one registered under
    the world's name, else "default", else none. `world` None (a still image) gets an
    `UnsupportedController`."""
    if world is None:
        return UnsupportedController(None, why="the query runs on a still image")
    if choice is not None:
        return CONTROLLERS.get(choice)(world)
    name = getattr(world, "name", "")
    key = name if name in CONTROLLERS else "default"
    if key not in CONTROLLERS:
        return UnsupportedController(world)
    return CONTROLLERS.get(key)(world)


def angle_close(a: float, b: float, tol: float) -> bool:
    """True when two angles (radians) differ by at most `tol`, modulo 2*pi."""
    return abs(math.remainder(a - b, math.tau)) <= tol
