"""The host side of a program's robot: one `RobotSession` per session, holding the state a program's
calls act on and doing what they ask (`attribot.api.robot.Robot` is the facade programs see).
"""

from __future__ import annotations

from collections.abc import Sequence

from attribot.control.base import Controller
from attribot.embodiments.base import Embodiment
from attribot.sensors import Sense, Sensor
from attribot.skills.acting import Acting
from attribot.skills.measuring import Measuring
from attribot.skills.robot_core import SessionCore
from attribot.skills.safeguards import Safeguards
from attribot.skills.sighting import Sighting

__all__ = ["RobotSession"]


class RobotSession(SessionCore):
    """A robot session: its state and core (`attribot.skills.robot_core`), which holds its readings
    (`measuring`, an `attribot.skills.measuring.Measuring`) and its actions (`acting`, an
    `attribot.skills.acting.Acting`) and hands each call of the facade to the one that does it."""

    def __init__(
        self,
        sensors: Sequence[str] = ("camera",),
        world: Embodiment | None = None,
        controller: Controller | None = None,
        safeguards: Safeguards | None = None,
        patch_type: type[Sighting] = Sighting,
    ) -> None:
        """A robot session (`SessionCore`'s arguments), with its actions and readings."""
        super().__init__(sensors, world, controller, safeguards, patch_type)
        self.acting = Acting(self)
        self.measuring = Measuring(self, self.acting)

    # ---- the readings ------------------------------------------------------------------------------
    def settle(self, chosen: Sighting) -> str | None:
        return self.measuring.settle(chosen)

    def as_named(self, chosen: Sighting) -> tuple[Sighting, str] | None:
        return self.measuring.as_named(chosen)

    def measure_distance(self, patch: Sighting) -> float:
        return self.measuring.measure_distance(patch)

    def measure_weight(self, patch: Sighting) -> float:
        return self.measuring.measure_weight(patch)

    def measure_fullness(self, patch: Sighting) -> float:
        return self.measuring.measure_fullness(patch)

    def uncertainty(self, patch: Sighting) -> float:
        return self.measuring.uncertainty(patch)

    def _sense(self, sensor: Sensor, sense: Sense, patch: Sighting) -> float:
        return self.measuring._sense(sensor, sense, patch)

    # ---- the actions -------------------------------------------------------------------------------
    def go_to_coords(self, x: float, y: float) -> None:
        self.acting.go_to_coords(x, y)

    def go_to_object(self, patch: Sighting) -> None:
        self.acting.go_to_object(patch)

    def pick_up(self, patch: Sighting) -> None:
        self.acting.pick_up(patch)

    def put_down(self) -> None:
        self.acting.put_down()

    def put_on(self, patch: Sighting) -> None:
        self.acting.put_on(patch)

    def push(self, patch: Sighting) -> None:
        self.acting.push(patch)
