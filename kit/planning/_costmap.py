"""Costmaps in Nav2's model (``nav2_costmap_2d``): costs, footprints, the static layer,
inflation and the keep-out filter.

A costmap is a grid of costs 0–255 with Nav2's constants: :data:`FREE_SPACE` 0, costs 1–252
for cells near obstacles, :data:`INSCRIBED_INFLATED_OBSTACLE` 253 (the robot's centre there
puts its footprint on an obstacle), :data:`LETHAL_OBSTACLE` 254 and :data:`NO_INFORMATION`
255. Array ``costs[row, col]`` has row 0 at the map origin (``y`` grows with the row, as in
``nav_msgs/OccupancyGrid``); Nav2's cell ``(mx, my)`` is ``(col, row)`` here.

Inflation (Nav2's ``InflationLayer``): a cell at distance ``d`` [m] from the nearest lethal
cell costs

.. math::

    c(d) = \\begin{cases} 254 & d = 0 \\\\ 253 & 0 < d \\le r_{ins} \\\\
           \\lfloor 252\\, e^{-k (d - r_{ins})} \\rfloor & r_{ins} < d \\end{cases}

with ``k = cost_scaling_factor`` and ``r_ins`` the footprint's inscribed radius. Distances
are Euclidean between cell centres, ``d = resolution · √(Δcol² + Δrow²)``; cells farther than
``ceil(inflation_radius / resolution)`` cells are left alone. A cell at exactly the inscribed
radius is inscribed (253): Nav2 compares ``d ≤ r_ins`` in double precision, and so does the
kit — mind that a map's ``resolution`` is a float32 (0.05 is 0.0500000007...), so two cells of
a 0.05 m map are 0.1000000015 m, *beyond* an inscribed radius of 0.1 m. The kit evaluates the
formula at the exact Euclidean distance to the nearest lethal cell. Nav2's layer is not exact:
it spreads outwards from the lethal cells cell by cell, and a cell keeps the distance to the
obstacle whose spread reached it first, which is not always the nearest (its cached table of
cell offsets then gives that distance; the newest layer rounds it to 1/100 cell first). On 20
random 120 × 120 maps of walls 0.06 % of the cells differ, by at most 9, the kit's the higher,
and no cell changes whether it is inscribed (253).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from kit import msgs

__all__ = [
    "FREE_SPACE",
    "INSCRIBED_INFLATED_OBSTACLE",
    "LETHAL_OBSTACLE",
    "MAX_NON_OBSTACLE",
    "NO_INFORMATION",
    "Costmap",
    "apply_keepout",
    "apply_keepout_costs",
    "cell_to_world",
    "footprint_from_radius",
    "footprint_radii",
    "inflate",
    "inflate_reference",
    "inflation_cost",
    "keepout_costs",
    "pad_footprint",
    "static_layer",
    "world_to_cell",
]

FREE_SPACE = 0
MAX_NON_OBSTACLE = 252
INSCRIBED_INFLATED_OBSTACLE = 253
LETHAL_OBSTACLE = 254
NO_INFORMATION = 255

CostArray = NDArray[np.uint8]
FloatArray = NDArray[np.float64]


# ------------------------------------------------------------------ world <-> grid

def world_to_cell(x: float, y: float, origin: tuple[float, float],
                  resolution: float) -> tuple[int, int]:
    """The ``(row, col)`` of the cell holding the point ``(x, y)`` [m].

    ``col = ⌊(x − x₀) / resolution⌋``, ``row = ⌊(y − y₀) / resolution⌋`` with ``(x₀, y₀)``
    the corner of cell ``(0, 0)`` (the map's ``origin``); the map's origin yaw is ignored, as
    Nav2's costmap ignores it. No bounds check: see :meth:`Costmap.world_to_cell`.

    >>> world_to_cell(0.27, -0.02, origin=(0.0, -1.0), resolution=0.05)
    (19, 5)
    """
    return (math.floor((y - origin[1]) / resolution),
            math.floor((x - origin[0]) / resolution))


def cell_to_world(row: int, col: int, origin: tuple[float, float],
                  resolution: float) -> tuple[float, float]:
    """The centre ``(x, y)`` [m] of cell ``(row, col)``.

    >>> [round(v, 9) for v in cell_to_world(19, 5, origin=(0.0, -1.0), resolution=0.05)]
    [0.275, -0.025]
    """
    return origin[0] + (col + 0.5) * resolution, origin[1] + (row + 0.5) * resolution


@dataclass(frozen=True, eq=False)
class Costmap:
    """A grid of Nav2 costs in a frame: what the planners plan on.

    ``costs`` has shape ``(height, width)``, row 0 at ``origin`` (the corner of cell (0, 0) in
    ``frame_id``, metres), ``resolution`` metres per cell. Read-only once built.
    """

    costs: CostArray
    resolution: float
    origin: tuple[float, float] = (0.0, 0.0)
    frame_id: str = "map"

    def __post_init__(self) -> None:
        costs = np.array(self.costs, dtype=np.uint8, copy=True)
        if costs.ndim != 2 or 0 in costs.shape:
            raise ValueError(f"Costmap.costs must be a non-empty (height, width) array; "
                             f"got shape {np.shape(self.costs)}")
        if not (math.isfinite(self.resolution) and self.resolution > 0):
            raise ValueError(f"Costmap.resolution must be a positive number of metres per "
                             f"cell; got {self.resolution!r}")
        costs.flags.writeable = False
        object.__setattr__(self, "costs", costs)
        object.__setattr__(self, "origin", (float(self.origin[0]), float(self.origin[1])))

    @property
    def height(self) -> int:
        return int(self.costs.shape[0])

    @property
    def width(self) -> int:
        return int(self.costs.shape[1])

    def world_to_cell(self, x: float, y: float, what: str = "point") -> tuple[int, int]:
        """``(row, col)`` of the point ``(x, y)``; ``ValueError`` naming ``what`` when it is off
        the map."""
        row, col = world_to_cell(x, y, self.origin, self.resolution)
        if not (0 <= row < self.height and 0 <= col < self.width):
            x1 = self.origin[0] + self.width * self.resolution
            y1 = self.origin[1] + self.height * self.resolution
            raise ValueError(f"{what} ({x:g}, {y:g}) is off the map: it covers x "
                             f"{self.origin[0]:g} … {x1:g}, y {self.origin[1]:g} … {y1:g} m")
        return row, col

    def cell_to_world(self, row: int, col: int) -> tuple[float, float]:
        """Centre ``(x, y)`` [m] of cell ``(row, col)``."""
        return cell_to_world(row, col, self.origin, self.resolution)

    def to_occupancy_grid(self) -> msgs.OccupancyGrid:
        """The costmap as Nav2's costmap publisher sends it: 0 → 0, 253 → 99, 254 → 100,
        255 → −1 and 1…252 → ``1 + 97 (c − 1) // 251``."""
        table = np.empty(256, dtype=np.int16)
        table[0], table[253], table[254], table[255] = 0, 99, 100, -1
        table[1:253] = 1 + (97 * (np.arange(1, 253) - 1)) // 251
        info = msgs.MapMetaData(resolution=self.resolution, width=self.width,
                                height=self.height,
                                origin=msgs.Pose(msgs.Point(self.origin[0], self.origin[1], 0.0)))
        return msgs.OccupancyGrid(msgs.Header(frame_id=self.frame_id), info,
                                  table[self.costs].astype(np.int8).ravel())


# ------------------------------------------------------------------ footprint

def footprint_from_radius(radius: float) -> FloatArray:
    """Nav2's footprint of a round robot: 16 points on the circle, shape ``(16, 2)`` [m]."""
    if not (math.isfinite(radius) and radius > 0):
        raise ValueError(f"robot_radius must be a positive number of metres; got {radius!r}")
    angles = np.arange(16) * 2.0 * math.pi / 16
    return radius * np.column_stack([np.cos(angles), np.sin(angles)])


def _check_polygon(points: ArrayLike) -> FloatArray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) < 3 or not np.isfinite(p).all():
        raise ValueError(f"a footprint is an (N, 2) polygon of N >= 3 points [m] in base_link; "
                         f"got shape {p.shape}")
    return p


