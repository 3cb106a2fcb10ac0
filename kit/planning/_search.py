"""Grid search on a costmap: Dijkstra, A* and Theta*, each as a plain reference version and
a compiled one that gives the same cells, costs and expansions.

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
  cell itself is cheaper — as Nav2 does; plain Theta* always takes the segment, which with
  traversal costs can be the dearer one.

Start or goal off the grid or untraversable raises :class:`PlanningError` (a ``ValueError``
carrying Nav2's ``ComputePathToPose`` error code); a goal that cannot be reached is a result
with no cells and a ``reason``, never an exception.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from kit.planning._costmap import MAX_NON_OBSTACLE, NO_INFORMATION

__all__ = [
    "GOAL_OCCUPIED",
    "GOAL_OUTSIDE_MAP",
    "NO_VALID_PATH",
    "START_OCCUPIED",
    "START_OUTSIDE_MAP",
    "GridSearch",
    "PlanningError",
    "SearchResult",
    "astar",
    "astar_reference",
    "diagonal_allowed",
    "dijkstra",
    "dijkstra_reference",
    "line_of_sight",
    "manhattan_distance",
    "octile_distance",
    "theta_star",
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
    of its segments); ``expanded_cells`` ``(K, 2)`` the cells taken off the open list, in
    order; ``reason`` empty when a path was found.
    """

    cells: IntArray
    cost: float
    length: float
    expanded_cells: IntArray
    reason: str = ""

    @property
    def found(self) -> bool:
        return len(self.cells) > 0

    @property
    def expanded(self) -> int:
        """Number of cells expanded."""
        return len(self.expanded_cells)


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


def _result(cells: list[Cell], cost: float, order: list[Cell], reason: str) -> SearchResult:
    path = np.array(cells, dtype=np.int64).reshape(-1, 2)
    steps = np.diff(path, axis=0)
    length = float(np.sqrt((steps * steps).sum(axis=1)).sum()) if len(path) else math.inf
    return SearchResult(path, cost, length, np.array(order, dtype=np.int64).reshape(-1, 2),
                        reason)


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
        return _result([], math.inf, order, _no_path(start, goal, len(order)))
    path = [goal]
    while path[-1] != start:
        path.append(parent[path[-1]])
    return _result(path[::-1], g[goal], order, "")


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
        return _result([], math.inf, order, _no_path(start, goal, len(order)))
    path = [goal]
    while path[-1] != start:
        path.append(parent[path[-1]])
    return _result(path[::-1], g[goal], order, "")


# ------------------------------------------------------------------ compiled versions
#
# The compiled searches work on the grid padded with one blocked cell all round, in flat
# indices ``p = (row + 1) · (width + 2) + col + 1`` (the same order as ``row · width + col``,
# so ties break the same way), with each cell's traversability, move-cost factor
# ``1 + cost_travel_multiplier · c / 252`` and Theta* cell term computed once per grid by the
# very expressions the reference versions use. The open list is a binary heap indexed by cell
# (decrease-key instead of stale entries) with the reference's key order, so both pop the same
# cells. Work arrays live in GridSearch and are reused between queries: ``mark[p] == 2·query``
# means "open in this query" (g and parent valid), ``2·query + 1`` "closed"; anything smaller,
# "not seen yet".

_DR = (1, -1, 0, 0, 1, 1, -1, -1)
_DC = (0, 0, 1, -1, 1, -1, 1, -1)


@njit(cache=True)
def _before(hf: Any, hh: Any, hn: Any, i: int, j: int) -> bool:
    if hf[i] != hf[j]:
        return hf[i] < hf[j]
    if hh[i] != hh[j]:
        return hh[i] < hh[j]
    return hn[i] < hn[j]


@njit(cache=True)
def _sift_up(hf: Any, hh: Any, hn: Any, pos: Any, i: int, f: float, h: float,
             cell: int) -> None:
    """Put the entry ``(f, h, cell)`` at hole ``i`` or above it."""
    while i > 0:
        p = (i - 1) >> 1
        if hf[p] < f or (hf[p] == f and (hh[p] < h or (hh[p] == h and hn[p] < cell))):
            break
        hf[i], hh[i], hn[i] = hf[p], hh[p], hn[p]
        pos[hn[i]] = i
        i = p
    hf[i], hh[i], hn[i] = f, h, cell
    pos[cell] = i


