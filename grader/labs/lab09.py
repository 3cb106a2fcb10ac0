"""Lab 09 — global planning (think): the exercises, their cases and their known mistakes.

Students write Nav2's inflation cost, the inflation of a grid of obstacles, the octile
distance and an A* that returns the length of the shortest 8-connected path without corner
cutting; the kit's :mod:`kit.planning` is the reference for each.
"""

from __future__ import annotations

import heapq
import math
from typing import Any, NamedTuple

import numpy as np

from grader.labs._hidden import until_each_shows
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
                  cap: float = 252.0, inclusive: bool = True, rounded: bool = False,
                  from_obstacle: bool = False) -> Any:
    d = np.asarray(d, dtype=np.float64)
    with np.errstate(over="ignore"):
        decay = np.minimum(scale * np.exp(-k * (d if from_obstacle else d - r)), cap)
    if rounded:
        decay = np.round(decay)
    cost = np.where((d <= r) if inclusive else (d < r), 253.0, decay)
    if lethal:
        cost = np.where(d == 0, 254.0, cost)
    return cost.astype(np.uint8)


def _cost_no_lethal(d: Any, r: float, k: float) -> Any:
    return _cost_formula(d, r, k, lethal=False)


def _cost_scaled_253(d: Any, r: float, k: float) -> Any:
    return _cost_formula(d, r, k, scale=253.0)


def _cost_scaled_254(d: Any, r: float, k: float) -> Any:
    return _cost_formula(d, r, k, scale=254.0, cap=254.0)


def _cost_inscribed_exclusive(d: Any, r: float, k: float) -> Any:
    return _cost_formula(d, r, k, inclusive=False)


def _cost_rounded(d: Any, r: float, k: float) -> Any:
    return _cost_formula(d, r, k, rounded=True)


def _cost_from_obstacle(d: Any, r: float, k: float) -> Any:
    return _cost_formula(d, r, k, from_obstacle=True)