def pad_footprint(points: ArrayLike, padding: float) -> FloatArray:
    """Nav2's ``footprint_padding``: each vertex moves ``padding`` [m] away from the axes, in x
    and in y (``x + sign(x)·padding``, with sign(0) = 0)."""
    p = _check_polygon(points)
    return p + np.sign(p) * padding


def footprint_radii(points: ArrayLike) -> tuple[float, float]:
    """``(inscribed_radius, circumscribed_radius)`` [m] of a footprint about ``base_link``'s
    origin, as Nav2 computes them: the smallest and largest distance from the origin to any
    vertex or edge.

    >>> [round(r, 6) for r in footprint_radii([[0.22, 0.2], [-0.18, 0.2], [-0.18, -0.2],
    ...                                        [0.22, -0.2]])]
    [0.18, 0.297321]
    """
    p = _check_polygon(points)
    a, b = p, np.roll(p, -1, axis=0)
    ab = b - a
    t = np.clip(-(a * ab).sum(axis=1) / np.maximum((ab * ab).sum(axis=1), 1e-300), 0.0, 1.0)
    edge = np.hypot(*(a + t[:, None] * ab).T)
    vertex = np.hypot(*p.T)
    return float(min(edge.min(), vertex.min())), float(max(edge.max(), vertex.max()))


