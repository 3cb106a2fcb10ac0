"""A navigator in the shape of Nav2's default behaviour tree
(``navigate_to_pose_w_replanning_and_recovery.xml``)::

    RecoveryNode (number_of_retries = 6)
      PipelineSequence
        RateController 1 Hz:  RecoveryNode(1) [ComputePathToPose, ClearGlobalCostmap]
        RecoveryNode(1) [FollowPath, ClearLocalCostmap]
      RoundRobin [ClearBothCostmaps, Spin 1.57, Wait 5 s, BackUp 0.30 m at 0.05 m/s]

Ticked at the controller's rate with the robot's pose in the map frame and its velocity, it
replans once a second on the global costmap, follows the path with the local controller on the
local costmap, and when planning or following fails twice in a row it runs the next recovery
(a recovery that fails hands over to the next one in the round, as Nav2's RoundRobin does).
After ``number_of_retries`` recoveries, or a round in which every recovery failed, it gives up
with the reason. ``NavigateThroughPoses`` plans through every remaining goal and drops those
the robot has passed (Nav2's ``RemovePassedGoals``, radius 0.5 m).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs
from kit.navigation._behaviors import (
    FAILED,
    RUNNING,
    SUCCEEDED,
    BackUp,
    Behavior,
    GoalChecker,
    ProgressChecker,
    Spin,
    Unavailable,
    Wait,
)
from kit.navigation._config import NavigationConfig, NavigatorParameters
from kit.navigation._dwb import DwbController
from kit.navigation._path import ControlError
from kit.navigation._pursuit import RegulatedPurePursuit
from kit.planning import (
    INSCRIBED_INFLATED_OBSTACLE,
    Costmap,
    CostmapParams,
    KeepoutFilterParams,
    LayeredCostmap,
    PlanningError,
    StaticLayerParams,
    compute_path_to_pose,
    path_to_points,
)
from kit.robots import RobotDescription

__all__ = ["Controller", "NavigationEvent", "Navigator"]

FloatArray = NDArray[np.float64]


class Controller(Protocol):
    """What the controller server runs: DWB, Regulated Pure Pursuit, or a student's."""

    def set_plan(self, path: ArrayLike, goal_yaw: float | None = None) -> None: ...

    def compute_velocity_commands(self, pose: ArrayLike, velocity: ArrayLike,
                                  costmap: Costmap) -> tuple[float, float]: ...


@dataclass
class NavigationEvent:
    """One thing the navigator did: ``(time, kind, detail)`` — plan, plan failed, control
    failed, recovery started / ended, goal reached, failed."""

    time: float
    kind: str
    detail: str = ""


@dataclass
class _State:
    goals: list[FloatArray] = field(default_factory=list)
    status: str = SUCCEEDED
    reason: str = ""
    next_plan: float = 0.0
    plan_failures: int = 0
    control_failures: int = 0
    recoveries: int = 0
    round_failed: int = 0
    behavior: Behavior | None = None
    next_behavior: int = 0
    last_failure: str = ""