def _distance_draw(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(3):
        r = float(rng.uniform(0.1, 0.3))
        k = float(rng.uniform(1.0, 12.0))
        # the obstacle, the inscribed radius itself, a hair beyond it (where 254 · exp(…)
        # still floors to 253) and a spread out to 1 m
        near = r + float(rng.uniform(1e-5, 1e-4))
        d = np.concatenate([[0.0, r, near], rng.uniform(0, 1.0, 7)])
        cases.append(Case(f"random {i}", (d, r, k)))
    return cases


def _distances(rng: np.random.Generator) -> list[Case]:
    return until_each_shows(rng, _distance_draw, _inflation_cost,
                            [d.wrong for d in _COST_MISTAKES])


_COST_MISTAKES = (
    Diagnostic("the obstacle cell itself not lethal", _cost_no_lethal,
               "a cell at distance 0 is the obstacle: LETHAL_OBSTACLE = 254, not 253"),
    Diagnostic("253 · exp(…) instead of (253 − 1) · exp(…)", _cost_scaled_253,
               "Nav2 scales the decay by INSCRIBED_INFLATED_OBSTACLE − 1 = 252, so that "
               "no cell outside the inscribed radius reaches 253"),
    Diagnostic("254 · exp(…) instead of (253 − 1) · exp(…)", _cost_scaled_254,
               "the decay starts from INSCRIBED_INFLATED_OBSTACLE − 1 = 252, not from "
               "LETHAL_OBSTACLE = 254: cells just beyond the inscribed radius come out 253 "
               "(inscribed) with 254"),
    Diagnostic("the inscribed radius exclusive (d < r_in)", _cost_inscribed_exclusive,
               "a cell exactly at the inscribed radius is inscribed too: 253 for "
               "0 < d ≤ inscribed_radius"),
    Diagnostic("the decayed cost rounded instead of truncated", _cost_rounded,
               "Nav2 casts the decayed cost to unsigned char, which truncates: floor, not "
               "round (astype(np.uint8) does it)"),
    Diagnostic("the decay measured from the obstacle (exp(−k d))", _cost_from_obstacle,
               "the cost decays from the inscribed radius: exp(−k (d − inscribed_radius))"),
)


inflation_cost = Exercise(
    id="lab09.inflation_cost", function="inflation_cost", title="Nav2's inflation cost",
    reference=_inflation_cost, points=2,
    public=(Case("Nav2's defaults around the Uiabot",
                 (np.array([0.0, 0.1, 0.1005, 0.2, 0.3, 0.55]), 0.1, 10.0)),
            Case("a gentle slope", (np.array([0.0, 0.22, 0.221, 0.3, 0.6, 1.2, 2.5]), 0.22,
                                    3.0))),
    hidden=_distances, rtol=0.0, atol=0.0,
    diagnostics=_COST_MISTAKES,
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
                      reach_in_metres: bool = False, cost_in_cells: bool = False,
                      reach_unrounded: bool = False, distance_of_obstacles: bool = False,
                      chessboard: bool = False) -> Any:
    """Nav2's inflation with one mistake: the reach compared in metres with a distance in
    cells, a distance in cells costed as if it were metres, the reach not rounded up to whole
    cells, the distance transform of the obstacles instead of the free cells, or chessboard
    distances."""
    from scipy import ndimage

    lethal = np.asarray(lethal, dtype=bool)
    costs = np.zeros(lethal.shape, dtype=np.uint8)
    if not lethal.any():
        return costs
    source = lethal if distance_of_obstacles else ~lethal
    cells = (ndimage.distance_transform_cdt(source).astype(float) if chessboard else
             ndimage.distance_transform_edt(source))
    reach = (inflation_radius if reach_in_metres else inflation_radius / resolution
             if reach_unrounded else math.ceil(inflation_radius / resolution))
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


def _inflate_reach_unrounded(lethal: Any, resolution: float, inscribed_radius: float,
                             inflation_radius: float, cost_scaling_factor: float) -> Any:
    return _inflate_mistaken(lethal, resolution, inscribed_radius, inflation_radius,
                             cost_scaling_factor, reach_unrounded=True)


def _inflate_obstacles_measured(lethal: Any, resolution: float, inscribed_radius: float,
                                inflation_radius: float, cost_scaling_factor: float) -> Any:
    return _inflate_mistaken(lethal, resolution, inscribed_radius, inflation_radius,
                             cost_scaling_factor, distance_of_obstacles=True)


def _inflate_chessboard(lethal: Any, resolution: float, inscribed_radius: float,
                        inflation_radius: float, cost_scaling_factor: float) -> Any:
    return _inflate_mistaken(lethal, resolution, inscribed_radius, inflation_radius,
                             cost_scaling_factor, chessboard=True)


def _grid(rng: np.random.Generator, shape: tuple[int, int], obstacles: int) -> Any:
    lethal = np.zeros(shape, dtype=bool)
    rows = rng.integers(0, shape[0], obstacles)
    cols = rng.integers(0, shape[1], obstacles)
    lethal[rows, cols] = True
    return lethal


def _inflate_draw(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (_grid(rng, (int(rng.integers(8, 20)), int(rng.integers(8, 20))),
                                       int(rng.integers(1, 6))),
                                 float(rng.choice([0.05, 0.1])), float(rng.uniform(0.1, 0.2)),
                                 float(rng.uniform(0.3, 0.6)), float(rng.uniform(2.0, 10.0))))
            for i in range(3)]


def _inflate_hidden(rng: np.random.Generator) -> list[Case]:
    return until_each_shows(rng, _inflate_draw, _inflate,
                            [d.wrong for d in _INFLATE_MISTAKES])


_INFLATE_MISTAKES = (
    Diagnostic("the inflation radius in metres against distances in cells",
               _inflate_reach_in_metres,
               "inflation_radius is in metres and the distances in cells: the reach is "
               "ceil(inflation_radius / resolution) cells"),
    Diagnostic("distances in cells costed as metres", _inflate_cost_in_cells,
               "inflation_cost takes metres: multiply a distance in cells by the "
               "resolution first"),
    Diagnostic("the reach not rounded up to whole cells", _inflate_reach_unrounded,
               "Nav2 inflates out to ceil(inflation_radius / resolution) cells (its "
               "cellDistance), a little beyond inflation_radius when it is not a whole "
               "number of cells"),
    Diagnostic("the distances of the obstacle cells instead of the free ones",
               _inflate_obstacles_measured,
               "distance_transform_edt gives each cell's distance to the nearest ZERO of its "
               "input: pass ~lethal, so that the obstacles are the zeros"),
    Diagnostic("chessboard distances (distance_transform_cdt)", _inflate_chessboard,
               "Nav2 measures Euclidean distances between cell centres: "
               "distance_transform_edt, not distance_transform_cdt (chessboard or taxicab)"),
)


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
    diagnostics=_INFLATE_MISTAKES,
    blocked=_BLOCKED,
    uses=("inflation_cost",),
)


# ---------------------------------------------------------------- octile distance

def _octile(a: Any, b: Any) -> float:
    return pl.octile_distance(tuple(a), tuple(b))


