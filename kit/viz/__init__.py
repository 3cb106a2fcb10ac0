"""Plots for the labs. Each ``plot_*`` draws on ``ax`` (a new figure when ``None``) and returns
the axes; nothing here calls ``plt.show()``. Importing this package imports matplotlib, which
``import kit`` does not.

One private module per topic: ``_robot`` (the robot, paths, wheels), ``_estimation`` (errors
against the truth), ``_grid`` (occupancy grids, maps with trajectories, scans); the labs of
the think half add theirs beside them.
"""

from kit.viz._estimation import plot_odometry_drift
from kit.viz._grid import plot_grid, plot_map_trajectory, plot_scan
from kit.viz._robot import plot_icc, plot_robot, plot_trajectories, plot_wheel_commands

__all__ = [
    "plot_grid",
    "plot_icc",
    "plot_map_trajectory",
    "plot_odometry_drift",
    "plot_robot",
    "plot_scan",
    "plot_trajectories",
    "plot_wheel_commands",
]
