import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from kit import geometry as g

finite = st.floats(-1e3, 1e3, allow_nan=False)
angles = st.floats(-20.0, 20.0, allow_nan=False)
poses = st.tuples(finite, finite, angles)


@given(st.floats(-1e6, 1e6, allow_nan=False))
def test_wrap_angle_lands_in_half_open_interval_and_keeps_direction(a):
    w = float(g.wrap_angle(a))
    assert -math.pi <= w < math.pi
    assert math.isclose(math.cos(w), math.cos(a), abs_tol=1e-6)
    assert math.isclose(math.sin(w), math.sin(a), abs_tol=1e-6)


def test_wrap_angle_maps_pi_to_minus_pi_and_is_vectorised():
    out = g.wrap_angle([math.pi, -math.pi, 3 * math.pi / 2, 0.0, -1e-300])
    np.testing.assert_allclose(out, [-math.pi, -math.pi, -math.pi / 2, 0.0, 0.0], atol=1e-15)
    assert np.all(out < math.pi)


@given(poses, poses)
def test_compose_then_relative_round_trips(a, b):
    c = g.compose(a, b)
    np.testing.assert_allclose(g.relative(a, c)[:2], b[:2], atol=1e-7)
    assert abs(float(g.wrap_angle(g.relative(a, c)[2] - b[2]))) < 1e-9


@given(poses)
def test_compose_with_inverse_is_identity(a):
    np.testing.assert_allclose(g.compose(a, g.inverse(a)), [0, 0, 0], atol=1e-9)
    np.testing.assert_allclose(g.compose(g.inverse(a), a), [0, 0, 0], atol=1e-9)


def test_compose_known_value_quarter_turn():
    np.testing.assert_allclose(g.compose([1, 2, math.pi / 2], [1, 0, math.pi / 2]),
                               [1, 3, -math.pi], atol=1e-12)


def test_compose_is_vectorised_over_many_poses():
    rng = np.random.default_rng(0)
    a = rng.uniform(-5, 5, (50, 3))
    b = rng.uniform(-5, 5, (50, 3))
    batch = g.compose(a, b)
    one_by_one = np.array([g.compose(x, y) for x, y in zip(a, b, strict=True)])
    np.testing.assert_allclose(batch, one_by_one)
    np.testing.assert_allclose(g.compose(a, b[0]), [g.compose(x, b[0]) for x in a])


def test_compose_agrees_with_homogeneous_matrices():
    def H(p):
        c, s = math.cos(p[2]), math.sin(p[2])
        return np.array([[c, -s, p[0]], [s, c, p[1]], [0, 0, 1]])

    a, b = [0.3, -1.2, 2.5], [1.5, 0.7, -2.9]
    M = H(a) @ H(b)
    c = g.compose(a, b)
    np.testing.assert_allclose(H(c), M, atol=1e-12)


def test_transform_points_matches_compose():
    pose = np.array([1.0, 2.0, 0.7])
    pts = np.array([[1.0, 0.0], [0.0, 2.0], [-1.0, -1.0]])
    out = g.transform_points(pose, pts)
    expected = [g.compose(pose, [p[0], p[1], 0.0])[:2] for p in pts]
    np.testing.assert_allclose(out, expected)


@given(angles)
def test_yaw_quaternion_round_trip_and_ros_order(yaw):
    q = g.yaw_to_quaternion(yaw)
    assert q[0] == 0 and q[1] == 0
    np.testing.assert_allclose(q[2:], [math.sin(yaw / 2), math.cos(yaw / 2)])
    assert abs(float(g.wrap_angle(g.quaternion_to_yaw(q) - yaw))) < 1e-9


def test_rpy_quaternion_matches_yaw_only_case_and_rotates_like_matrices():
    np.testing.assert_allclose(g.rpy_to_quaternion(0, 0, 0.4), g.yaw_to_quaternion(0.4))
    q = g.rpy_to_quaternion(0.1, -0.2, 0.3)
    cr, sr, cp, sp, cy, sy = (math.cos(0.1), math.sin(0.1), math.cos(-0.2), math.sin(-0.2),
                              math.cos(0.3), math.sin(0.3))
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    v = np.array([0.3, -1.0, 2.0])
    np.testing.assert_allclose(g.quaternion_rotate(q, v), Rz @ Ry @ Rx @ v, atol=1e-12)


