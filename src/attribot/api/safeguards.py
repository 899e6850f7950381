"""The mechanisms that catch perception, sensing and acting errors before they reach the answer.

Each is on by default, can be switched off on its own (for ablations: `--checks all,-look_again`), and
writes what it did into the answer's `checks` log, beside the trace:

- `look_again`: the first image is checked against views from other head poses (`attribot.api.looking`);
- `look_harder`: a find that comes back empty or unsure looks closer where depth sees objects stand, and
  sets aside a detection where depth sees nothing stand (`attribot.api.harder`; detectors that read pixels);
- `verify_actions`: a grasp that closed on nothing, slipped or lifted another object than the one meant
  is tried again; a distance reading is checked against the depth inside the object's box (the beam may
  have hit an edge or the wall behind);
- `remeasure`: readings are repeated and combined, each measurement with its uncertainty;
- `confidence`: a choice made by comparing measurements whose margin lies inside their uncertainty is
  measured again, and if still unsettled the answer says it cannot tell, naming both values;
- `reset`: a retry starts from the state the first try started from (the robot's pose, head and
  gripper, and the same first image).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Literal

from pydantic import BaseModel, ConfigDict

from attribot.mechanisms import MECHANISMS, Mechanism, parse_checks

__all__ = ["Mechanism", "MECHANISMS", "CheckEvent", "Safeguards", "parse_checks"]


class CheckEvent(BaseModel):
    """One thing a mechanism did: `caught` an error, `confirmed` a result, or left it `unsettled`."""

    model_config = ConfigDict(frozen=True)

    mechanism: Mechanism
    call: str
    outcome: Literal["confirmed", "caught", "unsettled"]
    detail: str


class Safeguards:
    """Which mechanisms are on, and the log of what they did."""

    def __init__(self, enabled: str | Iterable[str] = MECHANISMS) -> None:
        self.enabled = frozenset(parse_checks(enabled if isinstance(enabled, str) else list(enabled)))
        self.events: list[CheckEvent] = []

    def on(self, mechanism: Mechanism) -> bool:
        return mechanism in self.enabled

    def note(
        self,
        mechanism: Mechanism,
        call: str,
        outcome: Literal["confirmed", "caught", "unsettled"],
        detail: str,
    ) -> None:
        self.events.append(CheckEvent(mechanism=mechanism, call=call, outcome=outcome, detail=detail))
