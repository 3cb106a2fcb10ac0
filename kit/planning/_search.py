"""Grid search on a costmap: Dijkstra, A* and Theta* as plain reference versions (the
compiled ones, giving the same cells, costs and expansions, are in ``_gridsearch``).

Conventions:

* Cells are ``(row, col)`` of a ``costs[row, col]`` array of Nav2 costs (uint8). A Moving AI
  scenario's ``(x, y)`` is ``(col, row)``; Nav2's ``(mx, my)`` too.
* A cell is traversable when its cost is at most ``MAX_NON_OBSTACLE`` (252), or unknown (255)
  with ``allow_unknown``. Inscribed (253) and lethal (254) cells are never entered.
* Moves: 4-connected (up, down, left, right: length 1) or 8-connected (plus diagonals:
  length √2). **No corner cutting** by default: a diagonal move needs both cells beside it
  traversable, the rule of the Moving AI benchmarks. ``corner_cutting=True`` drops that rule.
* Traversal cost (Smac's 2-D planner; NavFn is the same shape): entering a cell of cost ``c``
  with a move of length ``ℓ`` costs ``ℓ · (1 + cost_travel_multiplier · c / 252)``; an
  unknown cell counts as ``c = 252``. On free cells a path's cost is its length in cells.
  (NavFn's ``50 + 0.8 c`` per cell is ``cost_travel_multiplier ≈ 4.03`` in this form.)
* A* uses the octile distance (8-connected) or the Manhattan distance (4-connected) as its
  heuristic, both admissible and consistent under these costs; Dijkstra uses none.
* Ties: the open list pops the smallest ``(f, h, row · width + col)``, so equal ``f`` goes to
  the cell nearer the goal, then the lower index: every run expands the same cells in the same
  order, in both versions.
* Theta* (Nash, Daniel, Koenig & Felner 2007) in Nav2's cost model: a segment from ``a`` to
  ``b`` costs ``w_euc_cost · |ab| + w_traversal_cost · Σ ((26 + 0.9 c) / 252)²`` over the
  cells the segment enters. Reaching a neighbour of the cell being expanded, the straight
  segment from that cell's parent (if in line of sight) is taken unless the step through the
  cell itself is cheaper; plain Theta* always takes the segment, which with traversal costs
  can be the dearer one. Nav2's Theta* planner (``theta_star.cpp``) shares the cost model but
  not the search, so its paths differ: it re-parents a cell to its grandparent only when the
  cell is expanded, it lets a diagonal step pass between two blocked cells, and (Humble to
  Kilted; Nav2 issue #5863, fixed in Lyrical) its line of sight along a row or column is
  blocked only where two neighbouring cells both are, so its paths can cross a lethal cell.
  The kit's never do.

Start or goal off the grid or untraversable raises :class:`PlanningError` (a ``ValueError``
carrying Nav2's ``ComputePathToPose`` error code); a goal that cannot be reached is a result
with no cells and a ``reason``, never an exception.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit.planning._costmap import MAX_NON_OBSTACLE, NO_INFORMATION

__all__ = [
    "GOAL_OCCUPIED",
    "GOAL_OUTSIDE_MAP",
    "NO_VALID_PATH",
    "START_OCCUPIED",
    "START_OUTSIDE_MAP",
    "PlanningError",
    "SearchResult",
    "astar_reference",
    "diagonal_allowed",
    "dijkstra_reference",
    "line_of_sight",
    "manhattan_distance",
    "octile_distance",
    "theta_star_reference",
    "traversable",
    "traversal_cost",
]

# nav2_msgs/action/ComputePathToPose error codes
START_OUTSIDE_MAP = 203
GOAL_OUTSIDE_MAP = 204
START_OCCUPIED = 205
GOAL_OCCUPIED = 206
NO_VALID_PATH = 208

SQRT2 = math.sqrt(2.0)
MOVES_4 = ((1, 0), (-1, 0), (0, 1), (0, -1))
"""``(d_row, d_col)`` of the 4-connected moves, in the order they are tried."""
MOVES_8 = (*MOVES_4, (1, 1), (1, -1), (-1, 1), (-1, -1))
"""The 8-connected moves: the four straight ones, then the diagonals."""

Cell = tuple[int, int]
CostArray = NDArray[np.uint8]
IntArray = NDArray[np.int64]


class PlanningError(ValueError):
    """A start or goal the planner cannot use; ``error_code`` is Nav2's (203–206)."""

    def __init__(self, message: str, error_code: int) -> None:
        super().__init__(message)
        self.error_code = error_code