def test_slerp_halfway_between_yaws():
    q = g.quaternion_slerp(g.yaw_to_quaternion(0.2), g.yaw_to_quaternion(1.0), 0.5)
    assert math.isclose(float(g.quaternion_to_yaw(q)), 0.6, abs_tol=1e-12)
    # across +-pi it takes the short way
    q = g.quaternion_slerp(g.yaw_to_quaternion(3.0), g.yaw_to_quaternion(-3.0), 0.5)
    assert abs(abs(float(g.quaternion_to_yaw(q))) - math.pi) < 1e-9


@pytest.mark.parametrize("bad", [[1, 2], [[1, 2, 3, 4]], [1, float("nan"), 0]])
def test_bad_pose_raises_with_expected_shape(bad):
    with pytest.raises(ValueError, match=r"\(3,\) or \(N, 3\)|NaN"):
        g.compose(bad, [0, 0, 0])


@pytest.mark.parametrize(("q_shape", "v_shape"), [((4,), (3,)), ((6, 4), (6, 3)),
                                                    ((4,), (7, 3)), ((5, 4), (3,)),
                                                    ((2, 3, 4), (2, 3, 3))])
def test_quaternion_rotate_is_scipys_rotation_and_numpys_cross_product_to_the_bit(q_shape,
                                                                                   v_shape):
    """``v + w t + u × t`` with ``t = 2 u × v``: scipy's ``Rotation.apply`` to rounding, and
    the same formula on ``np.cross`` exactly (one quaternion and one vector take a path of
    their own, on Python floats)."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(sum(q_shape) + 10 * sum(v_shape))
    for _ in range(50):
        q = rng.normal(size=q_shape)
        q /= np.linalg.norm(q, axis=-1, keepdims=True)
        v = rng.normal(size=v_shape) * 10.0 ** rng.integers(-3, 4)
        got = g.quaternion_rotate(q, v)
        u, w = q[..., :3], q[..., 3:4]
        t = 2.0 * np.cross(u, v)
        assert np.array_equal(got, v + w * t + np.cross(u, t))
        flat_q = np.broadcast_to(q, (*np.broadcast_shapes(q.shape[:-1], v.shape[:-1]), 4))
        flat_v = np.broadcast_to(v, (*flat_q.shape[:-1], 3))
        rotation = Rotation.from_quat(np.array(flat_q).reshape(-1, 4))
        want = rotation.apply(np.array(flat_v).reshape(-1, 3))
        np.testing.assert_allclose(got.reshape(-1, 3), want, rtol=1e-12,
                                   atol=1e-12 * np.abs(v).max())


def test_one_quaternion_product_is_the_batched_one_to_the_bit_and_scipys_to_rounding():
    """The single-quaternion path against the array path (a batch of two) and scipy's
    composition of rotations."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(5)
    for _ in range(500):
        q = rng.normal(size=(2, 4)) * 10.0 ** rng.integers(-2, 3)
        p = rng.normal(size=(2, 4))
        assert np.array_equal(g.quaternion_multiply(q[0], p[0]),
                              g.quaternion_multiply(q, p)[0])
    q, p = (r / np.linalg.norm(r) for r in rng.normal(size=(2, 4)))
    want = (Rotation.from_quat(q) * Rotation.from_quat(p)).as_quat()
    got = g.quaternion_multiply(q, p)
    np.testing.assert_allclose(got * np.sign(got[3]), want * np.sign(want[3]), atol=1e-12)


def test_bad_quaternion_shape_raises():
    with pytest.raises(ValueError, match=r"ROS order \(x, y, z, w\)"):
        g.quaternion_to_yaw([0, 0, 1])


@given(poses, poses)
def test_single_poses_take_the_same_arithmetic_as_a_batch(a, b):
    # one pose goes through plain floats, a batch through numpy: the results are equal to the bit
    np.testing.assert_array_equal(g.compose(a, b), g.compose([a], [b])[0])
    np.testing.assert_array_equal(g.inverse(a), g.inverse([a])[0])
    np.testing.assert_array_equal(g.wrap_angle(np.float64(a[2])), g.wrap_angle([a[2]])[0])
