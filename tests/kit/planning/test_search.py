"""Grid search: the compiled planners equal their plain references, and both find the
shortest paths scipy's graph Dijkstra finds on the same graph."""

import math

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra as csgraph_dijkstra

from kit import planning
from kit.planning import (
    GridSearch,
    PlanningError,
    astar,
    astar_reference,
    diagonal_allowed,
    dijkstra,
    dijkstra_reference,
    octile_distance,
)

SQRT2 = math.sqrt(2.0)


def random_costs(rng, shape, blocked=0.3, unknown=0.05):
    costs = rng.integers(0, 253, shape).astype(np.uint8)
    costs[rng.random(shape) < blocked] = planning.LETHAL_OBSTACLE
    costs[rng.random(shape) < unknown] = planning.NO_INFORMATION
    return costs


def free_pair(rng, costs, allow_unknown=True):
    ok = (costs <= 252) | (allow_unknown & (costs == 255))
    cells = np.argwhere(ok)
    a, b = rng.choice(len(cells), 2, replace=False)
    return tuple(int(v) for v in cells[a]), tuple(int(v) for v in cells[b])


def csgraph_lengths(costs, start, connectivity, corner_cutting, multiplier, allow_unknown):
    """Shortest path costs from ``start`` with scipy: one directed edge per allowed move,
    weighted step length x (1 + multiplier x cost / 252), as the module docs define."""
    h, w = costs.shape
    ok = (costs <= 252) | (allow_unknown & (costs == 255))
    c = np.where(costs == 255, 252, costs).astype(float)
    moves = [(1, 0), (-1, 0), (0, 1), (0, -1)]
    if connectivity == 8:
        moves += [(1, 1), (1, -1), (-1, 1), (-1, -1)]
    src, dst, weight = [], [], []
    for r in range(h):
        for col in range(w):
            if not ok[r, col]:
                continue
            for dr, dc in moves:
                r1, c1 = r + dr, col + dc
                if not (0 <= r1 < h and 0 <= c1 < w and ok[r1, c1]):
                    continue
                if dr and dc and not corner_cutting and not (ok[r1, col] and ok[r, c1]):
                    continue
                step = SQRT2 if dr and dc else 1.0
                src.append(r * w + col)
                dst.append(r1 * w + c1)
                weight.append(step * (1.0 + multiplier * c[r1, c1] / 252.0))
    graph = coo_matrix((weight, (src, dst)), shape=(h * w, h * w)).tocsr()
    return csgraph_dijkstra(graph, directed=True, indices=start[0] * w + start[1]).reshape(h, w)


@pytest.mark.parametrize("connectivity", [4, 8])
@pytest.mark.parametrize("corner_cutting", [False, True])
@pytest.mark.parametrize("multiplier", [0.0, 2.0])
def test_astar_and_dijkstra_costs_equal_scipy_graph_dijkstra(connectivity, corner_cutting,
                                                            multiplier):
    rng = np.random.default_rng(connectivity * 10 + corner_cutting * 2 + int(multiplier))
    for _ in range(15):
        costs = random_costs(rng, tuple(rng.integers(4, 20, 2)))
        if np.count_nonzero(costs <= 252) < 2:
            continue
        start, goal = free_pair(rng, costs)
        expected = csgraph_lengths(costs, start, connectivity, corner_cutting, multiplier, True)
        for search in (astar, dijkstra):
            r = search(costs, start, goal, connectivity=connectivity,
                       corner_cutting=corner_cutting, cost_travel_multiplier=multiplier)
            if np.isinf(expected[goal]):
                assert not r.found and "not reachable" in r.reason
            else:
                assert r.cost == pytest.approx(expected[goal], rel=1e-12, abs=1e-12)
                assert tuple(r.cells[0]) == start and tuple(r.cells[-1]) == goal


def test_compiled_searches_expand_the_same_cells_as_the_references():
    rng = np.random.default_rng(7)
    for _ in range(40):
        costs = random_costs(rng, tuple(rng.integers(3, 25, 2)))
        if np.count_nonzero(costs <= 252) < 2:
            continue
        start, goal = free_pair(rng, costs, allow_unknown=False)
        for kw in ({}, {"connectivity": 4}, {"corner_cutting": True},
                   {"cost_travel_multiplier": 0.0, "allow_unknown": False}):
            for reference, compiled in ((astar_reference, astar),
                                        (dijkstra_reference, dijkstra)):
                a, b = reference(costs, start, goal, **kw), compiled(costs, start, goal, **kw)
                np.testing.assert_array_equal(a.cells, b.cells)
                np.testing.assert_array_equal(a.expanded_cells, b.expanded_cells)
                assert a.cost == b.cost and a.length == b.length and a.reason == b.reason


def test_astar_expands_no_more_than_dijkstra_and_finds_the_same_cost():
    rng = np.random.default_rng(3)
    costs = random_costs(rng, (60, 60), blocked=0.25, unknown=0.0)
    search = GridSearch(costs)
    for _ in range(10):
        start, goal = free_pair(rng, costs)
        a, d = search.astar(start, goal), search.dijkstra(start, goal)
        assert a.found == d.found
        if a.found:
            assert a.cost == pytest.approx(d.cost, rel=1e-12)
            assert a.expanded <= d.expanded


def test_free_grid_path_is_the_octile_distance():
    costs = np.zeros((30, 40), np.uint8)
    r = astar(costs, (2, 3), (25, 37))
    assert r.length == pytest.approx(octile_distance((2, 3), (25, 37)), rel=1e-12)
    assert r.cost == pytest.approx(r.length)
    r4 = astar(costs, (2, 3), (25, 37), connectivity=4)
    assert r4.length == 23 + 34


