"""Planners turn a query into a program: `llm` (any OpenAI-compatible endpoint) and `rules` (offline).

`build_planner(name, settings)` gives a planner; `solve(planner, request, execute, max_tries)` runs the
plan -> execute -> feedback loop. The planners register themselves in `PLANNERS` when first looked up.

The names below load `attribot.planning.base` (and with it the API) on first use, so that a module of this
package that needs none of it (the rules planner's reader) imports light.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
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


def __getattr__(name: str) -> Any:
    if name in __all__:
        from attribot.planning import base

        return getattr(base, name)
    raise AttributeError(f"module 'attribot.planning' has no attribute {name!r}")
