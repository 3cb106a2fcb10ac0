"""Lab 09's hidden A* cases: the detours that every overestimating heuristic gets wrong."""

from __future__ import annotations

import heapq
import itertools
import math

import numpy as np
import pytest

from grader.labs import lab09
from grader.spec import course_seed
from kit import planning as pl

SQRT2 = math.sqrt(2.0)
TIES = ("oldest first", "newest first", "smaller h first", "larger h first", "by cell")
ORDERS = ([m for m in itertools.product((-1, 0, 1), repeat=2) if m != (0, 0)],
          [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)])
CLOSED = ("skip when popped", "never pushed again", "no closed set")


def _octile(a, b):
    dr, dc = abs(a[0] - b[0]), abs(a[1] - b[1])
    return max(dr, dc) - min(dr, dc) + SQRT2 * min(dr, dc)


HEURISTICS = {
    "Manhattan": lambda a, b: float(abs(a[0] - b[0]) + abs(a[1] - b[1])),
    "1.2 × octile": lambda a, b: 1.2 * _octile(a, b),
    "1.5 × octile": lambda a, b: 1.5 * _octile(a, b),
    "3 × octile": lambda a, b: 3.0 * _octile(a, b),
}


def weighted_astar(free, start, goal, h, tie, order, closed):
    """A* as a student might write it, with the heuristic ``h`` and one of several ways to
    break ties, order the neighbours and keep (or not) a closed set."""
    height, width = free.shape
    g, done, n = {start: 0.0}, set(), 0

    def key(cell, cost):
        f = cost + h(cell, goal)
        return {"oldest first": (f, n), "newest first": (f, -n),
                "smaller h first": (f, h(cell, goal), n),
                "larger h first": (f, -h(cell, goal), n), "by cell": (f, cell)}[tie]

    queue = [(key(start, 0.0), start)]
    while queue:
        k, cell = heapq.heappop(queue)
        if closed != "no closed set" and cell in done:
            continue
        if closed == "no closed set" and k[0] > g[cell] + h(cell, goal) + 1e-12:
            continue
        if cell == goal:
            return g[cell]
        done.add(cell)
        for dr, dc in ORDERS[order]:
            nxt = (cell[0] + dr, cell[1] + dc)
            if not (0 <= nxt[0] < height and 0 <= nxt[1] < width) or not free[nxt]:
                continue
            if closed == "never pushed again" and nxt in done:
                continue
            if dr and dc and not (free[cell[0] + dr, cell[1]] and free[cell[0], cell[1] + dc]):
                continue
            new = g[cell] + (SQRT2 if dr and dc else 1.0)
            if new < g.get(nxt, math.inf) - 1e-12:
                g[nxt] = new
                n += 1
                heapq.heappush(queue, (key(nxt, new), nxt))
    return math.inf


@pytest.mark.parametrize("trap", [*lab09._TRAPS, lab09._PUBLIC_TRAP],
                         ids=[f"trap {i}" for i in range(len(lab09._TRAPS))] + ["public"])
def test_every_overestimating_heuristic_returns_a_longer_path_on_each_trap(trap):
    """In each of the eight symmetries, whatever the tie order, neighbour order and closed
    set: so the hidden cases catch Manhattan, 1.2×, 1.5× and 3× the octile distance for every
    student, however they wrote their A*."""
    shortest = None
    for symmetry in range(8):
        free, start, goal = trap.case(symmetry)
        assert free[start] and free[goal]
        costs = np.where(free, 0, pl.LETHAL_OBSTACLE).astype(np.uint8)
        length = pl.astar_reference(costs, start, goal).cost
        shortest = length if shortest is None else shortest
        assert length == pytest.approx(shortest, abs=1e-9)      # a symmetry keeps lengths
        for (name, h), tie, order, closed in itertools.product(
                HEURISTICS.items(), TIES, range(len(ORDERS)), CLOSED):
            got = weighted_astar(free, start, goal, h, tie, order, closed)
            assert math.isfinite(got) and got > length + 1e-6, (symmetry, name, tie, order,
                                                                 closed)


def test_a_trap_turned_keeps_its_cells_where_the_grid_turned_them():
    trap = lab09._Trap(("..#", "..."), (0, 0), (1, 2))
    free, start, goal = trap.case(1)               # a quarter turn anticlockwise
    assert free.shape == (3, 2)
    assert not free[0, 0] and (start, goal) == ((2, 0), (0, 1))
    free, start, goal = trap.case(4)               # mirrored left to right
    assert (start, goal) == ((0, 2), (1, 0)) and not free[0, 0]


def test_every_students_hidden_astar_cases_hold_two_detours():
    for student in ("alice", "bob", "Zoë"):
        cases = lab09.astar.hidden_cases(course_seed(lab09.astar.id, student, "secret"))
        detours = [c for c in cases if c.name.startswith("a detour")]
        assert len(detours) == 2
        longer = lab09._astar_longer(*detours[0].args)
        assert longer == lab09._astar(*detours[0].args) + 1.0
        assert not longer == lab09._astar(*detours[0].args)


def test_a_longer_length_is_recognised_whatever_its_type():
    longer = lab09._Longer(5.0)
    assert longer == 6.0 and longer == np.float64(5.5) and 7 == longer
    assert not longer == 5.0 and not longer == math.inf and not longer == "6"
    assert not lab09._Longer(math.inf) == 7.0
