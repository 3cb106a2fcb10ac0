"""Occupancy-grid mapping with known poses: a log-odds grid and the inverse sensor model.

Each cell holds the log-odds ``l = log(p / (1 − p))`` of being occupied, 0 (p = ½) when
nothing is known. A beam from the sensor to its end point is traced through the grid
(Bresenham's line, all integer); the cells it crosses were seen empty and the cell it ends in
was seen occupied:

.. math:: l \\leftarrow \\mathrm{clamp}(l + l_{free}, l_{min}, l_{max}) \\text{ along the beam},
          \\quad l \\leftarrow \\mathrm{clamp}(l + l_{occ}, l_{min}, l_{max}) \\text{ at its end}

(Thrun, Burgard & Fox, *Probabilistic Robotics*, §9.2, with the prior's log-odds 0). Clamping
keeps a cell able to change its mind when the world changes (a door opens, a person walks by).

REP-117 decides what a beam says: a valid return clears up to its end and marks it; a
max-range beam (``+inf``, or a reading beyond ``range_max``) saw nothing, so it clears up to
``range_max`` (or ``max_clear_range``) and marks nothing; ``-inf`` (too close) and ``NaN``
say nothing. The grid grows when a scan reaches beyond it. ``probability()`` and
``trinary()`` are the views map_server knows; ``save()`` writes a map_server map through
:mod:`kit.maps`, so the map opens in Nav2 and RViz.

Cells are indexed ``[row, col]`` with row 0 at the map's origin (the bottom of the image), as
in ``nav_msgs/OccupancyGrid``: cell ``(row, col)`` covers
``x ∈ origin_x + [col, col + 1)·resolution``, ``y ∈ origin_y + [row, row + 1)·resolution``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, maps, msgs, perception

__all__ = [
    "InverseSensorModel",
    "OccupancyGridMap",
    "bresenham",
    "integrate_beams",
    "integrate_beams_reference",
    "log_odds",
    "probability",
    "update_log_odds",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def log_odds(p: ArrayLike) -> FloatArray:
    """``log(p / (1 − p))``.

    >>> float(log_odds(0.5)), round(float(log_odds(0.7)), 4)
    (0.0, 0.8473)
    """
    q = np.asarray(p, dtype=np.float64)
    if np.any((q <= 0) | (q >= 1)):
        raise ValueError(f"probabilities must lie strictly between 0 and 1; got {q}")
    return np.log(q / (1.0 - q))


def probability(l: ArrayLike) -> FloatArray:  # noqa: E741 - the textbook's symbol
    """``1 − 1 / (1 + exp(l))``, the inverse of :func:`log_odds`."""
    return 1.0 / (1.0 + np.exp(-np.asarray(l, dtype=np.float64)))


def update_log_odds(l: ArrayLike, change: ArrayLike, l_min: float, l_max: float  # noqa: E741
                    ) -> FloatArray:
    """One inverse-sensor-model update: ``clamp(l + change, l_min, l_max)``.

    >>> update_log_odds([0.0, 3.4, -1.9], [0.85, 0.85, -0.4], -2.0, 3.5).round(2).tolist()
    [0.85, 3.5, -2.0]
    """
    total = np.asarray(l, dtype=np.float64) + np.asarray(change, dtype=np.float64)
    return np.clip(total, l_min, l_max)


@dataclass(frozen=True)
class InverseSensorModel:
    """How much one beam changes a cell (probabilities are turned into log-odds).

    The defaults are GMapping-like assumptions: a hit makes a cell 70 % likely occupied, a
    pass 40 %; the clamps keep a cell between 12 % and 97 %.
    """

    p_occupied: float = 0.7
    p_free: float = 0.4
    p_min: float = 0.12
    p_max: float = 0.97
    max_clear_range: float = math.inf
    """Beams clear at most this far [m] (a long max-range beam crosses much unseen space)."""

    def __post_init__(self) -> None:
        if not 0 < self.p_min < self.p_free < 0.5 < self.p_occupied < self.p_max < 1:
            raise ValueError("the model needs 0 < p_min < p_free < 0.5 < p_occupied < p_max "
                             f"< 1; got {self}")
        if not self.max_clear_range > 0:
            raise ValueError(f"max_clear_range must be positive [m]; got {self.max_clear_range}")

    @functools.cached_property
    def l_occupied(self) -> float:
        return float(log_odds(self.p_occupied))

    @functools.cached_property
    def l_free(self) -> float:
        return float(log_odds(self.p_free))

    @functools.cached_property
    def l_min(self) -> float:
        return float(log_odds(self.p_min))

    @functools.cached_property
    def l_max(self) -> float:
        return float(log_odds(self.p_max))


def bresenham(start: tuple[int, int], end: tuple[int, int]) -> IntArray:
    """The cells ``(col, row)`` of the line from ``start`` to ``end``, both included, shape
    ``(max(|Δcol|, |Δrow|) + 1, 2)``; consecutive cells touch (8-connected).

    >>> bresenham((0, 0), (4, 2)).tolist()
    [[0, 0], [1, 1], [2, 1], [3, 2], [4, 2]]
    """
    x0, y0 = int(start[0]), int(start[1])
    x1, y1 = int(end[0]), int(end[1])
    dx, dy = abs(x1 - x0), -abs(y1 - y0)
    sx, sy = (1 if x0 < x1 else -1), (1 if y0 < y1 else -1)
    err = dx + dy
    cells = []
    while True:
        cells.append((x0, y0))
        if x0 == x1 and y0 == y1:
            break
        e2 = 2 * err
        if e2 >= dy:
            err += dy
            x0 += sx
        if e2 <= dx:
            err += dx
            y0 += sy
    return np.array(cells, dtype=np.int64)


def integrate_beams_reference(grid: FloatArray, start: tuple[int, int], ends: IntArray,
                              hits: NDArray[np.bool_], l_free: float, l_occupied: float,
                              l_min: float, l_max: float) -> None:
    """Apply the inverse sensor model to ``grid`` (log-odds, ``[row, col]``) in place, beam
    by beam: every cell of the line from ``start`` to ``ends[k]`` (``(col, row)``) but the
    last gets ``l_free``; the last gets ``l_occupied`` when ``hits[k]``, ``l_free`` otherwise.
    Every cell must lie in the grid. The plain version of :func:`integrate_beams`."""
    for end, hit in zip(ends, hits, strict=True):
        cells = bresenham(start, (int(end[0]), int(end[1])))
        for col, row in cells[:-1]:
            grid[row, col] = min(max(grid[row, col] + l_free, l_min), l_max)
        col, row = cells[-1]
        change = l_occupied if hit else l_free
        grid[row, col] = min(max(grid[row, col] + change, l_min), l_max)


def _integrate_python(grid: FloatArray, x0: int, y0: int, ends: IntArray,
                      hits: NDArray[np.bool_], l_free: float, l_occ: float, l_min: float,
                      l_max: float) -> None:  # pragma: no cover - compiled by numba
    """:func:`integrate_beams_reference` with the line traced inline, for numba."""
    for k in range(ends.shape[0]):
        x, y = x0, y0
        x1, y1 = ends[k, 0], ends[k, 1]
        dx, dy = abs(x1 - x), -abs(y1 - y)
        sx = 1 if x < x1 else -1
        sy = 1 if y < y1 else -1
        err = dx + dy
        while x != x1 or y != y1:
            v = grid[y, x] + l_free
            grid[y, x] = min(max(v, l_min), l_max)
            e2 = 2 * err
            if e2 >= dy:
                err += dy
                x += sx
            if e2 <= dx:
                err += dx
                y += sy
        v = grid[y, x] + (l_occ if hits[k] else l_free)
        grid[y, x] = min(max(v, l_min), l_max)


_COMPILED = None


def integrate_beams(grid: FloatArray, start: tuple[int, int], ends: IntArray,
                    hits: NDArray[np.bool_], l_free: float, l_occupied: float, l_min: float,
                    l_max: float) -> None:
    """:func:`integrate_beams_reference`, compiled with numba (the same cells, the same
    arithmetic in the same order, so the same grid)."""
    global _COMPILED
    if _COMPILED is None:
        import numba

        _COMPILED = numba.njit(cache=True, nogil=True)(_integrate_python)
    _COMPILED(grid, int(start[0]), int(start[1]), np.ascontiguousarray(ends, dtype=np.int64),
              np.ascontiguousarray(hits, dtype=np.bool_), float(l_free), float(l_occupied),
              float(l_min), float(l_max))


class OccupancyGridMap:
    """A growing log-odds occupancy grid in the ``map`` frame.

    Parameters
    ----------
    resolution
        Cell size [m].
    origin
        ``(x, y)`` [m] of cell (0, 0)'s corner; the grid grows from an empty one around the
        first scan when ``None``.
    model
        The inverse sensor model.
    update
        A log-odds update written elsewhere (a lab's ``update_log_odds(l, change, l_min,
        l_max)``) used in place of the kit's beam-by-beam one: each :meth:`insert_points`
        then adds up its beams' changes per cell and applies ``update`` once to the cells
        they touched (the textbook's per-scan update; the kit clamps after every beam).

    >>> m = OccupancyGridMap(resolution=0.1)
    >>> scan = msgs.LaserScan(angle_min=0.0, angle_increment=0.1, range_min=0.1,
    ...                       range_max=5.0, ranges=np.array([1.0, np.inf, np.nan]))
    >>> m.insert_scan(scan, [0.0, 0.0, 0.0])
    >>> m.probability_at([1.0, 0.0]) > 0.5, m.probability_at([0.5, 0.0]) < 0.5
    (True, True)
    """

    GROW_MARGIN = 64
    """Cells added beyond what a scan needs when the grid grows (fewer reallocations)."""

    def __init__(self, resolution: float = 0.05, origin: ArrayLike | None = None,
                 model: InverseSensorModel | None = None,
                 update: Callable[[FloatArray, FloatArray, float, float], ArrayLike] | None = None
                 ) -> None:
        if not resolution > 0:
            raise ValueError(f"resolution must be positive [m/cell]; got {resolution}")
        self.resolution = float(np.float32(resolution))  # as OccupancyGrid stores it
        self.model = model or InverseSensorModel()
        self.update = update
        self.log_odds: FloatArray = np.zeros((0, 0))
        self.origin = np.zeros(2) if origin is None else np.asarray(origin, dtype=np.float64)
        if self.origin.shape != (2,) or not np.all(np.isfinite(self.origin)):
            raise ValueError(f"origin is (x, y) [m]; got {origin!r}")
        self._empty = True

    # ------------------------------------------------------------------ geometry
    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        return (int(self.log_odds.shape[0]), int(self.log_odds.shape[1]))

    def cells(self, points: ArrayLike) -> IntArray:
        """``(col, row)`` of the cells holding ``points`` ``(M, 2)`` [m] (may lie outside)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        return np.floor((p - self.origin) / self.resolution).astype(np.int64)

    def _ensure(self, cells: IntArray) -> IntArray:
        """Grow the grid to hold ``cells``; returns them shifted to the grown grid."""
        lo, hi = cells.min(axis=0), cells.max(axis=0)
        rows, cols = self.shape
        if self._empty:
            m = self.GROW_MARGIN
            self.origin = self.origin + (lo - m) * self.resolution
            self.log_odds = np.zeros((int(hi[1] - lo[1]) + 2 * m + 1,
                                      int(hi[0] - lo[0]) + 2 * m + 1))
            self._empty = False
            return cells - (lo - m)
        if lo[0] >= 0 and lo[1] >= 0 and hi[0] < cols and hi[1] < rows:
            return cells
        m = self.GROW_MARGIN
        left = int(-lo[0] + m) if lo[0] < 0 else 0
        bottom = int(-lo[1] + m) if lo[1] < 0 else 0
        right = int(hi[0] - cols + 1 + m) if hi[0] >= cols else 0
        top = int(hi[1] - rows + 1 + m) if hi[1] >= rows else 0
        self.log_odds = np.pad(self.log_odds, ((bottom, top), (left, right)))
        self.origin = self.origin - np.array([left, bottom]) * self.resolution
        return cells + np.array([left, bottom])

    # ------------------------------------------------------------------ updates
    def insert_points(self, sensor: ArrayLike, endpoints: ArrayLike, hits: ArrayLike,
                      compiled: bool = True) -> None:
        """Trace beams from ``sensor`` ``(x, y)`` to ``endpoints`` ``(M, 2)`` [m, map frame];
        ``hits[k]`` says whether beam k ended on an obstacle (else it only clears)."""
        origin = np.asarray(sensor, dtype=np.float64)
        ends = np.asarray(endpoints, dtype=np.float64).reshape(-1, 2)
        hit = np.asarray(hits, dtype=bool).ravel()
        if origin.shape != (2,) or len(hit) != len(ends):
            raise ValueError(f"sensor is (x, y) and hits has one flag per endpoint; got "
                             f"{origin.shape}, {len(ends)} endpoints, {len(hit)} flags")
        if not (np.all(np.isfinite(origin)) and np.all(np.isfinite(ends))):
            raise ValueError("sensor and endpoints must be finite")
        if len(ends) == 0:
            return
        cells = self._ensure(self.cells(np.vstack([origin, ends])))
        m = self.model
        run = integrate_beams if compiled else integrate_beams_reference
        start = (int(cells[0, 0]), int(cells[0, 1]))
        if self.update is None:
            run(self.log_odds, start, cells[1:], hit, m.l_free, m.l_occupied, m.l_min, m.l_max)
            return
        # the beams' cells all lie in the box of their ends: the changes are traced there
        lo, hi = cells.min(axis=0), cells.max(axis=0)
        box = (int(hi[1] - lo[1]) + 1, int(hi[0] - lo[0]) + 1)
        local = cells - lo
        at = (int(local[0, 0]), int(local[0, 1]))
        traced = np.zeros(box, dtype=self.log_odds.dtype)
        touched = np.zeros(box, dtype=self.log_odds.dtype)
        run(traced, at, local[1:], hit, m.l_free, m.l_occupied, -np.inf, np.inf)
        run(touched, at, local[1:], hit, 1.0, 1.0, -np.inf, np.inf)
        rows, cols = np.nonzero(touched)
        change = traced[rows, cols]
        rows, cols = rows + int(lo[1]), cols + int(lo[0])
        new = np.asarray(self.update(self.log_odds[rows, cols], change, m.l_min, m.l_max),
                         dtype=np.float64)
        if new.shape != rows.shape:
            raise ValueError(f"update must return one log-odds per cell, shape {rows.shape}; "
                             f"got {new.shape}")
        self.log_odds[rows, cols] = new

    def insert_scan(self, scan: msgs.LaserScan, pose: ArrayLike, compiled: bool = True
                    ) -> None:
        """Integrate ``scan`` taken with its sensor at ``pose`` = ``T_map_laser``
        ``(x, y, θ)``, following REP-117 (see the module's docstring)."""
        x = geometry.check_pose(pose)
        if x.shape != (3,):
            raise ValueError(f"pose is one (x, y, θ); got shape {x.shape}")
        r = np.asarray(scan.ranges, dtype=np.float64)
        angles = perception.beam_angles(scan)
        valid = perception.valid_returns(scan)
        clear = perception.max_range_beams(scan)
        reach = min(float(scan.range_max), self.model.max_clear_range)
        length = np.where(valid, np.minimum(np.nan_to_num(r), reach), reach)
        used = valid | clear
        hit = valid & (r <= reach)
        a = angles[used] + x[2]
        ends = np.column_stack([x[0] + length[used] * np.cos(a),
                                x[1] + length[used] * np.sin(a)])
        self.insert_points(x[:2], ends, hit[used], compiled)

    # ------------------------------------------------------------------ views
    def probability(self) -> FloatArray:
        """``p(occupied)`` of every cell, ``[row, col]``."""
        return probability(self.log_odds)

    def probability_at(self, point: ArrayLike) -> float:
        """``p(occupied)`` at a point [m] (½ outside the grid)."""
        col, row = self.cells(point)[0]
        rows, cols = self.shape
        if not (0 <= row < rows and 0 <= col < cols):
            return 0.5
        return float(probability(self.log_odds[row, col]))

    def trinary(self, free_thresh: float = maps.FREE_THRESH,
                occupied_thresh: float = maps.OCCUPIED_THRESH) -> NDArray[np.int8]:
        """map_server's trinary values: 100 where ``p > occupied_thresh``, 0 where
        ``p < free_thresh``, −1 (unknown) between."""
        maps.check_thresholds(free_thresh, occupied_thresh)
        out = np.full(self.shape, -1, dtype=np.int8)
        step = 256  # rows at a time: no float copy of a whole large map (CSAIL's: 145 MB)
        for r in range(0, self.shape[0], step):
            p = probability(self.log_odds[r:r + step])
            part = out[r:r + step]
            part[p > occupied_thresh] = 100
            part[p < free_thresh] = 0
        return out

    def to_msg(self, frame_id: str = "map", stamp: msgs.Time | None = None,
               free_thresh: float = maps.FREE_THRESH,
               occupied_thresh: float = maps.OCCUPIED_THRESH) -> msgs.OccupancyGrid:
        """The trinary map as a ``nav_msgs/OccupancyGrid``."""
        rows, cols = self.shape
        info = msgs.MapMetaData(
            map_load_time=stamp or msgs.Time(), resolution=self.resolution, width=cols,
            height=rows, origin=msgs.Pose(msgs.Point(float(self.origin[0]),
                                                     float(self.origin[1]), 0.0)))
        return msgs.OccupancyGrid(msgs.Header(stamp or msgs.Time(), frame_id), info,
                                  self.trinary(free_thresh, occupied_thresh).ravel())

    def save(self, path: str | Path, free_thresh: float = maps.FREE_THRESH,
             occupied_thresh: float = maps.OCCUPIED_THRESH) -> Path:
        """Write a map_server map: ``path`` (YAML) and a PGM beside it; returns the PGM."""
        if self._empty:
            raise ValueError("the map is empty: insert a scan first")
        return maps.write_map(self.to_msg(free_thresh=free_thresh,
                                          occupied_thresh=occupied_thresh), path,
                              free_thresh, occupied_thresh)

    @classmethod
    def from_msg(cls, grid: msgs.OccupancyGrid, model: InverseSensorModel | None = None
                 ) -> OccupancyGridMap:
        """A grid from a map (unknown → log-odds 0, free → ``l_min``, occupied → ``l_max``,
        values between by their percentage). The map's origin must not be rotated."""
        o = grid.info.origin
        yaw = float(geometry.quaternion_to_yaw([o.orientation.x, o.orientation.y,
                                                o.orientation.z, o.orientation.w]))
        if abs(yaw) > 1e-9:
            raise ValueError(f"a map with a rotated origin (yaw {yaw} rad) is not supported")
        out = cls(grid.info.resolution, (o.position.x, o.position.y), model)
        cells = grid.data.reshape(grid.info.height, grid.info.width).astype(np.float64)
        p = np.clip(cells / 100.0, out.model.p_min, out.model.p_max)
        out.log_odds = np.where(cells < 0, 0.0, log_odds(p))
        out._empty = False
        return out

    @classmethod
    def load(cls, path: str | Path, model: InverseSensorModel | None = None
             ) -> OccupancyGridMap:
        """Read a map_server map (see :meth:`from_msg`)."""
        return cls.from_msg(maps.read_map(path), model)
