"""The office's glass meeting room: a map made by the lidar has no glass walls, so a path
runs straight through them; Nav2's keep-out filter with a mask of the glass sends it round by
the doors."""

import itertools

import numpy as np
import pytest

from kit import msgs
from kit.planning import (
    GridPlanner,
    KeepoutFilterParams,
    LayeredCostmap,
    ThetaStarPlanner,
    compute_path_to_pose,
    load_costmap_params,
    path_to_points,
    robot_footprint,
)
from sim.world import load_world

RES = 0.05


def rasterise(segments, shape):
    """Cells touched by the segments ((M, 4) [m]), sampled every quarter cell."""
    hit = np.zeros(shape, bool)
    for x1, y1, x2, y2 in segments:
        n = int(np.hypot(x2 - x1, y2 - y1) / (RES / 4)) + 2
        t = np.linspace(0, 1, n)
        col = np.floor((x1 + t * (x2 - x1)) / RES).astype(int).clip(0, shape[1] - 1)
        row = np.floor((y1 + t * (y2 - y1)) / RES).astype(int).clip(0, shape[0] - 1)
        hit[row, col] = True
    return hit


def grid_of(occupied):
    info = msgs.MapMetaData(resolution=RES, width=occupied.shape[1], height=occupied.shape[0])
    return msgs.OccupancyGrid(msgs.Header(frame_id="map"), info,
                              np.where(occupied, 100, 0).astype(np.int8).ravel())


def crosses(points, x, y0, y1):
    """Does the polyline cross the vertical line x between y0 and y1?"""
    for (ax, ay), (bx, by) in itertools.pairwise(points):
        if (ax - x) * (bx - x) < 0:
            y = ay + (x - ax) * (by - ay) / (bx - ax)
            if y0 <= y <= y1:
                return True
    return False


def crosses_row(points, y, x0, x1):
    """Does the polyline cross the horizontal line y between x0 and x1?"""
    return crosses(points[:, ::-1], y, x0, x1)


@pytest.mark.parametrize("planner", [GridPlanner(), ThetaStarPlanner()])
def test_keepout_mask_keeps_the_path_out_of_the_glass_walls(planner):
    world = load_world("office")
    shape = (int(12 / RES) + 1, int(20 / RES) + 1)
    seen = rasterise(world.lidar_segments, shape)          # what SLAM maps: no glass
    glass = rasterise(world.segments[world.segment_glass], shape)
    params = load_costmap_params({"resolution": RES, "filters": ["keepout_filter"],
                                  "keepout_filter": {"plugin": "nav2_costmap_2d::KeepoutFilter"},
                                  "inflation_layer": {"cost_scaling_factor": 3.0}})
    assert params.filters == (KeepoutFilterParams(),)
    layered = LayeredCostmap(params, grid_of(seen), footprint=robot_footprint("uiabot"))
    start, goal = (6.0, 10.0, 0.0), (15.0, 10.0, 0.0)       # west office to east office
    through = path_to_points(compute_path_to_pose(start, goal, layered.update(),
                                                  planner=planner).path)
    assert crosses(through, 8.0, 7.0, 12.0) and crosses(through, 13.0, 7.0, 12.0)
    layered.set_keepout_mask(grid_of(glass))
    around = compute_path_to_pose(start, goal, layered.update(), planner=planner)
    points = path_to_points(around.path)
    assert around.ok
    assert not crosses(points, 8.0, 7.0, 12.0) and not crosses(points, 13.0, 7.0, 12.0)
    # out of the west office's door (x 4.0 … 4.9), along the corridor, in at the east one's
    assert crosses_row(points, 7.0, 4.0, 4.9) and crosses_row(points, 7.0, 16.0, 16.9)
