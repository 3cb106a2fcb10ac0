"""The beam model's expected ranges: AMCL's ``map_calc_range`` (Bresenham's line of cells,
the range between cell centres, ``lookup="cells"``) and the exact ray (``lookup="exact"``),
each compiled and as a plain loop, held to the same numbers and to ranges worked out by hand.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from kit import msgs
from kit.localization import AmclParameters, LikelihoodField, expected_ranges
from kit.localization.likelihood_field import BeamModel, beam_model_weights

RES = 0.05


def grid_of(occupied: np.ndarray, unknown: np.ndarray | None = None,
            origin: tuple[float, float] = (0.0, 0.0)) -> LikelihoodField:
    data = np.where(occupied, 100, 0).astype(np.int8)
    if unknown is not None:
        data[unknown] = -1
    h, w = occupied.shape
    info = msgs.MapMetaData(resolution=RES, width=w, height=h,
                            origin=msgs.Pose(msgs.Point(origin[0], origin[1], 0.0)))
    return LikelihoodField.from_grid(msgs.OccupancyGrid(msgs.Header(frame_id="map"), info,
                                                        data.ravel()))


def wall_at_column(col: int) -> LikelihoodField:
    occupied = np.zeros((40, 40), bool)
    occupied[:, col] = True
    return grid_of(occupied)


@pytest.mark.parametrize("method", ["numba", "python"])
def test_cells_measure_between_cell_centres_wherever_the_scanner_is_in_its_cell(method):
    """A wall filling column 20; a scanner anywhere in column 5 looking along +x: AMCL
    gives 15 cells (0.75 m) whatever its place in the cell; the exact ray gives the gap
    from the scanner to the wall's face at x = 1.0 m."""
    field = wall_at_column(20)
    for x in (0.2501, 0.27, 0.2999):
        pose = np.array([x, 0.52, 0.0])
        cells = expected_ranges(field, pose, [0.0], 5.0, method, lookup="cells")
        exact = expected_ranges(field, pose, [0.0], 5.0, method, lookup="exact")
        assert cells[0] == pytest.approx(15 * RES, rel=1e-6)   # the grid's float32 0.05
        assert exact[0] == pytest.approx(1.0 - x, rel=1e-6)


@pytest.mark.parametrize("method", ["numba", "python"])
def test_cells_on_a_diagonal_step_one_cell_in_each_axis(method):
    """At 45° from the centre of cell (5, 5) Bresenham's line runs (6, 6), (7, 7), …; a
    blocked cell (12, 12) ends it 7√2 cells away; a blocked cell next to the line, (12, 11),
    is not on it."""
    occupied = np.zeros((40, 40), bool)
    occupied[12, 12] = True
    occupied[11, 12] = True   # row 11, column 12: beside the diagonal
    field = grid_of(occupied)
    pose = np.array([5.5 * RES, 5.5 * RES, math.pi / 4])
    got = expected_ranges(field, pose, [0.0], 5.0, method, lookup="cells")
    assert got[0] == pytest.approx(7 * math.sqrt(2) * RES, rel=1e-6)


@pytest.mark.parametrize("method", ["numba", "python"])
def test_cells_stop_at_unknown_and_off_the_map_and_give_max_range_past_the_end(method):
    occupied = np.zeros((40, 40), bool)
    unknown = np.zeros((40, 40), bool)
    unknown[20, 30] = True
    field = grid_of(occupied, unknown)
    centre = np.array([10.5 * RES, 20.5 * RES, 0.0])
    ranges = expected_ranges(field, centre, [0.0, math.pi, math.pi / 2], 5.0, method,
                             lookup="cells")
    assert ranges[0] == pytest.approx(20 * RES, rel=1e-6)  # the unknown cell, 20 cells on
    assert ranges[1] == pytest.approx(11 * RES, rel=1e-6)  # column -1: off the map
    assert ranges[2] == pytest.approx(20 * RES, rel=1e-6)  # row 40: off the map
    short = expected_ranges(field, centre, [math.pi / 2], 0.3, method, lookup="cells")
    assert short[0] == 0.3                             # nothing within 0.3 m: max range
    inside_a_wall = expected_ranges(field, np.array([30.5 * RES, 20.5 * RES, 0.0]), [0.0],
                                    5.0, method, lookup="cells")
    assert inside_a_wall[0] == 0.0


