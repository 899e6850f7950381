"""The mechanisms that catch perception, sensing and acting errors, by name: what `--checks` and the
settings' `checks` choose among (what each does: `attribot.skills.safeguards`). Plain names, below every
layer, so that the run configuration validates its choice where it is read."""

from __future__ import annotations

from enum import StrEnum

from attribot.errors import InputError

__all__ = ["Mechanism", "MECHANISMS", "parse_checks"]


class Mechanism(StrEnum):
    """An error-catching mechanism (see the module docstring), named as `--checks` spells it."""

    LOOK_AGAIN = "look_again"
    LOOK_HARDER = "look_harder"
    VERIFY_ACTIONS = "verify_actions"
    REMEASURE = "remeasure"
    CONFIDENCE = "confidence"
    RESET = "reset"


MECHANISMS: tuple[str, ...] = tuple(m.value for m in Mechanism)


def parse_checks(spec: str | list[str] | tuple[str, ...] | None) -> tuple[Mechanism, ...]:
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
    return tuple(m for m in Mechanism if m in chosen)
