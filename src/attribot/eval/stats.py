"""Intervals and comparisons of accuracies: the numbers every table, figure and verdict of the report uses."""

from __future__ import annotations

import math

__all__ = ["wilson", "compare"]


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of k successes in n trials (0, 1 when n is 0).

    >>> [round(v, 3) for v in wilson(48, 50)]
    [0.865, 0.989]
    """
    if n == 0:
        return 0.0, 1.0
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def compare(a: tuple[float, float, float], b: tuple[float, float, float]) -> str:
    """How accuracy `a` stands against `b`, each (accuracy, low, high): "above" or "below" when their
    95% intervals do not overlap, else "within" (the records cannot tell them apart).

    >>> compare((0.9, 0.8, 0.95), (0.5, 0.4, 0.6)), compare((0.6, 0.5, 0.7), (0.55, 0.45, 0.65))
    ('above', 'within')
    """
    if a[1] > b[2]:
        return "above"
    if a[2] < b[1]:
        return "below"
    return "within"
