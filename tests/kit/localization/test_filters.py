"""kit.localization's building blocks against numbers nobody here invented: the textbook's
histogram example, brute-force distances, the χ² quantile KLD-sampling approximates, the
low-variance sampler's guarantee, the three implementations of the likelihood field's hot
loop, and Nav2's own amcl parameter file."""

import math

import numpy as np
import pytest
from scipy import stats

from kit import msgs
from kit.localization import histogram as hist
from kit.localization.amcl import AmclParameters, load_parameters
from kit.localization.likelihood_field import (
    LikelihoodField,
    LikelihoodFieldModel,
    likelihood_field_weight,
    likelihood_field_weights,
)
from kit.localization.particles import (
    cluster_labels,
    effective_sample_size,
    kld_sample_limit,
    low_variance_resample,
    normalize_log_weights,
)


def test_histogram_filter_reproduces_the_cyclic_world_example():
    """Thrun's five-cell cyclic world (green, red, red, green, green): sense red, move 1,
    sense green, move 1 with p_hit 0.6, p_miss 0.2 and an 0.1/0.8/0.1 motion: the published
    final belief."""
    world = ["green", "red", "red", "green", "green"]
    belief = np.full(5, 0.2)
    for z in ("red", "green"):
        belief = hist.sense(belief, hist.binary_likelihood(world, z, 0.6, 0.2))
        belief = hist.move(belief, 1, {-1: 0.1, 0: 0.8, 1: 0.1})
    expected = [0.21157894736842103, 0.15157894736842106, 0.08105263157894739,
                0.16842105263157894, 0.3873684210526316]
    np.testing.assert_allclose(belief, expected, rtol=1e-12)


def test_histogram_first_sense_step_matches_bayes_rule_by_hand():
    prior = np.array([0.1, 0.2, 0.3, 0.4])
    likelihood = np.array([0.9, 0.1, 0.1, 0.9])
    posterior = hist.sense(prior, likelihood)
    by_hand = prior * likelihood / np.sum(prior * likelihood)
    np.testing.assert_allclose(posterior, by_hand, rtol=1e-15)
    with pytest.raises(ValueError, match="impossible"):
        hist.sense([1.0, 0.0], [0.0, 1.0])


def grid_message(occupied, resolution=0.1, origin=(-1.0, -2.0)):
    h, w = occupied.shape
    info = msgs.MapMetaData(resolution=resolution, width=w, height=h,
                            origin=msgs.Pose(msgs.Point(origin[0], origin[1], 0.0)))
    return msgs.OccupancyGrid(msgs.Header(frame_id="map"), info,
                              np.where(occupied, 100, 0).astype(np.int8).ravel())


def test_likelihood_field_distances_equal_a_brute_force_search():
    rng = np.random.default_rng(4)
    occupied = rng.random((30, 40)) < 0.03
    field = LikelihoodField.from_grid(grid_message(occupied), max_distance=1.0)
    res = float(np.float32(0.1))
    walls = np.argwhere(occupied)
    for row, col in np.argwhere(np.ones_like(occupied))[::7]:
        nearest = np.min(np.hypot(walls[:, 0] - row, walls[:, 1] - col)) * res
        assert field.distance[row, col] == pytest.approx(min(nearest, 1.0), abs=1e-9)


def test_the_three_likelihood_field_loops_agree():
    """The plain per-particle loop, the numpy version and the numba one give one answer, in
    both of AMCL's ways of combining beams."""
    rng = np.random.default_rng(5)
    occupied = np.zeros((60, 80), bool)
    occupied[[0, -1], :] = occupied[:, [0, -1]] = True
    occupied[30, 20:50] = True
    field = LikelihoodField.from_grid(grid_message(occupied))
    poses = np.column_stack([rng.uniform(0, 6, 50), rng.uniform(-1, 3, 50),
                             rng.uniform(-np.pi, np.pi, 50)])
    endpoints = rng.uniform(-4, 4, (60, 2))
    for combine in ("amcl", "product"):
        model = LikelihoodFieldModel(0.5, 0.5, 0.2, combine)
        plain = [likelihood_field_weight(p, endpoints, field, model, 12.0) for p in poses]
        for method in ("numpy", "numba"):
            np.testing.assert_allclose(likelihood_field_weights(poses, endpoints, field, model,
                                                                12.0, method=method),
                                       plain, rtol=1e-12)


def test_log_weights_of_tiny_likelihoods_normalise_without_underflow():
    """Sixty beams of likelihood 1e-10 each: the product underflows to 0 in doubles; summed as
    logs and normalised, the weights are exact."""
    logs = np.array([60 * math.log(1e-10), 60 * math.log(2e-10), 60 * math.log(1e-10)])
    assert np.prod(np.full(60, 1e-10)) == 0.0
    w = normalize_log_weights(logs)
    ratio = 2.0 ** 60
    np.testing.assert_allclose(w, np.array([1.0, ratio, 1.0]) / (ratio + 2.0), rtol=1e-12)
    assert effective_sample_size(w) == pytest.approx(1.0 / np.sum(w ** 2))


@pytest.mark.parametrize("seed", range(5))
def test_low_variance_resampling_draws_each_particle_floor_or_ceil_of_n_w(seed):
    rng = np.random.default_rng(seed)
    w = rng.random(37) ** 3
    w /= w.sum()
    n = 500
    counts = np.bincount(low_variance_resample(w, n, rng), minlength=len(w))
    assert counts.sum() == n
    assert np.all(counts >= np.floor(n * w) - 1e-9) and np.all(counts <= np.ceil(n * w) + 1e-9)


