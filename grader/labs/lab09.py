"""Lab 09 — global planning (think): the exercises, their cases and their known mistakes.

Students write Nav2's inflation cost, the inflation of a grid of obstacles, the octile
distance and an A* that returns the length of the shortest 8-connected path without corner
cutting; the kit's :mod:`kit.planning` is the reference for each.
"""

from __future__ import annotations

import heapq
import math
from typing import Any

import numpy as np

from grader.spec import Case, Diagnostic, Exercise, LabSpec
from kit import planning as pl

_BLOCKED = (
    "kit.planning._costmap:inflation_cost", "kit.planning._costmap:inflate",
    "kit.planning._costmap:inflate_reference", "kit.planning._search:octile_distance",
    "kit.planning._search:astar_reference", "kit.planning._search:dijkstra_reference",
    "kit.planning._search:theta_star_reference", "kit.planning._gridsearch:astar",
    "kit.planning._gridsearch:dijkstra", "kit.planning._gridsearch:theta_star",
    "kit.planning._gridsearch:GridSearch", "kit.planning._planner:compute_path_to_pose",
)

SQRT2 = math.sqrt(2.0)


# ---------------------------------------------------------------- inflation cost

def _inflation_cost(distance: Any, inscribed_radius: float, cost_scaling_factor: float) -> Any:
    return pl.inflation_cost(distance, inscribed_radius, cost_scaling_factor)


def _cost_formula(d: Any, r: float, k: float, scale: float = 252.0, lethal: bool = True,
                  sign: float = -1.0) -> Any:
    d = np.asarray(d, dtype=np.float64)
    with np.errstate(over="ignore"):
        decay = np.minimum(scale * np.exp(sign * k * (d - r)), 252.0)
    cost = np.where(d <= r, 253.0, decay)
    if lethal:
        cost = np.where(d == 0, 254.0, cost)
    return cost.astype(np.uint8)


def _cost_no_lethal(d: Any, r: float, k: float) -> Any:
    return _cost_formula(d, r, k, lethal=False)


def _cost_scaled_253(d: Any, r: float, k: float) -> Any:
    return _cost_formula(d, r, k, scale=253.0)


