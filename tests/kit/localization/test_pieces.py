"""AMCL built from pieces handed in as functions (a lab's exercises): the kit's own pieces,
handed in that way, give the kit's own filter to the last bit; the textbook's formula for the
likelihood field gives the kit's log-likelihoods; a broken piece changes the run or is refused
with its reason."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kit import geometry, models, msgs
from kit.localization import (
    Amcl,
    AmclParameters,
    LikelihoodField,
    LikelihoodFieldModel,
    expected_ranges,
    likelihood_field_weights,
)
from kit.localization.particles import effective_sample_size, normalize_log_weights
from kit.tf import RigidTransform

ANGLES = np.linspace(-math.pi, math.pi, 90, endpoint=False)
PARAMS = AmclParameters(laser_model_type="likelihood_field_prob", max_particles=600,
                        min_particles=200, max_beams=30, laser_max_range=8.0,
                        update_min_d=0.05, update_min_a=0.05)


def room() -> msgs.OccupancyGrid:
    """An 8 m × 6 m room at 5 cm with two wall stubs: not symmetric, so one pose fits best;
    its middle lies more than AMCL's 2 m from every wall."""
    occupied = np.zeros((120, 160), bool)
    occupied[[0, -1], :] = occupied[:, [0, -1]] = True
    occupied[40, 30:70] = True
    occupied[10:40, 140] = True
    info = msgs.MapMetaData(resolution=0.05, width=160, height=120,
                            origin=msgs.Pose(msgs.Point(0.0, 0.0, 0.0)))
    return msgs.OccupancyGrid(msgs.Header(frame_id="map"), info,
                              np.where(occupied, 100, 0).astype(np.int8).ravel())


def drive(node: Amcl, grid: msgs.OccupancyGrid) -> np.ndarray:
    """Scans the map predicts along a short drive (odometry = truth), fed to ``node``;
    returns the estimates after each update."""
    field = LikelihoodField.from_grid(grid)
    poses = [np.array([1.0 + 0.08 * k, 1.0 + 0.03 * k, 0.02 * k]) for k in range(25)]
    out = []
    for k, pose in enumerate(poses):
        ranges = expected_ranges(field, pose, ANGLES, 8.0)
        scan = msgs.LaserScan(msgs.Header(msgs.Time.from_sec(0.1 * k), "laser"),
                              angle_min=float(ANGLES[0]), angle_max=float(ANGLES[-1]),
                              angle_increment=float(ANGLES[1] - ANGLES[0]), range_min=0.05,
                              range_max=8.0, ranges=ranges)
        if node.process(scan, pose, RigidTransform.from_pose2d([0.0, 0.0, 0.0])):
            out.append(node.estimate[0].copy())
    return np.array(out)


def textbook_log_likelihoods(poses, endpoints, distance, resolution, origin, z_hit, z_rand,
                             sigma_hit, range_max):
    """Σ_k log(z_hit exp(−d_k²/2σ²) + z_rand/r_max), d off the grid = the field's largest."""
    p, e, d = (np.asarray(v, float) for v in (poses, endpoints, distance))
    c, s = np.cos(p[:, 2:3]), np.sin(p[:, 2:3])
    col = np.floor((p[:, 0:1] + c * e[:, 0] - s * e[:, 1] - origin[0]) / resolution).astype(int)
    row = np.floor((p[:, 1:2] + s * e[:, 0] + c * e[:, 1] - origin[1]) / resolution).astype(int)
    inside = (row >= 0) & (row < d.shape[0]) & (col >= 0) & (col < d.shape[1])
    dist = np.where(inside, d[row.clip(0, d.shape[0] - 1), col.clip(0, d.shape[1] - 1)],
                    d.max())
    return np.sum(np.log(z_hit * np.exp(-dist ** 2 / (2 * sigma_hit ** 2)) + z_rand / range_max),
                  axis=1)


def offset_sampler(weights, n, r):
    """The low-variance sampler given its offset r, written as the kit's."""
    cumulative = np.cumsum(np.asarray(weights, float) / np.sum(weights))
    cumulative[-1] = 1.0
    return np.searchsorted(cumulative, r + np.arange(n) / n, side="right")


def test_the_kits_own_pieces_handed_in_give_the_kits_filter_bit_for_bit():
    grid = room()
    plain, pieced = Amcl(grid, PARAMS, seed=3), Amcl(
        grid, PARAMS, seed=3, odometry_control=models.odometry_control,
        normalize=normalize_log_weights, sampler=offset_sampler,
        should_resample=lambda w, t: effective_sample_size(w) < t * len(w))
    for node in (plain, pieced):
        node.initialize([1.1, 0.9, 0.1], np.diag([0.1, 0.1, 0.05]))
    np.testing.assert_array_equal(drive(plain, grid), drive(pieced, grid))
    np.testing.assert_array_equal(plain.filter.poses, pieced.filter.poses)