@pytest.mark.parametrize("k", [20, 50, 100, 400])
def test_kld_particle_count_approximates_the_chi_square_quantile(k):
    """Fox (2003): n = χ²_{k−1}(1 − δ) / (2ε); AMCL's Wilson–Hilferty form is within 1 %."""
    z = 2.326  # the upper 1 % quantile of the standard normal
    exact = stats.chi2.ppf(stats.norm.cdf(z), k - 1) / (2 * 0.05)
    n = kld_sample_limit(k, 0.05, z, 1, 10**7)
    assert n == pytest.approx(exact, rel=0.01)
    assert kld_sample_limit(k, 0.05, z, 500, 2000) == min(max(n, 500), 2000)


@pytest.mark.parametrize("seed", range(6))
def test_clusters_are_the_connected_groups_of_touching_bins(seed):
    # a flood fill over the occupied (0.5 m, 0.5 m, 10 deg) bins, each bin touching its 26
    # neighbours and θ wrapping round, written out by hand as AMCL's pf_kdtree_cluster does
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 400))
    spread = float(rng.uniform(0.2, 3.0))
    poses = np.column_stack([rng.normal(0, spread, n), rng.normal(0, spread, n),
                             rng.uniform(-math.pi, math.pi, n)])
    keys = [(math.floor(x / 0.5), math.floor(y / 0.5), math.floor(t / math.radians(10)) % 36)
            for x, y, t in poses]
    occupied = set(keys)
    group: dict[tuple[int, int, int], int] = {}
    for start in sorted(occupied):
        if start in group:
            continue
        group[start], todo = len(group), [start]
        while todo:
            bx, by, bt = todo.pop()
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    for dt in (-1, 0, 1):
                        nb = (bx + dx, by + dy, (bt + dt) % 36)
                        if nb in occupied and nb not in group:
                            group[nb] = group[start]
                            todo.append(nb)
    labels = cluster_labels(poses)
    # the same partition of the particles (labels may be numbered differently)
    pairs = set(zip(labels.tolist(), (group[k] for k in keys), strict=True))
    assert len(pairs) == len(set(labels.tolist())) == len({group[k] for k in keys})


def test_nav2s_own_amcl_parameter_file_loads_as_it_is(tmp_path):
    """The amcl section of nav2_bringup's nav2_params.yaml (values as Nav2 ships them)."""
    text = """amcl:
  ros__parameters:
    alpha1: 0.2
    alpha2: 0.2
    alpha3: 0.2
    alpha4: 0.2
    alpha5: 0.2
    base_frame_id: "base_footprint"
    beam_skip_distance: 0.5
    beam_skip_error_threshold: 0.9
    beam_skip_threshold: 0.3
    do_beamskip: false
    global_frame_id: "map"
    lambda_short: 0.1
    laser_likelihood_max_dist: 2.0
    laser_max_range: 100.0
    laser_min_range: -1.0
    laser_model_type: "likelihood_field"
    max_beams: 60
    max_particles: 2000
    min_particles: 500
    odom_frame_id: "odom"
    pf_err: 0.05
    pf_z: 0.99
    recovery_alpha_fast: 0.0
    recovery_alpha_slow: 0.0
    random_seed: -1
    resample_interval: 1
    robot_model_type: "nav2_amcl::DifferentialMotionModel"
    save_pose_rate: 0.5
    sigma_hit: 0.2
    tf_broadcast: true
    transform_tolerance: 1.0
    introspection_mode: "disabled"
    update_min_a: 0.2
    update_min_d: 0.25
    z_hit: 0.5
    z_max: 0.05
    z_rand: 0.5
    z_short: 0.05
    scan_topic: scan
bt_navigator:
  ros__parameters:
    global_frame: map
"""
    path = tmp_path / "nav2_params.yaml"
    path.write_text(text)
    with pytest.warns(UserWarning, match="introspection_mode"):
        params = load_parameters(path)
    assert params == AmclParameters(random_seed=-1)
    assert params.max_particles == 2000 and params.update_min_d == 0.25
    np.testing.assert_array_equal(params.alphas, [0.2] * 4)


def test_bad_parameter_files_and_values_are_named(tmp_path):
    missing = tmp_path / "none.yaml"
    with pytest.raises(ValueError, match="no such parameter file"):
        load_parameters(missing)
    broken = tmp_path / "broken.yaml"
    broken.write_text("amcl: [unclosed\n")
    with pytest.raises(ValueError, match="not valid YAML"):
        load_parameters(broken)
    with pytest.raises(TypeError, match="max_particles is an integer"):
        AmclParameters.from_mapping({"max_particles": "many"})


def test_bad_inputs_are_refused_with_their_reason():
    with pytest.raises(ValueError, match="non-negative"):
        low_variance_resample([0.5, -0.1], 3, np.random.default_rng(0))
    with pytest.raises(ValueError, match="number of particles"):
        low_variance_resample([0.5, 0.5], 0, np.random.default_rng(0))
    with pytest.raises(TypeError, match="OccupancyGrid"):
        LikelihoodField.from_grid(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="max_distance"):
        LikelihoodField.from_grid(grid_message(np.zeros((3, 3), bool)), max_distance=0.0)
    with pytest.raises(ValueError, match="shape"):
        likelihood_field_weights(np.zeros((4, 2)), np.zeros((3, 2)),
                                 LikelihoodField.from_grid(grid_message(np.eye(4, dtype=bool))),
                                 LikelihoodFieldModel(0.5, 0.5, 0.2, "amcl"), 10.0)