@njit(cache=True)
def _pop(hf: Any, hh: Any, hn: Any, pos: Any, size: int) -> int:
    """Remove the smallest entry; returns its cell. ``size`` is the size before."""
    top = hn[0]
    size -= 1
    if size == 0:
        return top
    f, h, cell = hf[size], hh[size], hn[size]
    i = 0
    while True:
        child = 2 * i + 1
        if child >= size:
            break
        if child + 1 < size and _before(hf, hh, hn, child + 1, child):
            child += 1
        if not (hf[child] < f or (hf[child] == f and (
                hh[child] < h or (hh[child] == h and hn[child] < cell)))):
            break
        hf[i], hh[i], hn[i] = hf[child], hh[child], hn[child]
        pos[hn[i]] = i
        i = child
    hf[i], hh[i], hn[i] = f, h, cell
    pos[cell] = i
    return top


@njit(cache=True)
def _astar_compiled(free: Any, factor: Any, uniform: bool, stride: int, start: int, goal: int,
                    moves: int, corner_cutting: bool, heuristic: int, work: Any,
                    query: int) -> tuple[bool, int]:
    """A* (``heuristic`` 1 octile, 2 Manhattan) or Dijkstra (``heuristic`` 0) on the padded
    grid; returns ``(found, number of cells expanded)``, the expansion order in ``work[5]``.
    ``uniform``: every factor is 1 (skip reading them)."""
    mark, parent, hn, pos, order = work[0], work[1], work[2], work[3], work[5]
    g, hf, hh = work[6], work[7], work[8]
    is_open, is_closed = 2 * query, 2 * query + 1
    goal_row, goal_col = goal // stride, goal % stride
    g[start] = 0.0
    parent[start] = start
    mark[start] = is_open
    _sift_up(hf, hh, hn, pos, 0, 0.0, 0.0, start)
    size = 1
    expanded = 0
    while size > 0:
        u = _pop(hf, hh, hn, pos, size)
        size -= 1
        mark[u] = is_closed
        order[expanded] = u
        expanded += 1
        if u == goal:
            return True, expanded
        row, col = u // stride, u % stride
        g_u = g[u]
        for k in range(moves):
            v = u + _DR[k] * stride + _DC[k]
            if not free[v]:
                continue
            state = mark[v]
            if state == is_closed:
                continue
            step = 1.0
            if k >= 4:
                if not corner_cutting and not (free[v - _DC[k]] and free[u + _DC[k]]):
                    continue
                step = SQRT2
            new_g = g_u + step if uniform else g_u + step * factor[v]
            seen = state == is_open
            if seen:
                if new_g >= g[v]:
                    continue
                i = pos[v]
                h = hh[i]                      # the same cell, the same heuristic
            else:
                i = size
                size += 1
                h = 0.0
                if heuristic != 0:
                    d_row, d_col = abs(row + _DR[k] - goal_row), abs(col + _DC[k] - goal_col)
                    if heuristic == 1:
                        h = (max(d_row, d_col) - min(d_row, d_col)) + SQRT2 * min(d_row, d_col)
                    else:
                        h = float(d_row + d_col)
                mark[v] = is_open
            g[v] = new_g
            parent[v] = u
            _sift_up(hf, hh, hn, pos, i, new_g + h, h, v)
    return False, expanded


@njit(cache=True)
def _walk_compiled(free: Any, term: Any, stride: int, a: int, b: int) -> tuple[bool, float]:
    """Compiled :func:`_walk_line` on padded flat indices."""
    row, col, row1, col1 = a // stride, a % stride, b // stride, b % stride
    d_row, d_col = abs(row1 - row), abs(col1 - col)
    s_row = 1 if row1 > row else -1
    s_col = 1 if col1 > col else -1
    err = d_col - d_row
    total = 0.0
    while row != row1 or col != col1:
        e2 = 2 * err
        step_col, step_row = e2 > -d_row, e2 < d_col
        if step_col and step_row and not (free[(row + s_row) * stride + col]
                                          and free[row * stride + col + s_col]):
            return False, total
        if step_col:
            err -= d_row
            col += s_col
        if step_row:
            err += d_col
            row += s_row
        p = row * stride + col
        if not free[p]:
            return False, total
        total += term[p]
    return True, total


