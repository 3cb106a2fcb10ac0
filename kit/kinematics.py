"""Differential-drive kinematics.

The matrix form follows the Uiabot paper's derivation. With the robot's body velocity
``xi = [x_dot, y_dot, theta_dot]`` in base_link (base_link on the axle midpoint) and the wheel
speeds ``phi_dot = [phi_dot_r, phi_dot_l]`` (rad/s, **right first**, as in the derivation), the
rolling constraints of the two wheels and the no-sliding constraints stack into

.. math:: A\\,\\xi = B\\,\\dot\\phi,\\quad
          A = \\begin{bmatrix}1&0&b\\\\1&0&-b\\\\0&-1&0\\\\0&-1&0\\end{bmatrix},\\quad
          B = \\begin{bmatrix}r&0\\\\0&r\\\\0&0\\\\0&0\\end{bmatrix}

(``r`` wheel radius, ``b = l / 2`` half the wheel separation ``l``). Neither matrix is
square, so the forward kinematics is the least-squares solution ``xi = A⁺ B phi_dot`` and
the inverse ``phi_dot = B⁺ A xi`` (``⁺`` the Moore–Penrose pseudo-inverse), which work out to

    x_dot = r (phi_r + phi_l) / 2,  y_dot = 0,  theta_dot = r (phi_r - phi_l) / (2 b)
    phi_r = (x_dot + b theta_dot) / r,  phi_l = (x_dot - b theta_dot) / r

``theta_dot`` is positive — counter-clockwise, a **left** turn (REP-103) — when the right wheel
turns faster.

The IGV's equations (its paper) use wheel RPM ``u`` and 1.005 m per wheel turn:
``u_{L,R} = (4000 v ∓ 1440 ω) / 67``; its drives take velocities in counts/s × 2¹⁷/20000.

Every function takes the wheel separation ``wheel_separation`` (``l``, the distance between
the wheels' contact points) and orders wheel pairs (right, left), the IGV's included.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "DRIVE_VELOCITY_SCALE",
    "WHEEL_ORDER",
    "constraint_matrices",
    "drive_units_to_rpm",
    "forward_kinematics",
    "icc_body",
    "igv_body_velocity",
    "igv_wheel_rpm",
    "inverse_kinematics",
    "motor_speeds_to_twist",
    "rpm_to_drive_units",
    "saturate_wheel_speeds",
    "turning_radius",
    "turning_radius_from_wheels",
    "twist_to_motor_speeds",
    "twist_to_wheel_speeds",
    "wheel_speeds_to_twist",
]

FloatArray = NDArray[np.float64]

WHEEL_ORDER = ("right", "left")
"""Order of the wheels in every wheel-speed array of this module (the paper's order)."""

DRIVE_VELOCITY_SCALE = 2**17 / 20000
"""AMC DPRALTE velocity units per (count/s): the drive's 20 kHz loop in 2^17 fixed point."""

IGV_DISTANCE_PER_TURN = 1.005
IGV_WHEEL_SEPARATION = 0.72


def _positive(value: float, name: str, unit: str) -> float:
    v = float(value)
    if not v > 0 or not math.isfinite(v):
        raise ValueError(f"{name} must be a positive number of {unit}; got {value!r}")
    return v


def _last_axis(values: ArrayLike, n: int, name: str, meaning: str) -> FloatArray:
    a = np.asarray(values, dtype=np.float64)
    if a.ndim == 0 or a.shape[-1] != n:
        raise ValueError(f"{name} must have shape ({n},) or (N, {n}) as {meaning}; "
                         f"got shape {a.shape}")
    return a


def constraint_matrices(wheel_radius: float,
                        wheel_separation: float) -> tuple[FloatArray, FloatArray]:
    """The stacked rolling and no-sliding constraints ``A xi = B phi_dot``.

    Parameters
    ----------
    wheel_radius : float
        r [m].
    wheel_separation : float
        l, the distance between the wheels [m]; ``b = l / 2`` in the matrices.

    Returns
    -------
    A : ndarray, shape (4, 3)
        Rows: right rolling, left rolling, right no-slide, left no-slide.
    B : ndarray, shape (4, 2)
    """
    r = _positive(wheel_radius, "wheel_radius", "metres")
    b = _positive(wheel_separation, "wheel_separation", "metres") / 2.0
    A = np.array([[1.0, 0.0, b],
                  [1.0, 0.0, -b],
                  [0.0, -1.0, 0.0],
                  [0.0, -1.0, 0.0]])
    B = np.array([[r, 0.0],
                  [0.0, r],
                  [0.0, 0.0],
                  [0.0, 0.0]])
    return A, B


def forward_kinematics(wheel_speeds: ArrayLike, wheel_radius: float,
                       wheel_separation: float) -> FloatArray:
    """Body velocity from wheel speeds: ``xi = A⁺ B phi_dot``.

    Parameters
    ----------
    wheel_speeds : array_like, shape (2,) or (N, 2)
        ``[phi_dot_r, phi_dot_l]`` [rad/s], right wheel first.
    wheel_radius, wheel_separation : float
        r and l [m].

    Returns
    -------
    ndarray, shape (3,) or (N, 3)
        ``[x_dot, y_dot, theta_dot]`` in base_link [m/s, m/s, rad/s].

    >>> np.allclose(forward_kinematics([10.0, 10.0], 0.05, 0.361), [0.5, 0.0, 0.0])
    True
    """
    phi = _last_axis(wheel_speeds, 2, "wheel_speeds", "[right, left] wheel speeds in rad/s")
    return phi @ _jacobians(float(wheel_radius), float(wheel_separation))[0].T


def inverse_kinematics(body_velocity: ArrayLike, wheel_radius: float,
                       wheel_separation: float) -> FloatArray:
    """Wheel speeds from a body velocity: ``phi_dot = B⁺ A xi``.

    ``y_dot`` cannot be produced by a differential drive; the pseudo-inverse ignores it
    (least squares), as the no-sliding rows say it must be zero.

    Parameters
    ----------
    body_velocity : array_like, shape (3,) or (N, 3)
        ``[x_dot, y_dot, theta_dot]`` in base_link [m/s, m/s, rad/s].
    wheel_radius, wheel_separation : float
        r and l [m].

    Returns
    -------
    ndarray, shape (2,) or (N, 2)
        ``[phi_dot_r, phi_dot_l]`` [rad/s].

    >>> inverse_kinematics([0.0, 0.0, 1.0], 0.05, 0.361).round(12).tolist()
    [3.61, -3.61]
    """
    xi = _last_axis(body_velocity, 3, "body_velocity", "[x_dot, y_dot, theta_dot]")
    return xi @ _jacobians(float(wheel_radius), float(wheel_separation))[1].T


@functools.lru_cache(maxsize=64)
def _jacobians(wheel_radius: float, wheel_separation: float) -> tuple[FloatArray, FloatArray]:
    """``A⁺ B`` (3, 2) and ``B⁺ A`` (2, 3), kept per robot: odometry and the simulator ask
    for them at every message and every command."""
    A, B = constraint_matrices(wheel_radius, wheel_separation)
    forward, inverse = np.linalg.pinv(A) @ B, np.linalg.pinv(B) @ A
    forward.flags.writeable = inverse.flags.writeable = False
    return forward, inverse


def twist_to_wheel_speeds(linear: ArrayLike, angular: ArrayLike, wheel_radius: float,
                          wheel_separation: float) -> FloatArray:
    """``cmd_vel`` (v [m/s], ω [rad/s]) → ``[phi_dot_r, phi_dot_l]`` [rad/s], shape (..., 2)."""
    v = np.asarray(linear, dtype=np.float64)
    w = np.asarray(angular, dtype=np.float64)
    xi = np.stack(np.broadcast_arrays(v, np.zeros_like(v), w), axis=-1)
    return inverse_kinematics(xi, wheel_radius, wheel_separation)


def wheel_speeds_to_twist(wheel_speeds: ArrayLike, wheel_radius: float,
                          wheel_separation: float) -> tuple[FloatArray, FloatArray]:
    """``[phi_dot_r, phi_dot_l]`` [rad/s] → (v [m/s], ω [rad/s])."""
    xi = forward_kinematics(wheel_speeds, wheel_radius, wheel_separation)
    return xi[..., 0], xi[..., 2]


def motor_speeds_to_twist(motor_speeds: ArrayLike, wheel_radius: float, wheel_separation: float,
                          gear_ratio: float, left_sign: float = 1.0) -> FloatArray:
    """What the Uiabot's odometry node does: motor speeds [turns/s] → (v [m/s], ω [rad/s]).

    The ODrive reports each motor's speed in turns per second; through a gearbox of ratio
    ``i`` the wheel turns at ``phi_dot = 2 pi turns_per_s / i`` rad/s. A motor mounted mirrored
    turns backwards for a forward wheel: ``left_sign = -1`` undoes that.

    Parameters
    ----------
    motor_speeds : array_like, shape (2,) or (N, 2)
        (right, left) motor speeds [turns/s] as the motor controller reports them.

    Returns
    -------
    ndarray, shape (2,) or (N, 2)
        (v, ω).
    """
    m = _last_axis(motor_speeds, 2, "motor_speeds", "[right, left] motor speeds in turns/s")
    i = _positive(gear_ratio, "gear_ratio", "motor turns per wheel turn")
    wheel = m * np.array([1.0, float(left_sign)]) * 2.0 * np.pi / i
    xi = forward_kinematics(wheel, wheel_radius, wheel_separation)
    return np.stack([xi[..., 0], xi[..., 2]], axis=-1)


def twist_to_motor_speeds(linear: ArrayLike, angular: ArrayLike, wheel_radius: float,
                          wheel_separation: float, gear_ratio: float,
                          left_sign: float = 1.0) -> FloatArray:
    """What the Uiabot's twist node does: ``cmd_vel`` (v, ω) → motor speeds [turns/s].

    This is the **inverse** kinematics (erratum 6: the paper's text says forward):
    ``phi_dot_{r,l} = (v ± b ω) / r`` rad/s at the wheels, times ``i / (2 pi)`` for motor
    turns per second, the left one multiplied by ``left_sign``.

    Returns
    -------
    ndarray, shape (..., 2)
        (right, left) motor speed commands [turns/s].
    """
    i = _positive(gear_ratio, "gear_ratio", "motor turns per wheel turn")
    wheel = twist_to_wheel_speeds(linear, angular, wheel_radius, wheel_separation)
    return wheel * i / (2.0 * np.pi) * np.array([1.0, float(left_sign)])


# --------------------------------------------------------------------------- IGV

def igv_wheel_rpm(linear: ArrayLike, angular: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """The IGV paper's eq. 7: ``u_{R,L} = (4000 v ± 1440 ω) / 67`` [RPM].

    Follows from ``v_{L,R} = 1.005 u / 60`` and ``l = 0.72 m``. Returns ``(u_R, u_L)``,
    right first as every wheel pair in the kit (the paper writes ``u_{L,R}``, left first).

    Parameters
    ----------
    linear, angular : array_like
        v [m/s] along base_link's x and ω [rad/s], counter-clockwise positive.

    >>> [round(float(u), 6) for u in igv_wheel_rpm(0.0, 0.67)]
    [14.4, -14.4]
    """
    v = np.asarray(linear, dtype=np.float64)
    w = np.asarray(angular, dtype=np.float64)
    return (4000.0 * v + 1440.0 * w) / 67.0, (4000.0 * v - 1440.0 * w) / 67.0


def igv_body_velocity(u_right: ArrayLike, u_left: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """The IGV paper's eqs. 1, 3, 6: ``v = 67 (u_R + u_L) / 8000``, ``ω = 67 (u_R − u_L) / 2880``.

    Wheel speeds ``u_right``, ``u_left`` in RPM; returns (v [m/s], ω [rad/s]).
    """
    uR = np.asarray(u_right, dtype=np.float64)
    uL = np.asarray(u_left, dtype=np.float64)
    return 67.0 * (uL + uR) / 8000.0, 67.0 * (uR - uL) / 2880.0


def rpm_to_drive_units(rpm: ArrayLike, counts_per_rev: int = 400) -> NDArray[np.int64]:
    """Velocity command for an AMC DPRALTE drive: RPM → counts/s → drive units (rounded).

    units = rpm · counts_per_rev / 60 · 2¹⁷ / 20000

    >>> int(rpm_to_drive_units(10.0))
    437
    """
    counts_per_second = np.asarray(rpm, dtype=np.float64) * counts_per_rev / 60.0
    return np.rint(counts_per_second * DRIVE_VELOCITY_SCALE).astype(np.int64)


def drive_units_to_rpm(units: ArrayLike, counts_per_rev: int = 400) -> FloatArray:
    """Inverse of :func:`rpm_to_drive_units` (without its rounding)."""
    return np.asarray(units, dtype=np.float64) / DRIVE_VELOCITY_SCALE * 60.0 / counts_per_rev


# --------------------------------------------------------------------------- curvature

def turning_radius(linear: ArrayLike, angular: ArrayLike) -> FloatArray:
    """Signed turning radius ``R = v / ω`` [m]; positive turns left (centre on +y).

    Driving straight (ω = 0) gives ``±inf`` (the sign of v; ``+inf`` when standing still);
    turning in place gives 0.
    """
    v = np.asarray(linear, dtype=np.float64)
    w = np.asarray(angular, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        R = v / w
    straight = np.where(v < 0, -np.inf, np.inf)
    return np.where(w == 0.0, straight, R)


def turning_radius_from_wheels(v_right: ArrayLike, v_left: ArrayLike,
                               wheel_separation: float) -> FloatArray:
    """The IGV paper's eq. 5: ``R = l (v_R + v_L) / (2 (v_R − v_L))`` from the (right, left)
    wheel velocities [m/s]; ``±inf`` when both wheels run at the same speed."""
    vr = np.asarray(v_right, dtype=np.float64)
    vl = np.asarray(v_left, dtype=np.float64)
    l_ = _positive(wheel_separation, "wheel_separation", "metres")
    return turning_radius((vl + vr) / 2.0, (vr - vl) / l_)


def icc_body(linear: ArrayLike, angular: ArrayLike) -> FloatArray:
    """Instantaneous centre of curvature in base_link, ``(0, R)`` [m], shape (..., 2).

    Straight driving puts it at ``(0, ±inf)``: infinitely far to the side.
    """
    R = turning_radius(linear, angular)
    return np.stack([np.zeros_like(R), R], axis=-1)


def saturate_wheel_speeds(wheel_speeds: ArrayLike, max_wheel_speed: float) -> FloatArray:
    """Scale both wheel speeds by one factor so neither exceeds ``max_wheel_speed`` [rad/s].

    Clipping each wheel on its own would change the ratio of the two speeds, and with it the
    curvature ω / v: the robot would leave the commanded arc. Scaling both keeps the arc and
    slows down along it.

    >>> saturate_wheel_speeds([30.0, 10.0], 15.0).tolist()
    [15.0, 5.0]
    """
    phi = _last_axis(wheel_speeds, 2, "wheel_speeds", "[right, left] wheel speeds in rad/s")
    limit = _positive(max_wheel_speed, "max_wheel_speed", "rad/s")
    peak = np.max(np.abs(phi), axis=-1, keepdims=True)
    return phi * (limit / np.maximum(peak, limit))
