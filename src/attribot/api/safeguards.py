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

from attribot.errors import InputError

__all__ = ["MECHANISMS", "CheckEvent", "Safeguards", "parse_checks"]

MECHANISMS: tuple[str, ...] = (
    "look_again",
    "look_harder",
    "verify_actions",
    "remeasure",
    "confidence",
    "reset",
)


class CheckEvent(BaseModel):
    """One thing a mechanism did: `caught` an error, `confirmed` a result, or left it `unsettled`."""

    model_config = ConfigDict(frozen=True)

    mechanism: str
    call: str
    outcome: Literal["confirmed", "caught", "unsettled"]
    detail: str


class Safeguards:
    """Which mechanisms are on, and the log of what they did."""

    def __init__(self, enabled: str | Iterable[str] = MECHANISMS) -> None:
        self.enabled = frozenset(parse_checks(enabled if isinstance(enabled, str) else list(enabled)))
        self.events: list[CheckEvent] = []

    def on(self, mechanism: str) -> bool:
        return mechanism in self.enabled

    def note(
        self, mechanism: str, call: str, outcome: Literal["confirmed", "caught", "unsettled"], detail: str
    ) -> None:
        self.events.append(CheckEvent(mechanism=mechanism, call=call, outcome=outcome, detail=detail))


def parse_checks(spec: str | list[str] | tuple[str, ...] | None) -> tuple[str, ...]:
    """The mechanisms named by `spec`: "all" (default), "none", names, and "-name" to leave one out
    ("all,-look_again"), comma-separated or as a list."""
    if spec is None:
        spec = "all"
    parts = [p.strip() for p in spec.split(",")] if isinstance(spec, str) else list(spec)
    chosen: list[str] = []
    for part in (p for p in parts if p):
        drop = part.startswith("-")
        name = part.lstrip("-+").replace("-", "_")
        names = list(MECHANISMS) if name == "all" else [] if name == "none" else [name]
        for n in names:
            if n not in MECHANISMS:
                raise InputError(
                    f"unknown check {part!r}",
                    f"choose from: all, none, {', '.join(MECHANISMS)} (prefix - to leave one out)",
                )
            if drop and n in chosen:
                chosen.remove(n)
            elif not drop and n not in chosen:
                chosen.append(n)
    return tuple(n for n in MECHANISMS if n in chosen)
