"""The MuJoCo world's controllers: `servo` (perception alone, `attribot.control.servo`) by default, and
`privileged`, geometric pointing plus PRIVILEGED scripted manipulation, to compare against.

Approaching, picking up and putting back use `attribot.sim.scripted`, which reads the simulator's state
(the object's true pose, found by the object id of the detection) to compute targets and then moves the
robot with its ordinary commands. That is privileged information a real robot does not have, exactly as
the AI2-THOR actions of the paper were; the backend name says so ("sim-privileged") and it shows up in
every answer that names its backends. Navigating to image coordinates, placing on another object and
pushing are not scripted and raise `UnsupportedAction` (the servo controller does them).

It lives beside the MuJoCo embodiment (not in `control/`, which knows no simulator) and registers the
world's default in `CONTROLLERS` under the world's name when `attribot.embodiments.mujoco` is imported.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType

from attribot.control.base import CONTROLLERS, ControlError, Target, not_available
from attribot.control.pointing import PointingController
from attribot.control.servo import ServoController
from attribot.errors import UnsupportedAction

__all__ = ["SimController"]


def _scripted() -> ModuleType:
    # imported on use, so that building the controller stays cheap
    from attribot.sim import scripted

    return scripted


@dataclass
class SimController(PointingController):
    """Pointing by geometry; go_to_object / pick_up / put_down by privileged simulator scripts."""

    name: str = "sim-privileged"

    def _object_id(self, target: Target, action: str) -> str:
        body = getattr(getattr(self.world, "sim", None), "body", None)
        if body is not None and not body.scripted:
            raise not_available(
                action,
                self._world_name,
                f"the privileged scripts cannot move {body.called}: it acts by perception "
                "(--controller servo, its default)",
            )
        if not target.object_id:
            raise UnsupportedAction(
                f"robot action {action!r} in the simulator needs the world's id of {target.describe()}, "
                "and the detector that found it does not give one",
                "use the oracle detector (--detector oracle) in the simulator",
            )
        return target.object_id

    def approach(self, target: Target) -> None:
        _scripted().approach_object(self.world, self._object_id(target, "go_to_object"))

    def pick_up(self, target: Target) -> None:
        if not _scripted().pick_object(self.world, self._object_id(target, "pick_up")):
            raise ControlError(
                f"the gripper closed on nothing when picking up {target.describe()}",
                "call robot.go_to_object(patch) right before robot.pick_up(patch); the object may not be "
                "pickable (too large or fixed)",
            )

    def put_down(self) -> None:
        _scripted().place_back(self.world)

    def put_on(self, target: Target) -> None:
        raise not_available("put_on", self._world_name, "placing on another object is not scripted yet")

    def push(self, target: Target) -> None:
        raise not_available("push", self._world_name, "pushing is not scripted yet")

    def go_to_coords(self, target: Target) -> None:
        raise not_available(
            "go_to_coords", self._world_name, "navigating to image coordinates needs visual servoing"
        )


@CONTROLLERS.register("privileged", aliases=("sim-privileged",))
def _privileged(world: object) -> SimController:
    return SimController(world)


@CONTROLLERS.register("mujoco")
def _mujoco(world: object) -> ServoController:
    return ServoController(world)
