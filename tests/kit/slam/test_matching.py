"""The SLAM front end's scan-to-map step and its gates, in a known room: ICP held by the
odometry when they agree, the wider correlative search when the odometry jumped, the
odometry's prediction when nothing fits."""

from __future__ import annotations

import math

import numpy as np

from kit import geometry
from kit.slam import correlative
from kit.slam import scan_matching as sm
from kit.slam.config import SlamConfig
from kit.slam.matching import match_scan, prior_information, refine

ROOM = np.array([[0, 0], [8, 0], [8, 5], [5, 5], [5, 3], [3.5, 3], [3.5, 5], [0, 5]], float)


def walls(corners=ROOM, spacing=0.02):
    pts = []
    for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        n = max(2, int(np.hypot(*(b - a)) / spacing))
        t = np.linspace(0, 1, n, endpoint=False)[:, None]
        pts.append(a + t * (b - a))
    return np.vstack(pts)


def setting(truth):
    """The room as the local map, and the scan taken at ``truth`` (points in ``base``)."""
    reference = sm.PointCloudReference(walls())
    scan = geometry.transform_points(geometry.inverse(truth), walls(spacing=0.03))
    field = correlative.likelihood_field(walls(), 0.05, 0.05, margin=1.0)
    return reference, scan, (lambda: field)


def test_icp_held_by_the_odometry_is_taken_when_they_agree():
    truth = np.array([2.0, 1.5, 0.4])
    ref, scan, field = setting(truth)
    step = np.array([0.2, 0.0, 0.05])
    predicted = truth + np.array([0.02, -0.015, 0.01])
    match = match_scan(scan, predicted, prior_information(step, SlamConfig().odometry_noise),
                       ref, field, SlamConfig())
    assert match.how == "icp"
    assert np.allclose(match.pose, truth, atol=[3e-3, 3e-3, 1e-3])


def test_the_wider_search_finds_the_scan_after_the_odometry_jumped_40_degrees():
    """Wheel odometry turned 40° and slid 0.5 m too far (CSAIL's does so between two
    scans): ICP from there is trapped or refused, the search — widened when its answer lies
    on the window's edge — finds the room again, and it fits far better than the
    prediction."""
    truth = np.array([2.0, 1.5, 0.4])
    ref, scan, field = setting(truth)
    step = np.array([0.2, 0.0, 0.05])
    predicted = geometry.compose(truth, [0.5, 0.0, math.radians(40)])
    match = match_scan(scan, predicted, prior_information(step, SlamConfig().odometry_noise),
                       ref, field, SlamConfig())
    assert match.how == "search"
    assert np.allclose(match.pose, truth, atol=[0.01, 0.01, 0.005])


def test_a_scan_that_fits_nowhere_keeps_the_odometrys_prediction():
    truth = np.array([2.0, 1.5, 0.4])
    ref, _, field = setting(truth)
    clutter = np.random.default_rng(3).uniform(-3, 3, (300, 2))
    predicted = truth + np.array([0.3, 0.0, 0.2])
    omega = prior_information(np.array([0.2, 0.0, 0.05]), SlamConfig().odometry_noise)
    match = match_scan(clutter, predicted, omega, ref, field, SlamConfig())
    assert match.how == "odometry" and np.array_equal(match.pose, predicted)
    assert np.allclose(np.linalg.inv(match.covariance), omega)
    assert refine(clutter, match, omega, ref, SlamConfig()) is match


def test_the_scans_own_covariance_takes_the_odometry_back_out():
    """A match's covariance includes the odometry prior it was held by; the edge of the
    graph must carry the scan's own: ``(Σ⁻¹ − Ω_p)⁻¹``."""
    truth = np.array([2.0, 1.5, 0.4])
    ref, scan, field = setting(truth)
    omega = prior_information(np.array([0.2, 0.0, 0.05]), SlamConfig().odometry_noise)
    match = match_scan(scan, truth, omega, ref, field, SlamConfig())
    alone = sm.icp(scan, ref, match.pose)
    assert np.allclose(np.linalg.inv(match.scan_covariance()), np.linalg.inv(alone.covariance),
                       rtol=0.05)
