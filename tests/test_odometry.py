import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from kit import geometry, msgs, robots
from kit import odometry as o


def test_conversion_factor_has_pi_and_matches_robot():
    eddie = robots.load("eddie")
    cm = o.conversion_factor(2 * eddie.wheel_radius, eddie.gear_ratio, eddie.encoder_resolution)
    assert cm == pytest.approx(eddie.metres_per_tick)
    # 144 ticks are one wheel turn: the circumference
    assert 144 * cm == pytest.approx(math.pi * 0.1524)
    uiabot = robots.load("uiabot")
    assert o.conversion_factor(0.1, 20, 20480) * 409600 == pytest.approx(math.pi * 0.1)
    assert uiabot.metres_per_tick == pytest.approx(math.pi * 0.1 / 409600)


@given(st.integers(0, 65535), st.integers(-30000, 30000))
def test_tick_delta_recovers_true_increment_across_rollover(start, step):
    current = (start + step) % 65536
    assert int(o.tick_delta(start, current, counter_bits=16)) == step


def test_tick_delta_rejects_floats_and_bad_widths():
    with pytest.raises(TypeError, match="integers"):
        o.tick_delta(1.0, 2.0)
    with pytest.raises(ValueError, match="counter_bits"):
        o.tick_delta(1, 2, counter_bits=1)


def test_exact_arc_lands_on_the_circle_for_any_step():
    """Constant wheel travels trace a circle; the exact integrator has no discretisation error."""
    L = 0.39
    d_r, d_l = 0.02, 0.01
    R = L / 2 * (d_r + d_l) / (d_r - d_l)
    path = o.integrate_odometry(np.full(500, d_r), np.full(500, d_l), L, method="exact")
    centre = np.array([0.0, R])
    np.testing.assert_allclose(np.linalg.norm(path[:, :2] - centre, axis=1), R, rtol=1e-12)
    total_angle = 500 * (d_r - d_l) / L
    np.testing.assert_allclose(path[-1], [R * math.sin(total_angle),
                                          R - R * math.cos(total_angle),
                                          float(geometry.wrap_angle(total_angle))], atol=1e-10)


def test_euler_error_shrinks_with_step_and_midpoint_beats_euler():
    L, arc = 0.39, 2.0
    exact = o.integrate_odometry([arc], [arc * 0.5], L, method="exact")[-1]
    errors = {}
    for method in ("euler", "midpoint"):
        for n in (10, 100):
            p = o.integrate_odometry(np.full(n, arc / n), np.full(n, arc * 0.5 / n), L,
                                     method=method)[-1]
            errors[method, n] = np.linalg.norm(p[:2] - exact[:2])
    assert errors["euler", 100] < errors["euler", 10] / 5  # first order
    assert errors["midpoint", 100] < errors["midpoint", 10] / 50  # second order
    assert errors["midpoint", 10] < errors["euler", 10]


def test_vectorised_integration_equals_step_by_step():
    rng = np.random.default_rng(3)
    dr, dl = rng.uniform(-0.02, 0.05, (2, 300))
    for method in ("exact", "midpoint", "euler"):
        path = o.integrate_odometry(dr, dl, 0.361, initial_pose=[1, 2, 3], method=method)
        pose = np.array([1.0, 2.0, 3.0])
        for i in range(300):
            pose = o.odometry_step(pose, dr[i], dl[i], 0.361, method=method)
            np.testing.assert_allclose(path[i + 1], pose, atol=1e-9)


def test_pose_accumulates_not_overwrites():
    """Erratum 2: two identical steps must turn twice as far as one."""
    one = o.odometry_step([0, 0, 0], 0.1, 0.0, 0.39)
    two = o.odometry_step(one, 0.1, 0.0, 0.39)
    assert two[2] == pytest.approx(2 * one[2])


def test_right_wheel_further_is_counter_clockwise():
    """Erratum 7: Eddie's (left - right)/separation is clockwise-positive; REP-103 is CCW."""
    assert o.odometry_step([0, 0, 0], 0.2, 0.1, 0.39)[2] > 0