@dataclass(frozen=True, eq=False)
class SearchResult:
    """What a grid search found.

    ``cells`` ``(N, 2)`` the path's ``(row, col)`` from start to goal (``(0, 2)`` when there
    is none); ``cost`` its cost (``inf`` when none); ``length`` its length in cells (the sum
    of its segments); ``reason`` empty when a path was found; :attr:`expanded_cells` the cells
    taken off the open list, in order. (``order`` holds them as flat indices
    ``(row + padding) · stride + col + padding``, decoded only when asked for.)
    """

    cells: IntArray
    cost: float
    length: float
    reason: str
    order: NDArray[np.integer] = field(repr=False)
    stride: int = field(repr=False)
    padding: int = field(default=0, repr=False)

    @property
    def found(self) -> bool:
        return len(self.cells) > 0

    @property
    def expanded(self) -> int:
        """Number of cells expanded."""
        return len(self.order)

    @cached_property
    def expanded_cells(self) -> IntArray:
        """``(K, 2)`` the expanded cells' ``(row, col)``, in the order they were expanded."""
        flat = self.order.astype(np.int64)
        return np.column_stack([flat // self.stride - self.padding,
                                flat % self.stride - self.padding])


# ------------------------------------------------------------------ the pieces

def octile_distance(a: Cell, b: Cell) -> float:
    """Length of the shortest 8-connected path on a free grid: diagonal moves cover
    ``min(|Δrow|, |Δcol|)``, straight ones the rest.

    >>> octile_distance((0, 0), (3, 5))
    6.242640687119286
    """
    d_row, d_col = abs(a[0] - b[0]), abs(a[1] - b[1])
    return (max(d_row, d_col) - min(d_row, d_col)) + SQRT2 * min(d_row, d_col)


def manhattan_distance(a: Cell, b: Cell) -> float:
    """Length of the shortest 4-connected path on a free grid: ``|Δrow| + |Δcol|``."""
    return float(abs(a[0] - b[0]) + abs(a[1] - b[1]))


def traversable(cost: int, allow_unknown: bool) -> bool:
    """May a robot's centre stand on a cell of this cost?"""
    return cost <= MAX_NON_OBSTACLE or (allow_unknown and cost == NO_INFORMATION)


def traversal_cost(cost: int, step_length: float, cost_travel_multiplier: float) -> float:
    """Cost of a move of ``step_length`` cells into a cell of costmap ``cost``:
    ``step_length · (1 + cost_travel_multiplier · c / 252)``, unknown counted as 252."""
    c = MAX_NON_OBSTACLE if cost == NO_INFORMATION else cost
    return step_length * (1.0 + cost_travel_multiplier * (c / 252.0))


def diagonal_allowed(costs: CostArray, cell: Cell, move: tuple[int, int],
                     corner_cutting: bool = False, allow_unknown: bool = True) -> bool:
    """May the move ``(d_row, d_col)`` leave ``cell``? Straight moves always may; a diagonal
    one only when both cells it passes between are traversable, unless ``corner_cutting``.

    >>> c = np.array([[0, 254], [0, 0]], np.uint8)
    >>> diagonal_allowed(c, (0, 0), (1, 1)), diagonal_allowed(c, (0, 0), (1, 1), True)
    (False, True)
    """
    d_row, d_col = move
    if d_row == 0 or d_col == 0 or corner_cutting:
        return True
    row, col = cell
    return (traversable(int(costs[row + d_row, col]), allow_unknown)
            and traversable(int(costs[row, col + d_col]), allow_unknown))


def line_of_sight(costs: CostArray, a: Cell, b: Cell, allow_unknown: bool = True) -> bool:
    """Can a straight segment join the centres of ``a`` and ``b``?

    Walks the Bresenham line from ``a`` to ``b``; every cell on it must be traversable and, at
    a diagonal step, both cells beside the step too (the segment must not squeeze between
    two blocked cells or clip a blocked corner).

    >>> c = np.zeros((3, 3), np.uint8); c[1, 1] = 254
    >>> line_of_sight(c, (0, 0), (0, 2)), line_of_sight(c, (0, 0), (2, 2))
    (True, False)
    """
    return _walk_line(costs, a, b, allow_unknown)[0]


