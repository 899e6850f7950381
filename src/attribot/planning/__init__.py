"""Planners turn a query into a program: `llm` (any OpenAI-compatible endpoint) and `rules` (offline).

`build_planner(name, settings)` gives a planner; `solve(planner, request, execute, max_tries)` runs the
plan -> execute -> feedback loop. The planners register themselves in `PLANNERS` when first looked up.
"""

from attribot.planning.base import (
    ENTRY_POINT,
    PLANNERS,
    Attempt,
    NoProgram,
    Plan,
    Planner,
    PlanRequest,
    RunError,
    SolveResult,
    build_planner,
    check_query,
    solve,
)

__all__ = [
    "ENTRY_POINT",
    "PLANNERS",
    "Attempt",
    "NoProgram",
    "Plan",
    "Planner",
    "PlanRequest",
    "RunError",
    "SolveResult",
    "build_planner",
    "check_query",
    "solve",
]
