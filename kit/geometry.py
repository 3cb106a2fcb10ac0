"""Planar rigid-body geometry: SE(2) poses, angle wrapping and quaternions.

Conventions (stated once, used everywhere in the kit):

* A planar pose is ``(x, y, theta)`` in metres and radians, an array of shape ``(3,)`` or
  ``(N, 3)`` for many poses. ``theta`` is yaw, counter-clockwise about +z (REP-103).
* Transforms are named ``T_parent_child``, and only so: ``T_odom_base`` is base_link's pose in
  odom, the transform that maps coordinates in ``base_link`` into ``odom`` (what ROS's
  ``odom → base_link`` TransformStamped carries, ``frame_id`` the parent). Names chain left
  to right: ``T_odom_laser = compose(T_odom_base, T_base_laser)``.
* ``compose(a, b)`` is the SE(2) product ``a ⊕ b``: the pose ``b``, expressed in the frame of
  ``a``, taken into the frame ``a`` is expressed in.
* ``relative(a, b) = inverse(a) ⊕ b`` is ``b ⊖ a``: where ``b`` is, seen from ``a``.
* Quaternions are in ROS order ``(x, y, z, w)``.
* Every angle difference goes through :func:`wrap_angle`, which maps to ``[-pi, pi)``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "check_pose",
    "compose",
    "inverse",
    "quaternion_multiply",
    "quaternion_rotate",
    "quaternion_slerp",
    "quaternion_to_yaw",
    "relative",
    "rpy_to_quaternion",
    "transform_points",
    "wrap_angle",
    "yaw_to_quaternion",
]

FloatArray = NDArray[np.float64]


def wrap_angle(angle: ArrayLike) -> FloatArray:
    """Wrap angles in radians to the half-open interval ``[-pi, pi)``.

    Works on scalars and arrays; returns a float64 array (0-d for a scalar). An infinite or
    NaN angle has no direction: it wraps to NaN, without a warning.

    >>> float(wrap_angle(3 * np.pi / 2))
    -1.5707963267948966
    >>> float(wrap_angle(np.pi))
    -3.141592653589793
    """
    if isinstance(angle, float):  # float, np.float64: the same arithmetic without numpy
        w = (angle + math.pi) % (2.0 * math.pi) - math.pi
        return np.asarray(w - 2.0 * math.pi if w >= math.pi else w)
    a = np.asarray(angle, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        wrapped = np.mod(a + np.pi, 2.0 * np.pi) - np.pi
    # mod can round up to exactly 2*pi for inputs just below a multiple of 2*pi
    return np.where(wrapped >= np.pi, wrapped - 2.0 * np.pi, wrapped)


def check_pose(pose: ArrayLike, name: str = "pose") -> FloatArray:
    """Return ``pose`` as float64 of shape ``(3,)`` or ``(N, 3)``, or raise ``ValueError``."""
    p = np.asarray(pose, dtype=np.float64)
    if p.ndim not in (1, 2) or p.shape[-1] != 3:
        raise ValueError(
            f"{name} must have shape (3,) or (N, 3) as (x [m], y [m], theta [rad]); "
            f"got shape {p.shape}"
        )
    finite = (all(map(math.isfinite, p.tolist())) if p.ndim == 1   # one pose: no ufunc
              else bool(np.all(np.isfinite(p))))
    if not finite:
        raise ValueError(f"{name} contains NaN or infinite values: {p}")
    return p


def compose(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """SE(2) composition ``a ⊕ b``.

    .. math:: x = x_a + x_b\\cos\\theta_a - y_b\\sin\\theta_a,\\quad
              y = y_a + x_b\\sin\\theta_a + y_b\\cos\\theta_a,\\quad
              \\theta = \\mathrm{wrap}(\\theta_a + \\theta_b)

    Parameters
    ----------
    a, b : array_like, shape (3,) or (N, 3)
        Poses; broadcast against each other.

    >>> compose([1.0, 0.0, np.pi / 2], [1.0, 0.0, 0.0]).round(12).tolist()
    [1.0, 1.0, 1.570796326795]
    """
    pa, pb = check_pose(a, "a"), check_pose(b, "b")
    if pa.ndim == 1 and pb.ndim == 1:   # two single poses: the same arithmetic on floats
        xa, ya, ta = pa.tolist()
        xb, yb, tb = pb.tolist()
        c1, s1 = math.cos(ta), math.sin(ta)
        return np.array([xa + c1 * xb - s1 * yb, ya + s1 * xb + c1 * yb,
                         float(wrap_angle(ta + tb))])
    c, s = np.cos(pa[..., 2]), np.sin(pa[..., 2])
    x = pa[..., 0] + c * pb[..., 0] - s * pb[..., 1]
    y = pa[..., 1] + s * pb[..., 0] + c * pb[..., 1]
    theta = wrap_angle(pa[..., 2] + pb[..., 2])
    return np.stack(np.broadcast_arrays(x, y, theta), axis=-1)


def inverse(a: ArrayLike) -> FloatArray:
    """SE(2) inverse ``⊖a``, so that ``compose(a, inverse(a))`` is the identity."""
    pa = check_pose(a, "a")
    if pa.ndim == 1:                    # one pose: the same arithmetic on floats
        xa, ya, ta = pa.tolist()
        c1, s1 = math.cos(ta), math.sin(ta)
        return np.array([-c1 * xa - s1 * ya, s1 * xa - c1 * ya, float(wrap_angle(-ta))])
    c, s = np.cos(pa[..., 2]), np.sin(pa[..., 2])
    x = -c * pa[..., 0] - s * pa[..., 1]
    y = s * pa[..., 0] - c * pa[..., 1]
    return np.stack([x, y, wrap_angle(-pa[..., 2])], axis=-1)


def relative(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """Pose of ``b`` seen from ``a``: ``inverse(a) ⊕ b`` (written ``b ⊖ a``).

    >>> relative([1.0, 1.0, np.pi / 2], [1.0, 2.0, np.pi / 2]).round(12).tolist()
    [1.0, 0.0, 0.0]
    """
    return compose(inverse(a), b)


def transform_points(pose: ArrayLike, points: ArrayLike) -> FloatArray:
    """Map points given in the frame of ``pose`` into the frame ``pose`` is expressed in.

    Parameters
    ----------
    pose : array_like, shape (3,)
        ``T_parent_child`` as (x, y, theta).
    points : array_like, shape (M, 2)
        Points in the child frame [m].

    Returns
    -------
    ndarray, shape (M, 2)
        The same points in the parent frame; a point with an infinite coordinate (a beam
        with no return) may come out with NaN in it, without a warning.
    """
    p = check_pose(pose)
    if p.ndim != 1:
        raise ValueError(f"transform_points takes one pose of shape (3,); got shape {p.shape}")
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ValueError(f"points must have shape (M, 2); got shape {pts.shape}")
    c, s = math.cos(p[2]), math.sin(p[2])
    rotation = np.array([[c, -s], [s, c]])
    with np.errstate(invalid="ignore"):   # inf · 0 in the rotation: NaN, said above
        return pts @ rotation.T + p[:2]


def yaw_to_quaternion(yaw: ArrayLike) -> FloatArray:
    """Quaternion ``(x, y, z, w) = (0, 0, sin(yaw/2), cos(yaw/2))`` of a rotation about +z.

    >>> yaw_to_quaternion(np.pi).round(12).tolist()
    [0.0, 0.0, 1.0, 0.0]
    """
    if isinstance(yaw, (float, int)):                 # the common scalar case, without stack
        h = 0.5 * float(yaw)
        return np.array([0.0, 0.0, math.sin(h), math.cos(h)])
    half = 0.5 * np.asarray(yaw, dtype=np.float64)
    out = np.zeros((*half.shape, 4))
    out[..., 2], out[..., 3] = np.sin(half), np.cos(half)
    return out


def quaternion_to_yaw(quaternion: ArrayLike) -> FloatArray:
    """Yaw (rotation about +z, in ``[-pi, pi)``) of quaternions ``(x, y, z, w)``, shape (..., 4).

    Uses the ZYX (roll-pitch-yaw) decomposition, so it is correct for tilted bodies as well.
    """
    q = np.asarray(quaternion, dtype=np.float64)
    if q.shape[-1:] != (4,):
        raise ValueError(f"quaternion must have shape (..., 4) in ROS order (x, y, z, w); "
                         f"got shape {q.shape}")
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return wrap_angle(np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))


def rpy_to_quaternion(roll: float, pitch: float, yaw: float) -> FloatArray:
    """Quaternion ``(x, y, z, w)`` of fixed-axis roll, pitch, yaw (URDF ``rpy``), i.e. Rz·Ry·Rx."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    ])


