"""Everything the navigator is configured with, in one value: the rates and checkers, the
controller's, the planner's, the two costmaps' and the recoveries' parameters (and AMCL's,
for a localization running beside it), by Nav2's names.

:meth:`NavigationConfig.for_robot` gives the kit's own configuration for a robot;
:func:`kit.navigation.load_nav2_params` reads one from a Nav2 parameter file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

from kit.navigation._costmap import navigation_costmap_params
from kit.navigation._dwb import DwbParameters
from kit.navigation._pursuit import RppParameters
from kit.planning import CostmapParams, GridPlanner, ThetaStarPlanner
from kit.robots import RobotDescription

if TYPE_CHECKING:
    from kit.localization import AmclParameters
    from kit.nav2params import ParameterReport

__all__ = ["BehaviorParameters", "NavigationConfig", "NavigatorParameters", "PlannerParameters"]

CONTROLLERS = ("rpp", "dwb")


@dataclass(frozen=True)
class NavigatorParameters:
    """Rates, retries and the checkers' and costmaps' parameters (Nav2's names).

    ``inflation_radius``, ``cost_scaling_factor``, ``local_width``, ``moving_margin`` and
    ``footprint_padding`` configure the kit's own costmaps (:meth:`NavigationConfig.for_robot`);
    a Nav2 parameter file sets its costmaps' parameters itself."""

    planner_frequency: float = 1.0
    controller_frequency: float = 20.0
    local_update_frequency: float = 5.0
    number_of_retries: int = 6
    xy_goal_tolerance: float = 0.25
    yaw_goal_tolerance: float = 0.25
    stateful: bool = True
    """The goal checker's: once within ``xy_goal_tolerance`` it stays so while turning."""
    goal_checker: str = "simple"
    """``"simple"`` (Nav2's SimpleGoalChecker) or ``"stopped"`` (StoppedGoalChecker: also
    slower than ``trans_stopped_velocity`` and ``rot_stopped_velocity``)."""
    trans_stopped_velocity: float = 0.25
    rot_stopped_velocity: float = 0.25
    required_movement_radius: float = 0.5
    movement_time_allowance: float = 10.0
    required_movement_angle: float | None = None
    """rad: Nav2's PoseProgressChecker — turning this far also counts as progress; ``None``:
    the SimpleProgressChecker."""
    failure_tolerance: float = 0.0
    """s the controller may keep failing (a zero command meanwhile) before following fails;
    −1: for ever; 0: at once (Nav2's meaning and default)."""
    min_x_velocity_threshold: float = 0.0
    min_theta_velocity_threshold: float = 0.0
    """Odometry speeds below these [m/s, rad/s] reach the controller as 0 (Nav2's default
    0.0001; the kit's 0 passes every speed)."""
    inflation_radius: float = 0.55
    cost_scaling_factor: float = 10.0
    local_width: float = 3.0
    moving_margin: float = 0.0
    """m: the local costmap marks returns the map does not explain as discs this wide (a
    person's step before the next scan); 0 marks single cells, as Nav2's obstacle layer."""
    footprint_padding: float = 0.05
    """m around the footprint, in the costmaps and the controllers' collision checks (Nav2's
    default is 0.01; the kit's 0.05 keeps a margin for servos lagging the commands)."""
    remove_passed_goals_radius: float = 0.5

    def __post_init__(self) -> None:
        for name in ("planner_frequency", "controller_frequency", "local_update_frequency"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of Hz; got {value!r}")
        if self.goal_checker not in ("simple", "stopped"):
            raise ValueError(f"goal_checker is 'simple' or 'stopped'; got {self.goal_checker!r}")
        if not (self.failure_tolerance >= 0 or self.failure_tolerance == -1.0):
            raise ValueError(f"failure_tolerance is a duration [s] or -1 (for ever); got "
                             f"{self.failure_tolerance!r}")


@dataclass(frozen=True)
class PlannerParameters:
    """The planner server's ``GridBased`` planner: ``kind`` ``"grid"``
    (:class:`~kit.planning.GridPlanner`: A* or Dijkstra, NavFn's and Smac 2-D's kind) or
    ``"theta_star"`` (:class:`~kit.planning.ThetaStarPlanner`), with their options."""

    kind: str = "grid"
    use_astar: bool = True
    allow_unknown: bool = True
    tolerance: float = 0.0
    cost_travel_multiplier: float = 2.0
    downsampling_factor: int = 1
    max_iterations: int | None = None
    use_final_approach_orientation: bool = False
    how_many_corners: int = 8
    w_euc_cost: float = 1.0
    w_traversal_cost: float = 2.0

    def __post_init__(self) -> None:
        if self.kind not in ("grid", "theta_star"):
            raise ValueError(f"planner kind is 'grid' or 'theta_star'; got {self.kind!r}")
        self.make()                                   # checks the options now

    def make(self) -> GridPlanner | ThetaStarPlanner:
        if self.kind == "theta_star":
            return ThetaStarPlanner(how_many_corners=self.how_many_corners,
                                    w_euc_cost=self.w_euc_cost,
                                    w_traversal_cost=self.w_traversal_cost,
                                    allow_unknown=self.allow_unknown,
                                    use_final_approach_orientation=(
                                        self.use_final_approach_orientation))
        return GridPlanner(use_astar=self.use_astar, allow_unknown=self.allow_unknown,
                           tolerance=self.tolerance,
                           cost_travel_multiplier=self.cost_travel_multiplier,
                           downsampling_factor=self.downsampling_factor,
                           max_iterations=self.max_iterations,
                           use_final_approach_orientation=self.use_final_approach_orientation)


@dataclass(frozen=True)
class BehaviorParameters:
    """The behaviour server's parameters (Nav2's names) and the default tree's arguments to
    its recoveries (``spin_dist``, ``wait_duration``, ``backup_dist``, ``backup_speed``,
    each with a ``time_allowance``)."""

    simulate_ahead_time: float = 2.0
    max_rotational_vel: float = 1.0
    min_rotational_vel: float = 0.4
    rotational_acc_lim: float = 3.2
    spin_dist: float = 1.57
    wait_duration: float = 5.0
    backup_dist: float = 0.30
    backup_speed: float = 0.05
    time_allowance: float = 10.0
    unavailable: tuple[str, ...] = ()
    """The tree's recoveries (``spin``, ``backup``, ``wait``) the behaviour server does not
    offer: they fail at once."""


@dataclass(frozen=True, eq=False)
class NavigationConfig:
    """The navigator's whole configuration.

    ``controller`` is ``"rpp"`` or ``"dwb"`` (``rpp`` and ``dwb`` hold both controllers'
    parameters; the other one is there for a caller who switches); ``amcl`` is the
    localization's, when a parameter file has one; ``report`` tells what became of each key
    of the file it was read from (``None`` for the kit's own)."""

    navigator: NavigatorParameters
    controller: str
    rpp: RppParameters
    dwb: DwbParameters
    planner: PlannerParameters
    global_costmap: CostmapParams
    local_costmap: CostmapParams
    behaviors: BehaviorParameters = field(default_factory=BehaviorParameters)
    amcl: AmclParameters | None = None
    report: ParameterReport | None = None

    def __post_init__(self) -> None:
        if self.controller not in CONTROLLERS:
            raise ValueError(f"controller is 'rpp' or 'dwb'; got {self.controller!r}")
        if not self.local_costmap.rolling_window:
            raise ValueError("the local costmap must be a rolling window")

    @classmethod
    def for_robot(cls, robot: RobotDescription, controller: str = "rpp",
                  params: NavigatorParameters | None = None) -> NavigationConfig:
        """The kit's configuration for ``robot``: its footprint padded by
        ``footprint_padding``; costmaps of :func:`~kit.navigation.navigation_costmap_params`
        (a 0.05 m local window ``local_width`` wide); Regulated Pure Pursuit or DWB with the
        robot's speeds and accelerations (:meth:`RppParameters.for_robot`,
        :meth:`DwbParameters.for_robot`: DWB with 10 × 15 samples and 0.1 rad steps); A* on
        the global costmap; recoveries turning at up to 1 rad/s (or the robot's top turning
        rate)."""
        p = params or NavigatorParameters()
        global_costmap = navigation_costmap_params(
            robot.footprint, footprint_padding=p.footprint_padding,
            inflation_radius=p.inflation_radius, cost_scaling_factor=p.cost_scaling_factor)
        local_costmap = navigation_costmap_params(
            robot.footprint, rolling_window=True, width=p.local_width, height=p.local_width,
            moving_margin=p.moving_margin, footprint_padding=p.footprint_padding,
            inflation_radius=p.inflation_radius, cost_scaling_factor=p.cost_scaling_factor)
        rpp = RppParameters.for_robot(robot, controller_frequency=p.controller_frequency)
        dwb = DwbParameters.for_robot(robot, controller_frequency=p.controller_frequency,
                                      xy_goal_tolerance=p.xy_goal_tolerance, vx_samples=10,
                                      vtheta_samples=15, angular_granularity=0.1)
        behaviors = BehaviorParameters(max_rotational_vel=min(1.0, robot.max_angular_velocity))
        return cls(p, controller, rpp, dwb, PlannerParameters(), global_costmap, local_costmap,
                   behaviors)

    def with_controller(self, controller: str) -> NavigationConfig:
        """The same configuration with the other controller."""
        return replace(self, controller=controller)
