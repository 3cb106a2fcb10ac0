"""Plots for the labs. Each ``plot_*`` draws on ``ax`` (a new figure when ``None``) and returns
the axes; nothing here calls ``plt.show()``. Importing this package imports matplotlib, which
``import kit`` does not.

One private module per topic: ``_robot`` (the robot, paths, wheels), ``_drivers`` (what the
drivers read), ``_control`` (signals over time, step responses), ``_estimation`` (errors
against the truth, filters), ``_planning`` (costmaps, paths, searches), ``_grid`` (occupancy
grids, maps with trajectories, scans), ``_localization`` (particle clouds), ``_navigation``
(DWB's rollouts).
"""

from kit.viz._control import plot_signals, plot_step_response
from kit.viz._drivers import plot_lidar_turn
from kit.viz._estimation import plot_headings, plot_kalman_track, plot_odometry_drift
from kit.viz._grid import crop_to_known, known_extent, plot_grid, plot_map_trajectory, plot_scan
from kit.viz._localization import animate_particles, animation_html, plot_particles
from kit.viz._navigation import plot_rollouts
from kit.viz._planning import costmap_colors, plot_costmap, plot_path, plot_search
from kit.viz._robot import plot_icc, plot_robot, plot_trajectories, plot_wheel_commands

__all__ = [
    "animate_particles",
    "animation_html",
    "costmap_colors",
    "crop_to_known",
    "known_extent",
    "plot_costmap",
    "plot_grid",
    "plot_headings",
    "plot_icc",
    "plot_kalman_track",
    "plot_lidar_turn",
    "plot_map_trajectory",
    "plot_odometry_drift",
    "plot_particles",
    "plot_path",
    "plot_robot",
    "plot_rollouts",
    "plot_scan",
    "plot_search",
    "plot_signals",
    "plot_step_response",
    "plot_trajectories",
    "plot_wheel_commands",
]