def quaternion_multiply(q1: ArrayLike, q2: ArrayLike) -> FloatArray:
    """Hamilton product ``q1 * q2`` of quaternions in ROS order, shape (..., 4).

    Two single quaternions take the same terms on Python floats, in the same order: the same
    result to the bit, without numpy's per-call cost."""
    a, b = np.asarray(q1, dtype=np.float64), np.asarray(q2, dtype=np.float64)
    if a.shape == (4,) and b.shape == (4,):
        x1, y1, z1, w1 = a.tolist()
        x2, y2, z2, w2 = b.tolist()
        return np.array([w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                         w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                         w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
                         w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2])
    x1, y1, z1, w1 = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    x2, y2, z2, w2 = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack([
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
    ], axis=-1)


def _cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """``np.cross`` of 3-vectors (shapes (..., 3), broadcast), the same products and
    differences without its axis handling, which costs far more than the arithmetic on a
    few vectors."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack(np.broadcast_arrays(a1 * b2 - a2 * b1, a2 * b0 - a0 * b2,
                                        a0 * b1 - a1 * b0), axis=-1)


def quaternion_rotate(q: ArrayLike, v: ArrayLike) -> FloatArray:
    """Rotate 3-vectors ``v`` (shape (..., 3)) by unit quaternions ``q`` (shape (..., 4)):
    ``v + w t + u × t`` with ``t = 2 u × v``, ``q = (u, w)``.

    One quaternion and one vector (a transform tree's lookups) take the same arithmetic on
    Python floats, term for term: the same result to the bit, without numpy's per-call cost.
    """
    qa = np.asarray(q, dtype=np.float64)
    va = np.asarray(v, dtype=np.float64)
    if qa.shape == (4,) and va.shape == (3,):
        x, y, z, w = qa.tolist()
        a, b, c = va.tolist()
        t0, t1, t2 = 2.0 * (y * c - z * b), 2.0 * (z * a - x * c), 2.0 * (x * b - y * a)
        return np.array([a + w * t0 + (y * t2 - z * t1), b + w * t1 + (z * t0 - x * t2),
                         c + w * t2 + (x * t1 - y * t0)])
    u, w4 = qa[..., :3], qa[..., 3:4]
    t = 2.0 * _cross(u, va)
    return va + w4 * t + _cross(u, t)


def quaternion_slerp(q0: ArrayLike, q1: ArrayLike, fraction: float) -> FloatArray:
    """Spherical linear interpolation between unit quaternions, taking the short way round."""
    a = np.asarray(q0, dtype=np.float64)
    b = np.asarray(q1, dtype=np.float64)
    dot = float(np.dot(a, b))
    if dot < 0.0:
        b, dot = -b, -dot
    if dot > 0.9995:  # nearly parallel: normalised lerp avoids dividing by sin(~0)
        q = a + fraction * (b - a)
        return q / np.linalg.norm(q)
    omega = math.acos(dot)
    s = math.sin(omega)
    return (math.sin((1.0 - fraction) * omega) * a + math.sin(fraction * omega) * b) / s
