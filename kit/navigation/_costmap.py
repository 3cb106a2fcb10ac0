"""The navigation costmaps — Nav2's global costmap (the whole map) and its local costmap (a
window rolling with the robot), both the kit's one :class:`kit.planning.LayeredCostmap` — and
the footprint on a costmap: the costs under a pose and its outline, and collisions.

:func:`navigation_costmap_params` gives the kit's own navigation costmaps' parameters (a
static layer, one scan source marking and clearing, inflation reaching past the footprint;
the global one with a keep-out mask before the inflation); :class:`NavigationCostmap` builds
one in a call.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from kit import msgs
from kit.planning import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap,
    CostmapParams,
    InflationLayerParams,
    KeepoutFilterParams,
    LayeredCostmap,
    ObservationSource,
    ObstacleLayerParams,
    StaticLayerParams,
    footprint_radii,
    pad_footprint,
)

__all__ = ["NavigationCostmap", "collides_from", "footprint_collides", "footprint_costs",
           "navigation_costmap_params", "outline_points"]

FloatArray = NDArray[np.float64]


def navigation_costmap_params(footprint: ArrayLike, *, rolling_window: bool = False,
                              width: float = 3.0, height: float = 3.0,
                              resolution: float = 0.05, inflation_radius: float = 0.55,
                              cost_scaling_factor: float = 10.0,
                              obstacle_max_range: float = 2.5, raytrace_max_range: float = 3.0,
                              keepout: bool = False, moving_margin: float = 0.0,
                              footprint_padding: float = 0.0) -> CostmapParams:
    """The kit's navigation costmap: a static layer, an obstacle layer with one scan source
    (marking within ``obstacle_max_range``, clearing within ``raytrace_max_range`` [m]) and an
    inflation layer — a ``rolling_window`` of ``width`` × ``height`` metres for the local
    costmap; with ``keepout`` a keep-out filter between the static and the obstacle layer, so
    that the zone is inflated like a wall.

    The inflation radius is raised to the padded footprint's circumscribed radius + 0.1 m
    when it is smaller, so that a centre's cost tells whether its footprint can touch
    anything (Nav2 warns when it does not). The obstacle layer follows the kit's two rules
    (:class:`kit.planning.ObstacleLayer`: beams not shortened at the grid's edge, marking
    ranges in metres)."""
    padded = pad_footprint(footprint, footprint_padding)
    _, circumscribed = footprint_radii(padded)
    source = ObservationSource(clearing=True, obstacle_max_range=obstacle_max_range,
                               raytrace_max_range=raytrace_max_range)
    layers: list[Any] = [StaticLayerParams()]
    if keepout:
        layers.append(KeepoutFilterParams())
    layers += [ObstacleLayerParams(observation_sources=(source,), clip_rays=False,
                                   range_in_cells=False, moving_margin=moving_margin),
               InflationLayerParams(inflation_radius=max(float(inflation_radius),
                                                         circumscribed + 0.1),
                                    cost_scaling_factor=float(cost_scaling_factor))]
    return CostmapParams(resolution=resolution, width=width, height=height,
                         footprint=np.asarray(footprint, dtype=np.float64),
                         footprint_padding=footprint_padding, rolling_window=rolling_window,
                         layers=tuple(layers))


class NavigationCostmap(LayeredCostmap):
    """A :class:`~kit.planning.LayeredCostmap` with the kit's navigation parameters
    (:func:`navigation_costmap_params`), in one call.

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
        if resolution is None:
            resolution = float(grid.info.resolution) if grid is not None else 0.05
        params = navigation_costmap_params(
            footprint, rolling_window=rolling_window, width=width, height=height,
            resolution=resolution, inflation_radius=inflation_radius,
            cost_scaling_factor=cost_scaling_factor, obstacle_max_range=obstacle_max_range,
            raytrace_max_range=raytrace_max_range,
            keepout=keepout is not None and not rolling_window, moving_margin=moving_margin)
        super().__init__(params, grid)
        if keepout is not None and not rolling_window:
            self.set_keepout_mask(keepout)

    def set_static(self, grid: msgs.OccupancyGrid) -> None:
        """:meth:`~kit.planning.LayeredCostmap.set_map` (the name it had here)."""
        self.set_map(grid)


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
