"""Path measures and Nav2's smoothers: exact on known geometry, Savitzky–Golay weights equal
scipy's, smoothing never moves a point onto a costly cell."""

import numpy as np
import pytest
from scipy.signal import savgol_coeffs

from kit.planning import (
    LETHAL_OBSTACLE,
    Costmap,
    astar,
    curvature,
    inflate,
    path_length,
    resample,
    savitzky_golay_coefficients,
    savitzky_golay_smooth,
    simple_smooth,
)


def test_length_and_curvature_of_known_curves():
    t = np.linspace(0, 1.5 * np.pi, 200)
    arc = np.column_stack([3 * np.cos(t), 3 * np.sin(t)])
    assert path_length(arc) == pytest.approx(3 * 1.5 * np.pi, rel=1e-4)
    np.testing.assert_allclose(curvature(arc)[1:-1], 1 / 3, rtol=1e-9)
    np.testing.assert_allclose(curvature(arc[::-1])[1:-1], -1 / 3, rtol=1e-9)  # clockwise
    assert (curvature([[0, 0], [1, 0], [2, 0], [2, 0]]) == 0).all()


def test_resample_spaces_waypoints_evenly_along_the_path():
    points = resample([[0, 0], [3, 0], [3, 4]], 0.25)
    steps = np.hypot(*np.diff(points, axis=0).T)
    np.testing.assert_allclose(steps[:-1], 0.25, atol=1e-12)
    assert points[-1].tolist() == [3.0, 4.0] and len(points) == 29
    with pytest.raises(ValueError, match="spacing must be a positive"):
        resample([[0, 0], [1, 0]], 0)


@pytest.mark.parametrize(("window", "order"), [(5, 2), (7, 3), (9, 2), (11, 4)])
def test_savitzky_golay_weights_equal_scipy(window, order):
    np.testing.assert_allclose(savitzky_golay_coefficients(window, order),
                               savgol_coeffs(window, order), atol=1e-12)


def test_savitzky_golay_keeps_polynomials_of_its_order():
    x = np.linspace(0, 4, 30)
    cubic = np.column_stack([x, 0.1 * x ** 3 - x ** 2])
    once = savitzky_golay_smooth(cubic, window_size=7, poly_order=3, do_refinement=False)
    # points whose whole window lies on the path are fitted exactly; each refinement pass
    # carries the repeated-end effect three points further in
    np.testing.assert_allclose(once.points[3:-3], cubic[3:-3], atol=1e-9)
    thrice = savitzky_golay_smooth(cubic, window_size=7, poly_order=3)
    np.testing.assert_allclose(thrice.points[9:-9], cubic[9:-9], atol=1e-9)
    assert once.reason == thrice.reason == "" and thrice.iterations == 3
    with pytest.raises(ValueError, match="window_size must be odd"):
        savitzky_golay_coefficients(6, 2)


def zigzag_costmap():
    """A corridor with a pillar: an 8-connected path around it zigzags."""
    costs = np.zeros((40, 60), np.uint8)
    costs[15:25, 28:32] = LETHAL_OBSTACLE
    costs = inflate(costs, 0.05, inscribed_radius=0.1, inflation_radius=0.3)
    return Costmap(costs, 0.05)


def grid_path(cm):
    r = astar(cm.costs, (20, 2), (21, 57), cost_travel_multiplier=0.0)
    return np.array([cm.cell_to_world(int(a), int(b)) for a, b in r.cells])


@pytest.mark.parametrize("smoother", [simple_smooth, savitzky_golay_smooth])
def test_smoothing_straightens_the_path_and_keeps_it_off_obstacles(smoother):
    cm = zigzag_costmap()
    raw = grid_path(cm)
    out = smoother(raw, cm)
    assert out.points[0].tolist() == raw[0].tolist()
    assert out.points[-1].tolist() == raw[-1].tolist()
    assert np.abs(curvature(out.points)).max() < np.abs(curvature(raw)).max()
    assert path_length(out.points) <= path_length(raw)
    cells = np.floor(out.points / cm.resolution).astype(int)
    assert (cm.costs[cells[:, 1], cells[:, 0]] <= 252).all()


def cell_costs(cm, points):
    cells = np.floor(points / cm.resolution).astype(int)
    return cm.costs[cells[:, 1], cells[:, 0]]


