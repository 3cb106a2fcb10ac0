"""Paths as controllers see them: the part not yet driven, the carrot ahead, what is left.

A path here is an (N, 2) array of points [m] in the map frame (a planner's ``nav_msgs/Path``
through :func:`kit.planning.path_to_points`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["ControlError", "check_path", "closest_index", "lookahead_point", "remaining_length",
           "require_positive"]

FloatArray = NDArray[np.float64]


class ControlError(RuntimeError):
    """A controller cannot produce a safe command (Nav2's controller exceptions): no valid
    trajectory, a collision ahead, an empty path. ``reason`` says which."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def check_path(path: ArrayLike) -> FloatArray:
    """The path as a float (N, 2) array of finite points, N ≥ 1; ``ValueError`` otherwise."""
    p = np.asarray(path, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] < 2 or len(p) == 0:
        raise ValueError(f"a path is an (N, 2) array of points with N >= 1; got shape "
                         f"{p.shape}")
    p = np.ascontiguousarray(p[:, :2])
    if not np.all(np.isfinite(p)):
        raise ValueError("a path's points must be finite (a NaN or inf is in it)")
    return p


def closest_index(path: FloatArray, xy: FloatArray, start: int = 0,
                  search_distance: float = math.inf) -> int:
    """Index of the path point closest to ``xy`` among those from ``start`` on, looking no
    further than ``search_distance`` metres along the path (Nav2's pruning search)."""
    tail = path[start:]
    if math.isfinite(search_distance) and len(tail) > 1:
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(tail, axis=0).T))])
        tail = tail[:max(1, int(np.searchsorted(along, search_distance, side="right")))]
    d = np.hypot(tail[:, 0] - xy[0], tail[:, 1] - xy[1])
    return start + int(np.argmin(d))


def lookahead_point(path: FloatArray, xy: FloatArray, distance: float, start: int = 0
                    ) -> FloatArray:
    """The carrot: where a circle of radius ``distance`` around ``xy`` leaves the path, on
    the first segment from ``start`` whose far end lies outside the circle (the end of the
    path when every point is inside)."""
    x0, y0 = float(xy[0]), float(xy[1])
    d = np.hypot(path[start:, 0] - x0, path[start:, 1] - y0)
    beyond = np.flatnonzero(d >= distance)
    if len(beyond) == 0:
        return path[-1].copy()
    j = start + int(beyond[0])
    if j == start:
        return path[j].copy()
    a, b = path[j - 1], path[j]
    # the segment a→b enters at a (inside) and leaves at b (outside): solve |a + t(b−a)| = r
    dx, dy = b[0] - a[0], b[1] - a[1]
    fx, fy = a[0] - x0, a[1] - y0
    qa = dx * dx + dy * dy
    qb = 2.0 * (fx * dx + fy * dy)
    qc = fx * fx + fy * fy - distance * distance
    disc = max(qb * qb - 4.0 * qa * qc, 0.0)
    t = (-qb + math.sqrt(disc)) / (2.0 * qa) if qa > 0 else 1.0
    t = min(max(t, 0.0), 1.0)
    return np.array([a[0] + t * dx, a[1] + t * dy])


def remaining_length(path: FloatArray, xy: FloatArray, index: int) -> float:
    """Length [m] from ``xy`` to the path's end, through the path from point ``index``."""
    rest = path[index:]
    along = float(np.sum(np.hypot(*np.diff(rest, axis=0).T))) if len(rest) > 1 else 0.0
    return along + float(np.hypot(rest[0, 0] - xy[0], rest[0, 1] - xy[1]))


def require_positive(params: object, names: tuple[str, ...]) -> None:
    """``ValueError`` naming the first of ``params``' fields ``names`` that is not a finite
    positive number (the controllers' parameter checks)."""
    for name in names:
        value = getattr(params, name)
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f"{type(params).__name__}.{name} must be a positive number; got "
                             f"{value!r}")
