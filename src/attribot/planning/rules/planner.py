"""The rules planner as a planner (`attribot.planning.base.Planner`), registered as "rules"."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from attribot.planning.base import PLANNERS, Attempt, Plan, PlanRequest
from attribot.planning.rules import parse_query, write_program

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = ["RulesPlanner"]


class RulesPlanner:
    """The offline, deterministic planner. It ignores feedback: the same query gives the same program."""

    name = "rules"
    max_tries = 1

    def plan(self, request: PlanRequest, feedback: Sequence[Attempt] = ()) -> Plan:
        # the request's query was checked on its way here (`PlanRequest`): it is read as it is
        parsed = parse_query(request.query, checked=True)
        return Plan(program=write_program(parsed, request.query, request.sensors, request.embodied))


@PLANNERS.register("rules")
def _build_rules(settings: Settings) -> RulesPlanner:
    return RulesPlanner()