# ------------------------------------------------------------------ static layer

def static_layer(grid: msgs.OccupancyGrid, *, track_unknown_space: bool = False,
                 lethal_cost_threshold: int = 100, unknown_cost_value: int = 255,
                 trinary_costmap: bool = True,
                 inscribed_obstacle_cost_value: int | None = 99) -> CostArray:
    """Nav2's ``StaticLayer``: occupancy values (0–100, −1 read as 255) to costs.

    Value ``unknown_cost_value`` → 255 when ``track_unknown_space`` else 0; the value
    ``inscribed_obstacle_cost_value`` → 253; ``≥ lethal_cost_threshold`` → 254; anything else
    → 0 with ``trinary_costmap``, or ``254 · value / lethal_cost_threshold`` (truncated).
    Returns ``(height, width)`` costs, row 0 at the map's origin.

    The two values are bytes in Nav2, as the map's cells are: ``unknown_cost_value: -1`` (ROS
    1's default, still in many files) is 255, the same as Nav2's default. The inscribed rule
    is Lyrical's (Nav2 PR #5781: a costmap republished as a map keeps its 253 as 99); Jazzy
    and Humble have no such rule, which ``inscribed_obstacle_cost_value=None`` gives.
    """
    info = grid.info
    value = grid.data.astype(np.uint8).reshape(info.height, info.width).astype(np.int64)
    lethal = max(min(int(lethal_cost_threshold), 100), 0)
    cost: NDArray[np.int64]
    if trinary_costmap:
        cost = np.zeros(value.shape, dtype=np.int64)
    else:
        cost = (value / max(lethal, 1) * LETHAL_OBSTACLE).astype(np.int64)
    cost[value >= lethal] = LETHAL_OBSTACLE
    if inscribed_obstacle_cost_value is not None:
        cost[value == int(inscribed_obstacle_cost_value) % 256] = INSCRIBED_INFLATED_OBSTACLE
    unknown = int(unknown_cost_value) % 256                 # rclcpp's cast to unsigned char
    cost[value == unknown] = NO_INFORMATION if track_unknown_space else FREE_SPACE
    return cost.astype(np.uint8)


# ------------------------------------------------------------------ inflation

def inflation_cost(distance: ArrayLike, inscribed_radius: float,
                   cost_scaling_factor: float) -> CostArray:
    """Nav2's inflation cost of a cell ``distance`` metres from the nearest lethal cell.

    ``254`` at 0, ``253`` up to and including ``inscribed_radius``, then
    ``⌊(253 − 1) · exp(−cost_scaling_factor · (distance − inscribed_radius))⌋``.

    >>> inflation_cost([0.0, 0.1, 0.2, 0.3], inscribed_radius=0.1, cost_scaling_factor=10.0)
    array([254, 253,  92,  34], dtype=uint8)
    """
    d = np.asarray(distance, dtype=np.float64)
    with np.errstate(over="ignore"):
        decay = (INSCRIBED_INFLATED_OBSTACLE - 1) * np.exp(
            -1.0 * cost_scaling_factor * (d - inscribed_radius))
    cost = np.where(d <= inscribed_radius, float(INSCRIBED_INFLATED_OBSTACLE),
                    np.minimum(decay, float(MAX_NON_OBSTACLE)))
    cost = np.where(d == 0, float(LETHAL_OBSTACLE), cost)
    return cost.astype(np.uint8)


def _inflation_table(resolution: float, inflation_radius: float, inscribed_radius: float,
                     cost_scaling_factor: float, shape: tuple[int, ...] = ()
                     ) -> tuple[int, CostArray]:
    """``(R, table)``: the radius in cells, ``ceil(inflation_radius / resolution)`` as Nav2's
    ``cellDistance`` — no more than the diagonal of a grid of ``shape``, beyond which no cell
    lies — and the cost of every squared cell distance ``0 … R²``."""
    if not (math.isfinite(resolution) and resolution > 0):
        raise ValueError(f"resolution must be a positive number of metres per cell; "
                         f"got {resolution!r}")
    for name, value in (("inflation_radius", inflation_radius),
                        ("inscribed_radius", inscribed_radius),
                        ("cost_scaling_factor", cost_scaling_factor)):
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a non-negative number; got {value!r}")
    cells = int(max(0.0, math.ceil(inflation_radius / resolution)))
    if shape:
        cells = min(cells, math.ceil(math.hypot(*shape)) + 1)
    squared = np.arange(cells * cells + 1, dtype=np.float64)
    return cells, inflation_cost(np.sqrt(squared) * resolution, inscribed_radius,
                                 cost_scaling_factor)


