"""Path measures and the smoothers of Nav2's smoother server, keeping the path clear of
obstacles.

Paths here are ``(N, 2)`` arrays of ``(x, y)`` [m] in the costmap's frame (see
:func:`kit.planning.path_to_points`). Both smoothers keep the first and last point where they
are and never move a point onto a cell costlier than ``max_cost`` — by default
``MAX_NON_OBSTACLE`` (252), i.e. the robot's footprint stays off obstacles; a lower
``max_cost`` keeps more clearance. They return a :class:`SmoothedPath` whose ``reason`` says
when and why smoothing stopped short.

Both smooth a path piece by piece between its cusps (where it turns back: :func:`segments`),
each piece's ends kept, as Nav2's smoothers do; a piece too short is left as it is.

* :func:`simple_smooth` — Nav2's ``SimpleSmoother``: gradient steps
  ``y_i += w_data (x_i − y_i) + w_smooth (y_{i+1} + y_{i−1} − 2 y_i)`` until the total change
  of an iteration drops below ``tolerance``, at most ``max_its − 1`` of them (Nav2 stops when
  its count reaches ``max_its``); an iteration that would put a point on a costly cell is
  undone and that piece stops there. ``do_refinement`` smooths the result again,
  ``refinement_num`` times. Pieces of fewer than 5 points are left alone.
* :func:`savitzky_golay_smooth` — Nav2's ``SavitzkyGolaySmoother``: each interior point
  becomes the least-squares polynomial fit (``poly_order``) of the ``window_size`` points
  around it (the piece's ends repeated beyond them); refinement applies it again. Pieces of
  fewer than ``window_size + 4`` points (11: Nav2's filter has 7) are left alone. If the
  result touches a costly cell the input comes back unchanged: the kit's rule (Nav2's
  plugin never looks at the costmap; its smoother server checks only when the goal asks,
  ``check_for_collisions``, off by default).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit.planning._costmap import MAX_NON_OBSTACLE, NO_INFORMATION, Costmap

__all__ = [
    "SmoothedPath",
    "curvature",
    "path_length",
    "resample",
    "savitzky_golay_coefficients",
    "savitzky_golay_smooth",
    "segments",
    "simple_smooth",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class SmoothedPath:
    """``points`` ``(N, 2)`` [m]; ``iterations`` of the smoother; ``reason`` empty when it
    ran to completion."""

    points: FloatArray
    iterations: int
    reason: str = ""


def _check_points(points: ArrayLike, name: str = "points") -> FloatArray:
    p = np.array(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or not np.isfinite(p).all():
        raise ValueError(f"{name} must be an (N, 2) array of finite (x, y) [m]; got shape "
                         f"{p.shape}")
    return p


def path_length(points: ArrayLike) -> float:
    """Length [m] of the polyline through ``points`` ``(N, 2)``.

    >>> path_length([[0, 0], [3, 4], [3, 5]])
    6.0
    """
    p = _check_points(points)
    return float(np.sqrt((np.diff(p, axis=0) ** 2).sum(axis=1)).sum())


def curvature(points: ArrayLike) -> FloatArray:
    """Signed curvature [1/m] at each point, shape ``(N,)``: the Menger curvature
    ``κ = 2 ((b − a) × (c − b)) / (|ab| |bc| |ac|)`` of each point ``b`` with its neighbours
    (positive turning left, counter-clockwise); 0 at the ends and where points coincide.

    >>> t = np.linspace(0, np.pi, 5)
    >>> curvature(np.column_stack([2 * np.cos(t), 2 * np.sin(t)]))[1:-1].round(9).tolist()
    [0.5, 0.5, 0.5]
    """
    p = _check_points(points)
    kappa = np.zeros(len(p))
    if len(p) < 3:
        return kappa
    a, b, c = p[:-2], p[1:-1], p[2:]
    ab, bc, ac = b - a, c - b, c - a
    cross = ab[:, 0] * bc[:, 1] - ab[:, 1] * bc[:, 0]
    norms = (np.sqrt((ab ** 2).sum(1)) * np.sqrt((bc ** 2).sum(1)) * np.sqrt((ac ** 2).sum(1)))
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa[1:-1] = np.where(norms > 0, 2.0 * cross / norms, 0.0)
    return kappa


def resample(points: ArrayLike, spacing: float) -> FloatArray:
    """Points every ``spacing`` metres along the polyline, the last point included: evenly
    spaced waypoints for a controller, shape ``(M, 2)``.

    >>> resample([[0, 0], [1, 0], [1, 1]], 0.5).tolist()
    [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [1.0, 0.5], [1.0, 1.0]]
    """
    p = _check_points(points)
    if not (math.isfinite(spacing) and spacing > 0):
        raise ValueError(f"spacing must be a positive number of metres; got {spacing!r}")
    s = np.concatenate([[0.0], np.cumsum(np.sqrt((np.diff(p, axis=0) ** 2).sum(axis=1)))])
    if len(p) < 2 or s[-1] == 0:
        return p[:1].copy()
    stations = np.arange(0.0, s[-1], spacing)
    if s[-1] - stations[-1] > 1e-9 * max(1.0, s[-1]):
        stations = np.append(stations, s[-1])
    else:
        stations[-1] = s[-1]
    return np.column_stack([np.interp(stations, s, p[:, 0]), np.interp(stations, s, p[:, 1])])


def _too_costly(points: FloatArray, costmap: Costmap | None, max_cost: int) -> int:
    """Index of the first point on a cell costlier than ``max_cost`` (unknown cells pass, as in
    Nav2) or off the map; −1 if none."""
    if costmap is None:
        return -1
    col = np.floor((points[:, 0] - costmap.origin[0]) / costmap.resolution).astype(np.int64)
    row = np.floor((points[:, 1] - costmap.origin[1]) / costmap.resolution).astype(np.int64)
    off = (row < 0) | (col < 0) | (row >= costmap.height) | (col >= costmap.width)
    cost = np.zeros(len(points), dtype=np.int64)
    cost[~off] = costmap.costs[row[~off], col[~off]]
    bad = off | ((cost > max_cost) & (cost != NO_INFORMATION))
    return int(np.argmax(bad)) if bad.any() else -1


def segments(points: ArrayLike) -> list[tuple[int, int]]:
    """``(start, end)`` indices (inclusive) of a path's pieces between cusps, where it turns
    back (Nav2's ``findDirectionalPathSegments``: the steps into and out of a point have a
    negative dot product). A cusp ends one piece and starts the next; the smoothers keep it.

    >>> segments([(0, 0), (1, 0), (2, 0), (1.5, 0.1), (1, 0.2)])
    [(0, 2), (2, 4)]
    """
    p = _check_points(points)
    if len(p) < 3:
        return [(0, len(p) - 1)]
    step = np.diff(p, axis=0)
    cusps = np.flatnonzero(np.einsum("nd,nd->n", step[:-1], step[1:]) < 0.0) + 1
    bounds = [0, *cusps.tolist(), len(p) - 1]
    return list(itertools.pairwise(bounds))


def _simple_pass(data: FloatArray, costmap: Costmap | None, w_data: float, w_smooth: float,
                 tolerance: float, max_its: int, max_cost: int) -> tuple[FloatArray, int, str]:
    y = data.copy()
    for its in range(1, max_its):     # Nav2 stops when the count reaches max_its, undone
        last = y.copy()
        change = 0.0
        for i in range(1, len(y) - 1):             # Gauss-Seidel: y[i-1] is already new
            old = y[i].copy()
            y[i] += w_data * (data[i] - y[i]) + w_smooth * (y[i + 1] + y[i - 1] - 2.0 * y[i])
            change += float(np.abs(y[i] - old).sum())
        bad = _too_costly(y[1:-1], costmap, max_cost)
        if bad >= 0:
            return last, its, (f"stopped at iteration {its}: point {bad + 1} would move onto a "
                               f"cell of cost above {max_cost} (or off the map)")
        if change < tolerance:
            return y, its, ""
    return y, max(max_its - 1, 0), f"did not converge in max_its = {max_its} iterations"


def simple_smooth(points: ArrayLike, costmap: Costmap | None = None, *, w_data: float = 0.2,
                  w_smooth: float = 0.3, tolerance: float = 1e-10, max_its: int = 1000,
                  do_refinement: bool = True, refinement_num: int = 2,
                  max_cost: int = MAX_NON_OBSTACLE) -> SmoothedPath:
    """Nav2's simple smoother (parameters by Nav2's names; see the module docs): each piece
    between cusps (:func:`segments`) of at least 5 points smoothed on its own, its ends kept."""
    p = _check_points(points).copy()
    total, reasons = 0, []
    for start, end in segments(p):
        if end - start <= 3:                       # Nav2: too short to smooth
            continue
        piece = p[start:end + 1]
        for _ in range(1 + (refinement_num if do_refinement else 0)):
            piece, its, reason = _simple_pass(piece, costmap, w_data, w_smooth, tolerance,
                                              max_its, max_cost)
            total += its
            if reason:
                reasons.append(reason if start == 0 and end == len(p) - 1 else
                               f"points {start}-{end}: {reason}")
                break
        p[start:end + 1] = piece
    return SmoothedPath(p, total, "; ".join(reasons))


def savitzky_golay_coefficients(window_size: int = 7, poly_order: int = 3) -> FloatArray:
    """Weights of the Savitzky–Golay filter that gives a window's middle point, shape
    ``(window_size,)``: row 0 of the pseudo-inverse of the Vandermonde matrix of
    ``−h … h`` (``h = (window_size − 1) / 2``).

    >>> (savitzky_golay_coefficients(5, 2) * 35).round(6).tolist()
    [-3.0, 12.0, 17.0, 12.0, -3.0]
    """
    if window_size < 3 or window_size % 2 == 0:
        raise ValueError(f"window_size must be odd and at least 3; got {window_size}")
    if not 0 <= poly_order < window_size:
        raise ValueError(f"poly_order must be between 0 and window_size - 1; got {poly_order}")
    half = (window_size - 1) // 2
    v = np.arange(-half, half + 1, dtype=np.float64)
    vandermonde = v[:, None] ** np.arange(poly_order + 1)[None, :]
    return np.linalg.pinv(vandermonde)[0]


def savitzky_golay_smooth(points: ArrayLike, costmap: Costmap | None = None, *,
                          window_size: int = 7, poly_order: int = 3, do_refinement: bool = True,
                          refinement_num: int = 2,
                          max_cost: int = MAX_NON_OBSTACLE) -> SmoothedPath:
    """Nav2's Savitzky–Golay smoother (parameters by Nav2's names; see the module docs): each
    piece between cusps (:func:`segments`) of at least ``window_size + 4`` points (11 for
    Nav2's 7-point filter) filtered on its own, its ends kept."""
    weights = savitzky_golay_coefficients(window_size, poly_order)
    p = _check_points(points)
    y = p.copy()
    half = (window_size - 1) // 2
    rounds = 1 + (refinement_num if do_refinement else 0)
    smoothed = 0
    for start, end in segments(p):
        if end - start < window_size + 3:          # Nav2: end - start > 9 for 7 points
            continue
        n = end - start + 1
        index = start + np.clip(np.arange(1, n - 1)[:, None] +
                                np.arange(-half, half + 1)[None, :], 0, n - 1)
        for _ in range(rounds):
            y[start + 1:end] = np.einsum("w,nwd->nd", weights, y[index])
        smoothed += 1
    if not smoothed:
        return SmoothedPath(p, 0, f"no piece of at least window_size + 4 = {window_size + 4} "
                                  f"points between cusps")
    bad = _too_costly(y[1:-1], costmap, max_cost)
    if bad >= 0:
        return SmoothedPath(p, rounds, f"rejected: point {bad + 1} of the smoothed path is on a "
                                       f"cell of cost above {max_cost} (or off the map)")
    return SmoothedPath(y, rounds, "")
