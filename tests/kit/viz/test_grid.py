"""Plots of grids, maps with trajectories and scans draw what they are given."""

from __future__ import annotations

import matplotlib
import numpy as np

from kit import mapping, msgs, viz

matplotlib.use("Agg")


def test_grid_map_and_scan_plots_draw_in_metres():
    m = mapping.OccupancyGridMap(0.1)
    scan = msgs.LaserScan(angle_min=-1.0, angle_increment=0.5, range_min=0.1, range_max=5.0,
                          ranges=np.array([1.0, 2.0, np.inf, 1.5, 1.0]))
    m.insert_scan(scan, [1.0, 2.0, 0.3])
    ax = viz.plot_grid(m)
    x0, x1, y0, _ = ax.images[0].get_extent()
    assert (x0, y0) == tuple(m.origin) and x1 == x0 + m.shape[1] * m.resolution
    ax = viz.plot_map_trajectory(m.to_msg(), np.array([[1.0, 2.0, 0.0], [1.5, 2.0, 0.0]]))
    assert ax.lines[0].get_xydata().tolist() == [[1.0, 2.0], [1.5, 2.0]]
    ax = viz.plot_scan(scan, [1.0, 2.0, 0.3], rays=True)
    points = ax.lines[-2].get_xydata()
    assert len(points) == 4 and np.allclose(points[0], [1.0 + np.cos(-0.7), 2 + np.sin(-0.7)],
                                            atol=1e-6)
