"""Theta*: any-angle paths whose every segment is a true line of sight, the same from the
compiled and the plain version."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kit import planning
from kit.planning import astar, line_of_sight, theta_star, theta_star_reference


def segment_hits_blocked_cell(blocked, a, b):
    """Does the segment between the centres of cells ``a`` and ``b`` pass through the
    interior of a blocked cell? Exact slab test against each cell's square (side 1, centred
    on the cell), independent of any line-drawing algorithm."""
    (r0, c0), (r1, c1) = a, b
    for r, c in np.argwhere(blocked):
        t0, t1 = 0.0, 1.0
        inside = True
        for p0, d, lo, hi in ((c0, c1 - c0, c - 0.5, c + 0.5), (r0, r1 - r0, r - 0.5, r + 0.5)):
            if d == 0:
                if not lo < p0 < hi:
                    inside = False
                    break
                continue
            ta, tb = sorted(((lo - p0) / d, (hi - p0) / d))
            t0, t1 = max(t0, ta), min(t1, tb)
        if inside and t1 - t0 > 1e-9:
            return True
    return False


grids = st.integers(0, 2**32 - 1).map(np.random.default_rng)


@settings(max_examples=150, deadline=None)
@given(grids, st.integers(3, 14), st.integers(3, 14), st.floats(0.05, 0.4))
def test_line_of_sight_never_crosses_a_blocked_cell(rng, h, w, density):
    costs = np.where(rng.random((h, w)) < density, 254, 0).astype(np.uint8)
    free = np.argwhere(costs == 0)
    if len(free) < 2:
        return
    i, j = rng.choice(len(free), 2, replace=False)
    a, b = tuple(int(v) for v in free[i]), tuple(int(v) for v in free[j])
    if line_of_sight(costs, a, b):
        assert not segment_hits_blocked_cell(costs == 254, a, b)
    assert line_of_sight(costs, a, b) == line_of_sight(costs, a, b)   # deterministic


def test_line_of_sight_on_a_free_grid_is_always_true_and_a_wall_blocks_it():
    costs = np.zeros((9, 9), np.uint8)
    assert all(line_of_sight(costs, (0, 0), (r, c)) for r in range(9) for c in range(9))
    costs[:, 4] = planning.LETHAL_OBSTACLE
    assert not line_of_sight(costs, (0, 0), (8, 8))
    assert not line_of_sight(costs, (4, 3), (4, 5))


def test_free_grid_path_is_the_straight_line():
    costs = np.zeros((20, 30), np.uint8)
    r = theta_star(costs, (1, 2), (17, 27), w_traversal_cost=0.0)
    assert r.cells.tolist() == [[1, 2], [17, 27]]
    assert r.length == pytest.approx(math.hypot(16, 25))
    assert r.cost == pytest.approx(r.length)


def test_paths_are_visible_segments_never_longer_than_the_grid_optimum():
    rng = np.random.default_rng(11)
    shorter = 0
    for _ in range(25):
        costs = np.where(rng.random((25, 25)) < 0.2, 254, 0).astype(np.uint8)
        free = np.argwhere(costs == 0)
        i, j = rng.choice(len(free), 2, replace=False)
        a, b = tuple(int(v) for v in free[i]), tuple(int(v) for v in free[j])
        r = theta_star(costs, a, b, w_traversal_cost=0.0)
        grid = astar(costs, a, b, cost_travel_multiplier=0.0)
        assert r.found == grid.found
        if not r.found:
            continue
        for p, q in zip(r.cells[:-1], r.cells[1:], strict=True):
            assert not segment_hits_blocked_cell(costs == 254, tuple(p), tuple(q))
        assert math.dist(a, b) - 1e-9 <= r.length <= grid.length + 1e-9
        shorter += r.length < grid.length - 1e-9
    assert shorter >= 15          # any-angle paths beat 8-connected ones most of the time


def test_compiled_theta_star_equals_the_reference():
    rng = np.random.default_rng(5)
    for _ in range(30):
        costs = rng.integers(0, 253, (18, 22)).astype(np.uint8)
        costs[rng.random(costs.shape) < 0.25] = 254
        costs[rng.random(costs.shape) < 0.05] = 255
        free = np.argwhere(costs != 254)
        i, j = rng.choice(len(free), 2, replace=False)
        a, b = tuple(int(v) for v in free[i]), tuple(int(v) for v in free[j])
        for kw in ({}, {"how_many_corners": 4}, {"w_traversal_cost": 5.0, "w_euc_cost": 2.0},
                   {"allow_unknown": False}):
            try:
                ref = theta_star_reference(costs, a, b, **kw)
            except planning.PlanningError:
                continue
            fast = theta_star(costs, a, b, **kw)
            np.testing.assert_array_equal(ref.cells, fast.cells)
            np.testing.assert_array_equal(ref.expanded_cells, fast.expanded_cells)
            assert ref.cost == fast.cost


def test_traversal_cost_pulls_the_path_away_from_costly_cells():
    costs = np.zeros((11, 21), np.uint8)
    costs[4:7, 3:18] = 250                   # a costly band on the straight line
    direct = theta_star(costs, (5, 0), (5, 20), w_traversal_cost=0.0)
    careful = theta_star(costs, (5, 0), (5, 20), w_traversal_cost=50.0)
    assert direct.cells.tolist() == [[5, 0], [5, 20]]
    assert careful.length > direct.length


def test_theta_star_parameters_are_checked():
    with pytest.raises(ValueError, match="w_traversal_cost must be a non-negative"):
        theta_star(np.zeros((3, 3), np.uint8), (0, 0), (2, 2), w_traversal_cost=-1.0)
    with pytest.raises(ValueError, match="must be 4 or 8"):
        theta_star(np.zeros((3, 3), np.uint8), (0, 0), (2, 2), how_many_corners=3)