def numeric_jacobians(pose, dr, dl, L):
    def f(p, a, b):
        return o.odometry_step(p, a, b, L, method="midpoint")

    eps = 1e-7
    Fp = np.column_stack([(f(pose + eps * e, dr, dl) - f(pose - eps * e, dr, dl)) / (2 * eps)
                          for e in np.eye(3)])
    Fd = np.column_stack([(f(pose, dr + eps, dl) - f(pose, dr - eps, dl)) / (2 * eps),
                          (f(pose, dr, dl + eps) - f(pose, dr, dl - eps)) / (2 * eps)])
    return Fp, Fd


def test_covariance_step_uses_the_right_jacobians():
    pose, dr, dl, L, kr, kl = np.array([0.5, -0.2, 0.8]), 0.07, 0.03, 0.39, 1e-3, 2e-3
    P0 = np.diag([0.01, 0.02, 0.003])
    Fp, Fd = numeric_jacobians(pose, dr, dl, L)
    expected = Fp @ P0 @ Fp.T + Fd @ np.diag([kr * dr, kl * dl]) @ Fd.T
    got = o.odometry_covariance_step(P0, pose, dr, dl, L, kr, kl)
    np.testing.assert_allclose(got, expected, atol=1e-9)


def test_covariance_grows_with_distance_and_rotation_and_stays_psd():
    P = np.zeros((3, 3))
    pose = np.zeros(3)
    traces = []
    for _ in range(200):
        P = o.odometry_covariance_step(P, pose, 0.01, 0.008, 0.39, 1e-4, 1e-4)
        pose = o.odometry_step(pose, 0.01, 0.008, 0.39)
        traces.append(np.trace(P))
        assert np.allclose(P, P.T) and np.linalg.eigvalsh(P).min() > -1e-15
    assert np.all(np.diff(traces) > 0)
    spun = o.odometry_covariance_step(np.zeros((3, 3)), [0, 0, 0], 0.1, -0.1, 0.39, 1e-4, 1e-4)
    assert spun[2, 2] > 0  # turning in place also adds heading uncertainty


def test_odometry_message_quaternion_is_the_uiabot_one():
    theta = 2.4
    m = o.odometry_message([1.0, 2.0, theta], [0.3, 0.1], msgs.Time(5, 0), np.eye(3) * 0.01)
    q = m.pose.pose.orientation
    assert (q.x, q.y, q.z, q.w) == pytest.approx((0, 0, math.sin(theta / 2), math.cos(theta / 2)))
    assert m.header.frame_id == "odom" and m.child_frame_id == "base_link"
    cov = m.pose.covariance.reshape(6, 6)
    assert cov[0, 0] == cov[1, 1] == cov[5, 5] == 0.01 and cov[2, 2] == o.UNUSED_VARIANCE
    tf = o.odom_transform([1.0, 2.0, theta], msgs.Time(5, 0))
    assert tf.transform.rotation == m.pose.pose.orientation
    assert (tf.header.frame_id, tf.child_frame_id) == ("odom", "base_link")


def test_wheel_odometry_node_survives_counter_rollover():
    eddie = robots.load("eddie")
    node = o.WheelOdometry.for_robot(eddie)
    rng = np.random.default_rng(4)
    steps = rng.integers(0, 40, (400, 2))  # forward, with differing wheel speeds
    raw = (np.cumsum(steps, axis=0) + 65000) % 65536  # the 16-bit counters wrap
    node.update(65000, 65000, 0.0)
    for i, (right, left) in enumerate(raw):
        msg = node.update(int(right), int(left), 0.05 * (i + 1))
    expected = o.integrate_odometry(steps[:, 0] * eddie.metres_per_tick,
                                    steps[:, 1] * eddie.metres_per_tick, eddie.wheel_separation)
    np.testing.assert_allclose(node.pose, expected[-1], atol=1e-9)
    assert msg.pose.pose.position.x == pytest.approx(expected[-1, 0])
    with pytest.raises(ValueError, match="increasing time"):
        node.update(0, 0, 0.0)
