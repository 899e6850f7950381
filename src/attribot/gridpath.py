"""Shortest paths on a 2-D grid (A*, 8-connected), shortened by line of sight: the one path planner, used by
the perception-driven controller's floor map and the simulator's privileged scripts alike.

Cells are `(i, j)` index pairs. `cost(cell)` gives the price of entering a cell as a multiple of its
length (1 for free floor, more to discourage, None where it cannot be entered).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable

import numpy as np

__all__ = ["Cell", "astar", "clear_line", "shortcut"]

Cell = tuple[int, int]

_MOVES = [(di, dj, math.hypot(di, dj)) for di in (-1, 0, 1) for dj in (-1, 0, 1) if di or dj]


def astar(
    shape: tuple[int, int], start: Cell, goal: Cell, cost: Callable[[Cell], float | None]
) -> list[Cell] | None:
    """The cheapest 8-connected chain of cells from start to goal inside `shape`, or None.

    >>> astar((3, 3), (0, 0), (2, 2), lambda c: 1.0)
    [(0, 0), (1, 1), (2, 2)]
    >>> len(astar((3, 3), (0, 0), (2, 2), lambda c: None if c == (1, 1) else 1.0))
    4
    """
    dist = {start: 0.0}
    prev: dict[Cell, Cell] = {}
    heap = [(0.0, start)]
    while heap:
        _, c = heapq.heappop(heap)
        if c == goal:
            break
        for di, dj, w in _MOVES:
            nb = (c[0] + di, c[1] + dj)
            if not (0 <= nb[0] < shape[0] and 0 <= nb[1] < shape[1]):
                continue
            price = cost(nb)
            if price is None:
                continue
            nd = dist[c] + w * price
            if nd < dist.get(nb, math.inf):
                dist[nb], prev[nb] = nd, c
                heapq.heappush(heap, (nd + math.hypot(goal[0] - nb[0], goal[1] - nb[1]), nb))
    if goal not in dist:
        return None
    cells = [goal]
    while cells[-1] != start:
        cells.append(prev[cells[-1]])
    return cells[::-1]


def clear_line(blocked: np.ndarray, a: Cell, b: Cell) -> bool:
    """True when the straight line from cell a to cell b crosses no blocked cell."""
    steps = max(abs(a[0] - b[0]), abs(a[1] - b[1]), 1) * 2
    for t in np.linspace(0.0, 1.0, steps + 1):
        if blocked[round(a[0] + (b[0] - a[0]) * t), round(a[1] + (b[1] - a[1]) * t)]:
            return False
    return True


def shortcut(blocked: np.ndarray, cells: list[Cell]) -> list[Cell]:
    """The turning points of a chain of cells that line of sight over `blocked` cannot skip (its first and
    last cells included)."""
    keep, i = [cells[0]], 0
    while i < len(cells) - 1:
        j = len(cells) - 1
        while j > i + 1 and not clear_line(blocked, cells[i], cells[j]):
            j -= 1
        keep.append(cells[j])
        i = j
    return keep