def test_no_corner_cutting_goes_around_a_blocked_corner():
    costs = np.zeros((2, 2), np.uint8)
    costs[0, 1] = planning.LETHAL_OBSTACLE
    assert not diagonal_allowed(costs, (0, 0), (1, 1))
    assert diagonal_allowed(costs, (0, 0), (1, 1), corner_cutting=True)
    assert diagonal_allowed(costs, (0, 0), (1, 0))
    assert astar(costs, (0, 0), (1, 1)).length == 2.0
    assert astar(costs, (0, 0), (1, 1), corner_cutting=True).length == pytest.approx(SQRT2)


def test_squeezing_between_diagonal_obstacles_needs_corner_cutting():
    costs = np.array([[0, 254], [254, 0]], np.uint8)
    assert not astar(costs, (0, 0), (1, 1)).found
    assert astar(costs, (0, 0), (1, 1), corner_cutting=True).length == pytest.approx(SQRT2)


def test_ties_are_broken_the_same_way_every_run():
    costs = np.zeros((40, 40), np.uint8)
    first = astar(costs, (0, 0), (39, 20))
    search = GridSearch(costs)
    for _ in range(3):
        again = search.astar((0, 0), (39, 20))
        np.testing.assert_array_equal(again.cells, first.cells)
        np.testing.assert_array_equal(again.expanded_cells, first.expanded_cells)


def test_costs_steer_the_path_away_from_high_cost_cells():
    costs = np.zeros((5, 9), np.uint8)
    costs[2, 1:8] = 200                      # a costly band across the straight line
    costs[0, :] = 0
    plain = astar(costs, (2, 0), (2, 8), cost_travel_multiplier=0.0)
    careful = astar(costs, (2, 0), (2, 8), cost_travel_multiplier=2.0)
    assert plain.length == 8.0
    assert careful.length > plain.length
    assert all(costs[r, c] < 200 for r, c in careful.cells)


def test_unknown_cells_are_used_only_when_allowed():
    costs = np.full((3, 5), planning.LETHAL_OBSTACLE, np.uint8)
    costs[1, :] = [0, 255, 255, 255, 0]
    assert astar(costs, (1, 0), (1, 4)).found
    blocked = astar(costs, (1, 0), (1, 4), allow_unknown=False)
    assert not blocked.found and blocked.cost == math.inf and len(blocked.cells) == 0


def test_a_walled_in_goal_is_a_result_with_a_reason_not_an_exception():
    costs = np.zeros((7, 7), np.uint8)
    costs[2:5, 2] = costs[2:5, 4] = costs[2, 2:5] = costs[4, 2:5] = planning.LETHAL_OBSTACLE
    for search in (astar, dijkstra, astar_reference, planning.theta_star):
        r = search(costs, (0, 0), (3, 3))
        assert not r.found and r.reason.startswith("no path from (0, 0) to (3, 3)")
        assert r.expanded == 49 - 9                   # everything reachable was tried


@pytest.mark.parametrize(("start", "goal", "message", "code"), [
    ((5, 0), (0, 0), r"start \(row, col\) = \(5, 0\) is off the 5 x 6 grid",
     planning.START_OUTSIDE_MAP),
    ((0, 0), (0, -1), r"goal \(row, col\) = \(0, -1\) is off the 5 x 6 grid",
     planning.GOAL_OUTSIDE_MAP),
    ((2, 2), (0, 0), r"start \(row, col\) = \(2, 2\) is in an obstacle: cost 254",
     planning.START_OCCUPIED),
    ((0, 0), (3, 3), r"goal \(row, col\) = \(3, 3\) is in an obstacle: cost 253",
     planning.GOAL_OCCUPIED),
])
def test_start_or_goal_off_the_grid_or_in_an_obstacle_is_an_error(start, goal, message, code):
    costs = np.zeros((5, 6), np.uint8)
    costs[2, 2], costs[3, 3] = planning.LETHAL_OBSTACLE, planning.INSCRIBED_INFLATED_OBSTACLE
    for search in (astar, astar_reference, planning.theta_star_reference, planning.theta_star):
        with pytest.raises(PlanningError, match=message) as info:
            search(costs, start, goal)
        assert info.value.error_code == code


def test_bad_grids_and_options_are_errors():
    with pytest.raises(TypeError, match="not a boolean grid"):
        astar(np.ones((3, 3), bool), (0, 0), (1, 1))
    with pytest.raises(ValueError, match="uint8 array"):
        astar(np.zeros((3, 3)), (0, 0), (1, 1))
    with pytest.raises(ValueError, match="must be 4 or 8; got 6"):
        astar(np.zeros((3, 3), np.uint8), (0, 0), (1, 1), connectivity=6)
    with pytest.raises(ValueError, match="cost_travel_multiplier must be a non-negative"):
        GridSearch(np.zeros((3, 3), np.uint8), cost_travel_multiplier=-1.0)
    with pytest.raises(TypeError, match=r"start must be a \(row, col\) pair"):
        astar(np.zeros((3, 3), np.uint8), 4, (1, 1))


def test_the_pieces_students_write_give_the_textbook_numbers():
    assert octile_distance((0, 0), (3, 5)) == pytest.approx(2 + 3 * SQRT2)
    assert planning.manhattan_distance((1, 1), (4, -1)) == 5.0
    assert planning.traversal_cost(0, SQRT2, 2.0) == pytest.approx(SQRT2)
    assert planning.traversal_cost(126, 1.0, 2.0) == pytest.approx(2.0)
    assert planning.traversal_cost(255, 1.0, 2.0) == pytest.approx(3.0)   # unknown as 252
    assert planning.traversable(252, False) and not planning.traversable(253, True)
    assert planning.traversable(255, True) and not planning.traversable(255, False)