def _merge(old: CostArray, new: CostArray, inflate_unknown: bool) -> CostArray:
    """Nav2's rule for writing an inflation cost over a cell: an unknown cell takes it only
    when it is inscribed or lethal (any cost above 0 with ``inflate_unknown``), any other cell
    keeps the larger cost."""
    threshold = 1 if inflate_unknown else INSCRIBED_INFLATED_OBSTACLE
    return np.where(old == NO_INFORMATION, np.where(new >= threshold, new, old),
                    np.maximum(old, new)).astype(np.uint8)


def _check_costs(costs: ArrayLike) -> CostArray:
    c = np.asarray(costs)
    if c.ndim != 2 or c.dtype != np.uint8:
        raise ValueError(f"costs must be a (height, width) uint8 array of Nav2 costs; got "
                         f"{c.dtype} of shape {c.shape}")
    return c


def inflate_reference(costs: ArrayLike, resolution: float, *, inscribed_radius: float,
                      inflation_radius: float = 0.55, cost_scaling_factor: float = 10.0,
                      inflate_unknown: bool = False,
                      inflate_around_unknown: bool = False) -> CostArray:
    """Inflate ``costs`` (shape ``(H, W)``, uint8) as Nav2's inflation layer does: the plain
    version, one shifted copy of the obstacle mask per cell offset within the radius.

    Lethal cells (and unknown ones with ``inflate_around_unknown``) are the sources; every
    cell within ``ceil(inflation_radius / resolution)`` cells of one gets
    :func:`inflation_cost` of its distance, merged with the cell's own cost (see module
    docs). Returns a new array; :func:`inflate` computes the same, compiled.
    """
    c = _check_costs(costs)
    cells, table = _inflation_table(resolution, inflation_radius, inscribed_radius,
                                    cost_scaling_factor, c.shape)
    source = c == LETHAL_OBSTACLE
    if inflate_around_unknown:
        source |= c == NO_INFORMATION
    height, width = c.shape
    unreached = cells * cells + 1
    nearest = np.full(c.shape, unreached, dtype=np.int64)   # squared cell distance
    padded = np.zeros((height + 2 * cells, width + 2 * cells), dtype=bool)
    padded[cells:cells + height, cells:cells + width] = source
    for dr in range(-cells, cells + 1):
        for dc in range(-cells, cells + 1):
            d2 = dr * dr + dc * dc
            if d2 > cells * cells:
                continue
            shifted = padded[cells + dr:cells + dr + height, cells + dc:cells + dc + width]
            nearest[shifted & (nearest > d2)] = d2
    inside = nearest < unreached
    out = c.copy()
    out[inside] = _merge(c[inside], table[nearest[inside]], inflate_unknown)
    return out


@njit(cache=True)
def _inflate_compiled(costs: CostArray, cells: int, table: CostArray, inflate_unknown: bool,
                      inflate_around_unknown: bool) -> CostArray:
    """Exact squared Euclidean distance transform (Felzenszwalb & Huttenlocher 2012: one pass
    along the columns, the lower envelope of parabolas along the rows), cut off beyond
    ``cells``, and the inflation costs merged in the same sweep."""
    height, width = costs.shape
    far = cells + 1
    column = np.empty((height, width), dtype=np.int32)    # rows to the nearest source
    for r in range(height):
        for c in range(width):
            v = costs[r, c]
            if v == 254 or (inflate_around_unknown and v == 255):
                column[r, c] = 0
            elif r > 0 and column[r - 1, c] < far:
                column[r, c] = column[r - 1, c] + 1
            else:
                column[r, c] = far
    for r in range(height - 2, -1, -1):
        for c in range(width):
            below = column[r + 1, c] + 1
            if below < column[r, c]:
                column[r, c] = below
    out = costs.copy()
    limit = cells * cells
    threshold = 1 if inflate_unknown else 253
    site = np.empty(width, dtype=np.int64)
    bound = np.empty(width + 1, dtype=np.float64)
    s = 0.0
    for r in range(height):
        k = -1
        for q in range(width):
            if column[r, q] >= far:
                continue
            fq = float(column[r, q]) ** 2 + q * q
            while k >= 0:
                p = site[k]
                s = (fq - (float(column[r, p]) ** 2 + p * p)) / (2.0 * (q - p))
                if s <= bound[k]:
                    k -= 1
                else:
                    break
            if k < 0:
                k = 0
                site[0] = q
                bound[0] = -np.inf
            else:
                k += 1
                site[k] = q
                bound[k] = s
            bound[k + 1] = np.inf
        if k < 0:
            continue
        j = 0
        for c in range(width):
            while bound[j + 1] < c:
                j += 1
            p = site[j]
            d2 = (c - p) * (c - p) + column[r, p] * column[r, p]
            if d2 > limit:
                continue
            new = table[d2]
            old = out[r, c]
            if old == 255:
                if new >= threshold:
                    out[r, c] = new
            elif new > old:
                out[r, c] = new
    return out