def _chebyshev(a: Any, b: Any) -> float:
    return float(max(abs(a[0] - b[0]), abs(a[1] - b[1])))


def _manhattan(a: Any, b: Any) -> float:
    return float(abs(a[0] - b[0]) + abs(a[1] - b[1]))


def _euclidean(a: Any, b: Any) -> float:
    return float(math.hypot(a[0] - b[0], a[1] - b[1]))


def _octile_draw(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (tuple(int(v) for v in rng.integers(0, 50, 2)),
                                 tuple(int(v) for v in rng.integers(0, 50, 2))))
            for i in range(4)]


def _octile_hidden(rng: np.random.Generator) -> list[Case]:
    return until_each_shows(rng, _octile_draw, _octile, (_chebyshev, _manhattan, _euclidean))


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
        Diagnostic("the Euclidean distance", _euclidean,
                   "the straight line between the cells is shorter than any path along the "
                   "grid's moves: min(|Δr|, |Δc|) diagonal steps of √2, the rest straight"),
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


class _Longer:
    """What a heuristic that overestimates returns on a grid where it misleads the search: a
    length longer than the shortest — which one depends on how the student's search breaks
    ties, so every such length is recognised (an output compared with this is "equal" to it
    when it is a finite length longer than ``shortest``)."""

    __array_ufunc__ = None          # numpy defers ``array == _Longer(...)`` to __eq__ below
    __hash__ = None                 # type: ignore[assignment]

    def __init__(self, shortest: float) -> None:
        self.shortest = float(shortest)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, (str, bytes)):
            return False
        try:
            got = float(other)      # type: ignore[arg-type]
        except (TypeError, ValueError):
            return False
        return math.isfinite(self.shortest) and math.isfinite(got) and \
            got > self.shortest * (1.0 + 1e-9) + 1e-9

    def __repr__(self) -> str:
        return f"a length longer than {self.shortest:g}"


def _astar_longer(free: Any, start: Any, goal: Any) -> _Longer:
    return _Longer(_astar(free, start, goal))


def _astar_swapped(free: Any, start: Any, goal: Any) -> float:
    """Cells read as (x, y) = (col, row): the search runs on the transposed grid."""
    return _search(np.asarray(free, dtype=bool).T, tuple(start), tuple(goal), diagonal=SQRT2,
                   corner_cutting=False, heuristic=_octile_h)


class _Trap(NamedTuple):
    """A grid (rows of ``.`` free and ``#`` blocked), a start and a goal."""

    rows: tuple[str, ...]
    start: tuple[int, int]
    goal: tuple[int, int]

    def case(self, symmetry: int = 0) -> tuple[Any, tuple[int, int], tuple[int, int]]:
        """``(free, start, goal)`` turned by ``symmetry % 4`` quarter turns and mirrored when
        ``symmetry >= 4`` (the eight symmetries of the square: lengths are unchanged)."""
        free = np.array([[c == "." for c in row] for row in self.rows])
        index = np.arange(free.size).reshape(free.shape)

        def turn(a: Any) -> Any:
            a = np.rot90(a, symmetry % 4)
            return np.ascontiguousarray(a[:, ::-1] if symmetry >= 4 else a)

        free, index = turn(free), turn(index)
        width = len(self.rows[0])

        def cell(p: tuple[int, int]) -> tuple[int, int]:
            found = np.argwhere(index == p[0] * width + p[1])[0]
            return int(found[0]), int(found[1])

        return free, cell(self.start), cell(self.goal)