class Navigator:
    """Nav2's ``NavigateToPose`` / ``NavigateThroughPoses`` with replanning and recovery.

    Parameters
    ----------
    grid
        The map (``nav_msgs/OccupancyGrid``) the global costmap and planner use.
    robot
        The robot (its footprint and limits), e.g. ``kit.robots.load("uiabot")``.
    controller
        ``"rpp"``, ``"dwb"`` (default: the configuration's, else ``"rpp"``), or an object with
        ``set_plan`` and ``compute_velocity_commands`` (a student's controller).
    params
        The kit's navigator parameters, for the kit's own configuration
        (:meth:`NavigationConfig.for_robot`).
    keepout
        A keep-out mask for the global costmap (Nav2's keep-out filter); a configuration with
        no keep-out filter gets the kit's, right after the static layer, so that the zone is
        inflated like a wall.
    config
        The whole configuration, e.g. from a Nav2 parameter file
        (:func:`~kit.navigation.load_nav2_params`).
    """

    def __init__(self, grid: msgs.OccupancyGrid, robot: RobotDescription,
                 controller: str | Controller | None = None,
                 params: NavigatorParameters | None = None,
                 keepout: msgs.OccupancyGrid | None = None, *,
                 config: NavigationConfig | None = None) -> None:
        if config is None:
            name = controller if isinstance(controller, str) else "rpp"
            if name not in ("rpp", "dwb"):
                raise ValueError(f"controller is 'dwb', 'rpp' or a controller object; got "
                                 f"{controller!r}")
            config = NavigationConfig.for_robot(robot, name, params)
        elif params is not None:
            raise ValueError("give the navigator's parameters in config or in params, not both")
        elif isinstance(controller, str):
            if controller not in ("rpp", "dwb"):
                raise ValueError(f"controller is 'dwb', 'rpp' or a controller object; got "
                                 f"{controller!r}")
            config = config.with_controller(controller)
        self.config = config
        self.params = p = config.navigator
        self.robot = robot
        global_params = config.global_costmap
        if keepout is not None and not any(isinstance(layer, KeepoutFilterParams) for layer in
                                           (*global_params.layers, *global_params.filters)):
            global_params = _with_keepout(global_params)
        self.global_costmap = LayeredCostmap(global_params, grid)
        self.global_costmap.set_keepout_mask(keepout)
        self.local_costmap = LayeredCostmap(config.local_costmap, grid)
        footprint = self.local_costmap.footprint
        self.footprint = footprint
        self.planner = config.planner.make()
        if not isinstance(controller, (str, type(None))):
            self.controller: Controller = controller
        elif config.controller == "dwb":
            self.controller = DwbController(config.dwb, footprint,
                                            self.local_costmap.circumscribed_cost)
        else:
            self.controller = RegulatedPurePursuit(config.rpp, footprint)
        self.progress = ProgressChecker(p.required_movement_radius, p.movement_time_allowance,
                                        p.required_movement_angle)
        self.goal_checker = GoalChecker(p.xy_goal_tolerance, p.yaw_goal_tolerance, p.stateful,
                                        p.trans_stopped_velocity if p.goal_checker == "stopped"
                                        else None, p.rot_stopped_velocity)
        if hasattr(self.controller, "goal_dist_tol"):   # Nav2: getTolerances, every cycle
            self.controller.goal_dist_tol = p.xy_goal_tolerance
        fp, b = footprint, config.behaviors
        ahead, allowance = b.simulate_ahead_time, b.time_allowance
        self.behaviors: list[Behavior | None] = [
            None,                                    # clear both costmaps
            Spin(spin_dist=b.spin_dist, max_rotational_vel=b.max_rotational_vel,
                 min_rotational_vel=b.min_rotational_vel,
                 rotational_acc_lim=b.rotational_acc_lim, footprint=fp,
                 simulate_ahead_time=ahead, time_allowance=allowance),
            Wait(wait_duration=b.wait_duration, footprint=fp, simulate_ahead_time=ahead,
                 time_allowance=allowance),
            BackUp(backup_dist=b.backup_dist, backup_speed=b.backup_speed, footprint=fp,
                   simulate_ahead_time=ahead, time_allowance=allowance)]
        for i, behavior in enumerate(self.behaviors):
            if behavior is not None and behavior.name in b.unavailable:
                self.behaviors[i] = Unavailable(behavior.name)
        self.state = _State()
        self.events: list[NavigationEvent] = []
        self.path: FloatArray = np.zeros((0, 2))
        self._local: Costmap | None = None
        self._local_due = 0.0
        self._blind = False
        """True from a clearing of the local costmap until the next scan: no command but
        stop (a cleared costmap shows no obstacle at all)."""
        self._last_valid = 0.0

    # ------------------------------------------------------------------ goals
    def navigate_to_pose(self, goal: ArrayLike, time: float = 0.0) -> None:
        """Start for one goal ``(x, y, yaw)`` in the map frame."""
        self.navigate_through_poses([goal], time)

    def navigate_through_poses(self, goals: Sequence[ArrayLike], time: float = 0.0) -> None:
        """Start for goals visited in order, the last one with its heading."""
        if len(goals) == 0:
            raise ValueError("navigate_through_poses needs at least one goal")
        checked = [geometry.check_pose(g, f"goal {i + 1}").copy() for i, g in enumerate(goals)]
        self.state = _State(goals=checked, status=RUNNING, next_plan=float(time))
        self._last_valid = float(time)
        self.progress.reset()
        self.goal_checker.reset()
        if hasattr(self.controller, "reset"):
            self.controller.reset()
        self.events.append(NavigationEvent(time, "goal", f"{len(checked)} pose(s)"))

    @property
    def status(self) -> str:
        """``RUNNING``, ``SUCCEEDED`` or ``FAILED``."""
        return self.state.status

    @property
    def reason(self) -> str:
        """Why navigation failed ("" otherwise)."""
        return self.state.reason

    # ------------------------------------------------------------------ sensing
    def update_map(self, grid: msgs.OccupancyGrid) -> None:
        """A new map for the global costmap's static layer (SLAM's ``/map``, every few
        seconds while navigating and mapping); the next plan uses it. The local costmap keeps
        the map it was given (none, in effect, when that was unknown space: Nav2's default
        local costmap has no static layer): a person SLAM mapped as a wall while standing in
        a doorway must not hold the controller back once the lidar sees the doorway clear."""
        self.global_costmap.set_map(grid)

    def on_scan(self, scan: msgs.LaserScan, laser_pose: ArrayLike, robot_pose: ArrayLike
                ) -> None:
        """Mark and clear both costmaps with a scan taken at ``laser_pose`` (map frame)."""
        self.global_costmap.update_scan(scan, laser_pose)
        self.local_costmap.update_scan(scan, laser_pose, np.asarray(robot_pose)[:2])
        self._local = None                       # rebuilt at the next tick
        self._blind = False

    def on_points(self, points: ArrayLike, sensor: ArrayLike, robot_pose: ArrayLike) -> None:
        """Mark and clear both costmaps with a scan's returns already in the map frame
        ((N, 2) [m], e.g. de-skewed beam by beam), seen from ``sensor`` (x, y)."""
        s = (float(np.asarray(sensor)[0]), float(np.asarray(sensor)[1]))
        self.global_costmap.add_points(points, s)
        self.local_costmap.update_points(points, s, np.asarray(robot_pose)[:2])
        self._local, self._blind = None, False

    def local_costmap_now(self, time: float, pose: FloatArray) -> Costmap:
        if self._local is None or time >= self._local_due:
            self._local = self.local_costmap.update(pose)
            self._local_due = time + 1.0 / self.params.local_update_frequency
        return self._local

    # ------------------------------------------------------------------ ticking
    def tick(self, time: float, pose: ArrayLike, velocity: ArrayLike = (0.0, 0.0)
             ) -> tuple[float, float]:
        """One controller period: the command ``(v, ω)`` [m/s, rad/s]."""
        s = self.state
        if s.status != RUNNING:
            return 0.0, 0.0
        pose_ = geometry.check_pose(pose, "pose")
        self._remove_passed_goals(pose_)
        velocity = self._thresholded(velocity)
        if self.goal_checker.is_goal_reached(pose_, s.goals[-1], velocity):
            s.status = SUCCEEDED
            self.events.append(NavigationEvent(time, "succeeded"))
            return 0.0, 0.0
        if s.behavior is not None:
            return self._recover(time, pose_)
        if time >= s.next_plan:
            self._plan(time, pose_)
            if s.status != RUNNING or s.behavior is not None:
                return (0.0, 0.0) if s.behavior is None else self._recover(time, pose_)
        if len(self.path) == 0:
            return 0.0, 0.0
        return self._follow(time, pose_, velocity)

    def _thresholded(self, velocity: ArrayLike) -> ArrayLike:
        """The odometry's speeds with those below the controller server's thresholds set
        to 0 (none with the kit's thresholds of 0)."""
        p = self.params
        if p.min_x_velocity_threshold <= 0 and p.min_theta_velocity_threshold <= 0:
            return velocity
        v, w = (float(x) for x in np.asarray(velocity, dtype=float)[:2])
        return (0.0 if abs(v) < p.min_x_velocity_threshold else v,
                0.0 if abs(w) < p.min_theta_velocity_threshold else w)

    def _remove_passed_goals(self, pose: FloatArray) -> None:
        goals = self.state.goals
        while len(goals) > 1 and math.hypot(goals[0][0] - pose[0], goals[0][1] - pose[1]) < \
                self.params.remove_passed_goals_radius:
            goals.pop(0)

    def _plan(self, time: float, pose: FloatArray) -> None:
        s = self.state
        s.next_plan = time + 1.0 / self.params.planner_frequency
        goals = s.goals
        for attempt in range(2):
            costmap = _clear_start(self.global_costmap.update(pose), pose,
                                   self.global_costmap.inscribed_radius)
            try:
                result = compute_path_to_pose(pose, goals[-1], costmap, planner=self.planner,
                                              viapoints=goals[:-1])
                failure = "" if result.ok else f"no valid path: {result.error_msg}"
            except PlanningError as e:
                failure = str(e)
            if not failure:
                self.path = path_to_points(result.path)
                self.controller.set_plan(self.path, float(goals[-1][2]))
                self.goal_checker.reset()       # Nav2's setPlannerPath, on every new path
                s.plan_failures = 0
                self.events.append(NavigationEvent(time, "plan", f"{len(self.path)} points"))
                return
            if attempt == 0:
                self.global_costmap.clear()            # ClearGlobalCostmap, then once more
        self.events.append(NavigationEvent(time, "plan failed", failure))
        self._start_recovery(time, pose, f"planning failed: {failure}")

    def _follow(self, time: float, pose: FloatArray, velocity: ArrayLike
                ) -> tuple[float, float]:
        s = self.state
        if not self.progress.check(time, pose):
            self.events.append(NavigationEvent(time, "control failed", "no progress"))
            self.progress.reset()
            self._start_recovery(time, pose, "the controller made no progress for "
                                 f"{self.params.movement_time_allowance:g} s")
            return self._recover(time, pose)
        if self._blind:
            return 0.0, 0.0
        costmap = self.local_costmap_now(time, pose)
        try:
            v, w = self.controller.compute_velocity_commands(pose, velocity, costmap)
        except ControlError as e:
            tolerance = self.params.failure_tolerance
            if tolerance == -1.0 or (tolerance > 0 and time - self._last_valid <= tolerance):
                return 0.0, 0.0                       # the controller server's patience
            s.control_failures += 1
            self.events.append(NavigationEvent(time, "control failed", e.reason))
            if s.control_failures == 1:
                self.local_costmap.clear()              # ClearLocalCostmap, then once more
                self._local, self._blind = None, True
                return 0.0, 0.0
            self._start_recovery(time, pose, f"following failed: {e.reason}")
            return self._recover(time, pose)
        s.control_failures = 0
        self._last_valid = time
        if not (math.isfinite(v) and math.isfinite(w)):
            raise ValueError(f"the controller returned a non-finite command ({v}, {w})")
        return float(v), float(w)

    # ------------------------------------------------------------------ recoveries
    def _start_recovery(self, time: float, pose: FloatArray, failure: str) -> None:
        s = self.state
        s.last_failure = failure
        if s.recoveries >= self.params.number_of_retries:
            self._fail(time, f"{failure} (after {s.recoveries} recoveries)")
            return
        s.recoveries += 1
        s.round_failed = 0
        self._next_behavior(time, pose)

    def _next_behavior(self, time: float, pose: FloatArray) -> None:
        s = self.state
        index = s.next_behavior % len(self.behaviors)
        s.next_behavior += 1
        behavior = self.behaviors[index]
        s.control_failures = s.plan_failures = 0
        s.next_plan = time                            # replan as soon as it is over
        if behavior is None:
            self.global_costmap.clear()
            self.local_costmap.clear()
            self._local, self._blind = None, True
            self.events.append(NavigationEvent(time, "recovery", "clear costmaps"))
            s.behavior = None
            return
        behavior.start(time, pose)
        s.behavior = behavior
        self.events.append(NavigationEvent(time, "recovery", behavior.name))

    def _recover(self, time: float, pose: FloatArray) -> tuple[float, float]:
        s = self.state
        if s.status != RUNNING:
            return 0.0, 0.0
        behavior = s.behavior
        if behavior is None:
            return 0.0, 0.0
        costmap = self.local_costmap_now(time, pose)
        status, cmd = behavior.tick(time, pose, costmap)
        if status == RUNNING:
            return cmd
        if status == SUCCEEDED:
            s.behavior = None
            self._last_valid = time
            self.progress.reset()
            return 0.0, 0.0
        self.events.append(NavigationEvent(time, "recovery failed", behavior.reason))
        s.round_failed += 1
        if s.round_failed >= len(self.behaviors):
            self._fail(time, f"{s.last_failure}; every recovery failed")
            return 0.0, 0.0
        self._next_behavior(time, pose)
        return 0.0, 0.0

    def _fail(self, time: float, reason: str) -> None:
        s = self.state
        s.status, s.reason, s.behavior = FAILED, reason, None
        self.events.append(NavigationEvent(time, "failed", reason))


