"""A dynamic-window local planner in the design of Nav2's DWB controller.

Every control period (1 / ``controller_frequency``):

1. **The dynamic window** — the velocities reachable from the current ``(v, ω)`` within
   ``sim_time`` at the robot's acceleration limits (``acc_lim_*``, ``decel_lim_*``), clipped
   to ``[min_vel_x, max_vel_x]`` and ``±max_vel_theta``; ``vx_samples × vtheta_samples`` of
   them (DWB's standard generator); with Nav2's kinematic limits set (``max_speed_xy``,
   ``min_speed_xy`` with ``min_speed_theta``) the samples outside them, and standing still,
   are invalid.
2. **Forward simulation** — each sample driven for ``sim_time`` seconds, the velocity ramping
   towards it at the acceleration limits, in steps of at most ``linear_granularity`` metres
   and ``angular_granularity`` radians.
3. **Critics** — each trajectory scored by the critics listed in ``critics`` (Nav2's names;
   only those score or rule trajectories out), each with its ``scale``:
   ``BaseObstacle`` (the inflation costs under the trajectory, summed — ``sum_scores``, the
   kit's default — or the last pose's, Nav2's; invalid when the footprint meets a lethal
   cell), ``PathDist`` and ``GoalDist`` (distance of the last pose to the path and to the
   local goal, in cells), ``PathAlign`` and ``GoalAlign`` (the same for a point
   ``forward_point_distance`` — each critic its own — ahead of the last pose, so the robot
   faces along the path; off when the goal is within that distance plus
   ``xy_goal_tolerance``: the kit's rule — Nav2 turns PathAlign off within
   ``forward_point_distance`` and never GoalAlign, whose point it sets
   ``forward_point_distance`` beyond the goal; the kit's point ahead of the robot could only
   overshoot the path's end and hold a robot just outside the tolerance still),
   ``RotateToGoal`` (once the robot has come within
   ``xy_goal_tolerance`` of the goal: first only samples slower than now, scored by
   ``slowing_factor`` · v² and the heading error they end with — or have at ``lookahead_time``
   — ; once slower than ``trans_stopped_velocity`` only turns in place, scored by that error)
   and ``Oscillation`` (a trajectory that flips the sign of a command it flipped before,
   without having moved ``oscillation_reset_dist``, is invalid).
4. **The best** — the valid trajectory with the lowest weighted sum; none valid raises
   :class:`~kit.navigation.ControlError` ("no valid trajectory").

Parameter names and defaults are Nav2's; the kit's DWB differs from Nav2's in these ways,
stated:

- all trajectories have the same number of steps (that of the fastest sample);
- the distance grids are Euclidean distance transforms (scipy), where DWB's MapGrid
  propagates Manhattan distances over every cell (``propogateManhattanDistances``);
- every critic weighs its ``scale``: Nav2 weighs the four that score distances in cells
  (PathDist, GoalDist, PathAlign, GoalAlign) ``scale · resolution / 2`` (``getScale``), so
  with a Nav2 file's scales the kit's path and goal critics weigh 2 / resolution times more
  against BaseObstacle and RotateToGoal than Nav2's (40 times at 5 cm cells);
- standing still is a valid sample unless a kinematic limit is set; Nav2 never allows it,
  so where only standing still is left it reports no valid trajectory and recovers;
- BaseObstacle rules out a trajectory whose footprint meets a lethal cell (Nav2's
  BaseObstacle checks the centre's cost, its ObstacleFootprint the outline);
- the local plan runs from the closest point of the path forwards, where Nav2's starts up to
  ``prune_distance`` behind the robot.

The kit's scenarios are tuned to these; taking Nav2's weights and its standing-still rule
alone (measured: the office tour's first goal with the Uiabot) made the robot stall near
goals among people (67 s instead of 43 s, with recoveries), so they wait for a re-tuning.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from kit import geometry
from kit.navigation._costmap import footprint_costs, outline_points
from kit.navigation._path import ControlError, check_path, closest_index, require_positive
from kit.planning import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, Costmap
from kit.robots import RobotDescription

__all__ = ["CRITICS", "DwbController", "DwbParameters", "Trajectories", "dynamic_window"]

FloatArray = NDArray[np.float64]

CRITICS = ("BaseObstacle", "PathAlign", "PathDist", "GoalAlign", "GoalDist", "RotateToGoal",
           "Oscillation")
"""DWB's critics as the kit scores them, in Nav2's default order."""


@dataclass(frozen=True)
class DwbParameters:
    """Nav2's DWB parameters (``FollowPath`` with ``dwb_core::DWBLocalPlanner``)."""

    min_vel_x: float = 0.0
    max_vel_x: float = 0.5
    max_vel_theta: float = 1.0
    acc_lim_x: float = 2.5
    decel_lim_x: float = -2.5
    acc_lim_theta: float = 3.2
    decel_lim_theta: float = -3.2
    vx_samples: int = 20
    vtheta_samples: int = 20
    sim_time: float = 1.7
    linear_granularity: float = 0.05
    angular_granularity: float = 0.025
    controller_frequency: float = 20.0
    forward_point_distance: float = 0.325
    """PathAlign's ``forward_point_distance`` [m]."""
    goal_align_forward_point_distance: float = 0.325
    """GoalAlign's ``forward_point_distance`` [m] (Nav2: ``GoalAlign.forward_point_distance``)."""
    xy_goal_tolerance: float = 0.25
    trans_stopped_velocity: float = 0.25
    prune_distance: float = 2.0
    oscillation_reset_dist: float = 0.05
    oscillation_reset_angle: float = 0.2
    slowing_factor: float = 5.0
    """RotateToGoal's ``slowing_factor``: the weight of v² while arriving."""
    rotate_lookahead_time: float = -1.0
    """RotateToGoal's ``lookahead_time`` [s]: the heading error is taken where the trajectory
    is at that time (interpolated); negative: at its end."""
    sum_scores: bool = True
    """BaseObstacle's ``sum_scores``: the sum of the costs under the trajectory (the kit's
    default); ``False`` the cost under its last pose (Nav2's default)."""
    max_speed_xy: float = -1.0
    """A sample faster than this is invalid (Nav2's KinematicParameters); negative: no limit.
    Nav2's default, 0, would forbid every motion: Nav2's files set it."""
    min_speed_xy: float = -1.0
    min_speed_theta: float = -1.0
    """A sample slower than ``min_speed_xy`` that also turns slower than ``min_speed_theta``
    is invalid (Nav2's KinematicParameters), as is standing still (both 0) whenever either
    is set (not negative)."""
    critics: tuple[str, ...] = CRITICS
    """The critics that score (and may rule out) trajectories, by Nav2's names."""
    scales: dict[str, float] = field(default_factory=lambda: {
        "BaseObstacle": 0.02, "PathAlign": 32.0, "PathDist": 32.0, "GoalAlign": 24.0,
        "GoalDist": 24.0, "RotateToGoal": 32.0, "Oscillation": 1.0})

    def __post_init__(self) -> None:
        require_positive(self, ("max_vel_x", "max_vel_theta", "acc_lim_x", "acc_lim_theta",
                                "sim_time", "linear_granularity", "angular_granularity",
                                "controller_frequency"))
        if self.decel_lim_x >= 0 or self.decel_lim_theta >= 0:
            raise ValueError("decel_lim_x and decel_lim_theta are negative (Nav2's sign)")
        if self.vx_samples < 1 or self.vtheta_samples < 1:
            raise ValueError("vx_samples and vtheta_samples must be at least 1")
        unknown = (set(self.scales) | set(self.critics)) - set(CRITICS)
        if unknown:
            raise ValueError(f"unknown critics {sorted(unknown)}; the kit's are {CRITICS}")

    @classmethod
    def for_robot(cls, robot: RobotDescription, **overrides: object) -> DwbParameters:
        """Defaults with the robot's speed and acceleration limits (``hardware/robots``)."""
        a = robot.max_linear_acceleration
        base = cls(max_vel_x=robot.cruise_velocity,
                   max_vel_theta=min(1.0, robot.max_angular_velocity),
                   acc_lim_x=a, decel_lim_x=-a)
        return replace(base, **overrides)  # type: ignore[arg-type]