def _distances(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(3):
        r = float(rng.uniform(0.1, 0.3))
        d = np.concatenate([[0.0, r], rng.uniform(0, 1.0, 8)])
        cases.append(Case(f"random {i}", (d, r, float(rng.uniform(1.0, 12.0)))))
    return cases


inflation_cost = Exercise(
    id="lab09.inflation_cost", function="inflation_cost", title="Nav2's inflation cost",
    reference=_inflation_cost, points=2,
    public=(Case("Nav2's defaults around the Uiabot", (np.array([0.0, 0.1, 0.2, 0.3, 0.55]),
                                                     0.1, 10.0)),
            Case("a gentle slope", (np.array([0.0, 0.22, 0.3, 0.6, 1.2, 2.5]), 0.22, 3.0))),
    hidden=_distances, rtol=0.0, atol=0.0,
    diagnostics=(
        Diagnostic("the obstacle cell itself not lethal", _cost_no_lethal,
                   "a cell at distance 0 is the obstacle: LETHAL_OBSTACLE = 254, not 253"),
        Diagnostic("253 · exp(…) instead of (253 − 1) · exp(…)", _cost_scaled_253,
                   "Nav2 scales the decay by INSCRIBED_INFLATED_OBSTACLE − 1 = 252, so that "
                   "no cell outside the inscribed radius reaches 253"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- inflation

def _inflate(lethal: Any, resolution: float, inscribed_radius: float, inflation_radius: float,
             cost_scaling_factor: float) -> Any:
    costs = np.where(np.asarray(lethal, dtype=bool), pl.LETHAL_OBSTACLE, 0).astype(np.uint8)
    return pl.inflate_reference(costs, resolution, inscribed_radius=inscribed_radius,
                                inflation_radius=inflation_radius,
                                cost_scaling_factor=cost_scaling_factor)


def _inflate_mistaken(lethal: Any, resolution: float, inscribed_radius: float,
                      inflation_radius: float, cost_scaling_factor: float, *,
                      reach_in_metres: bool, cost_in_cells: bool) -> Any:
    """Nav2's inflation with one of the two unit slips: the reach compared in metres with a
    distance in cells, or a distance in cells costed as if it were metres."""
    from scipy import ndimage

    lethal = np.asarray(lethal, dtype=bool)
    costs = np.zeros(lethal.shape, dtype=np.uint8)
    if not lethal.any():
        return costs
    cells = ndimage.distance_transform_edt(~lethal)
    reach = inflation_radius if reach_in_metres else math.ceil(inflation_radius / resolution)
    near = cells <= reach
    d = cells[near] if cost_in_cells else cells[near] * resolution
    costs[near] = pl.inflation_cost(d, inscribed_radius, cost_scaling_factor)
    return costs


def _inflate_reach_in_metres(lethal: Any, resolution: float, inscribed_radius: float,
                             inflation_radius: float, cost_scaling_factor: float) -> Any:
    return _inflate_mistaken(lethal, resolution, inscribed_radius, inflation_radius,
                             cost_scaling_factor, reach_in_metres=True, cost_in_cells=False)


def _inflate_cost_in_cells(lethal: Any, resolution: float, inscribed_radius: float,
                           inflation_radius: float, cost_scaling_factor: float) -> Any:
    return _inflate_mistaken(lethal, resolution, inscribed_radius, inflation_radius,
                             cost_scaling_factor, reach_in_metres=False, cost_in_cells=True)


def _grid(rng: np.random.Generator, shape: tuple[int, int], obstacles: int) -> Any:
    lethal = np.zeros(shape, dtype=bool)
    rows = rng.integers(0, shape[0], obstacles)
    cols = rng.integers(0, shape[1], obstacles)
    lethal[rows, cols] = True
    return lethal


def _inflate_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (_grid(rng, (int(rng.integers(8, 20)), int(rng.integers(8, 20))),
                                       int(rng.integers(1, 6))),
                                 float(rng.choice([0.05, 0.1])), float(rng.uniform(0.1, 0.2)),
                                 float(rng.uniform(0.3, 0.6)), float(rng.uniform(2.0, 10.0))))
            for i in range(3)]


_WALL = np.zeros((9, 12), dtype=bool)
_WALL[4, 2:10] = True
_CORNERS = np.zeros((10, 10), dtype=bool)
_CORNERS[0, 0] = _CORNERS[9, 9] = True

inflate = Exercise(
    id="lab09.inflate", function="inflate", title="Inflating the obstacles",
    reference=_inflate, points=3,
    public=(Case("one obstacle cell", (np.pad(np.ones((1, 1), bool), 6), 0.05, 0.1, 0.3, 10.0)),
            Case("a wall, the Uiabot's radius", (_WALL, 0.05, 0.18, 0.4, 5.0)),
            Case("two corners at 10 cm", (_CORNERS, 0.1, 0.2, 0.55, 3.0))),
    hidden=_inflate_hidden, rtol=0.0, atol=0.0,
    diagnostics=(
        Diagnostic("the inflation radius in metres against distances in cells",
                   _inflate_reach_in_metres,
                   "inflation_radius is in metres and the distances in cells: the reach is "
                   "ceil(inflation_radius / resolution) cells"),
        Diagnostic("distances in cells costed as metres", _inflate_cost_in_cells,
                   "inflation_cost takes metres: multiply a distance in cells by the "
                   "resolution first"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- octile distance

def _octile(a: Any, b: Any) -> float:
    return pl.octile_distance(tuple(a), tuple(b))


def _chebyshev(a: Any, b: Any) -> float:
    return float(max(abs(a[0] - b[0]), abs(a[1] - b[1])))


def _manhattan(a: Any, b: Any) -> float:
    return float(abs(a[0] - b[0]) + abs(a[1] - b[1]))


def _octile_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (tuple(int(v) for v in rng.integers(0, 50, 2)),
                                 tuple(int(v) for v in rng.integers(0, 50, 2))))
            for i in range(4)]


octile_distance = Exercise(
    id="lab09.octile_distance", function="octile_distance", title="The octile distance",
    reference=_octile, points=1,
    public=(Case("three down, five across", ((0, 0), (3, 5))),
            Case("straight along a row", ((2, 1), (2, 7))),
            Case("back up a diagonal", ((6, 6), (2, 2)))),
    hidden=_octile_hidden, rtol=1e-12, atol=1e-12,
    diagnostics=(
        Diagnostic("a diagonal step costing 1", _chebyshev,
                   "a diagonal step is √2 long, not 1: min(|Δr|, |Δc|) diagonal steps cost "
                   "√2 each"),
        Diagnostic("Manhattan distance on an 8-connected grid", _manhattan,
                   "|Δr| + |Δc| counts a diagonal step as 2: on an 8-connected grid that "
                   "overestimates, so A* with it is not admissible"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- A*

def _costs(free: Any) -> Any:
    return np.where(np.asarray(free, dtype=bool), 0, pl.LETHAL_OBSTACLE).astype(np.uint8)


def _astar(free: Any, start: Any, goal: Any) -> float:
    result = pl.astar_reference(_costs(free), tuple(start), tuple(goal))
    return float(result.cost)


def _search(free: Any, start: tuple[int, int], goal: tuple[int, int], *, diagonal: float,
            corner_cutting: bool, heuristic: Any) -> float:
    """A plain A* with a mistake's knobs; returns the g of the goal as a student would."""
    free = np.asarray(free, dtype=bool)
    h, w = free.shape
    if not (0 <= start[0] < h and 0 <= start[1] < w and 0 <= goal[0] < h and 0 <= goal[1] < w):
        return math.inf
    if not (free[start] and free[goal]):
        return math.inf
    g = {start: 0.0}
    closed: set[tuple[int, int]] = set()
    heap = [(heuristic(start, goal), 0, start)]
    counter = 0
    while heap:
        _, _, cell = heapq.heappop(heap)
        if cell in closed:
            continue
        closed.add(cell)
        if cell == goal:
            return g[cell]
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                nxt = (cell[0] + dr, cell[1] + dc)
                if (dr, dc) == (0, 0) or not (0 <= nxt[0] < h and 0 <= nxt[1] < w):
                    continue
                if not free[nxt] or nxt in closed:
                    continue
                if dr and dc and not corner_cutting and not (free[cell[0] + dr, cell[1]] and
                                                            free[cell[0], cell[1] + dc]):
                    continue
                new = g[cell] + (diagonal if dr and dc else 1.0)
                if new < g.get(nxt, math.inf):
                    g[nxt] = new
                    counter += 1
                    heapq.heappush(heap, (new + heuristic(nxt, goal), counter, nxt))
    return math.inf


def _octile_h(a: tuple[int, int], b: tuple[int, int]) -> float:
    dr, dc = abs(a[0] - b[0]), abs(a[1] - b[1])
    return max(dr, dc) - min(dr, dc) + SQRT2 * min(dr, dc)


def _astar_diagonal_one(free: Any, start: Any, goal: Any) -> float:
    return _search(free, tuple(start), tuple(goal), diagonal=1.0, corner_cutting=False,
                   heuristic=_chebyshev)


def _astar_corner_cutting(free: Any, start: Any, goal: Any) -> float:
    return _search(free, tuple(start), tuple(goal), diagonal=SQRT2, corner_cutting=True,
                   heuristic=_octile_h)


def _astar_not_admissible(free: Any, start: Any, goal: Any) -> float:
    return _search(free, tuple(start), tuple(goal), diagonal=SQRT2, corner_cutting=False,
                   heuristic=lambda a, b: 3.0 * _octile_h(a, b))


def _astar_swapped(free: Any, start: Any, goal: Any) -> float:
    """Cells read as (x, y) = (col, row): the search runs on the transposed grid."""
    return _search(np.asarray(free, dtype=bool).T, tuple(start), tuple(goal), diagonal=SQRT2,
                   corner_cutting=False, heuristic=_octile_h)


def _astar_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(3):
        shape = (int(rng.integers(10, 22)), int(rng.integers(10, 22)))
        free = rng.random(shape) > float(rng.uniform(0.15, 0.3))
        cells = np.argwhere(free)
        start, goal = (tuple(int(v) for v in cells[k])
                       for k in rng.choice(len(cells), 2, replace=False))
        cases.append(Case(f"random {shape[0]}×{shape[1]} grid {i}", (free, start, goal)))
    return cases


# A room with a pillar (octile lengths), a diagonal squeeze between two blocks (no path
# without corner cutting), a wall with no gap (no path), a grid that is not symmetric, and an
# L-shaped wall that leads an inflated heuristic astray.
_SQUEEZE = np.ones((6, 6), dtype=bool)
_SQUEEZE[2, :3] = False
_SQUEEZE[3, 3:] = False
_ROOM = np.ones((8, 11), dtype=bool)
_ROOM[2:6, 4:6] = False
_SPLIT = np.ones((7, 7), dtype=bool)
_SPLIT[:, 3] = False
_SLANT = np.ones((9, 9), dtype=bool)
_SLANT[1:8, 4] = False
_SLANT[4, 1:4] = False
_TRAP = np.ones((10, 10), dtype=bool)
_TRAP[2, 2:8] = False
_TRAP[2:8, 7] = False

astar = Exercise(
    id="lab09.astar", function="astar", title="A*, octile moves, no corner cutting",
    reference=_astar, points=4,
    public=(Case("round a pillar", (_ROOM, (4, 0), (4, 10))),
            Case("a diagonal squeeze between two blocks", (_SQUEEZE, (0, 0), (5, 5))),
            Case("a wall with no gap", (_SPLIT, (3, 0), (3, 6))),
            Case("a slanted room", (_SLANT, (0, 2), (6, 8))),
            Case("an L-shaped wall in the way", (_TRAP, (0, 0), (9, 9)))),
    hidden=_astar_hidden, rtol=1e-9, atol=1e-9,
    diagnostics=(
        Diagnostic("a diagonal step costing 1", _astar_diagonal_one,
                   "a diagonal move is √2 long: count it as 1 and the lengths (and often the "
                   "paths) are wrong"),
        Diagnostic("corner cutting", _astar_corner_cutting,
                   "a diagonal move is allowed only when both cells beside it are free (no "
                   "corner cutting, as Nav2 and the Moving AI benchmark)"),
        Diagnostic("a heuristic that is not admissible", _astar_not_admissible,
                   "the heuristic must never overestimate the remaining length (the octile "
                   "distance is exact on a free grid): an inflated one returns longer paths"),
        Diagnostic("row and column swapped", _astar_swapped,
                   "cells are (row, col): free[row, col], not free[x][y]"),
    ),
    blocked=_BLOCKED,
)


SPEC = LabSpec(name="lab09", title="Global planning",
               exercises=(inflation_cost, inflate, octile_distance, astar))
