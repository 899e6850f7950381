"""The queries released with the seed paper (Mavrogiannis et al., ICRA 2025), shipped as package data.

One JSON object a line: `task` (the release's name for the query family, which is not one of the suite's
tasks: location, size, weight_image, weight_triplet_items_seen_by_vqa,
ai2thor_distance, ai2thor_weight_scene_items), `form` (superlative/absolute for size), `query`, and
task-specific fields. The O3 images they were written for are not released; use them as real phrasings.
"""

from __future__ import annotations

import json
from functools import cache
from importlib import resources

from pydantic import BaseModel, ConfigDict

__all__ = ["PaperQuery", "paper_queries", "released_families"]


class PaperQuery(BaseModel):
    """One released query; fields beyond these (image names, answers) are kept as extras."""

    model_config = ConfigDict(frozen=True, extra="allow")

    task: str
    form: str = "n/a"
    query: str | None = None  # absent where the row lists items instead (`items`)
    items: str | None = None


@cache
def _all() -> tuple[PaperQuery, ...]:
    text = resources.files("attribot.eval").joinpath("data/paper_queries.jsonl").read_text(encoding="utf-8")
    return tuple(PaperQuery.model_validate(json.loads(line)) for line in text.splitlines() if line.strip())


def released_families() -> list[str]:
    """The query families of the release (its `task` field, not the suite's tasks), in file order."""
    return list(dict.fromkeys(q.task for q in _all()))


def paper_queries(task: str | None = None) -> list[PaperQuery]:
    """The released queries, all of them or those of one family (a ValueError names the families)."""
    if task is not None and task not in released_families():
        raise ValueError(f"unknown paper family {task!r}; choose one of: {', '.join(released_families())}")
    return [q for q in _all() if task is None or q.task == task]