def _distance(a: Cell, b: Cell) -> float:
    """Straight-line distance between cell centres [cells] (``sqrt`` of an exact integer, so
    the compiled code computes the very same number)."""
    return math.sqrt((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2)


def _segment_cost(cost: int) -> float:
    """Nav2 Theta*'s per-cell term before its weight: ``((26 + 0.9 c) / 252)²``."""
    c = float(MAX_NON_OBSTACLE if cost == NO_INFORMATION else cost)
    v = 26.0 + 0.9 * c
    return v * v / 63504.0


def _walk_line(costs: CostArray, a: Cell, b: Cell, allow_unknown: bool) -> tuple[bool, float]:
    """``(visible, Σ per-cell Theta* costs of the cells entered after a)``."""
    (row, col), (row1, col1) = a, b
    d_row, d_col = abs(row1 - row), abs(col1 - col)
    s_row, s_col = (1 if row1 > row else -1), (1 if col1 > col else -1)
    err = d_col - d_row
    total = 0.0
    while (row, col) != (row1, col1):
        e2 = 2 * err
        step_col, step_row = e2 > -d_row, e2 < d_col
        if step_col and step_row and not (
                traversable(int(costs[row + s_row, col]), allow_unknown)
                and traversable(int(costs[row, col + s_col]), allow_unknown)):
            return False, total
        if step_col:
            err -= d_row
            col += s_col
        if step_row:
            err += d_col
            row += s_row
        if not traversable(int(costs[row, col]), allow_unknown):
            return False, total
        total += _segment_cost(int(costs[row, col]))
    return True, total


# ------------------------------------------------------------------ validation

def _check_costs(costs: ArrayLike) -> CostArray:
    c = np.asarray(costs)
    if c.dtype == np.bool_:
        raise TypeError("costs must be Nav2 costs (uint8), not a boolean grid: use "
                        "np.where(passable, 0, 254) or GridMap.costs()")
    if c.ndim != 2 or c.dtype != np.uint8 or 0 in c.shape:
        raise ValueError(f"costs must be a non-empty (height, width) uint8 array; got "
                         f"{c.dtype} of shape {c.shape}")
    return np.ascontiguousarray(c)


def _check_cell(costs: CostArray, cell: object, what: str, allow_unknown: bool) -> Cell:
    try:
        row, col = (int(v) for v in cell)  # type: ignore[attr-defined]
    except (TypeError, ValueError):
        raise TypeError(f"{what} must be a (row, col) pair of integers; got {cell!r}") from None
    height, width = costs.shape
    outside, occupied = ((START_OUTSIDE_MAP, START_OCCUPIED) if what == "start"
                         else (GOAL_OUTSIDE_MAP, GOAL_OCCUPIED))
    if not (0 <= row < height and 0 <= col < width):
        raise PlanningError(f"{what} (row, col) = ({row}, {col}) is off the {height} x {width} "
                            f"grid (rows 0…{height - 1}, cols 0…{width - 1})", outside)
    if not traversable(int(costs[row, col]), allow_unknown):
        raise PlanningError(f"{what} (row, col) = ({row}, {col}) is in an obstacle: cost "
                            f"{int(costs[row, col])} (253 inscribed, 254 lethal, 255 unknown)",
                            occupied)
    return row, col


def _connectivity(connectivity: int) -> tuple[tuple[int, int], ...]:
    if connectivity not in (4, 8):
        raise ValueError(f"connectivity (how_many_corners) must be 4 or 8; got {connectivity!r}")
    return MOVES_8 if connectivity == 8 else MOVES_4


def _result(cells: list[Cell], cost: float, order: list[Cell], width: int,
            reason: str) -> SearchResult:
    path = np.array(cells, dtype=np.int64).reshape(-1, 2)
    steps = np.diff(path, axis=0)
    length = float(np.sqrt((steps * steps).sum(axis=1)).sum()) if len(path) else math.inf
    flat = np.array([r * width + c for r, c in order], dtype=np.int64)
    return SearchResult(path, cost, length, reason, flat, width)


def _no_path(start: Cell, goal: Cell, expanded: int) -> str:
    return (f"no path from {start} to {goal}: the goal is not reachable "
            f"({expanded} cells expanded)")


# ------------------------------------------------------------------ reference versions

def astar_reference(costs: ArrayLike, start: Cell, goal: Cell, *, connectivity: int = 8,
                    corner_cutting: bool = False, cost_travel_multiplier: float = 2.0,
                    allow_unknown: bool = True,
                    heuristic: Callable[[Cell, Cell], float] | None = None) -> SearchResult:
    """A* in plain Python (``heapq``): the readable version of :func:`astar`.

    ``heuristic(cell, goal)`` defaults to :func:`octile_distance` (8-connected) or
    :func:`manhattan_distance` (4-connected); pass ``lambda a, b: 0.0`` for Dijkstra.
    """
    c = _check_costs(costs)
    start = _check_cell(c, start, "start", allow_unknown)
    goal = _check_cell(c, goal, "goal", allow_unknown)
    moves = _connectivity(connectivity)
    if heuristic is None:
        heuristic = octile_distance if connectivity == 8 else manhattan_distance
    height, width = c.shape
    g = {start: 0.0}
    parent = {start: start}
    closed: set[Cell] = set()
    order: list[Cell] = []
    h0 = heuristic(start, goal)
    open_list = [(h0, h0, start[0] * width + start[1])]
    while open_list:
        _, _, index = heapq.heappop(open_list)
        cell = divmod(index, width)
        if cell in closed:
            continue                       # a stale entry: this cell was reached cheaper
        closed.add(cell)
        order.append(cell)
        if cell == goal:
            break
        for move in moves:
            nxt = (cell[0] + move[0], cell[1] + move[1])
            if not (0 <= nxt[0] < height and 0 <= nxt[1] < width) or nxt in closed:
                continue
            if not traversable(int(c[nxt]), allow_unknown):
                continue
            if not diagonal_allowed(c, cell, move, corner_cutting, allow_unknown):
                continue
            step = SQRT2 if move[0] and move[1] else 1.0
            new_g = g[cell] + traversal_cost(int(c[nxt]), step, cost_travel_multiplier)
            if new_g < g.get(nxt, math.inf):
                g[nxt] = new_g
                parent[nxt] = cell
                h = heuristic(nxt, goal)
                heapq.heappush(open_list, (new_g + h, h, nxt[0] * width + nxt[1]))
    if goal not in closed:
        return _result([], math.inf, order, width, _no_path(start, goal, len(order)))
    path = [goal]
    while path[-1] != start:
        path.append(parent[path[-1]])
    return _result(path[::-1], g[goal], order, width, "")


def dijkstra_reference(costs: ArrayLike, start: Cell, goal: Cell, *, connectivity: int = 8,
                       corner_cutting: bool = False, cost_travel_multiplier: float = 2.0,
                       allow_unknown: bool = True) -> SearchResult:
    """Dijkstra in plain Python: :func:`astar_reference` with a zero heuristic."""
    return astar_reference(costs, start, goal, connectivity=connectivity,
                           corner_cutting=corner_cutting,
                           cost_travel_multiplier=cost_travel_multiplier,
                           allow_unknown=allow_unknown, heuristic=lambda a, b: 0.0)


def theta_star_reference(costs: ArrayLike, start: Cell, goal: Cell, *,
                         how_many_corners: int = 8, w_euc_cost: float = 1.0,
                         w_traversal_cost: float = 2.0,
                         allow_unknown: bool = True) -> SearchResult:
    """Theta* in plain Python: the readable version of :func:`theta_star` (Nav2's parameter
    names; see the module docs for the cost). The heuristic is ``min(w_euc_cost, 1)`` times the
    straight-line distance to the goal."""
    c = _check_costs(costs)
    start = _check_cell(c, start, "start", allow_unknown)
    goal = _check_cell(c, goal, "goal", allow_unknown)
    moves = _connectivity(how_many_corners)
    w_h = min(w_euc_cost, 1.0)
    height, width = c.shape
    g = {start: 0.0}
    parent = {start: start}
    closed: set[Cell] = set()
    order: list[Cell] = []
    h0 = w_h * _distance(start, goal)
    open_list = [(h0, h0, start[0] * width + start[1])]
    while open_list:
        _, _, index = heapq.heappop(open_list)
        cell = divmod(index, width)
        if cell in closed:
            continue
        closed.add(cell)
        order.append(cell)
        if cell == goal:
            break
        for move in moves:
            nxt = (cell[0] + move[0], cell[1] + move[1])
            if not (0 <= nxt[0] < height and 0 <= nxt[1] < width) or nxt in closed:
                continue
            if not traversable(int(c[nxt]), allow_unknown):
                continue
            if not diagonal_allowed(c, cell, move, False, allow_unknown):
                continue
            via = cell                     # path 1: through the cell being expanded
            new_g = (g[cell] + w_euc_cost * _distance(cell, nxt)
                     + w_traversal_cost * _segment_cost(int(c[nxt])))
            grand = parent[cell]           # path 2: straight from its parent, if visible
            if grand != cell:
                visible, along = _walk_line(c, grand, nxt, allow_unknown)
                straight = g[grand] + w_euc_cost * _distance(grand, nxt) + w_traversal_cost * along
                if visible and straight <= new_g:
                    via, new_g = grand, straight
            if new_g < g.get(nxt, math.inf):
                g[nxt] = new_g
                parent[nxt] = via
                h = w_h * _distance(nxt, goal)
                heapq.heappush(open_list, (new_g + h, h, nxt[0] * width + nxt[1]))
    if goal not in closed:
        return _result([], math.inf, order, width, _no_path(start, goal, len(order)))
    path = [goal]
    while path[-1] != start:
        path.append(parent[path[-1]])
    return _result(path[::-1], g[goal], order, width, "")
