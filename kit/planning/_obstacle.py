"""Nav2's ``ObstacleLayer`` for laser scans: marking obstacles where beams end, clearing the
cells a beam passed through by ray tracing.

Per update, as Nav2 does: first every clearing source clears (``FREE_SPACE``) the cells from
the sensor's cell along the Bresenham line to each return's cell, at most
``raytrace_max_range`` and from ``raytrace_min_range`` on (both rounded up to cells); then
every marking source marks ``LETHAL_OBSTACLE`` at each return between ``obstacle_min_range``
and ``obstacle_max_range`` of the sensor. Only valid returns take part (REP-117, see
:mod:`kit.perception`); with ``inf_is_valid`` a ``+inf`` beam counts as a return at
``range_max − 0.1 mm``, so it clears along its whole length (and marks, when that is within
``obstacle_max_range``, as in Nav2). The layer is 2-D: the sources' height limits do not apply.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs, perception
from kit.planning._costmap import FREE_SPACE, LETHAL_OBSTACLE, NO_INFORMATION

__all__ = ["ObservationSource", "ObstacleLayer", "cells_in_polygon", "raytrace_line"]

CostArray = NDArray[np.uint8]


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
    """

    def __init__(self, shape: tuple[int, int], resolution: float, origin: tuple[float, float],
                 track_unknown_space: bool = False) -> None:
        if not (math.isfinite(resolution) and resolution > 0):
            raise ValueError(f"resolution must be positive metres per cell; got {resolution!r}")
        self.resolution = float(resolution)
        self.origin = (float(origin[0]), float(origin[1]))
        self.default = NO_INFORMATION if track_unknown_space else FREE_SPACE
        self.costs = np.full(shape, self.default, dtype=np.uint8)

    def reset(self) -> None:
        """Forget every observation."""
        self.costs[:] = self.default

    def _cell(self, x: float, y: float) -> tuple[int, int] | None:
        """Nav2's ``worldToMap``: the cell, or ``None`` off the map."""
        if x < self.origin[0] or y < self.origin[1]:
            return None
        col = int((x - self.origin[0]) / self.resolution)
        row = int((y - self.origin[1]) / self.resolution)
        height, width = self.costs.shape
        return (row, col) if row < height and col < width else None

    def _clip(self, ox: float, oy: float, wx: float, wy: float) -> tuple[float, float]:
        """Shorten the ray from the sensor to ``(wx, wy)`` to end on the map, as Nav2 does."""
        a, b = wx - ox, wy - oy
        x0, y0 = self.origin
        x1 = x0 + self.costs.shape[1] * self.resolution
        y1 = y0 + self.costs.shape[0] * self.resolution
        if wx < x0:
            wx, wy = x0, oy + b * (x0 - ox) / a
        if wy < y0:
            wx, wy = ox + a * (y0 - oy) / b, y0
        if wx > x1:
            wx, wy = x1 - 0.001, oy + b * (x1 - ox) / a
        if wy > y1:
            wx, wy = ox + a * (y1 - oy) / b, y1 - 0.001
        return wx, wy

    def _cells(self, metres: float) -> int:
        return int(max(0.0, math.ceil(metres / self.resolution)))

    def clear(self, points: NDArray[np.float64], sensor: tuple[float, float],
              source: ObservationSource) -> int:
        """Ray-trace free space from ``sensor`` to each of ``points`` ((N, 2) [m]); returns
        the number of rays traced."""
        start = self._cell(*sensor)
        if start is None:
            return 0       # Nav2 cannot ray-trace from a sensor off the map either
        traced = 0
        for wx, wy in points:
            end = self._cell(*self._clip(sensor[0], sensor[1], float(wx), float(wy)))
            if end is None:
                continue
            cells = raytrace_line(start, end, self._cells(source.raytrace_max_range),
                                  self._cells(source.raytrace_min_range))
            self.costs[cells[:, 0], cells[:, 1]] = FREE_SPACE
            traced += 1
        return traced

    def mark(self, points: NDArray[np.float64], sensor: tuple[float, float],
             source: ObservationSource) -> int:
        """Mark ``points`` ((N, 2) [m]) lethal when within the source's obstacle ranges of
        ``sensor``; returns the number marked."""
        start = self._cell(*sensor)
        if start is None:
            return 0
        max_cells = self._cells(source.obstacle_max_range)
        min_cells = self._cells(source.obstacle_min_range)
        marked = 0
        for wx, wy in points:
            cell = self._cell(float(wx), float(wy))
            if cell is None:
                continue
            d2 = (wx - sensor[0]) ** 2 + (wy - sensor[1]) ** 2
            if not source.obstacle_min_range ** 2 <= d2 <= source.obstacle_max_range ** 2:
                continue
            cells_away = int(math.hypot(cell[0] - start[0], cell[1] - start[1]))
            if not min_cells <= cells_away <= max_cells:
                continue
            self.costs[cell] = LETHAL_OBSTACLE
            marked += 1
        return marked

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
                traced += self.clear(_points(scan, pose, source), sensor, source)
        for source in sources:
            if source.marking:
                marked += self.mark(_points(scan, pose, source), sensor, source)
        return traced, marked


def _points(scan: msgs.LaserScan, pose: NDArray[np.float64],
            source: ObservationSource) -> NDArray[np.float64]:
    """The scan's returns in the costmap's frame, with ``inf_is_valid`` applied."""
    if source.inf_is_valid:
        ranges = np.array(scan.ranges, dtype=np.float32)
        ranges[np.isposinf(ranges)] = np.float32(scan.range_max) - np.float32(0.0001)
        scan = dataclasses.replace(scan, ranges=ranges)
    return perception.scan_to_points(scan, pose)