def _with_keepout(params: CostmapParams) -> CostmapParams:
    """The costmap with the kit's keep-out layer right after the static layer (before the
    obstacles and the inflation, so that the zone is inflated like a wall)."""
    layers = list(params.layers)
    at = next((i + 1 for i, layer in enumerate(layers) if isinstance(layer, StaticLayerParams)),
              0)
    layers.insert(at, KeepoutFilterParams())
    return replace(params, layers=tuple(layers))


def _clear_start(costmap: Costmap, pose: FloatArray, radius: float) -> Costmap:
    """The costmap with the inscribed cells round the robot no worse than free's neighbour
    (NavFn's ``clearRobotCell``): a robot pushed against a wall still gets a path out, as
    long as it does not stand on a lethal cell."""
    try:
        row, col = costmap.world_to_cell(float(pose[0]), float(pose[1]), "robot")
    except ValueError:
        return costmap
    if costmap.costs[row, col] < INSCRIBED_INFLATED_OBSTACLE:
        return costmap
    costs = costmap.costs.copy()
    n = math.ceil(radius / costmap.resolution)
    r0, r1 = max(row - n, 0), min(row + n + 1, costmap.height)
    c0, c1 = max(col - n, 0), min(col + n + 1, costmap.width)
    window = costs[r0:r1, c0:c1]
    rr, cc = np.mgrid[r0:r1, c0:c1]
    near = np.hypot(rr - row, cc - col) * costmap.resolution <= radius
    window[near & (window == INSCRIBED_INFLATED_OBSTACLE)] = INSCRIBED_INFLATED_OBSTACLE - 1
    return Costmap(costs, costmap.resolution, costmap.origin, costmap.frame_id)
