"""Navigation as Nav2 navigates (Labs 10 and 11): following a path, a dynamic window among
obstacles, recoveries, and a navigator tying them to the planner.

* Path following — :func:`pure_pursuit_curvature`, :class:`PurePursuit` and Nav2's
  :class:`RegulatedPurePursuit` (:class:`RppParameters`).
* The dynamic-window local planner in DWB's design — :class:`DwbController`
  (:class:`DwbParameters`, :func:`dynamic_window`, its critics in :data:`CRITICS`).
* Costmaps for navigation — the kit's one :class:`kit.planning.LayeredCostmap`, global or a
  local window rolling with the robot (:class:`NavigationCostmap` builds the kit's own in a
  call), and the footprint on it: :func:`footprint_costs`, :func:`footprint_collides`.
* Recoveries and checkers — :class:`Spin`, :class:`BackUp`, :class:`Wait`,
  :class:`ProgressChecker`, :class:`GoalChecker`.
* :class:`Navigator` — Nav2's default behaviour tree for ``NavigateToPose`` and
  ``NavigateThroughPoses``: plan at 1 Hz, follow at 20 Hz, clear and recover, give up with a
  reason; configured by a :class:`NavigationConfig` — the kit's own
  (:meth:`NavigationConfig.for_robot`) or a Nav2 parameter file's
  (:func:`load_nav2_params`, every key used or reported).

Poses are ``(x, y, θ)`` in the map frame [m, m, rad]; commands ``(v, ω)`` [m/s, rad/s];
paths (N, 2) arrays of points [m].
"""

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
from kit.navigation._config import (
    BehaviorParameters,
    NavigationConfig,
    NavigatorParameters,
    PlannerParameters,
)
from kit.navigation._costmap import (
    NavigationCostmap,
    collides_from,
    footprint_collides,
    footprint_costs,
    navigation_costmap_params,
    outline_points,
)
from kit.navigation._dwb import CRITICS, DwbController, DwbParameters, Trajectories, dynamic_window
from kit.navigation._nav2 import load_nav2_params
from kit.navigation._navigator import Controller, NavigationEvent, Navigator
from kit.navigation._path import (
    ControlError,
    check_path,
    closest_index,
    lookahead_point,
    remaining_length,
)
from kit.navigation._pursuit import (
    PurePursuit,
    RegulatedPurePursuit,
    RppParameters,
    arc_poses,
    pure_pursuit_curvature,
)

__all__ = [
    "CRITICS",
    "FAILED",
    "RUNNING",
    "SUCCEEDED",
    "BackUp",
    "Behavior",
    "BehaviorParameters",
    "ControlError",
    "Controller",
    "DwbController",
    "DwbParameters",
    "GoalChecker",
    "NavigationConfig",
    "NavigationCostmap",
    "NavigationEvent",
    "Navigator",
    "NavigatorParameters",
    "PlannerParameters",
    "ProgressChecker",
    "PurePursuit",
    "RegulatedPurePursuit",
    "RppParameters",
    "Spin",
    "Trajectories",
    "Unavailable",
    "Wait",
    "arc_poses",
    "check_path",
    "closest_index",
    "collides_from",
    "dynamic_window",
    "footprint_collides",
    "footprint_costs",
    "load_nav2_params",
    "lookahead_point",
    "navigation_costmap_params",
    "outline_points",
    "pure_pursuit_curvature",
    "remaining_length",
]
