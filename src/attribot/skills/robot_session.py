"""The host side of a program's robot: one `RobotSession` per session, holding the state a program's
calls act on and doing what they ask (`attribot.api.robot.Robot` is the facade programs see).
"""

from __future__ import annotations

from attribot.skills.acting import Acting
from attribot.skills.measuring import Measuring

__all__ = ["RobotSession"]


class RobotSession(Measuring, Acting):
    """A robot session: its state and core (`attribot.skills.robot_core`), its readings
    (`attribot.skills.measuring`) and its actions (`attribot.skills.acting`)."""