def test_the_textbook_likelihood_field_weighs_as_the_kits_and_localizes_alike():
    grid = room()
    seen = []

    def spy(*args):
        seen.append(args)
        return textbook_log_likelihoods(*args)

    plain, pieced = Amcl(grid, PARAMS, seed=5), Amcl(grid, PARAMS, seed=5, log_likelihoods=spy)
    for node in (plain, pieced):
        node.initialize([1.1, 0.9, 0.1], np.diag([0.1, 0.1, 0.05]))
    a, b = drive(plain, grid), drive(pieced, grid)
    assert seen and np.allclose(a[-1, :2], b[-1, :2], atol=0.05)
    assert np.hypot(*(b[-1, :2] - [1.0 + 0.08 * 24, 1.0 + 0.03 * 24])) < 0.1
    poses, endpoints, distance, resolution, origin, z_hit, z_rand, sigma, rmax = seen[0]
    field = LikelihoodField.from_grid(grid, PARAMS.laser_likelihood_max_dist)
    assert distance.max() == field.max_distance   # "off the grid" is the same value for both

    kit = likelihood_field_weights(poses, endpoints, field,
                                   LikelihoodFieldModel(z_hit, z_rand, sigma, "product"), rmax)
    np.testing.assert_allclose(textbook_log_likelihoods(*seen[0]), kit, rtol=1e-12)
    np.testing.assert_array_equal(distance, field.distance)
    assert (resolution, tuple(origin), z_hit, z_rand, sigma, rmax) == (
        field.resolution, (0.0, 0.0), PARAMS.z_hit, PARAMS.z_rand, PARAMS.sigma_hit, 8.0)


def test_a_sampler_that_keeps_one_particle_collapses_the_cloud():
    grid = room()
    plain, broken = Amcl(grid, PARAMS, seed=3), Amcl(
        grid, PARAMS, seed=3, sampler=lambda w, n, r: np.full(n, int(np.argmax(w))),
        should_resample=lambda w, t: True)
    for node in (plain, broken):
        node.initialize([1.1, 0.9, 0.1], np.diag([0.1, 0.1, 0.05]))
    drive(plain, grid), drive(broken, grid)
    assert len(np.unique(broken.filter.poses, axis=0)) < len(np.unique(plain.filter.poses,
                                                                       axis=0)) / 3


def test_pieces_that_cannot_work_are_refused_with_their_reason():
    grid = room()
    with pytest.raises(ValueError, match="likelihood_field_prob"):
        Amcl(grid, AmclParameters(), log_likelihoods=textbook_log_likelihoods)
    node = Amcl(grid, PARAMS, seed=1, sampler=lambda w, n, r: np.full(n, len(w)),
                should_resample=lambda w, t: True)
    node.initialize([1.1, 0.9, 0.1])
    with pytest.raises(ValueError, match="integer indices"):
        drive(node, grid)
    node = Amcl(grid, PARAMS, seed=1, normalize=lambda lw: lw)     # exp forgotten
    node.initialize([1.1, 0.9, 0.1])
    with pytest.raises(ValueError, match="finite non-negative"):
        drive(node, grid)
    node = Amcl(grid, PARAMS, seed=1, log_likelihoods=lambda *a: np.zeros(3))
    node.initialize([1.1, 0.9, 0.1])
    with pytest.raises(ValueError, match="one value per particle"):
        drive(node, grid)


def test_a_control_in_degrees_sends_the_particles_astray():
    def degrees(a, b):
        u = models.odometry_control(a, b)
        return np.array([math.degrees(u[0]), u[1], math.degrees(u[2])])

    rng = np.random.default_rng(1)
    start = np.zeros((50, 3))
    right = models.sample_odometry_motion(start, [0, 0, 0], [1.0, 0.5, 0.5], [0] * 4, rng)
    wrong = models.sample_odometry_motion(start, [0, 0, 0], [1.0, 0.5, 0.5], [0] * 4, rng,
                                          control=degrees)
    np.testing.assert_allclose(right[0], [1.0, 0.5, 0.5], atol=1e-12)
    u = degrees([0, 0, 0], [1.0, 0.5, 0.5])
    np.testing.assert_allclose(wrong[0], [u[1] * math.cos(u[0]), u[1] * math.sin(u[0]),
                                          geometry.wrap_angle(u[0] + u[2])], atol=1e-12)
