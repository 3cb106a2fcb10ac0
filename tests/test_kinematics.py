import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from kit import kinematics as k
from kit import robots

speeds = st.floats(-50, 50, allow_nan=False)


def test_igv_known_values_from_the_paper():
    uR, uL = k.igv_wheel_rpm(1.0, 0.0)
    assert float(uL) == pytest.approx(4000 / 67) and float(uR) == pytest.approx(4000 / 67)
    assert float(uL) == pytest.approx(59.70, abs=0.005)
    uR, uL = k.igv_wheel_rpm(0.0, 1.0)  # right first, as every wheel pair in the kit
    assert float(uR) == pytest.approx(1440 / 67) and float(uL) == pytest.approx(-1440 / 67)


def test_drive_units_known_value_from_the_paper():
    assert int(k.rpm_to_drive_units(10.0)) == 437 == 0x000001B5
    assert float(k.drive_units_to_rpm(437)) == pytest.approx(10.0, rel=1e-3)


def test_igv_equations_agree_with_the_generic_matrix_kinematics():
    """Eq. 7 is the matrix inverse kinematics with r = 1.005/(2 pi), l = 0.72, in RPM."""
    r = 1.005 / (2 * math.pi)
    rng = np.random.default_rng(1)
    for v, w in rng.uniform(-1, 1, (20, 2)):
        phi_r, phi_l = k.inverse_kinematics([v, 0.0, w], r, 0.72)
        uR, uL = k.igv_wheel_rpm(v, w)
        assert float(uR) == pytest.approx(phi_r * 60 / (2 * math.pi))
        assert float(uL) == pytest.approx(phi_l * 60 / (2 * math.pi))
        v2, w2 = k.igv_body_velocity(uR, uL)
        assert (float(v2), float(w2)) == pytest.approx((v, w))


def test_closed_forms_of_the_pseudo_inverse():
    r, b = 0.05, 0.1805
    A, B = k.constraint_matrices(r, 2 * b)
    np.testing.assert_allclose(np.linalg.pinv(A) @ B,
                               [[r / 2, r / 2], [0, 0], [r / (2 * b), -r / (2 * b)]], atol=1e-15)
    np.testing.assert_allclose(np.linalg.pinv(B) @ A,
                               [[1 / r, 0, b / r], [1 / r, 0, -b / r]], atol=1e-12)


def test_right_wheel_faster_turns_left_counter_clockwise():
    """Erratum 5: the paper says 'turns right'; REP-103 makes it a CCW (left) turn."""
    xi = k.forward_kinematics([12.0, 8.0], 0.05, 0.361)
    assert xi[2] > 0
    assert xi[0] == pytest.approx(0.5) and xi[1] == 0


def test_inverse_kinematics_turn_in_place_gives_opposite_wheels():
    phi = k.inverse_kinematics([0.0, 0.0, 1.0], 0.05, 0.361)
    assert phi[0] == pytest.approx(-phi[1]) and phi[0] > 0


@given(speeds, speeds)
def test_inverse_of_forward_is_identity(pr, pl):
    r, sep = 0.0762, 0.39
    back = k.inverse_kinematics(k.forward_kinematics([pr, pl], r, sep), r, sep)
    np.testing.assert_allclose(back, [pr, pl], atol=1e-9)


@given(st.floats(-2, 2, allow_nan=False), st.floats(-3, 3, allow_nan=False))
def test_forward_of_inverse_is_identity_for_feasible_twists(v, w):
    xi = k.forward_kinematics(k.inverse_kinematics([v, 0.0, w], 0.16, 0.72), 0.16, 0.72)
    np.testing.assert_allclose(xi, [v, 0.0, w], atol=1e-9)


def test_vectorised_matches_scalar_calls():
    rng = np.random.default_rng(2)
    phi = rng.uniform(-10, 10, (100, 2))
    batch = k.forward_kinematics(phi, 0.05, 0.361)
    np.testing.assert_allclose(batch, [k.forward_kinematics(p, 0.05, 0.361) for p in phi])


def test_twist_helpers_use_robot_parameters():
    robot = robots.load("uiabot")
    phi = k.twist_to_wheel_speeds(0.5, 0.0, robot.wheel_radius, robot.wheel_separation)
    np.testing.assert_allclose(phi, [10.0, 10.0])
    v, w = k.wheel_speeds_to_twist([10.0, 0.0], robot.wheel_radius, robot.wheel_separation)
    assert float(v) == pytest.approx(0.25) and float(w) == pytest.approx(0.5 / 0.361)


def test_turning_radius_handles_straight_driving_and_spinning():
    assert float(k.turning_radius(1.0, 0.5)) == pytest.approx(2.0)
    assert float(k.turning_radius(1.0, -0.5)) == pytest.approx(-2.0)
    assert float(k.turning_radius(1.0, 0.0)) == math.inf
    assert float(k.turning_radius(-1.0, 0.0)) == -math.inf
    assert float(k.turning_radius(0.0, 1.0)) == 0.0
    np.testing.assert_allclose(k.icc_body(1.0, 0.5), [0.0, 2.0])


def test_igv_turning_radius_equation_6():
    uL, uR = 30.0, 50.0
    vL, vR = 67 * uL / 4000, 67 * uR / 4000
    R = float(k.turning_radius_from_wheels(vR, vL, 0.72))
    assert R == pytest.approx(9 * (uL + uR) / (25 * (uR - uL)))
    assert float(k.turning_radius_from_wheels(1.0, 1.0, 0.72)) == math.inf


@given(speeds, speeds, st.floats(0.5, 30))
def test_saturation_keeps_curvature_and_respects_the_limit(pr, pl, limit):
    out = k.saturate_wheel_speeds([pr, pl], limit)
    assert np.max(np.abs(out)) <= limit * (1 + 1e-12)
    # same direction of travel along the same arc: the ratio is preserved
    assert out[0] * pl == pytest.approx(out[1] * pr, abs=1e-9)
    if max(abs(pr), abs(pl)) <= limit:
        np.testing.assert_allclose(out, [pr, pl])


def test_bad_inputs_name_what_was_expected():
    with pytest.raises(ValueError, match=r"\[right, left\]"):
        k.forward_kinematics([1.0, 2.0, 3.0], 0.05, 0.361)
    with pytest.raises(ValueError, match="wheel_radius must be a positive"):
        k.forward_kinematics([1.0, 2.0], -0.05, 0.361)
    with pytest.raises(ValueError, match="wheel_separation must be a positive"):
        k.forward_kinematics([1.0, 2.0], 0.05, 0.0)
    with pytest.raises(ValueError, match=r"\[x_dot, y_dot, theta_dot\]"):
        k.inverse_kinematics([1.0, 2.0], 0.05, 0.361)


def test_uiabot_twist_node_and_odometry_node_round_trip():
    r = robots.load("uiabot")
    sign = r.parameters["drive"]["left_motor_sign"]
    motors = k.twist_to_motor_speeds(0.3, 0.4, r.wheel_radius, r.wheel_separation,
                                     r.gear_ratio, sign)
    # the paper's twist node: phi_r = (x_dot + theta_dot b) / r * i / (2 pi), left negated
    assert motors[0] == pytest.approx((0.3 + 0.4 * 0.1805) / 0.05 * 20 / (2 * math.pi))
    assert motors[1] == pytest.approx(-(0.3 - 0.4 * 0.1805) / 0.05 * 20 / (2 * math.pi))
    v, w = k.motor_speeds_to_twist(motors, r.wheel_radius, r.wheel_separation, r.gear_ratio, sign)
    assert (v, w) == pytest.approx((0.3, 0.4))