@njit(cache=True)
def _theta_star_compiled(free: Any, term: Any, stride: int, start: int, goal: int, moves: int,
                         w_euc: float, w_traversal: float, work: Any,
                         query: int) -> tuple[bool, int]:
    """Theta* as :func:`theta_star_reference` on the padded grid; ``(found, expanded)``."""
    mark, parent, hn, pos, order = work[0], work[1], work[2], work[3], work[5]
    g, hf, hh = work[6], work[7], work[8]
    is_open, is_closed = 2 * query, 2 * query + 1
    goal_row, goal_col = goal // stride, goal % stride
    w_h = min(w_euc, 1.0)
    g[start] = 0.0
    parent[start] = start
    mark[start] = is_open
    _sift_up(hf, hh, hn, pos, 0, 0.0, 0.0, start)
    size = 1
    expanded = 0
    while size > 0:
        u = _pop(hf, hh, hn, pos, size)
        size -= 1
        mark[u] = is_closed
        order[expanded] = u
        expanded += 1
        if u == goal:
            return True, expanded
        for k in range(moves):
            v = u + _DR[k] * stride + _DC[k]
            if mark[v] == is_closed or not free[v]:
                continue
            if k >= 4 and not (free[v - _DC[k]] and free[u + _DC[k]]):
                continue
            via = u
            d_row, d_col = v // stride - u // stride, v % stride - u % stride
            new_g = (g[u] + w_euc * np.sqrt(float(d_row * d_row + d_col * d_col))
                     + w_traversal * term[v])
            grand = parent[u]
            if grand != u:
                visible, along = _walk_compiled(free, term, stride, grand, v)
                d_row, d_col = v // stride - grand // stride, v % stride - grand % stride
                straight = (g[grand] + w_euc * np.sqrt(float(d_row * d_row + d_col * d_col))
                            + w_traversal * along)
                if visible and straight <= new_g:
                    via, new_g = grand, straight
            seen = mark[v] == is_open
            if seen and new_g >= g[v]:
                continue
            g[v] = new_g
            parent[v] = via
            d_row, d_col = v // stride - goal_row, v % stride - goal_col
            h = w_h * np.sqrt(float(d_row * d_row + d_col * d_col))
            mark[v] = is_open
            _sift_up(hf, hh, hn, pos, pos[v] if seen else size, new_g + h, h, v)
            if not seen:
                size += 1
    return False, expanded


@njit(cache=True)
def _trace(parent: Any, start: int, goal: int, out: Any) -> int:
    """Write the path goal → start into ``out``; returns its number of cells."""
    n = 0
    v = goal
    while True:
        out[n] = v
        n += 1
        if v == start:
            return n
        v = parent[v]