def inflate(costs: ArrayLike, resolution: float, *, inscribed_radius: float,
            inflation_radius: float = 0.55, cost_scaling_factor: float = 10.0,
            inflate_unknown: bool = False, inflate_around_unknown: bool = False) -> CostArray:
    """Nav2's inflation of ``costs`` (shape ``(H, W)``, uint8), compiled; the same result as
    :func:`inflate_reference` (parameters and rules there) in time linear in the map size.

    >>> c = np.zeros((1, 7), np.uint8); c[0, 0] = LETHAL_OBSTACLE
    >>> inflate(c, 0.05, inscribed_radius=0.1, inflation_radius=0.25).tolist()
    [[254, 253, 253, 152, 92, 56, 0]]
    """
    c = _check_costs(costs)
    cells, table = _inflation_table(resolution, inflation_radius, inscribed_radius,
                                    cost_scaling_factor, c.shape)
    if cells == 0:
        return c.copy()
    return _inflate_compiled(np.ascontiguousarray(c), cells, table, bool(inflate_unknown),
                             bool(inflate_around_unknown))


# ------------------------------------------------------------------ keep-out filter

def keepout_costs(mask: msgs.OccupancyGrid, shape: tuple[int, int], resolution: float,
                  origin: tuple[float, float]) -> NDArray[np.int16]:
    """The keep-out mask's cost for every cell of a grid (``shape``, ``resolution``,
    ``origin``), shape ``(H, W)``: ``round(254 · v / 100)`` for the mask value ``v`` (0–100)
    under the cell's centre, −1 where the mask is unknown or does not reach (no change).
    A costmap that keeps its geometry computes this once (see :func:`apply_keepout`)."""
    info = mask.info
    values = np.asarray(mask.data).reshape(info.height, info.width)
    rows, cols = np.indices(shape)
    x = origin[0] + (cols + 0.5) * resolution
    y = origin[1] + (rows + 0.5) * resolution
    mx = np.floor((x - info.origin.position.x) / info.resolution).astype(np.int64)
    my = np.floor((y - info.origin.position.y) / info.resolution).astype(np.int64)
    on = (mx >= 0) & (my >= 0) & (mx < info.width) & (my < info.height)
    v = np.full(shape, -1, dtype=np.int64)
    v[on] = values[my[on], mx[on]]
    known = v >= 0
    cost = np.full(shape, -1, dtype=np.int16)
    # std::round: halves away from zero (np.rint would round 190.5 to 190)
    cost[known] = np.floor(v[known] * (LETHAL_OBSTACLE - FREE_SPACE) / 100.0 + 0.5)
    return cost


def apply_keepout_costs(costs: ArrayLike, mask_costs: NDArray[np.int16]) -> CostArray:
    """``costs`` raised by a keep-out mask's per-cell costs (:func:`keepout_costs`): each
    known mask cost is written where it exceeds the cell's own or the cell is unknown."""
    c = _check_costs(costs).copy()
    write = (mask_costs >= 0) & ((mask_costs > c) | (c == NO_INFORMATION))
    c[write] = mask_costs[write]
    return c


def apply_keepout(costs: ArrayLike, mask: msgs.OccupancyGrid, resolution: float,
                  origin: tuple[float, float]) -> CostArray:
    """Nav2's ``KeepoutFilter``: raise the costs under a filter mask.

    Each cell's centre is looked up in ``mask`` (an ``OccupancyGrid`` in the same frame, any
    resolution and origin; its yaw ignored as Nav2 does). A mask value ``v`` (0–100) becomes
    the cost ``round(254 · v / 100)``; unknown (−1) and cells off the mask change nothing; the
    cost is written where it exceeds the cell's own or the cell is unknown. Filters run after
    the layers, so a keep-out zone is lethal but not inflated (as in Nav2).
    """
    c = _check_costs(costs)
    height, width = c.shape
    return apply_keepout_costs(c, keepout_costs(mask, (height, width), resolution, origin))
