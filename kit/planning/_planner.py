"""The planner interface, shaped like Nav2's ``ComputePathToPose`` action: a start and a goal
pose and a costmap in, a ``nav_msgs/Path`` out, so a navigator can swap planners.

:func:`compute_path_to_pose` takes ``start`` and ``goal`` (``PoseStamped`` in the costmap's
frame, or ``(x, y, θ)``), optional ``viapoints`` to pass through in order, and a planner — any
object with ``create_plan(start, goal, costmap) -> PlanResult`` (:class:`GridPlanner`:
A*/Dijkstra like Nav2's Smac 2-D and NavFn; :class:`ThetaStarPlanner`: Nav2's Theta*).

The path's poses are the cells' centres, except the first (the start's exact position) and
the last (the goal pose itself); each pose faces the next one. A start or goal off the map,
in an obstacle, or in another frame raises :class:`PlanningError` with Nav2's error code; a
goal that cannot be reached returns a :class:`PlanResult` with an empty path,
``error_code = NO_VALID_PATH`` (208) and the reason.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs
from kit.planning._costmap import Costmap
from kit.planning._gridsearch import GridSearch
from kit.planning._search import (
    GOAL_OCCUPIED,
    GOAL_OUTSIDE_MAP,
    NO_VALID_PATH,
    START_OCCUPIED,
    START_OUTSIDE_MAP,
    PlanningError,
    SearchResult,
    traversable,
)

__all__ = [
    "TF_ERROR",
    "GlobalPlanner",
    "GridPlanner",
    "PlanResult",
    "ThetaStarPlanner",
    "compute_path_to_pose",
    "path_to_points",
    "points_to_path",
]

TF_ERROR = 202
NONE = 0

FloatArray = NDArray[np.float64]
PoseLike = msgs.PoseStamped | ArrayLike


@dataclass(frozen=True, eq=False)
class PlanResult:
    """``ComputePathToPose``'s result: ``path``, ``planning_time`` [s], ``error_code`` (0 or
    ``NO_VALID_PATH``) and ``error_msg``; plus the searches behind it (one per leg), for
    plots and counts."""

    path: msgs.Path
    planning_time: float
    error_code: int = NONE
    error_msg: str = ""
    searches: tuple[SearchResult, ...] = ()

    @property
    def ok(self) -> bool:
        return self.error_code == NONE


class GlobalPlanner(Protocol):
    """What :func:`compute_path_to_pose` needs of a planner (Nav2's ``GlobalPlanner``)."""

    def create_plan(self, start: msgs.PoseStamped, goal: msgs.PoseStamped,
                    costmap: Costmap) -> PlanResult: ...


def path_to_points(path: msgs.Path) -> FloatArray:
    """A path's positions ``(N, 2)`` [m]."""
    return np.array([[p.pose.position.x, p.pose.position.y] for p in path.poses],
                    dtype=np.float64).reshape(-1, 2)


def points_to_path(points: ArrayLike, frame_id: str = "map", stamp: msgs.Time | None = None,
                   final_yaw: float | None = None) -> msgs.Path:
    """A ``nav_msgs/Path`` through ``points`` ``(N, 2)`` [m]: each pose faces the next one, the
    last faces ``final_yaw`` (or keeps the last direction)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    header = msgs.Header(stamp if stamp is not None else msgs.Time(), frame_id)
    if len(p) == 0:
        return msgs.Path(header, ())
    d = np.diff(p, axis=0)
    yaw = np.arctan2(d[:, 1], d[:, 0]) if len(d) else np.zeros(0)
    last = final_yaw if final_yaw is not None else (float(yaw[-1]) if len(yaw) else 0.0)
    yaw = np.append(yaw, last)
    # plain floats from tolist(): the messages can be filled without their checks
    pose, point, quat, stamped = (msgs.Pose.trusted_builder(), msgs.Point.trusted_builder(),
                                  msgs.Quaternion.trusted_builder(),
                                  msgs.PoseStamped.trusted_builder())
    poses = tuple(stamped(header, pose(point(x, y, 0.0), quat(*q)))
                  for (x, y), q in zip(p.tolist(), geometry.yaw_to_quaternion(yaw).tolist(),
                                       strict=True))
    return msgs.Path(header, poses)


def _pose(pose: PoseLike, frame_id: str, what: str) -> tuple[float, float, float]:
    if isinstance(pose, msgs.PoseStamped):
        if pose.header.frame_id not in ("", frame_id):
            raise PlanningError(f"{what} is in frame {pose.header.frame_id!r}, the costmap in "
                                f"{frame_id!r}: transform it first (kit.tf)", TF_ERROR)
        o = pose.pose.orientation
        yaw = float(geometry.quaternion_to_yaw([o.x, o.y, o.z, o.w]))
        return pose.pose.position.x, pose.pose.position.y, yaw
    p = geometry.check_pose(pose, what)
    if p.ndim != 1:
        raise ValueError(f"{what} must be one pose (x, y, theta)")
    return float(p[0]), float(p[1]), float(p[2])


def _check(costmap: Costmap, pose: tuple[float, float, float], what: str,
           allow_unknown: bool, occupied_ok: bool = False) -> None:
    """Raise :class:`PlanningError` for a pose off the map or on an untraversable cell (that
    only with ``occupied_ok`` false)."""
    start = what == "start"
    try:
        row, col = costmap.world_to_cell(pose[0], pose[1], what)
    except ValueError as exc:
        raise PlanningError(str(exc), START_OUTSIDE_MAP if start else GOAL_OUTSIDE_MAP) from None
    if occupied_ok:
        return
    cost = int(costmap.costs[row, col])
    if not traversable(cost, allow_unknown):
        raise PlanningError(f"{what} ({pose[0]:g}, {pose[1]:g}) is in an obstacle: its cell "
                            f"(row, col) = ({row}, {col}) has cost {cost} (253 inscribed, 254 "
                            f"lethal, 255 unknown)", START_OCCUPIED if start else GOAL_OCCUPIED)


class _SearchPlanner(ABC):
    """Shared by the planners: one compiled search per costmap, reused while it lasts.

    ``tolerance`` [m] (NavFn's rule): when the goal's cell cannot be entered or reached, the
    path ends at the reachable cell nearest the goal whose centre lies within ``tolerance``
    of it in x and in y (none: no path). ``downsampling_factor`` (Smac's): plan on a grid of
    cells that many times larger, each the costliest of the cells it covers.
    ``use_final_approach_orientation``: the path's last pose faces the way the path arrives,
    not the goal's heading. ``max_iterations``: see :class:`~kit.planning.GridSearch`."""

    tolerance = 0.0
    downsampling_factor = 1
    max_iterations: int | None = None
    use_final_approach_orientation = False

    def __init__(self, connectivity: int, allow_unknown: bool, corner_cutting: bool = False,
                 cost_travel_multiplier: float = 2.0) -> None:
        self.connectivity, self.allow_unknown = connectivity, allow_unknown
        self.corner_cutting, self.cost_travel_multiplier = corner_cutting, cost_travel_multiplier
        self._new_search(np.zeros((1, 1), np.uint8))        # checks the options now
        self._costmap: Costmap | None = None
        self._search: GridSearch | None = None
        self._coarse: tuple[Costmap, Costmap] | None = None

    def _set_options(self, tolerance: float, downsampling_factor: int,
                     max_iterations: int | None, use_final_approach_orientation: bool) -> None:
        if not (math.isfinite(tolerance) and tolerance >= 0):
            raise ValueError(f"tolerance must be a non-negative number of metres; got "
                             f"{tolerance!r}")
        if isinstance(downsampling_factor, bool) or not isinstance(downsampling_factor, int) \
                or downsampling_factor < 1:
            raise ValueError(f"downsampling_factor must be a whole number of at least 1; got "
                             f"{downsampling_factor!r}")
        self.tolerance, self.downsampling_factor = float(tolerance), downsampling_factor
        self.max_iterations = max_iterations
        self.use_final_approach_orientation = bool(use_final_approach_orientation)
        self._new_search(np.zeros((1, 1), np.uint8))

    def _new_search(self, costs: NDArray[np.uint8]) -> GridSearch:
        return GridSearch(costs, connectivity=self.connectivity,
                          corner_cutting=self.corner_cutting,
                          cost_travel_multiplier=self.cost_travel_multiplier,
                          allow_unknown=self.allow_unknown, max_iterations=self.max_iterations)

    def _searcher(self, costmap: Costmap) -> GridSearch:
        if self._search is None or self._costmap is not costmap:
            self._search = self._new_search(costmap.costs)
            self._costmap = costmap
        return self._search

    def grid(self, costmap: Costmap) -> Costmap:
        """The costmap the search runs on: ``costmap`` itself, or its downsampled version."""
        f = self.downsampling_factor
        if f == 1:
            return costmap
        if self._coarse is None or self._coarse[0] is not costmap:
            h, w = costmap.costs.shape
            padded = np.zeros((-(-h // f) * f, -(-w // f) * f), dtype=np.uint8)
            padded[:h, :w] = costmap.costs
            coarse = padded.reshape(padded.shape[0] // f, f, padded.shape[1] // f, f).max(
                axis=(1, 3))
            self._coarse = (costmap, Costmap(coarse, costmap.resolution * f, costmap.origin,
                                             costmap.frame_id))
        return self._coarse[1]

    @abstractmethod
    def _run(self, search: GridSearch, start: tuple[int, int],
             goal: tuple[int, int]) -> SearchResult:
        """The planner's search from ``start`` to ``goal`` cells."""

    def create_plan(self, start: msgs.PoseStamped, goal: msgs.PoseStamped,
                    costmap: Costmap) -> PlanResult:
        """Plan from ``start`` to ``goal`` on ``costmap``; see :func:`compute_path_to_pose`."""
        return compute_path_to_pose(start, goal, costmap, planner=self)

    def leg(self, start: tuple[float, float, float], goal: tuple[float, float, float],
            costmap: Costmap, tolerance: float = 0.0) -> tuple[FloatArray, SearchResult]:
        """One leg's points ``(N, 2)`` [m] (none when there is no path) and its search; with
        ``tolerance`` the leg may end near the goal instead (see the class)."""
        grid = self.grid(costmap)
        search = self._searcher(grid)
        first = grid.world_to_cell(*start[:2], what="start")
        last = grid.world_to_cell(*goal[:2], what="goal")
        end = goal[:2]
        enterable = traversable(int(grid.costs[last]), self.allow_unknown)
        result = self._run(search, first, last) if enterable or tolerance <= 0 else None
        if (result is None or not result.found) and tolerance > 0:
            near = self._nearest_reachable(search, grid, first, goal, tolerance)
            if near is not None:
                result, end = self._run(search, first, near), grid.cell_to_world(*near)
            else:
                why = f"no reachable cell within tolerance {tolerance:g} m of the goal"
                return np.zeros((0, 2)), (
                    SearchResult(np.zeros((0, 2), np.int64), math.inf, math.inf, why,
                                 np.zeros(0, np.int32), 1) if result is None
                    else dataclasses.replace(result, reason=f"{result.reason}; {why}"))
        assert result is not None
        if not result.found:
            return np.zeros((0, 2)), result
        inner = [grid.cell_to_world(int(r), int(c)) for r, c in result.cells[1:-1]]
        return np.array([start[:2], *inner, end], dtype=np.float64), result

    def _nearest_reachable(self, search: GridSearch, grid: Costmap, start: tuple[int, int],
                           goal: tuple[float, float, float], tolerance: float
                           ) -> tuple[int, int] | None:
        """The reachable cell nearest ``goal`` with its centre within ``tolerance`` of it in x
        and y (ties: the lower row, then column), or ``None``."""
        reach = search.reachable(start)
        res, (ox, oy) = grid.resolution, grid.origin
        c0 = max(math.floor((goal[0] - tolerance - ox) / res - 0.5), 0)
        c1 = min(math.ceil((goal[0] + tolerance - ox) / res - 0.5), grid.width - 1)
        r0 = max(math.floor((goal[1] - tolerance - oy) / res - 0.5), 0)
        r1 = min(math.ceil((goal[1] + tolerance - oy) / res - 0.5), grid.height - 1)
        if c0 > c1 or r0 > r1:
            return None
        rows, cols = np.mgrid[r0:r1 + 1, c0:c1 + 1]
        dx = ox + (cols + 0.5) * res - goal[0]
        dy = oy + (rows + 0.5) * res - goal[1]
        ok = reach[rows, cols] & (np.abs(dx) <= tolerance + 1e-9) & \
            (np.abs(dy) <= tolerance + 1e-9)
        if not ok.any():
            return None
        d2 = np.where(ok, dx * dx + dy * dy, np.inf)
        k = int(np.argmin(d2))                    # row-major: ties go to the lower row, col
        return int(rows.flat[k]), int(cols.flat[k])


class GridPlanner(_SearchPlanner):
    """A* or Dijkstra on the costmap (Nav2's Smac 2-D / NavFn kind of planner).

    ``use_astar`` picks A* (else Dijkstra, as NavFn's default); ``tolerance``,
    ``downsampling_factor``, ``max_iterations`` and ``use_final_approach_orientation`` as
    Nav2's (see ``_SearchPlanner``; the kit's default tolerance is 0: a goal in an obstacle is
    an error, where NavFn's 0.5 m and Smac's 0.125 m would end the path beside it); the rest
    as :class:`~kit.planning.GridSearch`.
    """

    def __init__(self, *, use_astar: bool = True, connectivity: int = 8,
                 corner_cutting: bool = False, cost_travel_multiplier: float = 2.0,
                 allow_unknown: bool = True, tolerance: float = 0.0,
                 downsampling_factor: int = 1, max_iterations: int | None = None,
                 use_final_approach_orientation: bool = False) -> None:
        super().__init__(connectivity, allow_unknown, corner_cutting, cost_travel_multiplier)
        self._set_options(tolerance, downsampling_factor, max_iterations,
                          use_final_approach_orientation)
        self.use_astar = use_astar

    def _run(self, search: GridSearch, start: tuple[int, int],
             goal: tuple[int, int]) -> SearchResult:
        return search.astar(start, goal) if self.use_astar else search.dijkstra(start, goal)


class ThetaStarPlanner(_SearchPlanner):
    """Theta* with Nav2's parameters: ``how_many_corners`` (4 or 8), ``w_euc_cost``,
    ``w_traversal_cost``, ``allow_unknown``.

    The path between Theta*'s corners has a point every ``resolution`` metres along each
    segment, as Nav2's Theta* planner gives it (``linearInterpolation``): a controller
    following it sees a dense path, as it does behind the other planners. It ends at the goal
    itself, where Nav2's stops one to two cells short of it.
    """

    def __init__(self, *, how_many_corners: int = 8, w_euc_cost: float = 1.0,
                 w_traversal_cost: float = 2.0, allow_unknown: bool = True,
                 use_final_approach_orientation: bool = False) -> None:
        super().__init__(how_many_corners, allow_unknown)
        self._set_options(0.0, 1, None, use_final_approach_orientation)
        for name, value in (("w_euc_cost", w_euc_cost), ("w_traversal_cost", w_traversal_cost)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a non-negative number; got {value!r}")
        self.w_euc_cost, self.w_traversal_cost = w_euc_cost, w_traversal_cost

    def _run(self, search: GridSearch, start: tuple[int, int],
             goal: tuple[int, int]) -> SearchResult:
        return search.theta_star(start, goal, w_euc_cost=self.w_euc_cost,
                                 w_traversal_cost=self.w_traversal_cost)

    def leg(self, start: tuple[float, float, float], goal: tuple[float, float, float],
            costmap: Costmap, tolerance: float = 0.0) -> tuple[FloatArray, SearchResult]:
        corners, result = super().leg(start, goal, costmap, tolerance)
        return interpolate_corners(corners, self.grid(costmap).resolution), result


def interpolate_corners(corners: ArrayLike, spacing: float) -> FloatArray:
    """Nav2 Theta*'s ``linearInterpolation``: each corner, then points ``k · spacing`` along
    the segment to the next (``k = 1 … ⌊length / spacing⌋ − 1``); the last corner closes it.

    >>> interpolate_corners([(0.0, 0.0), (0.35, 0.0), (0.35, 0.2)], 0.1).round(2).tolist()
    [[0.0, 0.0], [0.1, 0.0], [0.2, 0.0], [0.35, 0.0], [0.35, 0.1], [0.35, 0.2]]
    """
    c = np.asarray(corners, dtype=np.float64).reshape(-1, 2)
    if len(c) < 2:
        return c
    out = []
    for a, b in itertools.pairwise(c):
        out.append(a)
        length = float(np.hypot(*(b - a)))
        loops = int(length / spacing)
        if loops > 1:
            k = np.arange(1, loops)[:, None]
            out.extend(a + k * spacing * (b - a) / length)
    out.append(c[-1])
    return np.array(out, dtype=np.float64)


def compute_path_to_pose(start: PoseLike, goal: PoseLike, costmap: Costmap, *,
                         planner: _SearchPlanner | None = None,
                         viapoints: Sequence[PoseLike] = ()) -> PlanResult:
    """Plan a path from ``start`` through ``viapoints`` to ``goal`` on ``costmap``.

    Raises
    ------
    PlanningError
        Start, a viapoint or the goal off the map or in an obstacle, or in another frame
        (``error_code`` 202–206).

    >>> from kit.planning import Costmap
    >>> r = compute_path_to_pose((0.05, 0.05, 0.0), (0.35, 0.05, 0.0),
    ...                          Costmap(np.zeros((2, 4), np.uint8), 0.1))
    >>> r.ok, len(r.path.poses), round(r.path.poses[-1].pose.position.x, 3)
    (True, 4, 0.35)
    """
    begin = time.perf_counter()
    planner = planner if planner is not None else GridPlanner()
    frame = costmap.frame_id
    poses = [_pose(start, frame, "start"),
             *(_pose(v, frame, f"viapoint {i + 1}") for i, v in enumerate(viapoints)),
             _pose(goal, frame, "goal")]
    names = [f"viapoint {i + 1}" for i in range(len(viapoints))] + ["goal"]
    tolerance = planner.tolerance
    for pose, name in zip(poses, ["start", *names], strict=True):   # all checked first
        _check(costmap, pose, name, planner.allow_unknown,
               occupied_ok=name == "goal" and tolerance > 0)
    pieces: list[FloatArray] = []
    searches: list[SearchResult] = []
    stamp = start.header.stamp if isinstance(start, msgs.PoseStamped) else msgs.Time()
    for a, b, name in zip(poses[:-1], poses[1:], names, strict=True):
        points, search = planner.leg(a, b, costmap, tolerance if name == "goal" else 0.0)
        searches.append(search)
        if not search.found:
            return PlanResult(msgs.Path(msgs.Header(stamp, frame), ()),
                              time.perf_counter() - begin, NO_VALID_PATH,
                              f"{name}: {search.reason}", tuple(searches))
        pieces.append(points if not pieces else points[1:])
    path = points_to_path(np.vstack(pieces), frame, stamp,
                          final_yaw=None if planner.use_final_approach_orientation
                          else poses[-1][2])
    return PlanResult(path, time.perf_counter() - begin, NONE, "", tuple(searches))
