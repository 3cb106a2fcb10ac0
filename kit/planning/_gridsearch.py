"""Compiled grid search (numba): the same Dijkstra, A* and Theta* as the reference versions
in ``_search`` (conventions there), many times faster; :class:`GridSearch` keeps one grid's
work arrays for many queries.

The compiled searches work on the grid padded with one blocked cell all round, in flat
indices ``p = (row + 1) · (width + 2) + col + 1`` (the same order as ``row · width + col``,
so ties break the same way), with each cell's traversability, move-cost factor
``1 + cost_travel_multiplier · c / 252`` and Theta* cell term computed once per grid by the
very expressions the reference versions use. The open list is a binary heap indexed by cell
(decrease-key instead of stale entries) with the reference's key order, so both pop the same
cells. Work arrays live in GridSearch and are reused between queries: ``mark[p] == 2·query``
means "open in this query" (g and parent valid), ``2·query + 1`` "closed"; anything smaller,
"not seen yet".
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from kit.planning._costmap import MAX_NON_OBSTACLE, NO_INFORMATION
from kit.planning._search import (
    SQRT2,
    Cell,
    IntArray,
    SearchResult,
    _check_cell,
    _check_costs,
    _connectivity,
    _no_path,
)

__all__ = ["GridSearch", "astar", "dijkstra", "theta_star"]

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
                    query: int, limit: int) -> tuple[bool, int]:
    """A* (``heuristic`` 1 octile, 2 Manhattan) or Dijkstra (``heuristic`` 0) on the padded
    grid; returns ``(found, number of cells expanded)``, the expansion order in ``work[5]``.
    ``uniform``: every factor is 1 (skip reading them). At most ``limit`` cells are expanded
    (negative: no limit); a ``goal`` of −1 expands every reachable cell."""
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
        if expanded == limit:
            return False, expanded
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
    max_iterations
        At most this many cells expanded by A* and Dijkstra (Smac's ``max_iterations``); a
        search that stops there finds no path. ``None``: no limit.

    >>> search = GridSearch(np.zeros((3, 4), np.uint8))
    >>> r = search.astar((0, 0), (2, 3))
    >>> r.cells.tolist(), round(r.cost, 6)
    ([[0, 0], [1, 1], [1, 2], [2, 3]], 3.828427)
    """

    def __init__(self, costs: ArrayLike, *, connectivity: int = 8, corner_cutting: bool = False,
                 cost_travel_multiplier: float = 2.0, allow_unknown: bool = True,
                 max_iterations: int | None = None) -> None:
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
        if max_iterations is not None and (isinstance(max_iterations, bool) or
                                           not isinstance(max_iterations, int) or
                                           max_iterations < 1):
            raise ValueError(f"max_iterations must be a positive whole number or None; got "
                             f"{max_iterations!r}")
        self.max_iterations = max_iterations
        height, width = self.costs.shape
        self._stride = width + 2
        c = self.costs.astype(np.float64)
        c[self.costs == NO_INFORMATION] = MAX_NON_OBSTACLE
        ok = (self.costs <= MAX_NON_OBSTACLE) | (allow_unknown & (self.costs == NO_INFORMATION))
        self._free = np.pad(ok, 1).ravel()
        factor = 1.0 + self.cost_travel_multiplier * (c / 252.0)
        self._uniform = bool(np.all(factor[ok] == 1.0))
        # a uniform grid never reads its factors: keep one, not one per cell
        self._factor = np.ones(1) if self._uniform else np.pad(factor, 1).ravel()
        self._term: NDArray[np.float64] | None = None     # Theta*'s, made on its first query
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
        expanded_order = order[:expanded].copy()
        if not found:
            reason = (f"no path from {start} to {goal} within max_iterations = "
                      f"{self.max_iterations} cells expanded"
                      if expanded == self.max_iterations else _no_path(start, goal, expanded))
            return SearchResult(np.zeros((0, 2), np.int64), math.inf, math.inf,
                                reason, expanded_order, self._stride, 1)
        t = self._index(goal)
        n = _trace(parent, self._index(start), t, path)
        rc = self._cells(path[:n][::-1])
        steps = np.diff(rc, axis=0)
        length = float(np.sqrt((steps * steps).sum(axis=1)).sum())
        return SearchResult(rc, float(self._floats[0][t]), length, "", expanded_order,
                            self._stride, 1)

    def _run_astar(self, start: object, goal: object, heuristic: int) -> SearchResult:
        s, t = self._begin(start, goal)
        found, expanded = _astar_compiled(
            self._free, self._factor, self._uniform, self._stride, self._index(s),
            self._index(t), self.connectivity, self.corner_cutting, heuristic,
            self._ints + self._floats,
            self._query, -1 if self.max_iterations is None else self.max_iterations)
        return self._finish(s, t, found, expanded)

    def reachable(self, start: Cell) -> NDArray[np.bool_]:
        """``(height, width)``: the cells a path from ``start`` can reach (a Dijkstra over
        every cell it can, whatever ``max_iterations``)."""
        s = _check_cell(self.costs, start, "start", self.allow_unknown)
        self._query += 1
        if 2 * self._query + 1 >= np.iinfo(np.int32).max:
            self._ints[0][:] = 0
            self._query = 1
        _, expanded = _astar_compiled(
            self._free, self._factor, self._uniform, self._stride, self._index(s), -1,
            self.connectivity, self.corner_cutting, 0, self._ints + self._floats,
            self._query, -1)
        out = np.zeros(self.costs.shape, dtype=bool)
        cells = self._cells(self._ints[5][:expanded])
        out[cells[:, 0], cells[:, 1]] = True
        return out

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
        if self._term is None:
            c = self.costs.astype(np.float64)
            c[self.costs == NO_INFORMATION] = MAX_NON_OBSTACLE
            v = 26.0 + 0.9 * c                  # Theta*'s term, as _segment_cost computes it
            self._term = np.pad(v * v / 63504.0, 1).ravel()
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
