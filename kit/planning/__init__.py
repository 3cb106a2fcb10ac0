"""Global planning as Nav2 plans (Lab 09): costmaps, grid search, any-angle paths, smoothing.

* Costmaps in Nav2's model — :class:`Costmap` (costs 0–255 with Nav2's constants),
  :func:`static_layer`, :func:`inflate` (and :func:`inflate_reference`, the plain version) with
  :func:`inflation_cost`, footprints (:func:`footprint_radii`, :func:`robot_footprint`), the
  :class:`ObstacleLayer` (marking and ray-trace clearing from scans, compiled beside
  :func:`raytrace_line`), :func:`apply_keepout` (Nav2's keep-out filter), all combined by
  :class:`LayeredCostmap` from Nav2's parameters (:func:`load_costmap_params` reads a Nav2 YAML
  as it is) — the whole map, or a window rolling with the robot. It is the kit's one costmap:
  the planner plans on it, the navigator's global and local costmaps are two of it.
* Grid search — :func:`dijkstra`, :func:`astar`, :func:`theta_star` (compiled) beside their
  readable ``*_reference`` versions, with the pieces: :func:`octile_distance`,
  :func:`diagonal_allowed` (the corner-cutting rule), :func:`traversal_cost`,
  :func:`line_of_sight`; :class:`GridSearch` for many queries on one grid.
* Paths — :func:`compute_path_to_pose` (shaped like Nav2's ``ComputePathToPose``) with
  :class:`GridPlanner` or :class:`ThetaStarPlanner`; :func:`simple_smooth` and
  :func:`savitzky_golay_smooth` (Nav2's smoothers, keeping clear of obstacles),
  :func:`path_length`, :func:`curvature`, :func:`resample`.
* Moving AI benchmarks — :func:`read_grid_map`, :func:`read_scenarios`; ``kit plan``.

Cells are ``(row, col)`` everywhere, row 0 at the map's origin (a Moving AI map's top line);
Nav2's ``(mx, my)`` and Moving AI's ``(x, y)`` are ``(col, row)``.
"""

from kit.planning._costmap import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    MAX_NON_OBSTACLE,
    NO_INFORMATION,
    Costmap,
    apply_keepout,
    apply_keepout_costs,
    cell_to_world,
    footprint_from_radius,
    footprint_radii,
    inflate,
    inflate_reference,
    inflation_cost,
    keepout_costs,
    pad_footprint,
    static_layer,
    world_to_cell,
)
from kit.planning._gridsearch import GridSearch, astar, dijkstra, theta_star
from kit.planning._layered import (
    CostmapParams,
    InflationLayerParams,
    KeepoutFilterParams,
    LayeredCostmap,
    ObstacleLayerParams,
    StaticLayerParams,
    costmap_from_map,
    load_costmap_params,
    robot_footprint,
)
from kit.planning._movingai import (
    GridMap,
    MovingAIError,
    Scenario,
    read_grid_map,
    read_scenarios,
)
from kit.planning._obstacle import ObservationSource, ObstacleLayer, raytrace_line
from kit.planning._planner import (
    GlobalPlanner,
    GridPlanner,
    PlanResult,
    ThetaStarPlanner,
    compute_path_to_pose,
    path_to_points,
    points_to_path,
)
from kit.planning._search import (
    GOAL_OCCUPIED,
    GOAL_OUTSIDE_MAP,
    NO_VALID_PATH,
    START_OCCUPIED,
    START_OUTSIDE_MAP,
    PlanningError,
    SearchResult,
    astar_reference,
    diagonal_allowed,
    dijkstra_reference,
    line_of_sight,
    manhattan_distance,
    octile_distance,
    theta_star_reference,
    traversable,
    traversal_cost,
)
from kit.planning._smoothing import (
    SmoothedPath,
    curvature,
    path_length,
    resample,
    savitzky_golay_coefficients,
    savitzky_golay_smooth,
    simple_smooth,
)

__all__ = [
    "FREE_SPACE",
    "GOAL_OCCUPIED",
    "GOAL_OUTSIDE_MAP",
    "INSCRIBED_INFLATED_OBSTACLE",
    "LETHAL_OBSTACLE",
    "MAX_NON_OBSTACLE",
    "NO_INFORMATION",
    "NO_VALID_PATH",
    "START_OCCUPIED",
    "START_OUTSIDE_MAP",
    "Costmap",
    "CostmapParams",
    "GlobalPlanner",
    "GridMap",
    "GridPlanner",
    "GridSearch",
    "InflationLayerParams",
    "KeepoutFilterParams",
    "LayeredCostmap",
    "MovingAIError",
    "ObservationSource",
    "ObstacleLayer",
    "ObstacleLayerParams",
    "PlanResult",
    "PlanningError",
    "Scenario",
    "SearchResult",
    "SmoothedPath",
    "StaticLayerParams",
    "ThetaStarPlanner",
    "apply_keepout",
    "apply_keepout_costs",
    "astar",
    "astar_reference",
    "cell_to_world",
    "compute_path_to_pose",
    "costmap_from_map",
    "curvature",
    "diagonal_allowed",
    "dijkstra",
    "dijkstra_reference",
    "footprint_from_radius",
    "footprint_radii",
    "inflate",
    "inflate_reference",
    "inflation_cost",
    "keepout_costs",
    "line_of_sight",
    "load_costmap_params",
    "manhattan_distance",
    "octile_distance",
    "pad_footprint",
    "path_length",
    "path_to_points",
    "points_to_path",
    "raytrace_line",
    "read_grid_map",
    "read_scenarios",
    "resample",
    "robot_footprint",
    "savitzky_golay_coefficients",
    "savitzky_golay_smooth",
    "simple_smooth",
    "static_layer",
    "theta_star",
    "theta_star_reference",
    "traversable",
    "traversal_cost",
    "world_to_cell",
]
