"""Wheel odometry: encoder ticks → wheel travel → pose, with its uncertainty.

Per sampling interval the right and left encoders count ``N_r`` and ``N_l`` ticks; with the
conversion factor ``c_m = pi D / (n C_e)`` (wheel diameter D, gear ratio n, encoder counts
per motor turn C_e) the wheels travel ``Δs_{r,l} = c_m N_{r,l}``, the robot

    Δs = (Δs_r + Δs_l) / 2,        Δθ = (Δs_r − Δs_l) / L        (L: wheel separation)

and the pose is **accumulated**: ``θ_{k+1} = θ_k + Δθ`` (never ``θ = θ̇ Δt``). Three ways to
move (x, y) over one interval are offered:

* ``"euler"``:    ``x += Δs cos θ_k``
* ``"midpoint"``: ``x += Δs cos(θ_k + Δθ/2)``
* ``"exact"``:    the arc of constant curvature: ``x += Δs sinc(Δθ/2) cos(θ_k + Δθ/2)``,
  i.e. ``R (sin θ_{k+1} − sin θ_k)`` with ``R = Δs/Δθ``, written so that Δθ → 0 is exact too.

(and the same with sin for y). Wheel arrays are ordered right, left, as in
:mod:`kit.kinematics`.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs

__all__ = [
    "UNUSED_VARIANCE",
    "WheelOdometry",
    "conversion_factor",
    "covariance_to_ros",
    "eddie_odometry_step",
    "integrate_odometry",
    "odom_transform",
    "odometry_covariance_step",
    "odometry_message",
    "odometry_step",
    "tick_delta",
    "ticks_to_travel",
]

FloatArray = NDArray[np.float64]
Real = float | np.floating[Any] | NDArray[np.floating[Any]]
"""One step's value (a float or numpy scalar) or many steps' (an array)."""
Method = Literal["exact", "midpoint", "euler"]
_METHODS = ("exact", "midpoint", "euler")

UNUSED_VARIANCE = 1.0e6
"""Variance written for z, roll and pitch, which a planar odometry does not measure."""


def conversion_factor(wheel_diameter: float, gear_ratio: float,
                      encoder_resolution: float) -> float:
    """Metres of wheel travel per encoder count: ``c_m = pi D / (n C_e)``.

    Parameters
    ----------
    wheel_diameter : float
        D [m].
    gear_ratio : float
        n, motor turns per wheel turn (1 when the encoder is on the wheel).
    encoder_resolution : float
        C_e, counts per motor turn.

    >>> round(conversion_factor(2 * 0.0762, 1.0, 144), 9)   # Eddie
    0.003324852
    """
    for value, name in ((wheel_diameter, "wheel_diameter"), (gear_ratio, "gear_ratio"),
                        (encoder_resolution, "encoder_resolution")):
        if not (math.isfinite(float(value)) and float(value) > 0):
            raise ValueError(f"{name} must be a positive number; got {value!r}")
    return math.pi * float(wheel_diameter) / (float(gear_ratio) * float(encoder_resolution))


def tick_delta(previous: ArrayLike, current: ArrayLike,
               counter_bits: int = 16) -> NDArray[np.int64]:
    """Signed tick increment between two readings of a counter that rolls over.

    A ``counter_bits`` counter counts modulo ``2**counter_bits``; the increment is taken as
    the one of smallest magnitude, so a counter that wrapped from 65535 to 2 moved +3 ticks.
    Valid while a wheel turns less than half the counter's range per sample.

    >>> int(tick_delta(65534, 3, counter_bits=16)), int(tick_delta(3, 65534, counter_bits=16))
    (5, -5)
    """
    if not isinstance(counter_bits, (int, np.integer)) or not 2 <= counter_bits <= 63:
        raise ValueError(f"counter_bits must be an integer from 2 to 63; got {counter_bits!r}")
    modulus = 1 << int(counter_bits)
    if type(previous) is int and type(current) is int:   # one reading, as a node gets it
        step = (current - previous) % modulus
        return np.array(step - modulus if step >= modulus // 2 else step, dtype=np.int64)
    prev = np.asarray(previous)
    cur = np.asarray(current)
    if prev.dtype.kind not in "iu" or cur.dtype.kind not in "iu":
        raise TypeError(f"encoder readings must be integers; got {prev.dtype} and {cur.dtype}")
    d = (cur.astype(np.int64) - prev.astype(np.int64)) % modulus
    return np.where(d >= modulus // 2, d - modulus, d).astype(np.int64)


def ticks_to_travel(delta_ticks: ArrayLike, metres_per_tick: float) -> FloatArray:
    """Wheel travel [m] of tick increments: ``Δs = c_m N``."""
    return np.asarray(delta_ticks, dtype=np.float64) * float(metres_per_tick)


def _increments(theta: Real, d_right: Real, d_left: Real, wheel_separation: float, method: str
                ) -> tuple[Real, Real, Real]:
    if method not in _METHODS:
        raise ValueError(f"method must be one of {_METHODS}; got {method!r}")
    if not wheel_separation > 0:
        raise ValueError(f"wheel_separation must be positive metres; got {wheel_separation!r}")
    ds = 0.5 * (d_right + d_left)
    dtheta = (d_right - d_left) / wheel_separation
    if method == "euler":
        heading, length = theta, ds
    else:
        heading = theta + 0.5 * dtheta
        # np.sinc(x) = sin(pi x)/(pi x): the chord of the arc is Δs sin(Δθ/2)/(Δθ/2)
        length = ds * _sinc(dtheta / (2.0 * np.pi)) if method == "exact" else ds
    if isinstance(heading, float):   # one step (float or np.float64): math, as numpy computes
        return length * math.cos(heading), length * math.sin(heading), dtheta
    return length * np.cos(heading), length * np.sin(heading), dtheta


def _sinc(x: Real) -> Real:
    """``np.sinc``, with the same arithmetic on a scalar without the ufunc calls."""
    if isinstance(x, float):
        y = math.pi * (x if x != 0 else 1.0e-20)
        return math.sin(y) / y
    return np.sinc(x)


def odometry_step(pose: ArrayLike, d_right: float, d_left: float, wheel_separation: float,
                  method: Method = "exact") -> FloatArray:
    """Advance a pose by one interval's wheel travel.

    Parameters
    ----------
    pose : array_like, shape (3,)
        (x, y, θ) in odom [m, m, rad] before the interval.
    d_right, d_left : float
        Δs_r, Δs_l, each wheel's travel in the interval [m].
    wheel_separation : float
        L [m].
    method : {"exact", "midpoint", "euler"}

    Returns
    -------
    ndarray, shape (3,)
        The pose after the interval, θ wrapped to [−π, π).

    >>> odometry_step([0, 0, 0], np.pi * 0.25, -np.pi * 0.25, 0.5).round(12).tolist()
    [0.0, 0.0, -3.14159265359]
    """
    p = geometry.check_pose(pose)
    if p.ndim != 1:
        raise ValueError(f"odometry_step takes one pose of shape (3,); got {p.shape}")
    dx, dy, dth = _increments(np.float64(p[2]), np.float64(d_right), np.float64(d_left),
                              float(wheel_separation), method)
    return np.array([p[0] + dx, p[1] + dy, float(geometry.wrap_angle(p[2] + dth))])


def eddie_odometry_step(pose: ArrayLike, d_right: float, d_left: float,
                        wheel_separation: float) -> FloatArray:
    """The service robot's (Eddie's) odometry update, with its heading sign fixed.

    Eddie's code turns first and then moves along the *new* heading:
    ``θ' = θ + (Δs_r − Δs_l)/L``, ``x' = x + Δs cos θ'``, ``y' = y + Δs sin θ'``. The paper
    prints ``(left − right)``, which is clockwise-positive (erratum 7); REP-103 needs
    ``(right − left)``. Like Euler it is first order: its error shrinks with the step.
    """
    p = geometry.check_pose(pose)
    ds = 0.5 * (float(d_right) + float(d_left))
    theta = float(geometry.wrap_angle(p[2] + (float(d_right) - float(d_left)) /
                                      float(wheel_separation)))
    return np.array([p[0] + ds * math.cos(theta), p[1] + ds * math.sin(theta), theta])


def integrate_odometry(d_right: ArrayLike, d_left: ArrayLike, wheel_separation: float,
                       initial_pose: ArrayLike = (0.0, 0.0, 0.0),
                       method: Method = "exact") -> FloatArray:
    """Accumulate a whole sequence of wheel travels into a path, vectorised.

    Parameters
    ----------
    d_right, d_left : array_like, shape (N,)
        Each interval's wheel travel [m].

    Returns
    -------
    ndarray, shape (N + 1, 3)
        The initial pose and the pose after each interval.
    """
    dr = np.asarray(d_right, dtype=np.float64)
    dl = np.asarray(d_left, dtype=np.float64)
    if dr.ndim != 1 or dr.shape != dl.shape:
        raise ValueError(f"d_right and d_left must be 1-D arrays of equal length; got shapes "
                         f"{dr.shape} and {dl.shape}")
    p0 = geometry.check_pose(initial_pose, "initial_pose")
    if not np.all(np.isfinite(dr)) or not np.all(np.isfinite(dl)):
        raise ValueError("wheel travels contain NaN or infinite values")
    dtheta = (dr - dl) / float(wheel_separation)
    theta_before = p0[2] + np.concatenate([[0.0], np.cumsum(dtheta)[:-1]])
    dx, dy, _ = _increments(theta_before, dr, dl, float(wheel_separation), method)
    path = np.empty((len(dr) + 1, 3))
    path[0] = p0
    path[1:, 0] = p0[0] + np.cumsum(dx)
    path[1:, 1] = p0[1] + np.cumsum(dy)
    path[1:, 2] = geometry.wrap_angle(theta_before + dtheta)
    return path


def odometry_covariance_step(covariance: ArrayLike, pose: ArrayLike, d_right: float,
                             d_left: float, wheel_separation: float, k_right: float,
                             k_left: float) -> FloatArray:
    """Propagate the 3×3 pose covariance over one interval (Siegwart's wheel-error model).

    Each wheel's travel error is zero-mean with variance ``k |Δs|`` (it grows with the
    distance each wheel rolls, so with distance and with rotation), and the pose follows
    the midpoint model; to first order

    .. math:: P' = F_p P F_p^T + F_Δ \\,\\mathrm{diag}(k_r|Δs_r|, k_l|Δs_l|)\\, F_Δ^T

    with ``F_p = ∂pose'/∂pose`` and ``F_Δ = ∂pose'/∂(Δs_r, Δs_l)``.
    """
    P = np.asarray(covariance, dtype=np.float64)
    if P.shape != (3, 3):
        raise ValueError(f"covariance must have shape (3, 3); got {P.shape}")
    p = geometry.check_pose(pose)
    L = float(wheel_separation)
    ds = 0.5 * (d_right + d_left)
    a = float(p[2]) + 0.5 * (d_right - d_left) / L
    c, s = math.cos(a), math.sin(a)
    # F_p = [[1, 0, fx], [0, 1, fy], [0, 0, 1]] and F_Δ's rows (dr, dl), written out: the
    # products of 3×3 matrices in floats (an odometry node runs this at 50 Hz)
    fx, fy = -ds * s, ds * c
    h = ds / (2 * L)
    F_d = ((0.5 * c - h * s, 0.5 * c + h * s), (0.5 * s + h * c, 0.5 * s - h * c),
           (1.0 / L, -1.0 / L))
    q_r, q_l = k_right * abs(d_right), k_left * abs(d_left)
    (p00, p01, p02), (p10, p11, p12), (p20, p21, p22) = P.tolist()
    m = ((p00 + fx * p20, p01 + fx * p21, p02 + fx * p22),    # F_p P
         (p10 + fy * p20, p11 + fy * p21, p12 + fy * p22),
         (p20, p21, p22))
    fpf = [(r0 + fx * r2, r1 + fy * r2, r2) for r0, r1, r2 in m]   # F_p P F_p^T
    out = np.array([[fpf[i][j] + F_d[i][0] * F_d[j][0] * q_r + F_d[i][1] * F_d[j][1] * q_l
                     for j in range(3)] for i in range(3)])
    return 0.5 * (out + out.T)  # keep it exactly symmetric


# flat indices of (x, y, yaw) × (x, y, yaw) and of the z, roll, pitch diagonal in a 6×6
_ROS_XY_YAW = np.array([6 * r + c for r in (0, 1, 5) for c in (0, 1, 5)])
_ROS_UNUSED = np.array([14, 21, 28])


def covariance_to_ros(covariance_xy_yaw: ArrayLike) -> FloatArray:
    """Embed a 3×3 (x, y, yaw) covariance into ROS's row-major 6×6 (x, y, z, roll, pitch, yaw).

    z, roll and pitch get :data:`UNUSED_VARIANCE` on the diagonal: not measured.
    """
    C = np.asarray(covariance_xy_yaw, dtype=np.float64)
    if C.shape != (3, 3):
        raise ValueError(f"covariance must have shape (3, 3); got {C.shape}")
    full = np.zeros(36)
    full[_ROS_XY_YAW] = C.ravel()
    full[_ROS_UNUSED] = UNUSED_VARIANCE
    return full


def odometry_message(pose: ArrayLike, velocity: ArrayLike, stamp: msgs.Time,
                     pose_covariance: ArrayLike | None = None,
                     twist_covariance: ArrayLike | None = None, frame_id: str = "odom",
                     child_frame_id: str = "base_link") -> msgs.Odometry:
    """A ``nav_msgs/Odometry``: pose (x, y, θ) in ``odom``, velocity (v, ω) in ``base_link``.

    The orientation is the quaternion of θ: ``(0, 0, sin θ/2, cos θ/2)``.
    """
    p = geometry.check_pose(pose)
    v = np.asarray(velocity, dtype=np.float64)
    if v.shape != (2,):
        raise ValueError(f"velocity must be (v [m/s], omega [rad/s]); got shape {v.shape}")
    x, y, yaw = p.tolist()
    v_lin, v_ang = v.tolist()
    zeros3 = np.zeros((3, 3))
    # fresh arrays made read-only: the messages keep them instead of copying
    pose_cov = covariance_to_ros(pose_covariance if pose_covariance is not None else zeros3)
    twist_cov = covariance_to_ros(twist_covariance if twist_covariance is not None else zeros3)
    pose_cov.flags.writeable = twist_cov.flags.writeable = False
    return msgs.Odometry(
        header=msgs.Header(stamp, frame_id),
        child_frame_id=child_frame_id,
        pose=msgs.PoseWithCovariance(
            msgs.Pose(msgs.Point(x, y, 0.0),
                      msgs.Quaternion(*geometry.yaw_to_quaternion(yaw).tolist())),
            pose_cov),
        twist=msgs.TwistWithCovariance(
            msgs.Twist(msgs.Vector3(v_lin, 0.0, 0.0), msgs.Vector3(0.0, 0.0, v_ang)),
            twist_cov),
    )


def odom_transform(pose: ArrayLike, stamp: msgs.Time, frame_id: str = "odom",
                   child_frame_id: str = "base_link") -> msgs.TransformStamped:
    """The ``odom → base_link`` transform of a planar pose, as the odometry node broadcasts it."""
    p = geometry.check_pose(pose)
    q = geometry.yaw_to_quaternion(p[2])
    return msgs.TransformStamped(
        msgs.Header(stamp, frame_id), child_frame_id,
        msgs.Transform(msgs.Vector3(float(p[0]), float(p[1]), 0.0),
                       msgs.Quaternion(*map(float, q))))


def _single_pose(pose: ArrayLike, name: str) -> FloatArray:
    p = geometry.check_pose(pose, name)
    if p.shape != (3,):
        raise ValueError(f"{name} is one pose (x [m], y [m], theta [rad]); got shape {p.shape}")
    return p.copy()


class WheelOdometry:
    """Stateful odometry node logic: raw counter readings in, ``Odometry`` out.

    Calls only the pure functions of this module; it keeps the last readings, the pose and
    its covariance. The first :meth:`update` only latches the counters.

    Parameters
    ----------
    metres_per_tick : float
        c_m [m/count].
    wheel_separation : float
        L [m].
    counter_bits : int
        Width of the encoder counters (roll-over).
    k_right, k_left : float
        Wheel-travel variance per metre [m²/m] for the covariance.
    method : {"exact", "midpoint", "euler"}
    initial_pose : array_like, shape (3,)
        (x, y, θ) in odom [m, m, rad] where the robot starts (odom's origin by default).
    """

    def __init__(self, metres_per_tick: float, wheel_separation: float, counter_bits: int = 32,
                 k_right: float = 0.0, k_left: float = 0.0, method: Method = "exact",
                 initial_pose: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        if not metres_per_tick > 0 or not wheel_separation > 0:
            raise ValueError("metres_per_tick and wheel_separation must be positive")
        self.metres_per_tick = float(metres_per_tick)
        self.wheel_separation = float(wheel_separation)
        self.counter_bits = int(counter_bits)
        self.k = (float(k_right), float(k_left))
        self.method: Method = method
        self.pose = _single_pose(initial_pose, "initial_pose")
        self.covariance: FloatArray = np.zeros((3, 3))
        self.velocity: FloatArray = np.zeros(2)
        self.twist_covariance: FloatArray = np.diag([1e-9, UNUSED_VARIANCE, 1e-9])
        self._last: tuple[int, int, float] | None = None

    @classmethod
    def for_robot(cls, robot: object, method: Method = "exact",
                  initial_pose: ArrayLike = (0.0, 0.0, 0.0)) -> WheelOdometry:
        """Set up from a :class:`kit.robots.RobotDescription` (``Simulation.description()``
        gives a simulated robot's), starting at ``initial_pose``."""
        from kit.robots import RobotDescription

        if not isinstance(robot, RobotDescription):
            raise TypeError(f"expected a RobotDescription; got {type(robot).__name__}")
        return cls(robot.metres_per_tick, robot.wheel_separation, robot.counter_bits,
                   robot.odometry_k[0], robot.odometry_k[1], method, initial_pose)

    def update(self, ticks_right: int, ticks_left: int, time: float) -> msgs.Odometry:
        """Feed one pair of raw counter readings taken at ``time`` [s]."""
        if self._last is not None:
            last_r, last_l, last_t = self._last
            dt = time - last_t
            if not dt > 0:
                raise ValueError(f"odometry readings must come in increasing time; got t={time} "
                                 f"after t={last_t}")
            d_r = float(ticks_to_travel(tick_delta(last_r, ticks_right, self.counter_bits),
                                        self.metres_per_tick))
            d_l = float(ticks_to_travel(tick_delta(last_l, ticks_left, self.counter_bits),
                                        self.metres_per_tick))
            self.covariance = odometry_covariance_step(
                self.covariance, self.pose, d_r, d_l, self.wheel_separation, *self.k)
            self.pose = odometry_step(self.pose, d_r, d_l, self.wheel_separation, self.method)
            self.velocity = np.array([0.5 * (d_r + d_l) / dt,
                                      (d_r - d_l) / self.wheel_separation / dt])
            # the same wheel-error model for the velocities of this interval
            travel_var = self.k[0] * abs(d_r) + self.k[1] * abs(d_l)
            self.twist_covariance = np.diag([travel_var / (4 * dt * dt), UNUSED_VARIANCE,
                                             travel_var / (self.wheel_separation * dt) ** 2])
        self._last = (int(ticks_right), int(ticks_left), float(time))
        return self.message(time)

    def message(self, time: float) -> msgs.Odometry:
        return odometry_message(self.pose, self.velocity, msgs.Time.from_sec(time),
                                self.covariance, self.twist_covariance)

    def transform(self, time: float) -> msgs.TransformStamped:
        return odom_transform(self.pose, msgs.Time.from_sec(time))