def _invalid_speed(vx: FloatArray, vth: FloatArray, p: DwbParameters) -> NDArray[np.bool_]:
    """Nav2's ``isValidSpeed`` (1e-5 of slack): faster than ``max_speed_xy``, or slower than
    ``min_speed_xy`` while turning slower than ``min_speed_theta``, or standing still — each
    only when its limit is set (not negative)."""
    eps = 1e-5
    bad = np.zeros(len(vx), dtype=bool)
    if p.max_speed_xy >= 0:
        bad |= vx * vx > p.max_speed_xy ** 2 + eps
    if p.min_speed_xy >= 0 and p.min_speed_theta >= 0:
        bad |= (vx * vx + eps < p.min_speed_xy ** 2) & (np.abs(vth) + eps < p.min_speed_theta)
    if p.max_speed_xy >= 0 or p.min_speed_xy >= 0:
        bad |= (vx == 0.0) & (vth == 0.0)
    return bad


def _yaw_at(poses: FloatArray, yaw0: float, sim_time: float, t: float) -> FloatArray:
    """Each trajectory's heading at time ``t`` [s] (Nav2's ``projectPose``: linear between
    the poses around it, the start at 0 s; the last pose beyond the end)."""
    steps = poses.shape[1]
    dt = sim_time / steps
    times = np.arange(steps + 1) * dt
    yaws = np.concatenate([np.full((poses.shape[0], 1), yaw0), poses[:, :, 2]], axis=1)
    if t <= 0.0:
        return yaws[:, 0]
    if t >= times[-1]:
        return yaws[:, -1]
    i = min(int(t / dt), steps - 1)
    ratio = (t - times[i]) / dt
    return yaws[:, i] * (1.0 - ratio) + yaws[:, i + 1] * ratio


