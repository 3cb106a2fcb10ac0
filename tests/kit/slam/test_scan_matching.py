"""Scan matching: point-to-line ICP and the correlative matcher, on synthetic rooms with known
poses, against an exhaustive search, and on the CSAIL log's ground-truth relations."""

from __future__ import annotations

import numpy as np
import pytest

from kit import geometry, perception
from kit.slam import carmen
from kit.slam import scan_matching as sm


def walls(corners, spacing=0.02):
    """Points every ``spacing`` metres along a closed polyline."""
    pts = []
    for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        n = max(2, int(np.hypot(*(b - a)) / spacing))
        t = np.linspace(0, 1, n, endpoint=False)[:, None]
        pts.append(a + t * (b - a))
    return np.vstack(pts)


ROOM = np.array([[0, 0], [6, 0], [6, 4], [3.5, 4], [3.5, 2.5], [2.5, 2.5], [2.5, 4], [0, 4]],
                float)


def seen_from(points, pose, rng=None, noise=0.0, max_range=8.0):
    """The points in the frame of ``pose`` (a scan taken there, without occlusion)."""
    local = geometry.transform_points(geometry.inverse(pose), points)
    local = local[np.hypot(local[:, 0], local[:, 1]) < max_range]
    if rng is not None and noise:
        local = local + rng.normal(0, noise, local.shape)
    return local


def test_normals_of_a_wall_are_perpendicular_to_it_and_corners_unusable():
    pts = walls(np.array([[0, 0], [2, 0], [2, 2], [0, 2]], float), 0.05)
    n, ok = sm.estimate_normals(pts, neighbours=5)
    on_bottom = (pts[:, 1] == 0) & (pts[:, 0] > 0.3) & (pts[:, 0] < 1.7)
    assert ok[on_bottom].all()
    assert np.allclose(np.abs(n[on_bottom, 1]), 1.0, atol=1e-9)
    corner = np.argmin(np.hypot(pts[:, 0] - 2, pts[:, 1] - 2))
    assert not ok[corner]


def test_icp_recovers_a_known_pose_in_a_room():
    rng = np.random.default_rng(0)
    reference = walls(ROOM)
    truth = np.array([2.0, 1.2, 0.3])
    source = seen_from(reference, truth, rng, noise=0.005)
    result = sm.icp(source, reference, truth + np.array([0.15, -0.1, 0.08]))
    assert result.converged
    assert np.allclose(result.pose, truth, atol=[3e-3, 3e-3, 2e-3])
    assert result.rmse < 0.01 and result.inlier_fraction > 0.85
    cov = result.covariance
    assert np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) > 0)


def test_one_icp_iteration_moves_towards_the_truth():
    reference = walls(ROOM)
    truth = np.array([2.0, 1.2, 0.3])
    source = seen_from(reference, truth)
    ref = sm.PointCloudReference(reference)
    start = truth + np.array([0.05, 0.05, 0.02])
    new, H, r = sm.icp_iteration(source, ref, start)
    assert np.abs(new - truth).max() < 0.3 * np.abs(start - truth).max()
    assert H.shape == (3, 3) and np.all(np.linalg.eigvalsh(H) > 0)
    assert r.ndim == 1 and len(r) > 100