class GridSearch:
    """Repeated searches on one grid of costs, compiled (numba), sharing their work arrays.

    Parameters
    ----------
    costs
        ``(height, width)`` uint8 Nav2 costs, ``costs[row, col]``.
    connectivity
        4 or 8 (Nav2 Theta*'s ``how_many_corners``).
    corner_cutting
        Let diagonal moves pass blocked corners (A* and Dijkstra only; Theta* never does).
    cost_travel_multiplier
        Weight of the costmap in a move's cost (Smac 2-D's parameter; 0 plans by length).
    allow_unknown
        Plan through unknown cells (cost 255).

    >>> search = GridSearch(np.zeros((3, 4), np.uint8))
    >>> r = search.astar((0, 0), (2, 3))
    >>> r.cells.tolist(), round(r.cost, 6)
    ([[0, 0], [1, 1], [1, 2], [2, 3]], 3.828427)
    """

    def __init__(self, costs: ArrayLike, *, connectivity: int = 8, corner_cutting: bool = False,
                 cost_travel_multiplier: float = 2.0, allow_unknown: bool = True) -> None:
        self.costs = _check_costs(costs).copy()
        self.costs.flags.writeable = False
        _connectivity(connectivity)
        if not (math.isfinite(cost_travel_multiplier) and cost_travel_multiplier >= 0):
            raise ValueError(f"cost_travel_multiplier must be a non-negative number; got "
                             f"{cost_travel_multiplier!r}")
        self.connectivity = connectivity
        self.corner_cutting = bool(corner_cutting)
        self.cost_travel_multiplier = float(cost_travel_multiplier)
        self.allow_unknown = bool(allow_unknown)
        height, width = self.costs.shape
        self._stride = width + 2
        c = self.costs.astype(np.float64)
        c[self.costs == NO_INFORMATION] = MAX_NON_OBSTACLE
        ok = (self.costs <= MAX_NON_OBSTACLE) | (allow_unknown & (self.costs == NO_INFORMATION))
        self._free = np.pad(ok, 1).ravel()
        self._factor = np.pad(1.0 + self.cost_travel_multiplier * (c / 252.0), 1).ravel()
        self._uniform = bool(np.all(self._factor[self._free] == 1.0))
        v = 26.0 + 0.9 * c                      # Theta*'s term, as _segment_cost computes it
        self._term = np.pad(v * v / 63504.0, 1).ravel()
        n = (height + 2) * (width + 2)
        # mark, parent, heap cells, heap positions, path, expansion order; g, f, h
        self._ints = tuple(np.zeros(n, np.int32) for _ in range(6))
        self._floats = tuple(np.zeros(n, np.float64) for _ in range(3))
        self._query = 0

    def _index(self, cell: Cell) -> int:
        return (cell[0] + 1) * self._stride + cell[1] + 1

    def _cells(self, flat: NDArray[np.int32]) -> IntArray:
        p = flat.astype(np.int64)
        return np.column_stack([p // self._stride - 1, p % self._stride - 1])

    def _begin(self, start: object, goal: object) -> tuple[Cell, Cell]:
        s = _check_cell(self.costs, start, "start", self.allow_unknown)
        t = _check_cell(self.costs, goal, "goal", self.allow_unknown)
        self._query += 1
        if 2 * self._query + 1 >= np.iinfo(np.int32).max:
            self._ints[0][:] = 0
            self._query = 1
        return s, t

    def _finish(self, start: Cell, goal: Cell, found: bool, expanded: int) -> SearchResult:
        _, parent, _, _, path, order = self._ints
        order_rc = self._cells(order[:expanded])
        if not found:
            return SearchResult(np.zeros((0, 2), np.int64), math.inf, math.inf, order_rc,
                                _no_path(start, goal, expanded))
        t = self._index(goal)
        n = _trace(parent, self._index(start), t, path)
        rc = self._cells(path[:n][::-1])
        steps = np.diff(rc, axis=0)
        length = float(np.sqrt((steps * steps).sum(axis=1)).sum())
        return SearchResult(rc, float(self._floats[0][t]), length, order_rc, "")

    def _run_astar(self, start: object, goal: object, heuristic: int) -> SearchResult:
        s, t = self._begin(start, goal)
        found, expanded = _astar_compiled(
            self._free, self._factor, self._uniform, self._stride, self._index(s),
            self._index(t), self.connectivity, self.corner_cutting, heuristic,
            self._ints + self._floats,
            self._query)
        return self._finish(s, t, found, expanded)

    def astar(self, start: Cell, goal: Cell) -> SearchResult:
        """A* from ``start`` to ``goal`` (``(row, col)`` cells)."""
        return self._run_astar(start, goal, 1 if self.connectivity == 8 else 2)

    def dijkstra(self, start: Cell, goal: Cell) -> SearchResult:
        """Dijkstra from ``start`` to ``goal``: A* without a heuristic."""
        return self._run_astar(start, goal, 0)

    def theta_star(self, start: Cell, goal: Cell, *, w_euc_cost: float = 1.0,
                   w_traversal_cost: float = 2.0) -> SearchResult:
        """Theta* from ``start`` to ``goal``; the path's cells are its corners."""
        for name, value in (("w_euc_cost", w_euc_cost), ("w_traversal_cost", w_traversal_cost)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a non-negative number; got {value!r}")
        s, t = self._begin(start, goal)
        found, expanded = _theta_star_compiled(
            self._free, self._term, self._stride, self._index(s), self._index(t),
            self.connectivity, float(w_euc_cost), float(w_traversal_cost),
            self._ints + self._floats, self._query)
        return self._finish(s, t, found, expanded)


def astar(costs: ArrayLike, start: Cell, goal: Cell, *, connectivity: int = 8,
          corner_cutting: bool = False, cost_travel_multiplier: float = 2.0,
          allow_unknown: bool = True) -> SearchResult:
    """A* on ``costs`` from ``start`` to ``goal`` (``(row, col)``), compiled; the same result
    as :func:`astar_reference`. For many queries on one grid, keep a :class:`GridSearch`."""
    return GridSearch(costs, connectivity=connectivity, corner_cutting=corner_cutting,
                      cost_travel_multiplier=cost_travel_multiplier,
                      allow_unknown=allow_unknown).astar(start, goal)


def dijkstra(costs: ArrayLike, start: Cell, goal: Cell, *, connectivity: int = 8,
             corner_cutting: bool = False, cost_travel_multiplier: float = 2.0,
             allow_unknown: bool = True) -> SearchResult:
    """Dijkstra, compiled; the same result as :func:`dijkstra_reference`."""
    return GridSearch(costs, connectivity=connectivity, corner_cutting=corner_cutting,
                      cost_travel_multiplier=cost_travel_multiplier,
                      allow_unknown=allow_unknown).dijkstra(start, goal)


def theta_star(costs: ArrayLike, start: Cell, goal: Cell, *, how_many_corners: int = 8,
               w_euc_cost: float = 1.0, w_traversal_cost: float = 2.0,
               allow_unknown: bool = True) -> SearchResult:
    """Theta*, compiled; the same result as :func:`theta_star_reference`."""
    return GridSearch(costs, connectivity=how_many_corners,
                      allow_unknown=allow_unknown).theta_star(
        start, goal, w_euc_cost=w_euc_cost, w_traversal_cost=w_traversal_cost)
