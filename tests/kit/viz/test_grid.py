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


def _message(cells: np.ndarray, resolution: float = 0.05) -> msgs.OccupancyGrid:
    rows, cols = cells.shape
    return msgs.OccupancyGrid(info=msgs.MapMetaData(resolution=resolution, width=cols,
                                                    height=rows),
                              data=cells.astype(np.int8).ravel())


def test_a_grid_larger_than_a_figure_is_drawn_in_blocks_that_keep_a_one_cell_wall():
    """A 3 × 4100 corridor map (a log's beams reach 80 m): the image handed to matplotlib is
    at most MAX_SIDE wide, a wall one cell thick still shows, a block is unknown only where
    all its cells are, and the image spans the grid (padded to whole blocks)."""
    cells = np.zeros((3, 4100), dtype=np.int16)
    cells[:, 4000:] = -1
    cells[1, 1001] = 100
    grid = _message(cells)
    ax = viz.plot_grid(grid)
    image = ax.images[0].get_array()
    k = 3  # ceil(4100 / 2048)
    assert image.shape == (1, -(-4100 // k)) and max(image.shape) <= viz._grid.MAX_SIDE
    shown = 1.0 - image[0]  # occupancy as drawn: 0 free, 0.5 unknown, 1 occupied
    assert shown[1001 // k] == 1.0
    assert shown[0] == 0.0 and shown[3999 // k] == 0.0  # block 1333 holds free cell 3999
    assert np.all(shown[4002 // k:] == 0.5)
    x0, x1, y0, y1 = ax.images[0].get_extent()
    assert (x0, y0) == (0.0, 0.0) and np.isclose(x1, 1367 * k * 0.05) and np.isclose(y1, 3 * 0.05)


def test_known_extent_is_numpys_quantile_of_the_known_cells_and_can_take_the_walls_alone():
    rng = np.random.default_rng(3)
    cells = rng.choice([-1, 0, 100], size=(70, 90), p=[0.6, 0.35, 0.05])
    cells[5, 80] = 100
    grid = _message(cells, resolution=0.1)
    res = grid.info.resolution  # a message's float32 0.1
    for occupied, known in ((False, cells >= 0), (True, cells == 100)):
        rows, cols = np.nonzero(known)
        for stray in (0.001, 0.2):
            c0, c1 = np.quantile(cols, [stray, 1 - stray])
            r0, r1 = np.quantile(rows, [stray, 1 - stray])
            want = (max(0.0, c0 * res - 0.5), min(90 * res, (c1 + 1) * res + 0.5),
                    max(0.0, r0 * res - 0.5), min(70 * res, (r1 + 1) * res + 0.5))
            got = viz.known_extent(grid, stray=stray, occupied=occupied)
            assert np.allclose(got, want, rtol=0, atol=1e-12), (occupied, stray, got, want)
    # a log-odds grid's walls are its cells above map_server's occupied_thresh, as in the map
    log_odds = mapping.OccupancyGridMap.from_msg(grid)
    assert viz.known_extent(log_odds, occupied=True) == viz.known_extent(grid, occupied=True)
    unknown = _message(np.full((4, 5), -1))  # nothing known: the whole grid
    res = unknown.info.resolution
    assert viz.known_extent(unknown) == (0.0, 5 * res, 0.0, 4 * res)


def test_blocks_are_each_blocks_largest_value_unknown_only_where_the_whole_block_is():
    """The k × k reduction against a loop over the blocks: probabilities with NaN (never
    observed) take the largest known value of a block, NaN only where the whole block is
    NaN; a message's int8 cells take the largest value, -1 where all are unknown; the padding
    at the top and right is the fill."""
    rng = np.random.default_rng(3)
    p = rng.random((7, 11))
    p[rng.random(p.shape) < 0.5] = np.nan
    p[0:3, 0:3] = np.nan                       # one block wholly unknown
    cells = rng.integers(-1, 101, size=(7, 11)).astype(np.int8)
    cells[3:6, 3:6] = -1
    for values, fill in ((p, np.nan), (cells, -1)):
        k = 3
        got = viz._grid._blocks(values, k, fill)
        assert got.shape == (3, 4) and got.dtype == values.dtype
        for r in range(3):
            for c in range(4):
                block = values[r * k:(r + 1) * k, c * k:(c + 1) * k].ravel().tolist()
                known = [v for v in block if v == v]      # NaN is not equal to itself
                want = max(known) if known else fill
                assert got[r, c] == want or (want != want and got[r, c] != got[r, c])
    assert np.isnan(viz._grid._blocks(p, 3, np.nan)[0, 0])
    assert viz._grid._blocks(cells, 3, -1)[1, 1] == -1
