"""Navigation as Nav2 navigates (Labs 10 and 11): following a path, a dynamic window among
obstacles, recoveries, and a navigator tying them to the planner.

* Path following — :func:`pure_pursuit_curvature`, :class:`PurePursuit` and Nav2's
  :class:`RegulatedPurePursuit` (:class:`RppParameters`).
* The dynamic-window local planner in DWB's design — :class:`DwbController`
  (:class:`DwbParameters`, :func:`dynamic_window`, its critics in :data:`CRITICS`).
* Costmaps for navigation — :class:`NavigationCostmap` (global, or a local window rolling
  with the robot), :func:`footprint_costs`, :func:`footprint_collides`.
* Recoveries and checkers — :class:`Spin`, :class:`BackUp`, :class:`Wait`,
  :class:`ProgressChecker`, :class:`GoalChecker`.
* :class:`Navigator` — Nav2's default behaviour tree for ``NavigateToPose`` and
  ``NavigateThroughPoses``: plan at 1 Hz, follow at 20 Hz, clear and recover, give up with a
  reason.

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
    Wait,
)
from kit.navigation._costmap import (
    NavigationCostmap,
    collides_from,
    footprint_collides,
    footprint_costs,
    outline_points,
)
from kit.navigation._dwb import CRITICS, DwbController, DwbParameters, Trajectories, dynamic_window
from kit.navigation._navigator import (
    Controller,
    NavigationEvent,
    Navigator,
    NavigatorParameters,
)
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
    "ControlError",
    "Controller",
    "DwbController",
    "DwbParameters",
    "GoalChecker",
    "NavigationCostmap",
    "NavigationEvent",
    "Navigator",
    "NavigatorParameters",
    "ProgressChecker",
    "PurePursuit",
    "RegulatedPurePursuit",
    "RppParameters",
    "Spin",
    "Trajectories",
    "Wait",
    "arc_poses",
    "check_path",
    "closest_index",
    "collides_from",
    "dynamic_window",
    "footprint_collides",
    "footprint_costs",
    "lookahead_point",
    "outline_points",
    "pure_pursuit_curvature",
    "remaining_length",
]
