"""A world drawn as a map_server map: what bumps the robot, what the lidar sees, the glass."""

import numpy as np
import pytest

from kit import maps
from sim.world import load_world


def cells(grid):
    return grid.data.reshape(grid.info.height, grid.info.width) == 100


def cell_of(grid, x, y):
    info = grid.info
    return (int((y - info.origin.position.y) // info.resolution),
            int((x - info.origin.position.x) // info.resolution))


def test_the_glass_is_in_the_full_map_and_the_mask_but_not_in_what_the_lidar_sees():
    world = load_world("office")
    full, seen, glass = (world.occupancy_grid(0.05, layer=k) for k in ("all", "lidar", "glass"))
    assert np.array_equal(cells(full), cells(seen) | cells(glass))
    a, b = world.segments[world.segment_glass][0].reshape(2, 2)
    middle = cell_of(glass, *(a + b) / 2)
    assert cells(glass)[middle] and cells(full)[middle] and not cells(seen)[middle]


def test_every_wall_end_is_occupied_and_a_disc_fills_its_cells(tmp_path):
    world = load_world("pillars")
    grid = world.occupancy_grid(0.1)
    for x1, y1, x2, y2 in world.segments:
        assert cells(grid)[cell_of(grid, x1, y1)] and cells(grid)[cell_of(grid, x2, y2)]
    for x, y, r in world.circles:
        assert cells(grid)[cell_of(grid, x, y)]
        assert cells(grid)[cell_of(grid, x + 0.9 * r, y)]
    maps.write_map(grid, tmp_path / "pillars.yaml")       # opens as a map_server map
    again = maps.read_map(tmp_path / "pillars.yaml")
    assert np.array_equal(cells(again), cells(grid))


def test_bad_arguments_are_named():
    world = load_world("square")
    with pytest.raises(ValueError, match="resolution"):
        world.occupancy_grid(0.0)
    with pytest.raises(ValueError, match="layer"):
        world.occupancy_grid(0.05, layer="walls")