def test_trimming_ignores_clutter_that_is_not_in_the_reference():
    rng = np.random.default_rng(1)
    reference = walls(ROOM)
    truth = np.array([1.5, 2.0, -0.2])
    source = seen_from(reference, truth, rng, noise=0.003)
    clutter = rng.uniform(-0.6, 0.6, (len(source) // 8, 2))  # people near the sensor
    result = sm.icp(np.vstack([source, clutter]), reference, truth + np.array([0.05, 0.05, 0.03]),
                    config=sm.IcpConfig(trim=0.8))
    assert np.allclose(result.pose, truth, atol=[5e-3, 5e-3, 3e-3])


def test_in_a_corridor_the_prior_holds_the_unobservable_direction():
    corridor = np.vstack([np.column_stack([np.arange(0, 30, 0.02), np.zeros(1500)]),
                          np.column_stack([np.arange(0, 30, 0.02), np.full(1500, 1.5)])])
    truth = np.array([10.0, 0.7, 0.0])
    source = seen_from(corridor, truth)
    guess = truth + np.array([0.3, 0.05, 0.02])   # odometry 0.3 m off along the corridor
    info = np.diag([1 / 0.1**2, 1 / 0.1**2, 1 / 0.05**2])
    result = sm.icp(source, corridor, guess, prior_information=info)
    assert abs(result.pose[0] - guess[0]) < 0.01        # along: the prior decides
    assert abs(result.pose[1] - truth[1]) < 0.005       # across: the walls decide
    assert abs(result.pose[2] - truth[2]) < 0.002
    sd = np.sqrt(np.diag(result.covariance))
    assert sd[0] > 0.05 > 10 * sd[1]                    # and the covariance says so


def stepped_icp(source, ref, initial, omega=None):
    """:func:`sm.icp`'s loop written with :func:`sm.icp_iteration` (numpy, the k-d tree):
    ``(pose, H, pairs, sum of squared residuals, iterations)``."""
    prior = np.array(initial, float) if omega is not None else None
    x = np.array(initial, float)
    for it in range(1, ref.config.max_iterations + 1):  # noqa: B007
        new, _, r = sm.icp_iteration(source, ref, x, prior, omega)
        moved = max(abs(new[0] - x[0]), abs(new[1] - x[1]),
                    abs(float(geometry.wrap_angle(new[2] - x[2]))))
        x = new
        if len(r) < 3 or moved < ref.config.tolerance:
            break
    _, H, r = sm.icp_iteration(source, ref, x, prior, omega)
    return x, H, len(r), float(r @ r), it


def test_the_buckets_find_the_k_d_trees_nearest_point_within_the_bound(monkeypatch):
    """ICP's nearest-neighbour search gives scipy's cKDTree answer, for queries on the
    points, near them, beyond the reference's extent and far away, and with the cells
    widened for a reference spread too wide for the usual cell count."""
    from scipy.spatial import cKDTree

    sm._compiled_icp()
    rng = np.random.default_rng(7)
    for trial in range(12):
        if trial == 8:
            monkeypatch.setattr(sm._Buckets, "MAX_CELLS", 50)
        points = rng.uniform(-5, 5, (int(rng.integers(1, 2500)), 2)) * rng.uniform(0.05, 4)
        queries = rng.uniform(-30, 30, (1500, 2))
        queries[:1000] = points[rng.integers(0, len(points), 1000)] + \
            rng.normal(0, 0.3, (1000, 2))
        bound = float(rng.choice([0.1, 0.5, 2.0]))
        b = sm._Buckets.of(points, bound)
        d, idx = cKDTree(points).query(queries, k=1, distance_upper_bound=bound)
        found = [sm._nearest(x, y, points, b.origin, b.cell, b.width, b.height, b.start,
                             b.order, bound) for x, y in queries]
        assert np.array_equal(found, np.where(d < np.inf, idx, -1)), trial
    assert b.width * b.height <= 2 * 50
    for x, y in [(np.nan, 0.0), (0.0, np.inf), (1e300, 0.0), (-1e20, 5.0)]:  # a wild pose
        assert sm._nearest(x, y, points, b.origin, b.cell, b.width, b.height, b.start,
                           b.order, bound) == -1


@pytest.mark.parametrize("prior", [False, True])
def test_compiled_icp_takes_icp_iterations_steps_to_rounding(prior):
    """The compiled loop lands where stepping :func:`sm.icp_iteration` lands, after as
    many iterations, with as many pairs, the same residuals and the same covariance (to
    rounding), from near and far starts, in clutter, and with nothing to pair with."""
    rng = np.random.default_rng(3)
    reference = walls(ROOM)
    omega = sm.ODOMETRY_PRIOR if prior else None
    for trial in range(40):
        truth = np.array([rng.uniform(1, 5), rng.uniform(0.5, 3.5), rng.uniform(-3, 3)])
        source = seen_from(reference, truth, rng, noise=0.01)
        if trial % 4 == 1:
            source = np.vstack([source, rng.uniform(-1, 1, (len(source) // 5, 2))])
        if trial % 10 == 9:
            source = source[:5] + 50.0       # nothing pairs: a singular system, no step
        ref = sm.PointCloudReference(reference, sm.IcpConfig(trim=[0.9, 0.7][trial % 2]))
        start = truth + rng.normal(0, [0.15, 0.15, 0.08])
        result = sm.icp(source, ref, start, omega)
        x, H, pairs, squares, iterations = stepped_icp(source, ref, start, omega)
        assert result.iterations == iterations, trial
        assert np.allclose(result.pose, x, rtol=0, atol=1e-9), trial
        assert round(result.inlier_fraction * len(source)) == pairs, trial
        assert result.rmse == pytest.approx(np.sqrt(squares / max(pairs, 1)), rel=1e-9)
        sigma2 = ref.config.sigma**2
        info = H * (sigma2 / max(squares / max(pairs - 3, 1), sigma2))
        covariance = sm._inverse(info if omega is None else info + omega)
        assert np.allclose(result.covariance, covariance, rtol=1e-6, atol=1e-15), trial


def test_bad_input_is_rejected():
    with pytest.raises(ValueError, match=r"shape \(M, 2\)"):
        sm.icp(np.zeros((5, 3)), walls(ROOM), [0, 0, 0])
    with pytest.raises(ValueError, match="NaN"):
        sm.icp(np.full((5, 2), np.nan), walls(ROOM), [0, 0, 0])
    for omega in (np.full((3, 3), np.nan), np.eye(2)):
        with pytest.raises(ValueError, match="finite 3 × 3"):
            sm.icp(walls(ROOM)[::3], walls(ROOM), [0, 0, 0], omega)
    with pytest.raises(ValueError, match="trim"):
        sm.IcpConfig(trim=0.0)
    with pytest.raises(ValueError, match="at least one"):
        sm.likelihood_field(np.zeros((0, 2)))


def exhaustive(source, field, initial, window, angles):
    """Every pose of the grid, scored the slow way."""
    res = field.resolution
    half = int(np.ceil(window / res))
    best = (-1.0, None)
    h, w = field.values.shape
    for a in angles:
        q = geometry.transform_points([initial[0], initial[1], a], source)
        ix = np.floor((q[:, 0] - field.origin[0]) / res).astype(int)
        iy = np.floor((q[:, 1] - field.origin[1]) / res).astype(int)
        for dx in range(-half, half + 1):
            for dy in range(-half, half + 1):
                cx, cy = ix + dx, iy + dy
                ok = (cx >= 0) & (cx < w) & (cy >= 0) & (cy < h)
                score = np.where(ok, field.values[np.clip(cy, 0, h - 1),
                                                  np.clip(cx, 0, w - 1)], 0).mean()
                if score > best[0]:
                    best = (score, (initial[0] + dx * res, initial[1] + dy * res, a))
    return best


def test_correlative_branch_and_bound_finds_the_exhaustive_optimum():
    rng = np.random.default_rng(2)
    reference = walls(ROOM, 0.05)
    field = sm.likelihood_field(reference, resolution=0.05, sigma=0.05)
    truth = np.array([2.0, 1.2, 0.3])
    source = seen_from(reference, truth, rng, noise=0.01)
    initial = truth + np.array([0.2, -0.15, 0.1])
    result = sm.correlative_match(source, field, initial, linear_window=0.3,
                                  angular_window=0.15, angular_step=0.02, coarse_factor=3)
    n = int(np.floor(0.15 / 0.02))
    score, pose = exhaustive(source, field, initial, 0.3 / 0.05 // 3 * 3 * 0.05 + 1e-9,
                             initial[2] + 0.02 * np.arange(-n, n + 1))
    assert result.response == pytest.approx(score, abs=1e-12)
    assert np.allclose(result.pose, pose)
    assert np.allclose(result.pose, truth, atol=[0.05, 0.05, 0.02])


def test_correlative_match_escapes_where_icp_is_trapped_and_reports_its_spread():
    reference = walls(ROOM, 0.05)
    field = sm.likelihood_field(reference, resolution=0.05, sigma=0.05)
    truth = np.array([4.5, 1.0, 0.0])
    source = seen_from(reference, truth)
    initial = truth + np.array([-0.45, 0.4, 0.3])
    result = sm.correlative_match(source, field, initial, linear_window=0.6,
                                  angular_window=0.4)
    assert np.allclose(result.pose, truth, atol=[0.05, 0.05, 0.02])
    assert result.response > 0.8
    cov = result.covariance
    assert np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) > 0)
    assert np.sqrt(cov[0, 0]) < 0.1 and np.sqrt(cov[2, 2]) < 0.05


@pytest.mark.dataset
def test_icp_beats_odometry_on_the_csail_local_relations(shared_data):
    """Every fifth ≤ 1 s relation (the benchmark script runs all 1,040): scan-to-scan ICP
    from the raw odometry guess must stay within the issue's 0.03 m and 0.5° means."""
    bench = shared_data / "kummerle2009-slam-benchmark"
    log = carmen.read_carmen(bench / "mit-csail.clf.gz")
    rel = carmen.read_relations(bench / "mit-csail.relations")
    index = {round(t, 3): k for k, t in enumerate(log.laser_timestamps)}
    local = np.flatnonzero(np.abs(rel.t2 - rel.t1) <= 1.0)[::5]
    odo = np.array([r.robot_pose for r in log.lasers])
    trans, rot, odo_rot = [], [], []
    for k in local:
        i, j = index[round(rel.t1[k], 3)], index[round(rel.t2[k], 3)]
        scans = [perception.scan_to_points(carmen.laser_to_scan(log.lasers[m])) for m in (i, j)]
        guess = geometry.relative(odo[i], odo[j])
        result = sm.icp(scans[1], scans[0], guess, sm.ODOMETRY_PRIOR)
        eps = geometry.compose(geometry.inverse(result.pose), rel.delta[k])
        trans.append(np.hypot(eps[0], eps[1]))
        rot.append(abs(float(geometry.wrap_angle(eps[2]))))
        odo_rot.append(abs(float(geometry.wrap_angle(
            geometry.compose(geometry.inverse(guess), rel.delta[k])[2]))))
    assert np.mean(trans) <= 0.03
    assert np.degrees(np.mean(rot)) <= 0.5 < np.degrees(np.mean(odo_rot))


def test_compiled_likelihood_field_equals_the_distance_transform_within_four_sigma():
    """The smeared field (numba) is the exact distance transform's wherever the nearest
    reference cell lies within 4σ, and at most e⁻⁸ below it elsewhere."""
    from kit.slam import correlative

    rng = np.random.default_rng(5)
    points = np.vstack([walls(ROOM, 0.03), rng.uniform(0, 6, (40, 2))])
    exact = correlative.likelihood_field(points, 0.02, 0.03, margin=0.3, method="numpy")
    fast = correlative.likelihood_field(points, 0.02, 0.03, margin=0.3, method="numba")
    assert fast.values.shape == exact.values.shape
    assert np.allclose(fast.origin, exact.origin)
    assert np.abs(fast.values - exact.values).max() <= np.exp(-8.0) + 1e-12
    with pytest.raises(ValueError, match="'numba' or 'numpy'"):
        correlative.likelihood_field(points, method="edt")


@pytest.mark.parametrize("penalty", [0.0, 0.3])
def test_compiled_branch_and_bound_equals_the_exhaustive_numpy_search(penalty):
    """Branch and bound (compiled) returns the exhaustive search's pose and response, with
    and without the penalty toward the guess, also when the window reaches past the field's
    edge (the coarse bound must hold for blocks that only partly overlap it)."""
    from kit.slam import correlative

    rng = np.random.default_rng(6)
    reference = walls(ROOM, 0.05)
    field = correlative.likelihood_field(reference, 0.05, 0.05, margin=0.1)
    for trial in range(4):
        truth = np.array([rng.uniform(1, 5), rng.uniform(0.5, 3.5), rng.uniform(-3, 3)])
        source = seen_from(reference, truth, rng, noise=0.01)
        initial = truth + np.array([*rng.uniform(-0.25, 0.25, 2), rng.uniform(-0.1, 0.1)])
        kw = dict(linear_window=0.4, angular_window=0.12, angular_step=0.02,
                  coarse_factor=3 + trial % 2, penalty=penalty)
        fast = correlative.correlative_match(source, field, initial, method="numba", **kw)
        slow = correlative.correlative_match(source, field, initial, method="numpy", **kw)
        assert np.allclose(fast.pose, slow.pose)
        assert fast.response == pytest.approx(slow.response, abs=1e-12)
        assert np.allclose(fast.covariance, slow.covariance)


def test_a_penalty_picks_the_pose_nearest_the_guess_where_a_corridor_cannot_tell():
    """Along a featureless corridor every shift scores alike; Karto's penalty makes the
    search keep the guess's position along it (and the walls still fix the rest)."""
    from kit.slam import correlative

    corridor = np.vstack([np.column_stack([np.arange(0, 30, 0.02), np.zeros(1500)]),
                          np.column_stack([np.arange(0, 30, 0.02), np.full(1500, 1.5)])])
    truth = np.array([10.0, 0.7, 0.0])
    source = seen_from(corridor, truth, max_range=4.0)
    field = correlative.likelihood_field(corridor, 0.05, 0.05)
    guess = truth + np.array([0.2, 0.1, 0.02])
    result = correlative.correlative_match(source, field, guess, 0.4, 0.05, 0.01,
                                           penalty=0.2)
    assert result.pose[0] == pytest.approx(guess[0], abs=1e-9)
    assert result.pose[1] == pytest.approx(truth[1], abs=0.05)
    assert result.pose[2] == pytest.approx(truth[2], abs=0.011)
    with pytest.raises(ValueError, match="penalty"):
        correlative.correlative_match(source, field, guess, penalty=1.0)


def test_the_partition_picks_the_sorted_element_and_the_elimination_solves_as_lapack():
    """ICP's two compiled helpers against numpy: the k-th smallest of arrays with ties is
    ``np.sort``'s k-th element, for every k; a 3 × 3 system is solved as
    ``np.linalg.solve`` solves it (the residual at rounding, the answers no farther apart
    than the condition number lets two backward-stable solvers be), and the exactly
    singular ones that LAPACK refuses are refused."""
    sm._compiled_icp()
    rng = np.random.default_rng(11)
    for trial in range(60):
        values = np.round(rng.exponential(1.0, int(rng.integers(1, 120))), trial % 3)
        ranked = np.sort(values)
        for k in range(len(values)):
            assert sm._smallest(values.copy(), k) == ranked[k], (trial, k)
    for trial in range(400):
        A = rng.normal(0, 1, (3, 3)) * 10.0 ** rng.uniform(-2, 2, 3)
        if trial % 2:
            A = A @ A.T                                 # symmetric, as ICP's systems are
        b = rng.normal(0, 1, 3)
        x, solved = sm._solve3(A, b)
        assert solved
        # both backward stable: residuals at rounding, answers apart at most cond(A) · ε
        eps, expected = np.finfo(np.float64).eps, np.linalg.solve(A, b)
        assert np.linalg.norm(A @ x - b) <= 50 * eps * np.linalg.norm(A) * np.linalg.norm(x)
        assert np.linalg.norm(x - expected) <= \
            50 * eps * np.linalg.cond(A) * np.linalg.norm(expected), trial
    singular = [np.zeros((3, 3)), np.array([[1.0, 2, 3], [1, 2, 3], [0, 1, 5]]),
                np.array([[0.0, 2, 3], [0, 1, 4], [0, 7, 5]]),
                np.array([[4.0, 0, 1], [0, 0, 0], [1, 0, 2]])]
    for A in singular:
        with pytest.raises(np.linalg.LinAlgError):
            np.linalg.solve(A, np.ones(3))
        assert not sm._solve3(A, np.ones(3))[1]


def test_a_straight_wall_is_an_exactly_singular_system_solved_by_least_squares(monkeypatch):
    """Along one straight wall nothing fixes the pose along the wall: each iteration's
    system is exactly singular, and the compiled loop hands it to numpy's least squares
    (the minimum-norm step, no slide along the wall), landing where icp_iteration's steps
    land."""
    calls = []
    lstsq = np.linalg.lstsq
    monkeypatch.setattr(np.linalg, "lstsq", lambda *a, **k: calls.append(1) or lstsq(*a, **k))
    wall = np.column_stack([np.linspace(-4, 4, 161), np.zeros(161)])
    ref = sm.PointCloudReference(wall)
    truth = np.array([0.0, 0.3, 0.0])
    source = geometry.transform_points(geometry.inverse(truth), wall[20:140])
    start = [0.05, 0.2, 0.02]
    result = sm.icp(source, ref, start)
    compiled_calls = len(calls)
    x, _, pairs, _, iterations = stepped_icp(source, ref, start, None)
    assert compiled_calls >= 1 and len(calls) > compiled_calls
    assert result.iterations == iterations
    assert np.allclose(result.pose, x, rtol=0, atol=1e-9)
    assert abs(result.pose[1] - 0.3) < 1e-6 and abs(result.pose[2]) < 1e-9
    assert round(result.inlier_fraction * len(source)) == pairs