@pytest.mark.parametrize("lookup", ["cells", "exact"])
def test_compiled_and_plain_loops_agree_on_a_random_map(lookup):
    rng = np.random.default_rng(5)
    occupied = rng.random((60, 80)) < 0.04
    unknown = rng.random((60, 80)) < 0.02
    field = grid_of(occupied, unknown, origin=(-1.3, 0.7))
    poses = np.column_stack([rng.uniform(-1.5, 2.9, 40), rng.uniform(0.5, 3.9, 40),
                             rng.uniform(-math.pi, math.pi, 40)])
    angles = np.linspace(-math.pi, math.pi, 37)
    fast = expected_ranges(field, poses, angles, 3.0, "numba", lookup)
    slow = expected_ranges(field, poses, angles, 3.0, "python", lookup)
    np.testing.assert_array_equal(fast, slow)
    assert np.ptp(fast) > 1.0


@pytest.mark.dataset
def test_compiled_and_plain_cells_agree_to_the_bit_on_the_real_olin_map(shared_data):
    """AMCL's lookup on a real map (the Olin MAC floor, 903 × 1706 cells of 3 cm), from
    scanners on and off it at ranges up to past the map's size: the compiled loop gives the
    plain loop's ranges to the bit. (With ``math.hypot`` for the distance, CPython's own
    rounding differed from the compiled one's on about one ray in 2,000 here.)"""
    from kit import maps

    grid = maps.read_map(shared_data / "maps/olin-mac-first-floor-real/mac_1st_floor_final.yaml")
    field = LikelihoodField.from_grid(grid)
    info = grid.info
    rng = np.random.default_rng(1)
    width, height = info.width * info.resolution, info.height * info.resolution
    poses = np.column_stack([info.origin.position.x + rng.uniform(-1, width + 1, 150),
                             info.origin.position.y + rng.uniform(-1, height + 1, 150),
                             rng.uniform(-math.pi, math.pi, 150)])
    angles = np.linspace(-math.pi, math.pi, 60, endpoint=False)
    for max_range in (3.0, 12.0, 60.0):
        fast = expected_ranges(field, poses, angles, max_range, "numba", "cells")
        slow = expected_ranges(field, poses, angles, max_range, "python", "cells")
        np.testing.assert_array_equal(fast, slow)
        assert np.ptp(fast) > 1.0 and np.mean(fast == 0.0) < 0.5  # rays of all lengths


def test_the_two_lookups_differ_by_a_cell_or_so_except_past_a_corner():
    """AMCL's lookup measures from the scanner's cell centre to the blocked cell's centre
    instead of from the scanner to the cell's face: a range moves by about a cell (half a
    cell at each end, the line's jaggies). Where the exact ray clips a blocked cell's corner
    that Bresenham's line of cells passes beside, AMCL's range goes on to the next obstacle
    (and the line can touch a corner the ray passes by), as Nav2's does: a few beams in a
    hundred here."""
    rng = np.random.default_rng(9)
    occupied = np.zeros((80, 80), bool)
    occupied[[0, -1], :] = occupied[:, [0, -1]] = True
    occupied[30:36, 20:50] = True
    field = grid_of(occupied)
    poses = np.column_stack([rng.uniform(0.3, 3.7, 50), rng.uniform(2.0, 3.7, 50),
                             rng.uniform(-math.pi, math.pi, 50)])
    angles = np.linspace(-math.pi, math.pi, 90, endpoint=False)
    cells = expected_ranges(field, poses, angles, 8.0, lookup="cells")
    exact = expected_ranges(field, poses, angles, 8.0, lookup="exact")
    near = np.abs(cells - exact) < 1.5 * math.sqrt(2) * RES
    assert near.mean() > 0.95
    assert np.mean((cells - exact)[near]) > 0    # measured to the far cell's centre: longer


def test_the_beam_model_and_amcl_use_amcls_lookup_unless_told():
    occupied = np.zeros((40, 40), bool)
    occupied[:, 30] = True
    field = grid_of(occupied)
    poses = np.array([[0.51, 1.0, 0.0], [0.54, 1.0, 0.0]])   # one cell, two places
    ranges, bearings = np.array([0.97]), np.array([0.0])
    cells = beam_model_weights(poses, ranges, bearings, [0.0, 0.0], field, BeamModel(), 12.0)
    exact = beam_model_weights(poses, ranges, bearings, [0.0, 0.0], field,
                               BeamModel(lookup="exact"), 12.0)
    assert cells[0] == cells[1]        # the same cell: the same expected range
    assert exact[0] != exact[1]
    assert AmclParameters().beam_lookup == "cells"
    with pytest.raises(ValueError, match="beam_lookup is cells or exact"):
        AmclParameters(beam_lookup="bresenham")
    with pytest.raises(ValueError, match="lookup is 'cells' or 'exact'"):
        expected_ranges(field, poses[0], [0.0], 5.0, lookup="centre")  # type: ignore[arg-type]
