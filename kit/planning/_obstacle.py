"""Nav2's ``ObstacleLayer`` for laser scans: marking obstacles where beams end, clearing the
cells a beam passed through by ray tracing.

Per update, as Nav2 does: first every clearing source clears (``FREE_SPACE``) the cells from
the sensor's cell along the Bresenham line to each return's cell, at most
``raytrace_max_range`` and from ``raytrace_min_range`` on (both rounded up to cells); then
every marking source marks ``LETHAL_OBSTACLE`` at each return between ``obstacle_min_range``
and ``obstacle_max_range`` of the sensor — in metres, and in cells between the sensor's cell
and the return's, ``⌊√(Δcol² + Δrow²)⌋`` against the ranges rounded up to cells (Nav2 Jazzy
checks both; Humble only the cells, which lets a return up to a cell beyond the range in).
A beam that leaves the grid is shortened to end on its edge, as Nav2's ``raytraceFreespace``
shortens it. Only valid returns take part (REP-117, see :mod:`kit.perception`); with
``inf_is_valid`` a ``+inf`` beam counts as a return at ``range_max − 0.1 mm``, so it clears
along its whole length (and marks, when that is within ``obstacle_max_range``, as in Nav2).
The layer is 2-D: the sources' height limits do not apply, and a voxel layer is read as this
obstacle layer.

The ray tracing of a whole scan runs in one compiled loop (numba); :func:`raytrace_line` and
:meth:`ObstacleLayer.clear_reference` are the plain versions, beam by beam, that the tests
compare it with.

Two rules of the kit's navigation costmaps, chosen per layer (:class:`ObstacleLayer`'s
``clip_rays`` and ``range_in_cells``), are not Nav2's: a beam that leaves the grid is not
shortened (the cells beyond the edge are dropped, the ones inside cleared as they lie on the
full beam), and the marking ranges are compared in metres between the sensor and the return.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs, perception
from kit.planning._costmap import FREE_SPACE, LETHAL_OBSTACLE, NO_INFORMATION

__all__ = ["ObservationSource", "ObstacleLayer", "cells_in_polygon", "raytrace_line"]

CostArray = NDArray[np.uint8]
FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ObservationSource:
    """One of the obstacle layer's ``observation_sources``, with Nav2's parameter names and
    defaults (ranges in metres)."""

    name: str = "scan"
    topic: str = "scan"
    data_type: str = "LaserScan"
    marking: bool = True
    clearing: bool = False
    obstacle_max_range: float = 2.5
    obstacle_min_range: float = 0.0
    raytrace_max_range: float = 3.0
    raytrace_min_range: float = 0.0
    inf_is_valid: bool = False

    def __post_init__(self) -> None:
        if self.data_type != "LaserScan":
            raise ValueError(f"observation source {self.name!r}: the kit's obstacle layer "
                             f"reads LaserScan only; got data_type {self.data_type!r}")
        for key in ("obstacle_max_range", "obstacle_min_range", "raytrace_max_range",
                    "raytrace_min_range"):
            value = getattr(self, key)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"observation source {self.name!r}: {key} must be a "
                                 f"non-negative number of metres; got {value!r}")


def raytrace_line(start: tuple[int, int], end: tuple[int, int], max_length: float = math.inf,
                  min_length: float = 0.0) -> NDArray[np.int64]:
    """The cells ``(row, col)`` of Nav2's ray trace from ``start`` to ``end``, shape ``(K, 2)``.

    Bresenham along the dominant axis, at most ``max_length`` cells long (scaled onto the
    dominant axis), starting ``min_length`` cells from ``start``; both ends included.

    >>> raytrace_line((0, 0), (2, 5)).tolist()
    [[0, 0], [0, 1], [1, 2], [1, 3], [2, 4], [2, 5]]
    """
    (y0, x0), (y1, x1) = start, end
    dx_full, dy_full = x1 - x0, y1 - y0
    dist = math.hypot(dx_full, dy_full)
    if dist < min_length:
        return np.zeros((0, 2), dtype=np.int64)
    if dist > 0.0:
        x0, y0 = int(x0 + dx_full / dist * min_length), int(y0 + dy_full / dist * min_length)
    dx, dy = x1 - x0, y1 - y0
    scale = 1.0 if dist == 0.0 else min(1.0, max_length / dist)
    x_dominant = abs(dx) >= abs(dy)
    major, minor = (abs(dx), abs(dy)) if x_dominant else (abs(dy), abs(dx))
    step_major = (1 if dx > 0 else -1, 0) if x_dominant else (0, 1 if dy > 0 else -1)
    step_minor = (0, 1 if dy > 0 else -1) if x_dominant else (1 if dx > 0 else -1, 0)
    steps = min(int(scale * major), major)
    error = major // 2
    x, y = x0, y0
    cells = [(y, x)]
    for _ in range(steps):
        x, y = x + step_major[0], y + step_major[1]
        error += minor
        if error >= major:
            x, y = x + step_minor[0], y + step_minor[1]
            error -= major
        cells.append((y, x))
    return np.array(cells, dtype=np.int64)


@njit(cache=True)
def _raytrace_compiled(grid: Any, r0: int, c0: int, ends: Any, max_cells: int,
                       min_cells: int, value: int) -> None:
    """Set to ``value`` the cells of :func:`raytrace_line` from ``(r0, c0)`` to each of
    ``ends`` ((N, 2) rows and columns), those that lie on ``grid``; the same arithmetic, all
    rays in one loop (a cell's offset across the line in closed form: Bresenham's error term
    after ``k`` steps is ``major // 2 + k · minor``)."""
    h, w = grid.shape
    for i in range(ends.shape[0]):
        y1, x1 = ends[i, 0], ends[i, 1]
        dx_full, dy_full = x1 - c0, y1 - r0
        dist = math.hypot(dx_full, dy_full)
        if dist < min_cells:
            continue
        x0, y0 = c0, r0
        if dist > 0.0 and min_cells > 0:
            x0 = int(c0 + dx_full / dist * min_cells)
            y0 = int(r0 + dy_full / dist * min_cells)
        dx, dy = x1 - x0, y1 - y0
        scale = 1.0 if dist == 0.0 else min(1.0, max_cells / dist)
        x_major = abs(dx) >= abs(dy)
        major = abs(dx) if x_major else abs(dy)
        minor = abs(dy) if x_major else abs(dx)
        steps = min(int(scale * major), major)
        s_major = (1 if dx > 0 else -1) if x_major else (1 if dy > 0 else -1)
        s_minor = (1 if dy > 0 else -1) if x_major else (1 if dx > 0 else -1)
        safe = max(major, 1)
        for k in range(steps + 1):
            along = k * s_major
            across = (major // 2 + k * minor) // safe * s_minor
            row = y0 + (across if x_major else along)
            col = x0 + (along if x_major else across)
            if 0 <= row < h and 0 <= col < w:
                grid[row, col] = value


def cells_in_polygon(polygon: ArrayLike, shape: tuple[int, int], resolution: float,
                     origin: tuple[float, float]) -> NDArray[np.bool_]:
    """``True`` for the cells of a grid whose centre lies inside ``polygon`` ((N, 2) [m], in
    the grid's frame), by the even–odd rule."""
    poly = np.asarray(polygon, dtype=np.float64)
    inside = np.zeros(shape, dtype=bool)
    lo = np.floor((poly.min(axis=0) - origin) / resolution).astype(int)
    hi = np.ceil((poly.max(axis=0) - origin) / resolution).astype(int)
    c0, r0 = max(lo[0], 0), max(lo[1], 0)
    c1, r1 = min(hi[0] + 1, shape[1]), min(hi[1] + 1, shape[0])
    if c0 >= c1 or r0 >= r1:
        return inside
    rows, cols = np.mgrid[r0:r1, c0:c1]
    x = origin[0] + (cols + 0.5) * resolution
    y = origin[1] + (rows + 0.5) * resolution
    odd = np.zeros(x.shape, dtype=bool)
    for (xa, ya), (xb, yb) in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        crosses = (ya > y) != (yb > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_cross = xa + (y - ya) * (xb - xa) / (yb - ya)
        odd ^= crosses & (x < x_cross)
    inside[r0:r1, c0:c1] = odd
    return inside


class ObstacleLayer:
    """The obstacle layer's own grid of costs: unknown (or free, without
    ``track_unknown_space``) until scans mark and clear it.

    Parameters
    ----------
    shape, resolution, origin
        The costmap's geometry: ``(height, width)`` cells, metres per cell, corner of cell
        (0, 0) in the costmap's frame [m].
    track_unknown_space
        Start unknown (255) rather than free (0), as Nav2's parameter of that name.
    clip_rays
        Shorten a beam that leaves the grid to end on its edge (Nav2); ``False``: trace the
        whole beam and drop its cells beyond the edge (the kit's navigation costmaps).
    range_in_cells
        Compare the marking ranges between the sensor's cell and the return's cell, in cells
        (Nav2); ``False``: between the sensor and the return, in metres (the kit's
        navigation costmaps).
    """

    def __init__(self, shape: tuple[int, int], resolution: float, origin: tuple[float, float],
                 track_unknown_space: bool = False, *, clip_rays: bool = True,
                 range_in_cells: bool = True) -> None:
        if not (math.isfinite(resolution) and resolution > 0):
            raise ValueError(f"resolution must be positive metres per cell; got {resolution!r}")
        self.resolution = float(resolution)
        self.origin = (float(origin[0]), float(origin[1]))
        self.default = NO_INFORMATION if track_unknown_space else FREE_SPACE
        self.clip_rays = bool(clip_rays)
        self.range_in_cells = bool(range_in_cells)
        self.costs = np.full(shape, self.default, dtype=np.uint8)

    def reset(self) -> None:
        """Forget every observation."""
        self.costs[:] = self.default

    def move(self, origin: tuple[float, float]) -> None:
        """Move the grid's corner to ``origin`` (a whole number of cells away): what stays on
        the grid is kept, the cells that come in are unknown (free)."""
        res = self.resolution
        dc = round((origin[0] - self.origin[0]) / res)
        dr = round((origin[1] - self.origin[1]) / res)
        self.origin = (float(origin[0]), float(origin[1]))
        if dc == 0 and dr == 0:
            return
        h, w = self.costs.shape
        shifted = np.full_like(self.costs, self.default)
        src_r = slice(max(dr, 0), min(h, h + dr))
        dst_r = slice(max(-dr, 0), min(h, h - dr))
        src_c = slice(max(dc, 0), min(w, w + dc))
        dst_c = slice(max(-dc, 0), min(w, w - dc))
        if src_r.start < src_r.stop and src_c.start < src_c.stop:
            shifted[dst_r, dst_c] = self.costs[src_r, src_c]
        self.costs = shifted

    def _cell(self, x: float, y: float) -> tuple[int, int] | None:
        """Nav2's ``worldToMap``: the cell, or ``None`` off the map."""
        if x < self.origin[0] or y < self.origin[1]:
            return None
        col = int((x - self.origin[0]) / self.resolution)
        row = int((y - self.origin[1]) / self.resolution)
        height, width = self.costs.shape
        return (row, col) if row < height and col < width else None

    def _clip(self, ox: float, oy: float, wx: float, wy: float) -> tuple[float, float]:
        """Shorten the ray from the sensor to ``(wx, wy)`` to end on the map, as Nav2's
        ``raytraceFreespace`` does: the beam's direction taken once, each edge's crossing at
        ``t = (edge − o) / a`` along it."""
        a, b = wx - ox, wy - oy
        x0, y0 = self.origin
        x1 = x0 + self.costs.shape[1] * self.resolution
        y1 = y0 + self.costs.shape[0] * self.resolution
        if wx < x0:
            wx, wy = x0, oy + b * ((x0 - ox) / a)
        if wy < y0:
            wx, wy = ox + a * ((y0 - oy) / b), y0
        if wx > x1:
            wx, wy = x1 - 0.001, oy + b * ((x1 - ox) / a)
        if wy > y1:
            wx, wy = ox + a * ((y1 - oy) / b), y1 - 0.001
        return wx, wy

    def _clip_all(self, sensor: tuple[float, float], points: FloatArray) -> FloatArray:
        """:meth:`_clip` for every point at once (the same steps, in the same order)."""
        ox, oy = sensor
        x0, y0 = self.origin
        x1 = x0 + self.costs.shape[1] * self.resolution
        y1 = y0 + self.costs.shape[0] * self.resolution
        wx, wy = points[:, 0].copy(), points[:, 1].copy()
        a, b = wx - ox, wy - oy                     # the direction, once (as Nav2)
        with np.errstate(divide="ignore", invalid="ignore"):
            for low, end, is_x, inset in ((x0, x0, True, 0.0), (y0, y0, False, 0.0),
                                          (None, x1, True, 0.001), (None, y1, False, 0.001)):
                beyond = (wx < end) if low is not None and is_x else \
                    (wy < end) if low is not None else (wx > end) if is_x else (wy > end)
                if not beyond.any():
                    continue
                if is_x:
                    wy = np.where(beyond, oy + b * ((end - ox) / a), wy)
                    wx = np.where(beyond, end - inset, wx)
                else:
                    wx = np.where(beyond, ox + a * ((end - oy) / b), wx)
                    wy = np.where(beyond, end - inset, wy)
        return np.column_stack([wx, wy])

    def _cells(self, metres: float) -> int:
        """Nav2's ``cellDistance``: metres rounded up to cells."""
        return int(max(0.0, math.ceil(metres / self.resolution)))

    def _end_cells(self, sensor: tuple[float, float], points: FloatArray
                   ) -> NDArray[np.int64]:
        """The cells the rays to ``points`` end in: on the grid (clipped), or anywhere."""
        if not self.clip_rays:
            return np.column_stack([np.floor((points[:, 1] - self.origin[1]) / self.resolution),
                                    np.floor((points[:, 0] - self.origin[0]) / self.resolution)]
                                   ).astype(np.int64)
        ends = self._clip_all(sensor, points)
        height, width = self.costs.shape
        fx = (ends[:, 0] - self.origin[0]) / self.resolution
        fy = (ends[:, 1] - self.origin[1]) / self.resolution
        ok = (ends[:, 0] >= self.origin[0]) & (ends[:, 1] >= self.origin[1]) & \
            np.isfinite(fx) & np.isfinite(fy)
        col = np.where(ok, fx, -1.0).astype(np.int64)
        row = np.where(ok, fy, -1.0).astype(np.int64)
        ok &= (row < height) & (col < width)
        return np.column_stack([row[ok], col[ok]])

    def _sensor_cell(self, sensor: tuple[float, float]) -> tuple[int, int] | None:
        if self.clip_rays or self.range_in_cells:
            return self._cell(*sensor)
        return (math.floor((sensor[1] - self.origin[1]) / self.resolution),
                math.floor((sensor[0] - self.origin[0]) / self.resolution))

    def clear(self, points: ArrayLike, sensor: tuple[float, float],
              source: ObservationSource) -> int:
        """Ray-trace free space from ``sensor`` to each of ``points`` ((N, 2) [m]), all rays
        in one compiled loop; returns the number of rays traced."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        start = self._sensor_cell(sensor)
        if start is None or len(pts) == 0:
            return 0       # Nav2 cannot ray-trace from a sensor off the map either
        ends = self._end_cells(sensor, pts)
        _raytrace_compiled(self.costs, start[0], start[1], np.ascontiguousarray(ends),
                           self._cells(source.raytrace_max_range),
                           self._cells(source.raytrace_min_range), FREE_SPACE)
        return len(ends)

    def clear_reference(self, points: ArrayLike, sensor: tuple[float, float],
                        source: ObservationSource) -> int:
        """:meth:`clear` beam by beam with :func:`raytrace_line` (Nav2's steps as written);
        the grid must be one that clips its rays."""
        start = self._cell(*sensor)
        if start is None:
            return 0
        traced = 0
        for wx, wy in np.asarray(points, dtype=np.float64).reshape(-1, 2):
            end = self._cell(*self._clip(sensor[0], sensor[1], float(wx), float(wy)))
            if end is None:
                continue
            cells = raytrace_line(start, end, self._cells(source.raytrace_max_range),
                                  self._cells(source.raytrace_min_range))
            self.costs[cells[:, 0], cells[:, 1]] = FREE_SPACE
            traced += 1
        return traced

    def mark(self, points: ArrayLike, sensor: tuple[float, float],
             source: ObservationSource) -> int:
        """Mark ``points`` ((N, 2) [m]) lethal when within the source's obstacle ranges of
        ``sensor``; returns the number marked."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if len(pts) == 0:
            return 0
        height, width = self.costs.shape
        if self.range_in_cells:
            start = self._cell(*sensor)
            if start is None:
                return 0
            fx = (pts[:, 0] - self.origin[0]) / self.resolution
            fy = (pts[:, 1] - self.origin[1]) / self.resolution
            on = (pts[:, 0] >= self.origin[0]) & (pts[:, 1] >= self.origin[1])
            col = np.where(on, fx, -1.0).astype(np.int64)
            row = np.where(on, fy, -1.0).astype(np.int64)
            on &= (row < height) & (col < width)
            d2 = (pts[:, 0] - sensor[0]) ** 2 + (pts[:, 1] - sensor[1]) ** 2
            away = np.hypot(col - start[1], row - start[0]).astype(np.int64)
            keep = on & (d2 <= source.obstacle_max_range ** 2) & \
                (d2 >= source.obstacle_min_range ** 2) & \
                (away >= self._cells(source.obstacle_min_range)) & \
                (away <= self._cells(source.obstacle_max_range))
        else:
            d = np.hypot(pts[:, 0] - sensor[0], pts[:, 1] - sensor[1])
            near = pts[(d <= source.obstacle_max_range) & (d >= source.obstacle_min_range)]
            col = np.floor((near[:, 0] - self.origin[0]) / self.resolution).astype(np.int64)
            row = np.floor((near[:, 1] - self.origin[1]) / self.resolution).astype(np.int64)
            keep = (row >= 0) & (row < height) & (col >= 0) & (col < width)
        self.costs[row[keep], col[keep]] = LETHAL_OBSTACLE
        return int(keep.sum())

    def mark_points(self, points: ArrayLike) -> int:
        """Mark every one of ``points`` ((N, 2) [m]) that lies on the grid, whatever its
        range; returns the number marked."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        height, width = self.costs.shape
        col = np.floor((pts[:, 0] - self.origin[0]) / self.resolution).astype(np.int64)
        row = np.floor((pts[:, 1] - self.origin[1]) / self.resolution).astype(np.int64)
        keep = (row >= 0) & (row < height) & (col >= 0) & (col < width)
        self.costs[row[keep], col[keep]] = LETHAL_OBSTACLE
        return int(keep.sum())

    def update_points(self, points: ArrayLike, sensor: tuple[float, float],
                      sources: tuple[ObservationSource, ...]) -> tuple[int, int]:
        """Clear, then mark, with returns already in the grid's frame ((N, 2) [m], e.g.
        de-skewed beam by beam) seen from ``sensor`` ``(x, y)``; every source takes them.
        Returns ``(rays traced, cells marked)``."""
        traced = marked = 0
        for source in sources:
            if source.clearing:
                traced += self.clear(points, sensor, source)
        for source in sources:
            if source.marking:
                marked += self.mark(points, sensor, source)
        return traced, marked

    def update(self, scan: msgs.LaserScan, sensor_pose: ArrayLike,
               sources: tuple[ObservationSource, ...] | None = None) -> tuple[int, int]:
        """Clear, then mark, with one scan taken at ``sensor_pose`` (``(x, y, θ)`` of the
        scanner in the costmap's frame, e.g. ``T_map_laser``). ``sources`` are the
        observation sources this scan feeds (default: one that marks and clears with Nav2's
        ranges). Returns ``(rays traced, cells marked)``."""
        if sources is None:
            sources = (ObservationSource(clearing=True),)
        pose = geometry.check_pose(sensor_pose, "sensor_pose")
        if pose.ndim != 1:
            raise ValueError("sensor_pose must be one pose (x, y, theta)")
        sensor = (float(pose[0]), float(pose[1]))
        traced = marked = 0
        for source in sources:
            if source.clearing:
                traced += self.clear(scan_points(scan, pose, source), sensor, source)
        for source in sources:
            if source.marking:
                marked += self.mark(scan_points(scan, pose, source), sensor, source)
        return traced, marked


def scan_points(scan: msgs.LaserScan, pose: FloatArray,
                source: ObservationSource) -> FloatArray:
    """The scan's returns in the costmap's frame, with ``inf_is_valid`` applied."""
    if source.inf_is_valid:
        ranges = np.array(scan.ranges, dtype=np.float32)
        ranges[np.isposinf(ranges)] = np.float32(scan.range_max) - np.float32(0.0001)
        scan = dataclasses.replace(scan, ranges=ranges)
    return perception.scan_to_points(scan, pose)
