"""The navigation costmaps: Nav2's global costmap (the whole map) and its local costmap (a
window rolling with the robot), each a static layer, an obstacle layer fed by scans (marking
the returns, clearing along the beams) and an inflation layer; the global one also takes a
keep-out mask.

The obstacle layer here traces all of a scan's beams in one compiled loop (numba) — Nav2's
Bresenham line, the same cells :class:`kit.planning.ObstacleLayer` walks beam by beam (a test
compares them) — at a speed a 20 Hz controller in a simulation running many times faster than
real time can afford.
Unlike Nav2 it does not shorten a beam that leaves the grid: the cells beyond are dropped.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from kit import geometry, msgs, perception
from kit.planning import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap,
    apply_keepout,
    footprint_radii,
    inflate,
    inflation_cost,
    pad_footprint,
    static_layer,
)
from kit.planning._obstacle import cells_in_polygon

__all__ = ["NavigationCostmap", "collides_from", "footprint_collides", "footprint_costs",
           "outline_points"]

FloatArray = NDArray[np.float64]


class NavigationCostmap:
    """A static layer, an obstacle layer and inflation, in Nav2's model.

    Parameters
    ----------
    grid
        The static map (``nav_msgs/OccupancyGrid``); ``None`` for a costmap of obstacles only
        (then ``rolling_window`` is required).
    footprint
        The robot's footprint ((N, 2) [m] in ``base_link``), padded already (Nav2 pads it by
        ``footprint_padding``: :func:`kit.planning.pad_footprint`).
    rolling_window
        The local costmap: ``width`` × ``height`` metres centred on the robot, moving with it
        (cells leaving the window are forgotten, as Nav2's rolling window forgets them).
    resolution
        Metres per cell of a rolling window (default: the map's, else 0.05).
    inflation_radius, cost_scaling_factor
        The inflation layer's parameters (Nav2's names and meaning).
    obstacle_max_range, raytrace_max_range
        Marking and clearing ranges of the scan source [m].
    keepout
        A keep-out mask (0 free … 100 keep out), applied before inflation.
    moving_margin
        Returns farther than 0.15 m from the static map's obstacles — people, most likely —
        are marked as discs of this radius [m] rather than single cells: where a walking
        person can be by the time the next scan arrives (0: single cells, as Nav2).
    """

    def __init__(self, grid: msgs.OccupancyGrid | None, footprint: ArrayLike, *,
                 rolling_window: bool = False, width: float = 3.0, height: float = 3.0,
                 resolution: float | None = None, inflation_radius: float = 0.55,
                 cost_scaling_factor: float = 10.0, obstacle_max_range: float = 2.5,
                 raytrace_max_range: float = 3.0,
                 keepout: msgs.OccupancyGrid | None = None,
                 moving_margin: float = 0.0) -> None:
        if grid is None and not rolling_window:
            raise ValueError("a costmap without a static map must be a rolling window")
        self.footprint = np.asarray(footprint, dtype=np.float64)
        self.inscribed_radius, self.circumscribed_radius = footprint_radii(self.footprint)
        # inflate beyond the circumscribed circle, so that a centre's cost tells whether its
        # footprint can touch anything (Nav2 warns when it does not)
        self.inflation_radius = max(float(inflation_radius), self.circumscribed_radius + 0.1)
        self.cost_scaling_factor = float(cost_scaling_factor)
        self.obstacle_max_range = float(obstacle_max_range)
        self.raytrace_max_range = float(raytrace_max_range)
        self.keepout = keepout
        self.rolling = bool(rolling_window)
        self.moving_margin = float(moving_margin)
        self.static: NDArray[np.uint8] | None = None
        self.static_origin = (0.0, 0.0)
        if grid is not None:
            self.static = static_layer(grid)
            self.static_origin = (grid.info.origin.position.x, grid.info.origin.position.y)
            self.resolution = float(grid.info.resolution)
        else:
            self.resolution = 0.05
        self._static_distance: FloatArray | None = None
        if self.moving_margin > 0 and self.static is not None:
            self._static_distance = ndimage.distance_transform_edt(
                self.static != LETHAL_OBSTACLE) * self.resolution
        if keepout is not None and self.static is not None and not rolling_window:
            # the mask is static: folded into the static layer once (Nav2 applies it to the
            # master grid on every update; lethal either way)
            self.static = apply_keepout(self.static, keepout, self.resolution,
                                        self.static_origin)
        if self.rolling:
            if resolution is not None:
                if grid is not None and not math.isclose(resolution, self.resolution):
                    raise ValueError(f"a rolling window over a map takes the map's resolution "
                                     f"({self.resolution} m); got {resolution}")
                self.resolution = float(resolution)
            cells = (round(height / self.resolution), round(width / self.resolution))
            if min(cells) < 3:
                raise ValueError(f"a rolling window needs at least 3 × 3 cells; got {cells}")
            self.origin = (math.nan, math.nan)
            self.obstacles = np.full(cells, FREE_SPACE, dtype=np.uint8)
        else:
            assert self.static is not None
            self.origin = self.static_origin
            self.obstacles = np.full(self.static.shape, FREE_SPACE, dtype=np.uint8)

    def set_static(self, grid: msgs.OccupancyGrid) -> None:
        """A new static map, as Nav2's static layer takes each ``/map`` that SLAM publishes.

        The keep-out mask is applied again. A rolling window keeps what it has seen; a global
        costmap keeps its marks when the map keeps its size and origin (SLAM drawn on a fixed
        canvas) and starts its obstacle layer afresh otherwise. The resolution cannot change.
        """
        resolution = float(grid.info.resolution)
        if not math.isclose(resolution, self.resolution):
            raise ValueError(f"the new map's resolution {resolution} m differs from the "
                             f"costmap's {self.resolution} m")
        static = static_layer(grid)
        origin = (grid.info.origin.position.x, grid.info.origin.position.y)
        if self.keepout is not None and not self.rolling:
            static = apply_keepout(static, self.keepout, self.resolution, origin)
        if self.moving_margin > 0:
            self._static_distance = ndimage.distance_transform_edt(
                static != LETHAL_OBSTACLE) * self.resolution
        if not self.rolling and (static.shape != self.obstacles.shape or not (
                math.isclose(origin[0], self.static_origin[0], abs_tol=1e-9) and
                math.isclose(origin[1], self.static_origin[1], abs_tol=1e-9))):
            self.obstacles = np.full(static.shape, FREE_SPACE, dtype=np.uint8)
            self.origin = origin
        self.static, self.static_origin = static, origin

    @property
    def circumscribed_cost(self) -> int:
        """The cost at a centre one cell beyond the circumscribed radius from the nearest
        lethal cell: a pose whose centre costs less cannot touch an obstacle."""
        return int(inflation_cost(self.circumscribed_radius + self.resolution,
                                  self.inscribed_radius, self.cost_scaling_factor))

    # ------------------------------------------------------------------ the window
    def _roll(self, x: float, y: float) -> None:
        """Move a rolling window's centre to ``(x, y)``, shifting what it remembers."""
        h, w = self.obstacles.shape
        res = self.resolution
        anchor = self.static_origin
        ox = anchor[0] + math.floor((x - w * res / 2 - anchor[0]) / res) * res
        oy = anchor[1] + math.floor((y - h * res / 2 - anchor[1]) / res) * res
        if math.isnan(self.origin[0]):
            self.origin = (ox, oy)
            return
        dc = round((ox - self.origin[0]) / res)
        dr = round((oy - self.origin[1]) / res)
        if dc == 0 and dr == 0:
            return
        shifted = np.full_like(self.obstacles, FREE_SPACE)
        src_r = slice(max(dr, 0), min(h, h + dr))
        dst_r = slice(max(-dr, 0), min(h, h - dr))
        src_c = slice(max(dc, 0), min(w, w + dc))
        dst_c = slice(max(-dc, 0), min(w, w - dc))
        if src_r.start < src_r.stop and src_c.start < src_c.stop:
            shifted[dst_r, dst_c] = self.obstacles[src_r, src_c]
        self.obstacles = shifted
        self.origin = (ox, oy)

    def _static_window(self) -> NDArray[np.uint8]:
        """The static layer's costs under the window (unknown off the map)."""
        h, w = self.obstacles.shape
        if self.static is None:
            return np.full((h, w), FREE_SPACE, dtype=np.uint8)
        if not self.rolling:
            return self.static
        out = np.full((h, w), NO_INFORMATION, dtype=np.uint8)
        r0 = round((self.origin[1] - self.static_origin[1]) / self.resolution)
        c0 = round((self.origin[0] - self.static_origin[0]) / self.resolution)
        sh, sw = self.static.shape
        rs, re = max(r0, 0), min(r0 + h, sh)
        cs, ce = max(c0, 0), min(c0 + w, sw)
        if rs < re and cs < ce:
            out[rs - r0:re - r0, cs - c0:ce - c0] = self.static[rs:re, cs:ce]
        return out

    # ------------------------------------------------------------------ observations
    def update_scan(self, scan: msgs.LaserScan, sensor_pose: ArrayLike,
                    robot_xy: ArrayLike | None = None) -> int:
        """Clear along every beam of ``scan`` and mark its returns, the scanner at
        ``sensor_pose`` (``(x, y, θ)`` in the costmap's frame); a rolling window first moves to
        ``robot_xy`` (default: the scanner). Returns the number of cells marked."""
        pose = geometry.check_pose(sensor_pose, "sensor_pose")
        if self.rolling:
            centre = pose[:2] if robot_xy is None else np.asarray(robot_xy, dtype=float)
            self._roll(float(centre[0]), float(centre[1]))
        points = perception.scan_to_points(scan, pose)
        return self.add_points(points, (float(pose[0]), float(pose[1])))

    def update_points(self, points: ArrayLike, sensor: tuple[float, float],
                      robot_xy: ArrayLike) -> int:
        """:meth:`add_points` for a scan already in the costmap's frame (de-skewed beam by
        beam), a rolling window first moving to ``robot_xy``."""
        if self.rolling:
            self._roll(float(np.asarray(robot_xy)[0]), float(np.asarray(robot_xy)[1]))
        return self.add_points(points, sensor)

    def add_points(self, points: ArrayLike, sensor: tuple[float, float]) -> int:
        """Clear from ``sensor`` towards each of ``points`` ((N, 2) [m]) and mark them."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if len(pts) == 0:
            return 0
        res, (h, w) = self.resolution, self.obstacles.shape
        sx, sy = sensor
        d = pts - (sx, sy)
        dist = np.hypot(d[:, 0], d[:, 1])
        _clear_rays(self.obstacles, self._cell_index(np.array([[sx, sy]]))[0],
                    self._cell_index(pts), math.ceil(self.raytrace_max_range / res))
        near = pts[dist <= self.obstacle_max_range]
        if self.moving_margin > 0:
            near = np.vstack([near, self._moving_discs(near)])
        cols = np.floor((near[:, 0] - self.origin[0]) / res).astype(np.int64)
        rows = np.floor((near[:, 1] - self.origin[1]) / res).astype(np.int64)
        inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
        self.obstacles[rows[inside], cols[inside]] = LETHAL_OBSTACLE
        return int(inside.sum())

    def _cell_index(self, xy: FloatArray) -> NDArray[np.int64]:
        """(row, col) of points (N, 2) — not bounded to the grid."""
        return np.column_stack([np.floor((xy[:, 1] - self.origin[1]) / self.resolution),
                                np.floor((xy[:, 0] - self.origin[0]) / self.resolution)]
                               ).astype(np.int64)

    def _moving_discs(self, points: FloatArray) -> FloatArray:
        """Points filling a ``moving_margin`` disc round each return that the static map does
        not explain (farther than 0.15 m from its obstacles; all of them without a map)."""
        if self._static_distance is not None:
            d = self._static_distance
            cols = np.floor((points[:, 0] - self.static_origin[0]) / self.resolution)
            rows = np.floor((points[:, 1] - self.static_origin[1]) / self.resolution)
            ok = (rows >= 0) & (rows < d.shape[0]) & (cols >= 0) & (cols < d.shape[1])
            away = np.ones(len(points), dtype=bool)
            away[ok] = d[rows[ok].astype(int), cols[ok].astype(int)] > 0.15
            points = points[away]
        if len(points) == 0:
            return np.zeros((0, 2))
        r = self.moving_margin
        step = self.resolution
        g = np.arange(-r, r + 1e-9, step)
        gx, gy = np.meshgrid(g, g)
        disc = np.column_stack([gx.ravel(), gy.ravel()])
        disc = disc[np.hypot(disc[:, 0], disc[:, 1]) <= r]
        return (points[:, None, :] + disc[None, :, :]).reshape(-1, 2)

    def clear(self) -> None:
        """Forget every observation (Nav2's ClearEntireCostmap)."""
        self.obstacles[:] = FREE_SPACE

    # ------------------------------------------------------------------ the costmap
    def costmap(self, robot_pose: ArrayLike | None = None) -> Costmap:
        """The combined, inflated :class:`~kit.planning.Costmap`; with ``robot_pose`` the
        obstacle cells under the footprint are cleared first (a rolling window also moves
        there)."""
        if robot_pose is not None:
            pose = geometry.check_pose(robot_pose, "robot_pose")
            if self.rolling:
                self._roll(float(pose[0]), float(pose[1]))
            polygon = geometry.transform_points(pose, self.footprint)
            self.obstacles[cells_in_polygon(polygon, self.obstacles.shape, self.resolution,
                                            self.origin)] = FREE_SPACE
        elif self.rolling and math.isnan(self.origin[0]):
            raise ValueError("a rolling window has no position before its first update")
        master = np.maximum(self._static_window(), self.obstacles)
        master[(self.obstacles == LETHAL_OBSTACLE)] = LETHAL_OBSTACLE
        costs = inflate(master, self.resolution, inscribed_radius=self.inscribed_radius,
                        inflation_radius=self.inflation_radius,
                        cost_scaling_factor=self.cost_scaling_factor)
        return Costmap(costs, self.resolution, self.origin)


@njit(cache=True)
def _clear_rays(grid: Any, start: Any, ends: Any, max_cells: int) -> None:
    """Set to free the cells of Nav2's ray trace (:func:`kit.planning.raytrace_line`:
    Bresenham along the dominant axis, at most ``max_cells`` long, both ends included) from
    ``start`` (row, col) to each of ``ends`` (N, 2) that lie on ``grid``."""
    h, w = grid.shape
    r0, c0 = start[0], start[1]
    for i in range(ends.shape[0]):
        dy = ends[i, 0] - r0
        dx = ends[i, 1] - c0
        length = math.hypot(dx, dy)
        x_major = abs(dx) >= abs(dy)
        major = abs(dx) if x_major else abs(dy)
        minor = abs(dy) if x_major else abs(dx)
        scale = max_cells / max(length, 1e-12) if length > max_cells else 1.0
        steps = min(int(scale * major), major)
        s_major = np.sign(dx) if x_major else np.sign(dy)
        s_minor = np.sign(dy) if x_major else np.sign(dx)
        safe = max(major, 1)
        for k in range(steps + 1):
            along = k * s_major
            across = (major // 2 + k * minor) // safe * s_minor
            row = r0 + (across if x_major else along)
            col = c0 + (along if x_major else across)
            if 0 <= row < h and 0 <= col < w:
                grid[row, col] = FREE_SPACE


# ---------------------------------------------------------------- the footprint on a costmap

def outline_points(footprint: ArrayLike, spacing: float) -> FloatArray:
    """Points along the footprint's edges, at most ``spacing`` apart, shape (M, 2) [m]."""
    poly = np.asarray(footprint, dtype=np.float64)
    out = []
    for a, b in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        n = max(1, math.ceil(float(np.hypot(*(b - a))) / spacing))
        out.append(a + (b - a) * (np.arange(n)[:, None] / n))
    return np.vstack(out)


def footprint_costs(costmap: Costmap, poses: ArrayLike, outline: ArrayLike,
                    circumscribed_cost: int = 0) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """The cost under each pose's centre and the highest cost under its outline.

    ``poses`` (..., 3) [m, m, rad]; ``outline`` (M, 2) points in ``base_link``
    (:func:`outline_points`). Off the costmap counts as unknown (255). Poses whose centre
    costs less than ``circumscribed_cost`` (:attr:`NavigationCostmap.circumscribed_cost`)
    cannot touch anything: their outline is not looked up and reads as their centre's cost.
    Returns two arrays of the poses' leading shape.
    """
    p = np.asarray(poses, dtype=np.float64)
    lead = p.shape[:-1]
    p = np.ascontiguousarray(p.reshape(-1, 3))
    o = np.ascontiguousarray(np.asarray(outline, dtype=np.float64).reshape(-1, 2))
    centre, edge = _footprint_costs_compiled(
        costmap.costs, float(costmap.resolution), float(costmap.origin[0]),
        float(costmap.origin[1]), p, o, int(circumscribed_cost))
    return centre.reshape(lead), edge.reshape(lead)


@njit(cache=True)
def _cost_at(costs: Any, res: float, ox: float, oy: float, x: float, y: float) -> int:
    """The cost of the cell under (x, y); off the grid (or not finite): unknown."""
    fx, fy = (x - ox) / res, (y - oy) / res
    if not (math.isfinite(fx) and math.isfinite(fy)):
        return NO_INFORMATION
    col, row = math.floor(fx), math.floor(fy)
    if 0 <= row < costs.shape[0] and 0 <= col < costs.shape[1]:
        return costs[row, col]
    return NO_INFORMATION


@njit(cache=True)
def _footprint_costs_compiled(costs: Any, res: float, ox: float, oy: float, poses: Any,
                              outline: Any, threshold: int) -> tuple[Any, Any]:
    """:func:`footprint_costs` in one compiled loop (the same arithmetic, pose by pose)."""
    n = poses.shape[0]
    centre = np.empty(n, dtype=np.uint8)
    edge = np.empty(n, dtype=np.uint8)
    for i in range(n):
        x, y = poses[i, 0], poses[i, 1]
        c0 = _cost_at(costs, res, ox, oy, x, y)
        worst = c0
        if c0 >= threshold:
            c, s = math.cos(poses[i, 2]), math.sin(poses[i, 2])
            for j in range(outline.shape[0]):
                ex, ey = outline[j, 0], outline[j, 1]
                v = _cost_at(costs, res, ox, oy, x + c * ex - s * ey, y + s * ex + c * ey)
                if v > worst:
                    worst = v
        centre[i] = c0
        edge[i] = worst
    return centre, edge


def footprint_collides(costmap: Costmap, poses: ArrayLike, outline: ArrayLike,
                       circumscribed_cost: int = 0) -> NDArray[np.bool_]:
    """True where the footprint at a pose touches a lethal (or unknown) cell, or its centre is
    within the inscribed radius of one (cost ≥ 253)."""
    centre, edge = footprint_costs(costmap, poses, outline, circumscribed_cost)
    return (centre >= INSCRIBED_INFLATED_OBSTACLE) | (edge >= LETHAL_OBSTACLE)


def collides_from(costmap: Costmap, start: ArrayLike, poses: ArrayLike, outline: ArrayLike,
                  circumscribed_cost: int = 0, margin: float = 0.025) -> NDArray[np.bool_]:
    """:func:`footprint_collides` for motions from ``start``: the lethal cells the footprint
    already touches at ``start``, and the cells beside them (the same surface), count only
    where the footprint with ``margin`` [m] of its padding taken back (half the kit's
    padding; :func:`kit.planning.pad_footprint` with ``-margin``) covers more of them than at
    the start (the area of the cells under it). So a robot a person has walked into,
    or that stopped with its padding on a wall, may still move away or along it, and within
    the outer half of its padding freely, but not creep further in — a long robot's rear
    swinging into the wall it stands beside. Any other cell met is a collision, as
    everywhere else."""
    st = np.asarray(start, dtype=np.float64)
    o = np.asarray(outline, dtype=np.float64)
    centres0, edges0 = footprint_costs(costmap, st[None], o)
    centre0 = centres0[0]
    # the cells themselves only when the outline stands on something (rare)
    touched = _outline_cells(costmap, st[None], o)[0] if edges0[0] >= LETHAL_OBSTACLE \
        else set()
    if not touched and centre0 < INSCRIBED_INFLATED_OBSTACLE:
        return footprint_collides(costmap, poses, outline, circumscribed_cost)
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    centre, _ = footprint_costs(costmap, p, o, circumscribed_cost)
    hit = (centre >= INSCRIBED_INFLATED_OBSTACLE) & (centre0 < INSCRIBED_INFLATED_OBSTACLE)
    corners = _corners(o)
    inner = pad_footprint(corners, -margin)       # half the padding taken back, as it was put
    if np.any(np.sign(inner) != np.sign(corners)):
        inner = corners                           # a footprint too small to take it back from
    for i, cells in enumerate(_outline_cells(costmap, p, o)):
        new = cells - touched
        if any(c == (-1, -1) or not _beside(c, touched) for c in new):
            hit[i] = True                       # something else met: a collision as ever
            continue
        if hit[i]:
            continue
        squares = np.array([c for c in touched | cells if c != (-1, -1)], dtype=np.int64)
        if len(squares) == 0:
            continue
        before = _overlap(costmap, st, inner, squares)
        hit[i] = _overlap(costmap, p[i], inner, squares) > before + 1e-7
    return hit.reshape(np.shape(poses)[:-1])


def _beside(cell: tuple[int, int], cells: set[tuple[int, int]]) -> bool:
    """Whether ``cell`` is one of ``cells`` or next to one (8-neighbours): the same surface."""
    r, c = cell
    return any(abs(r - a) <= 1 and abs(c - b) <= 1 for a, b in cells if a >= 0)


def _corners(outline: FloatArray) -> FloatArray:
    """The outline's polygon without the points along straight edges (its corners)."""
    prev, nxt = np.roll(outline, 1, axis=0), np.roll(outline, -1, axis=0)
    turn = (outline[:, 0] - prev[:, 0]) * (nxt[:, 1] - outline[:, 1]) - \
        (outline[:, 1] - prev[:, 1]) * (nxt[:, 0] - outline[:, 0])
    keep = np.abs(turn) > 1e-12
    return np.ascontiguousarray(outline[keep] if keep.sum() >= 3 else outline)


def _overlap(costmap: Costmap, pose: FloatArray, corners: FloatArray,
             squares: NDArray[np.int64]) -> float:
    """The area [m²] the footprint polygon at ``pose`` covers of the cells ``squares``
    ((K, 2) rows and columns): how far it has pushed into them, continuous as it moves (a
    count of cells or a depth measured from cell centres jumps by whole cells)."""
    return float(_overlap_compiled(float(costmap.resolution), float(costmap.origin[0]),
                                   float(costmap.origin[1]), float(pose[0]), float(pose[1]),
                                   float(pose[2]), corners, squares))


@njit(cache=True)
def _overlap_compiled(res: float, ox: float, oy: float, x: float, y: float, th: float,
                      corners: Any, squares: Any) -> float:
    n = corners.shape[0]
    c, s = math.cos(th), math.sin(th)
    poly = np.empty((n, 2))
    for j in range(n):
        poly[j, 0] = x + c * corners[j, 0] - s * corners[j, 1]
        poly[j, 1] = y + s * corners[j, 0] + c * corners[j, 1]
    total = 0.0
    for k in range(squares.shape[0]):
        x0, y0 = ox + squares[k, 1] * res, oy + squares[k, 0] * res
        bounds = (x0, y0, x0 + res, y0 + res)
        cur = poly
        for side in range(4):              # Sutherland-Hodgman against each edge of the cell
            m = cur.shape[0]
            if m == 0:
                break
            out = np.empty((2 * m, 2))
            count = 0
            axis = side % 2
            limit = bounds[side]
            keep_above = side < 2             # x >= x0, y >= y0, then x <= x1, y <= y1
            for j in range(m):
                ax, ay = cur[j - 1, 0], cur[j - 1, 1]
                bx, by = cur[j, 0], cur[j, 1]
                av = ax if axis == 0 else ay
                bv = bx if axis == 0 else by
                a_in = av >= limit if keep_above else av <= limit
                b_in = bv >= limit if keep_above else bv <= limit
                if a_in != b_in:
                    t = (limit - av) / (bv - av)
                    out[count, 0] = ax + t * (bx - ax)
                    out[count, 1] = ay + t * (by - ay)
                    count += 1
                if b_in:
                    out[count, 0] = bx
                    out[count, 1] = by
                    count += 1
            cur = out[:count]
        area = 0.0
        m = cur.shape[0]
        for j in range(m):
            area += cur[j - 1, 0] * cur[j, 1] - cur[j, 0] * cur[j - 1, 1]
        total += abs(area) / 2.0
    return total


def _outline_cells(costmap: Costmap, poses: FloatArray, outline: FloatArray
                   ) -> list[set[tuple[int, int]]]:
    """Per pose, the lethal or unknown cells under the outline (off the map: (-1, -1))."""
    c, s = np.cos(poses[:, 2:3]), np.sin(poses[:, 2:3])
    xs = poses[:, 0:1] + c * outline[None, :, 0] - s * outline[None, :, 1]
    ys = poses[:, 1:2] + s * outline[None, :, 0] + c * outline[None, :, 1]
    res = costmap.resolution
    cols = np.floor((xs - costmap.origin[0]) / res).astype(np.int64)
    rows = np.floor((ys - costmap.origin[1]) / res).astype(np.int64)
    inside = (rows >= 0) & (rows < costmap.height) & (cols >= 0) & (cols < costmap.width)
    cost = np.full(xs.shape, NO_INFORMATION, dtype=np.uint8)
    cost[inside] = costmap.costs[rows[inside], cols[inside]]
    bad = cost >= LETHAL_OBSTACLE
    if not bad.any():                      # the common case: nothing under any outline
        return [set() for _ in range(len(poses))]
    out = []
    for i in range(len(poses)):
        k = bad[i]
        out.append({(int(r), int(cc)) if ok else (-1, -1)
                    for r, cc, ok in zip(rows[i, k], cols[i, k], inside[i, k], strict=True)})
    return out