def dynamic_window(velocity: ArrayLike, p: DwbParameters) -> tuple[FloatArray, FloatArray]:
    """The sampled target velocities: ``(vx (S,), vθ (S,))``, S = ``vx_samples ×
    vtheta_samples``.

    As DWB's standard generator: the window is what the accelerations reach from the current
    velocity within ``sim_time`` (``acc_lim`` up, ``decel_lim`` down), clipped to the limits;
    each trajectory then ramps towards its target at those accelerations.

    >>> vx, vth = dynamic_window((0.2, 0.0), DwbParameters(vx_samples=3, vtheta_samples=1,
    ...                                                    acc_lim_x=0.1, decel_lim_x=-0.1))
    >>> vx.round(3).tolist(), vth.tolist()
    ([0.03, 0.2, 0.37], [0.0, 0.0, 0.0])
    """
    v, w = (float(x) for x in np.asarray(velocity, dtype=float)[:2])
    span = p.sim_time
    lo_v = max(p.min_vel_x, v + p.decel_lim_x * span)
    hi_v = min(p.max_vel_x, v + p.acc_lim_x * span)
    if lo_v > hi_v:                       # outside the limits already: come back into them
        lo_v = hi_v = min(max(v, p.min_vel_x), p.max_vel_x)
    lo_w = max(-p.max_vel_theta, w + p.decel_lim_theta * span)
    hi_w = min(p.max_vel_theta, w + p.acc_lim_theta * span)
    if lo_w > hi_w:
        lo_w = hi_w = min(max(w, -p.max_vel_theta), p.max_vel_theta)
    vx = np.linspace(lo_v, hi_v, p.vx_samples) if p.vx_samples > 1 else np.array([hi_v])
    vth = np.linspace(lo_w, hi_w, p.vtheta_samples) if p.vtheta_samples > 1 else \
        np.array([0.5 * (lo_w + hi_w)])
    if p.vtheta_samples > 1 and lo_w < 0.0 < hi_w:
        vth[np.argmin(np.abs(vth))] = 0.0      # driving straight is always a candidate
    gx, gth = np.meshgrid(vx, vth, indexing="ij")
    return gx.ravel(), gth.ravel()


@dataclass(frozen=True)
class Trajectories:
    """Sampled trajectories: ``velocities`` (S, 2) [m/s, rad/s], ``poses`` (S, T, 3), the
    critics' ``scores`` (name → (S,)), ``valid`` (S,) and ``total`` (S,) (inf if invalid)."""

    velocities: FloatArray
    poses: FloatArray
    scores: dict[str, FloatArray]
    valid: NDArray[np.bool_]
    total: FloatArray
    reasons: dict[str, int]


