"""Free space the SLAM front end has seen: where a return cannot come from a wall.

A person walking beside or behind the robot returns points that scan matching cannot tell
from a wall's, and a matcher that pairs them with the same person's points in the last scans
is dragged along. The map itself says otherwise: the cells the person now stands in were
crossed by many earlier beams, and nothing stopped them. So the front end keeps the recent
nodes' beams in a log-odds occupancy grid (:class:`kit.mapping.OccupancyGridMap`) and a
return is taken for something that moves when every cell within ``margin`` of it has been
*seen free* — its occupancy probability below ``free_probability`` — which needs several
beams through it and none ending there. Returns in unknown space, or near anything not free
(walls, and the margin covers a pose a few centimetres off), are kept. This is the
map-consistency test of SLAM front ends that map among people (compare the dynamic-object
filtering of Hähnel et al., "Map building with mobile robots in dynamic environments",
ICRA 2003, which removes beams that contradict the map built so far).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, mapping

__all__ = ["FreeSpace"]

FloatArray = NDArray[np.float64]


class FreeSpace:
    """A log-odds grid of the beams of recent scans, and the test for returns that move.

    Parameters
    ----------
    resolution
        Cell size [m].
    margin
        A return is moving only if every cell within this distance [m] is seen free.
    free_probability
        A cell is seen free when its occupancy probability is below this.
    max_range
        Beams clear at most this far [m] (people matter near the robot).
    """

    def __init__(self, resolution: float = 0.05, margin: float = 0.15,
                 free_probability: float = 0.25, max_range: float = 10.0) -> None:
        if not (resolution > 0 and margin >= 0 and 0 < free_probability < 0.5 and
                max_range > 0):
            raise ValueError("resolution and max_range must be positive, margin >= 0 and "
                             f"free_probability in (0, 0.5); got {resolution}, {margin}, "
                             f"{free_probability}, {max_range}")
        self.resolution = float(resolution)
        self.margin = float(margin)
        self.max_range = float(max_range)
        self._l_free = float(mapping.log_odds(free_probability))
        self._model = mapping.InverseSensorModel(max_clear_range=max_range)
        self.clear()
        r = math.ceil(margin / resolution - 1e-9)
        dr, dc = np.mgrid[-r:r + 1, -r:r + 1]
        inside = np.hypot(dr, dc) * resolution <= margin + 1e-9
        self._offsets = np.column_stack([dc[inside], dr[inside]]).astype(np.int64)

    def clear(self) -> None:
        """Forget every beam."""
        self.grid = mapping.OccupancyGridMap(self.resolution, model=self._model)
        self.scans = 0

    def insert(self, sensor: ArrayLike, ends: ArrayLike, hits: ArrayLike) -> None:
        """Add one scan's beams: from ``sensor`` ``(x, y)`` to ``ends`` ``(N, 2)`` in the
        grid's frame [m]; ``hits[k]`` says whether beam ``k`` ended on something (a return
        found to move should be given as ``False``: its beam still crossed free space)."""
        e = np.asarray(ends, dtype=np.float64).reshape(-1, 2)
        h: NDArray[np.bool_] = np.asarray(hits, dtype=bool).ravel()
        s = np.asarray(sensor, dtype=np.float64)
        d = e - s
        length = np.hypot(d[:, 0], d[:, 1])
        far = length > self.max_range
        if far.any():  # a long beam clears only the first max_range metres
            e = e.copy()
            e[far] = s + d[far] * (self.max_range / length[far])[:, None]
            h = h & ~far
        self.grid.insert_points(s, e, h)
        self.scans += 1

    def moving(self, points: ArrayLike, compiled: bool = True) -> NDArray[np.bool_]:
        """For each point ``(M, 2)`` [m, the grid's frame]: does it lie where every cell
        within ``margin`` has been seen free? (``compiled=False``: the same answer by numpy,
        every cell of every point tested; compiled, a point's test stops at its first cell
        not seen free.)"""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if self.scans == 0 or len(p) == 0:
            return np.zeros(len(p), dtype=bool)
        log_odds = self.grid.log_odds
        cells = self.grid.cells(p)
        if compiled:
            return np.asarray(_compiled_moving()(log_odds, self._l_free, cells, self._offsets),
                              dtype=bool)
        rows, cols = log_odds.shape
        cx = cells[:, 0, None] + self._offsets[None, :, 0]
        cy = cells[:, 1, None] + self._offsets[None, :, 1]
        inside = (cx >= 0) & (cx < cols) & (cy >= 0) & (cy < rows)
        free = log_odds[np.clip(cy, 0, rows - 1), np.clip(cx, 0, cols - 1)] < self._l_free
        seen = free & inside
        return np.asarray(seen.all(axis=1), dtype=bool)


def _moving_python(log_odds: FloatArray, l_free: float, cells: NDArray[np.int64],
                   offsets: NDArray[np.int64]) -> NDArray[np.bool_]:
    # pragma: no cover - compiled by numba
    """:meth:`FreeSpace.moving`'s test: every cell ``cells[m] + offsets[k]`` inside the grid
    with log-odds below ``l_free``."""
    rows, cols = log_odds.shape
    out = np.zeros(cells.shape[0], dtype=np.bool_)
    for m in range(cells.shape[0]):
        seen = True
        for k in range(offsets.shape[0]):
            cx, cy = cells[m, 0] + offsets[k, 0], cells[m, 1] + offsets[k, 1]
            if cx < 0 or cx >= cols or cy < 0 or cy >= rows or not log_odds[cy, cx] < l_free:
                seen = False
                break
        out[m] = seen
    return out


_COMPILED: list = []


def _compiled_moving() -> Callable[..., NDArray[np.bool_]]:
    """:func:`_moving_python` compiled once (``cache=True``: later sessions load it)."""
    if not _COMPILED:
        import numba

        _COMPILED.append(numba.njit(cache=True, nogil=True)(_moving_python))
    return _COMPILED[0]


def laser_beams(pose: ArrayLike, base_to_laser: ArrayLike, ends: FloatArray
                ) -> tuple[FloatArray, FloatArray]:
    """The scanner's position and the beams' ends in the map for a scan whose ends are given
    in ``base`` (``ends`` ``(N, 2)``) with the robot at ``pose`` = ``T_map_base``."""
    laser = geometry.compose(pose, base_to_laser)
    return laser[:2].copy(), geometry.transform_points(pose, ends)