def test_simple_smoother_keeps_the_clearance_it_is_asked_for():
    cm = zigzag_costmap()
    raw = grid_path(cm)
    limit = int(cell_costs(cm, raw).max())          # no point closer than the grid path's
    free = simple_smooth(raw, None)                 # without a costmap it cuts closer
    assert cell_costs(cm, free.points).max() > limit
    kept = simple_smooth(raw, cm, max_cost=limit)
    assert kept.reason.startswith("stopped at iteration")
    assert cell_costs(cm, kept.points).max() <= limit
    assert np.abs(curvature(kept.points)).max() < np.abs(curvature(raw)).max()


def test_straight_lines_stay_straight_and_short_paths_are_left_alone():
    line = np.column_stack([np.linspace(0, 5, 20), np.linspace(1, 2, 20)])
    np.testing.assert_allclose(simple_smooth(line).points, line, atol=1e-9)
    two = np.array([[0.0, 0.0], [1.0, 1.0]])
    assert simple_smooth(two).points.tolist() == two.tolist()
    assert "no piece of at least" in savitzky_golay_smooth(two).reason
    with pytest.raises(ValueError, match=r"\(N, 2\) array of finite"):
        simple_smooth([[0, 0, 0]])


def test_savitzky_golay_rejects_a_result_that_would_collide():
    costs = np.zeros((8, 8), np.uint8)
    costs[1, 4] = LETHAL_OBSTACLE                # inside the corner of an L-shaped path
    cm = Costmap(costs, 1.0)
    corner = np.array([[0.5 + i, 0.5] for i in range(6)] + [[5.5, 1.5 + i] for i in range(5)])
    out = savitzky_golay_smooth(corner, cm, window_size=5, poly_order=1, do_refinement=False)
    # the corner point becomes the mean of its window, (4.9, 1.1): cell (1, 4), lethal
    assert out.reason.startswith("rejected: point 5 ")
    np.testing.assert_array_equal(out.points, corner)
    free = savitzky_golay_smooth(corner, Costmap(np.zeros((8, 8), np.uint8), 1.0),
                                 window_size=5, poly_order=1, do_refinement=False)
    np.testing.assert_allclose(free.points[5], [4.9, 1.1])


def _zigzag(n):
    x = np.arange(n) * 0.1
    return np.column_stack([x, 0.05 * np.sin(2.1 * x / 0.1)])


def test_pieces_too_short_for_nav2s_smoothers_are_left_alone():
    """Nav2 smooths a piece only when ``end − start > 3`` (simple: 5 points) or ``> 9``
    (Savitzky–Golay's 7-point filter: 11 points); shorter ones come back as they went in."""
    for n, moved in ((4, False), (5, True)):
        path = _zigzag(n)
        assert (np.abs(simple_smooth(path).points - path).max() > 1e-3) == moved, n
    for n, moved in ((10, False), (11, True)):
        path = _zigzag(n)
        assert (np.abs(savitzky_golay_smooth(path).points - path).max() > 1e-3) == moved, n


def test_max_its_counts_as_nav2s_loop_does():
    """Nav2's loop stops, undoing nothing more, when its count reaches ``max_its``: at most
    ``max_its − 1`` iterations. One iteration is one Gauss–Seidel sweep of Nav2's update."""
    path = _zigzag(8)
    none = simple_smooth(path, max_its=1, do_refinement=False)
    assert none.iterations == 0 and none.points.tolist() == path.tolist()
    one = simple_smooth(path, max_its=2, do_refinement=False)
    y = path.copy()
    for i in range(1, len(y) - 1):
        y[i] += 0.2 * (path[i] - y[i]) + 0.3 * (y[i + 1] + y[i - 1] - 2.0 * y[i])
    assert one.iterations == 1 and "did not converge" in one.reason
    np.testing.assert_array_equal(one.points, y)


def test_a_cusp_splits_the_path_and_stays_where_it_is():
    """A three-point turn: forward along x, then back up and to the left. Nav2 smooths each
    piece between cusps on its own (``findDirectionalPathSegments``), keeping the cusp."""
    forward = np.column_stack([np.linspace(0.0, 1.0, 11), 0.02 * np.sin(np.arange(11))])
    back = np.column_stack([np.linspace(0.95, 0.3, 14), np.linspace(0.05, 0.7, 14)])
    path = np.vstack([forward, back])
    from kit.planning._smoothing import segments
    assert segments(path) == [(0, 10), (10, 24)]
    for smoother in (simple_smooth, savitzky_golay_smooth):
        out = smoother(path).points
        np.testing.assert_array_equal(out[10], path[10])
        np.testing.assert_array_equal(out[:11], smoother(path[:11]).points)
        np.testing.assert_array_equal(out[10:], smoother(path[10:]).points)