class DwbController:
    """Nav2's DWB local planner over a local costmap.

    ``set_plan(path, goal_yaw)`` then, each period, ``compute_velocity_commands(pose,
    velocity, costmap)`` → ``(v, ω)``; the last scored :class:`Trajectories` stay in
    ``last``.

    ``window(v, w, sim_time, max_v, max_w, acc_v, acc_w, n_v, n_w) -> (S, 2)`` and
    ``rollout(pose, v, w, sim_time, steps) -> (steps, 3)``, when given, take the place of
    :func:`dynamic_window` and of the ramped forward simulation (each sample then held
    constant over ``sim_time``) — a student's functions (Lab 10) scored by the critics; the
    window is opened with ``acc_lim_x`` both ways, from ``min_vel_x`` = 0.
    """

    def __init__(self, params: DwbParameters | None = None,
                 footprint: ArrayLike | None = None, circumscribed_cost: int = 0, *,
                 window: Callable[..., ArrayLike] | None = None,
                 rollout: Callable[..., ArrayLike] | None = None) -> None:
        self.params = params or DwbParameters()
        self.window, self.rollout = window, rollout
        self.circumscribed_cost = int(circumscribed_cost)
        """Centres cheaper than this skip the footprint check (0: check every pose)."""
        self.footprint = (np.asarray(footprint, dtype=np.float64) if footprint is not None
                          else np.array([[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.2, -0.2]]))
        self.path: FloatArray = np.zeros((0, 2))
        self.goal_yaw: float | None = None
        self._index = 0
        self._outline: FloatArray | None = None
        self._outline_res = 0.0
        self.last: Trajectories | None = None
        self._flips: dict[str, int] = {}
        self._last_sign = (0, 0)
        self._since: FloatArray = np.zeros(3)
        self._in_window = self._rotating = False

    def set_plan(self, path: ArrayLike, goal_yaw: float | None = None) -> None:
        """A new global path ((N, 2) [m] in the costmap's frame) and the goal's heading; the
        critics start afresh, as Nav2's DWB resets them in ``setPlan`` (every replan)."""
        self.path = check_path(path)
        self.goal_yaw = goal_yaw
        self._index = 0
        self.reset()

    def reset(self) -> None:
        """Forget the oscillation history and RotateToGoal's state (Nav2's critics'
        ``reset``)."""
        self._flips, self._last_sign = {}, (0, 0)
        self._in_window = self._rotating = False

    # ------------------------------------------------------------------ trajectories
    def simulate(self, pose: FloatArray, vx: FloatArray, vth: FloatArray,
                 velocity: ArrayLike = (0.0, 0.0)) -> FloatArray:
        """Poses (S, T, 3) of each sample driven for ``sim_time`` from ``pose``: the velocity
        ramps from ``velocity`` towards the sample at the acceleration limits, the pose
        integrated step by step (Euler, as DWB's generator)."""
        p = self.params
        v0, w0 = (float(x) for x in np.asarray(velocity, dtype=float)[:2])
        steps = self.steps(vx, vth)
        dt = p.sim_time / steps
        k = np.arange(1, steps + 1) * dt
        v = v0 + np.clip((vx - v0)[:, None], p.decel_lim_x * k, p.acc_lim_x * k)
        w = w0 + np.clip((vth - w0)[:, None], p.decel_lim_theta * k, p.acc_lim_theta * k)
        th = pose[2] + np.cumsum(w * dt, axis=1)
        heading = np.concatenate([np.full((len(vx), 1), pose[2]), th[:, :-1]], axis=1)
        x = pose[0] + np.cumsum(v * np.cos(heading) * dt, axis=1)
        y = pose[1] + np.cumsum(v * np.sin(heading) * dt, axis=1)
        return np.stack([x, y, th], axis=-1)

    def steps(self, vx: FloatArray, vth: FloatArray) -> int:
        """Steps of every trajectory: the fastest sample's, at most ``linear_granularity``
        metres and ``angular_granularity`` radians each."""
        p = self.params
        reach = max(float(np.max(np.abs(vx))) * p.sim_time / p.linear_granularity,
                    float(np.max(np.abs(vth))) * p.sim_time / p.angular_granularity, 1.0)
        return math.ceil(reach)

    def samples(self, pose: FloatArray, velocity: ArrayLike
                ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(vx (S,), vθ (S,), poses (S, T, 3))``: the window's samples and their
        trajectories (the ``window`` and ``rollout`` given, else the kit's)."""
        p = self.params
        if self.window is None:
            vx, vth = dynamic_window(velocity, p)
        else:
            v, w = (float(x) for x in np.asarray(velocity, dtype=float)[:2])
            rows = np.asarray(self.window(v, w, p.sim_time, p.max_vel_x, p.max_vel_theta,
                                          p.acc_lim_x, p.acc_lim_theta, p.vx_samples,
                                          p.vtheta_samples), dtype=np.float64).reshape(-1, 2)
            vx, vth = rows[:, 0].copy(), rows[:, 1].copy()
        if self.rollout is None:
            return vx, vth, self.simulate(pose, vx, vth, velocity)
        steps = self.steps(vx, vth)
        start = (float(pose[0]), float(pose[1]), float(pose[2]))
        poses = np.stack([np.asarray(self.rollout(start, float(a), float(b), p.sim_time, steps),
                                     dtype=np.float64).reshape(steps, 3)
                          for a, b in zip(vx, vth, strict=True)])
        return vx, vth, poses

    # ------------------------------------------------------------------ the local plan
    def local_plan(self, pose: FloatArray, costmap: Costmap) -> FloatArray:
        """The global path from the point closest to the robot, up to ``prune_distance``
        along it and no further than the costmap's edge."""
        self._index = closest_index(self.path, pose, self._index, 2.0)
        rest = self.path[self._index:]
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(rest, axis=0).T))])
        rest = rest[along <= self.params.prune_distance + 1e-9]
        x0, y0 = costmap.origin
        x1 = x0 + costmap.width * costmap.resolution
        y1 = y0 + costmap.height * costmap.resolution
        inside = (rest[:, 0] >= x0) & (rest[:, 0] < x1) & (rest[:, 1] >= y0) & \
            (rest[:, 1] < y1)
        first_out = np.flatnonzero(~inside)
        return rest[:first_out[0]] if len(first_out) else rest

    def _distance_grid(self, costmap: Costmap, points: FloatArray) -> FloatArray:
        """Distance [cells] from each cell to the nearest of ``points``; lethal cells and
        unknown ones far (the window's diagonal)."""
        res = costmap.resolution
        seed = np.ones(costmap.costs.shape, dtype=bool)
        cols = np.floor((points[:, 0] - costmap.origin[0]) / res).astype(int)
        rows = np.floor((points[:, 1] - costmap.origin[1]) / res).astype(int)
        ok = (rows >= 0) & (rows < costmap.height) & (cols >= 0) & (cols < costmap.width)
        seed[rows[ok], cols[ok]] = False
        if seed.all():
            raise ControlError("the path leaves the local costmap before it starts")
        dist = ndimage.distance_transform_edt(seed)
        dist[costmap.costs >= LETHAL_OBSTACLE] = float(np.hypot(costmap.height, costmap.width))
        return np.asarray(dist, dtype=np.float64)

    @staticmethod
    def _at(grid: FloatArray, costmap: Costmap, xy: FloatArray) -> FloatArray:
        res = costmap.resolution
        cols = np.floor((xy[..., 0] - costmap.origin[0]) / res).astype(int)
        rows = np.floor((xy[..., 1] - costmap.origin[1]) / res).astype(int)
        ok = (rows >= 0) & (rows < grid.shape[0]) & (cols >= 0) & (cols < grid.shape[1])
        out = np.full(xy.shape[:-1], float(np.hypot(grid.shape[0], grid.shape[1])))
        out[ok] = grid[rows[ok], cols[ok]]
        return out

    # ------------------------------------------------------------------ scoring
    def score(self, pose: FloatArray, velocity: ArrayLike, costmap: Costmap) -> Trajectories:
        """Sample, simulate and score every trajectory (no command chosen)."""
        p = self.params
        if len(self.path) == 0:
            raise ControlError("no path to follow")
        vx, vth, poses = self.samples(pose, velocity)
        if self._outline is None or self._outline_res != costmap.resolution:
            self._outline = outline_points(self.footprint, costmap.resolution)
            self._outline_res = costmap.resolution
        centre, edge = footprint_costs(costmap, poses, self._outline,
                                       self.circumscribed_cost)
        reasons: dict[str, int] = {}
        critics = set(p.critics)
        hit = np.any((edge >= LETHAL_OBSTACLE) | (centre >= INSCRIBED_INFLATED_OBSTACLE),
                     axis=1) if "BaseObstacle" in critics else np.zeros(len(vx), dtype=bool)
        reasons["collision"] = int(hit.sum())
        slow = _invalid_speed(vx, vth, p)
        reasons["speed limits"] = int(slow.sum())
        scores: dict[str, FloatArray] = {"BaseObstacle": (
            centre.astype(float).sum(axis=1) if p.sum_scores else centre[:, -1].astype(float))}
        local = self.local_plan(pose, costmap)
        goal = self.path[-1]
        v_now = float(np.asarray(velocity, dtype=float)[0])
        self._in_window = self._in_window or \
            math.hypot(goal[0] - pose[0], goal[1] - pose[1]) <= p.xy_goal_tolerance
        self._rotating = self._rotating or (self._in_window and
                                            abs(v_now) <= p.trans_stopped_velocity)
        end = poses[:, -1, :]
        ahead = end[:, :2] + p.forward_point_distance * np.column_stack(
            [np.cos(end[:, 2]), np.sin(end[:, 2])])
        path_grid = self._distance_grid(costmap, local)
        goal_grid = self._distance_grid(costmap, local[-1:])
        to_goal = math.hypot(goal[0] - pose[0], goal[1] - pose[1])
        scores["PathDist"] = self._at(path_grid, costmap, end[:, :2])
        scores["GoalDist"] = self._at(goal_grid, costmap, end[:, :2])
        zero = np.zeros(len(vx))
        scores["PathAlign"] = zero if to_goal <= p.forward_point_distance + \
            p.xy_goal_tolerance else self._at(path_grid, costmap, ahead)
        if p.goal_align_forward_point_distance != p.forward_point_distance:
            ahead = end[:, :2] + p.goal_align_forward_point_distance * np.column_stack(
                [np.cos(end[:, 2]), np.sin(end[:, 2])])
        scores["GoalAlign"] = zero if to_goal <= p.goal_align_forward_point_distance + \
            p.xy_goal_tolerance else self._at(goal_grid, costmap, ahead)
        valid = ~hit & ~slow
        if self._in_window and "RotateToGoal" in critics:
            target = self.goal_yaw if self.goal_yaw is not None else float(pose[2])
            yaw = end[:, 2] if p.rotate_lookahead_time < 0 else \
                _yaw_at(poses, float(pose[2]), p.sim_time, p.rotate_lookahead_time)
            rotation = np.abs(geometry.wrap_angle(target - yaw))
            if self._rotating:                 # at the goal: turning in place only
                moving = np.abs(vx) > 0.0
                scores["RotateToGoal"] = rotation
            else:                              # arriving: slow down, whatever else
                moving = vx ** 2 >= v_now ** 2
                scores["RotateToGoal"] = p.slowing_factor * vx ** 2 + rotation
            valid &= ~moving
            reasons["moving near the goal"] = int(moving.sum())
        else:
            scores["RotateToGoal"] = zero
        if "Oscillation" in critics:
            flips = self._oscillating(vx, vth)
            valid &= ~flips
            reasons["oscillation"] = int(flips.sum())
        scores["Oscillation"] = zero
        total = sum((p.scales.get(name, 0.0) * s for name, s in scores.items()
                     if name in critics), start=np.zeros(len(vx)))
        total = np.where(valid, total, np.inf)
        return Trajectories(np.column_stack([vx, vth]), poses, scores, valid, total, reasons)

    def _oscillating(self, vx: FloatArray, vth: FloatArray) -> NDArray[np.bool_]:
        """Samples that would flip a sign already flipped since the robot last moved on."""
        bad = np.zeros(len(vx), dtype=bool)
        sx, sw = self._last_sign
        if self._flips.get("x") and sx:
            bad |= np.sign(vx) == -sx
        if self._flips.get("theta") and sw:
            bad |= (np.sign(vth) == -sw) & (np.abs(vx) < 1e-3)
        return bad

    def _remember(self, pose: FloatArray, v: float, w: float) -> None:
        sx = int(np.sign(v)) if abs(v) > 1e-3 else 0
        sw = int(np.sign(w)) if abs(w) > 1e-3 else 0
        last_x, last_w = self._last_sign
        if sx and last_x and sx != last_x:
            self._flips["x"] = 1
        if sw and last_w and sw != last_w and abs(v) < 1e-3:
            self._flips["theta"] = 1
        moved = math.hypot(pose[0] - self._since[0], pose[1] - self._since[1])
        turned = abs(float(geometry.wrap_angle(pose[2] - self._since[2])))
        if moved > self.params.oscillation_reset_dist or \
                (turned > self.params.oscillation_reset_angle and abs(v) > 1e-3):
            self._flips = {}
            self._since = pose.copy()
        self._last_sign = (sx or last_x, sw or last_w)

    def compute_velocity_commands(self, pose: ArrayLike, velocity: ArrayLike,
                                  costmap: Costmap) -> tuple[float, float]:
        """The best ``(v, ω)`` [m/s, rad/s]; :class:`ControlError` when none is valid."""
        pose_ = geometry.check_pose(pose, "pose")
        result = self.score(pose_, velocity, costmap)
        self.last = result
        if not np.any(result.valid):
            why = ", ".join(f"{n} {k}" for k, n in result.reasons.items() if n)
            raise ControlError(f"no valid trajectory among {len(result.valid)} ({why})")
        best = int(np.argmin(result.total))
        v, w = (float(x) for x in result.velocities[best])
        self._remember(pose_, v, w)
        return v, w