_TRAPS = (
    # Grids where A* with a heuristic that overestimates — Manhattan on 8 moves, or the
    # octile distance weighted by 1.2, 1.5 or 3 — returns a longer path than the shortest, in
    # each of the eight symmetries, whatever order it expands neighbours in and however its
    # queue breaks ties (tests/grader/test_diagnostics.py checks each); found by a seeded
    # search over random 8–12-cell grids.
    _Trap(("..#.#..##...", "..##....#.#.", "#........#..", "##.##...##..", "...#..#..#..",
           "...#........", "....##......", "..#......#..", ".#.....###..", "........#.#."),
          (9, 1), (2, 2)),
    _Trap(("#......#...", "..##....#.#", ".#....#.#..", "......#..#.", "##.#...#...",
           "........#..", "...........", "...##...#..", ".#.#....##.", "##...#.#...",
           "....#......"), (9, 9), (0, 5)),
    _Trap(("##.#......", ".....#...#", "#...#..#..", "..#....#..", ".....##...", "#..###.#..",
           "..#......#", "#....#...#", ".#.#......", "#..#.....#", ".#...##..."),
          (8, 4), (2, 6)),
    _Trap((".....#.....", "....#..##..", ".#..##.....", "..#...#....", "#.##..#....",
           "....#......", "...#...#...", "....#....#.", "......#...#", "#...#...##.",
           "##.......##"), (5, 7), (3, 1)),
    _Trap(("##........#", ".....#.....", "...........", ".....#..#.#", ".##.##.#..#",
           ".....#.##.#", ".....##....", "##.##....#.", ".#......#..", "##.......#."),
          (0, 9), (8, 3)),
    _Trap(("..##......#.", "#.#.....#...", "#....#.#...#", "............", "..##..#.#...",
           "...##.......", ".....#.#..#.", "..#.........", ".#.###.#....", "#.......#..."),
          (7, 3), (0, 6)),
    _Trap(("..##......", ".##.......", "..#..#..#.", "..........", ".#.##..#..", "..#...###.",
           "##........", "..##..###.", "..........", "..#####...", "....#....."),
          (0, 7), (10, 7)),
)
_PUBLIC_TRAP = _Trap((".#...#...", "......#..", ".#.#..#.#", ".###....#", "....#....",
                      "...#..##.", "##...#...", ".....#..."), (3, 0), (4, 6))


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
_L_WALL = np.ones((10, 10), dtype=bool)
_L_WALL[2, 2:8] = False
_L_WALL[2:8, 7] = False


def _random_astar_draw(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(2):
        shape = (int(rng.integers(10, 19)), int(rng.integers(10, 19)))
        free = rng.random(shape) > float(rng.uniform(0.15, 0.3))
        cells = np.argwhere(free)
        start, goal = (tuple(int(v) for v in cells[k])
                       for k in rng.choice(len(cells), 2, replace=False))
        cases.append(Case(f"random {shape[0]}×{shape[1]} grid {i}", (free, start, goal)))
    return cases


def _astar_hidden(rng: np.random.Generator) -> list[Case]:
    """Two of the traps, each turned at random (every overestimating heuristic returns a
    longer path there), and random grids among which a unit diagonal, corner cutting and a
    transposed grid each give a wrong length."""
    traps = [_TRAPS[int(k)].case(int(rng.integers(8)))
             for k in rng.choice(len(_TRAPS), 2, replace=False)]
    cases = [Case(f"a detour {i}", trap) for i, trap in enumerate(traps)]
    return cases + until_each_shows(rng, _random_astar_draw, _astar,
                                    (_astar_diagonal_one, _astar_corner_cutting,
                                     _astar_swapped))


astar = Exercise(
    id="lab09.astar", function="astar", title="A*, octile moves, no corner cutting",
    reference=_astar, points=4,
    public=(Case("round a pillar", (_ROOM, (4, 0), (4, 10))),
            Case("a diagonal squeeze between two blocks", (_SQUEEZE, (0, 0), (5, 5))),
            Case("a wall with no gap", (_SPLIT, (3, 0), (3, 6))),
            Case("a slanted room", (_SLANT, (0, 2), (6, 8))),
            Case("an L-shaped wall in the way", (_L_WALL, (0, 0), (9, 9))),
            Case("a detour a greedy heuristic misses", _PUBLIC_TRAP.case())),
    hidden=_astar_hidden, rtol=1e-9, atol=1e-9,
    diagnostics=(
        Diagnostic("a diagonal step costing 1", _astar_diagonal_one,
                   "a diagonal move is √2 long: count it as 1 and the lengths (and often the "
                   "paths) are wrong"),
        Diagnostic("corner cutting", _astar_corner_cutting,
                   "a diagonal move is allowed only when both cells beside it are free (no "
                   "corner cutting, as Nav2 and the Moving AI benchmark)"),
        Diagnostic("a heuristic that is not admissible", _astar_longer,
                   "a length longer than the shortest: the heuristic must never overestimate "
                   "the length still to go — Manhattan counts a diagonal step as 2, a weight "
                   "above 1 inflates the octile distance, and either leads A* past the "
                   "shortest path (or the search stopped before the goal came off the queue)"),
        Diagnostic("row and column swapped", _astar_swapped,
                   "cells are (row, col): free[row, col], not free[x][y]"),
    ),
    blocked=_BLOCKED,
    uses=("octile_distance",),
)


SPEC = LabSpec(name="lab09", title="Global planning",
               exercises=(inflation_cost, inflate, octile_distance, astar))
