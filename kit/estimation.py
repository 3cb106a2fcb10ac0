"""State estimation: a generic extended Kalman filter and a planar fusion filter configured
the way ROS's robot_localization is.

The EKF is a pair of pure functions in textbook symbols (Thrun, Burgard & Fox; Labbe's
*Kalman and Bayesian Filters in Python*)::

    predict:  x⁻ = f(x),  P⁻ = F P Fᵀ + Q
    update:   y = z ⊖ h(x⁻),  S = H P⁻ Hᵀ + R,  K = P⁻ Hᵀ S⁻¹,
              x⁺ = x⁻ + K y,  P⁺ = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ   (Joseph form)

The Joseph form keeps P symmetric positive semi-definite even with rounding and a K that is
not exactly optimal, which the short form (I − K H) P does not. Residuals of angle components
are wrapped to [−π, π) (``⊖``): a heading of 179° measured as −179° is 2° off, not 358°.

:class:`FusionFilter` runs that EKF on the planar state ``x = [x, y, yaw, vx, vyaw, ax]``
(robot_localization's state with ``two_d_mode``, without the lateral velocity a differential
drive cannot have), fed by ``Odometry`` and ``Imu`` messages selected per sensor by
robot_localization's 15-element boolean vectors ``[x, y, z, roll, pitch, yaw, vx, vy, vz,
vroll, vpitch, vyaw, ax, ay, az]``, with its ``differential`` and ``relative`` modes, and
publishes ``Odometry`` in ``odom`` and the ``odom → base_link`` transform at ``frequency``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs, odometry

__all__ = [
    "CONFIG_FIELDS",
    "EKF",
    "FusionFilter",
    "PlanarModel",
    "SensorConfig",
    "nees",
    "nis",
    "predict",
    "residual",
    "update",
]

FloatArray = NDArray[np.float64]

CONFIG_FIELDS = ("x", "y", "z", "roll", "pitch", "yaw", "vx", "vy", "vz", "vroll", "vpitch",
                 "vyaw", "ax", "ay", "az")
"""robot_localization's order of a sensor's ``*_config`` vector."""

STATE = ("x", "y", "yaw", "vx", "vyaw", "ax")
"""The planar fusion state."""


def residual(z: ArrayLike, z_hat: ArrayLike, angle_indices: Sequence[int] = ()) -> FloatArray:
    """``z − z_hat`` with the angle components wrapped to [−π, π)."""
    y = np.asarray(z, dtype=np.float64) - np.asarray(z_hat, dtype=np.float64)
    for i in angle_indices:
        y[i] = float(geometry.wrap_angle(y[i]))
    return y


def predict(x: ArrayLike, P: ArrayLike, f: Callable[[FloatArray], FloatArray],
            F: ArrayLike, Q: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """EKF prediction: ``x⁻ = f(x)``, ``P⁻ = F P Fᵀ + Q`` (F is ∂f/∂x at x)."""
    xa = np.asarray(x, dtype=np.float64)
    Pa = np.asarray(P, dtype=np.float64)
    Fa = np.asarray(F, dtype=np.float64)
    x_new = np.asarray(f(xa), dtype=np.float64)
    P_new = Fa @ Pa @ Fa.T + np.asarray(Q, dtype=np.float64)
    return x_new, 0.5 * (P_new + P_new.T)


def update(x: ArrayLike, P: ArrayLike, z: ArrayLike, h: Callable[[FloatArray], FloatArray],
           H: ArrayLike, R: ArrayLike, angle_indices: Sequence[int] = (),
           state_angle_indices: Sequence[int] = ()
           ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """EKF update with the Joseph-form covariance.

    Returns ``(x⁺, P⁺, y, S)``: the innovation ``y`` and its covariance ``S`` give the NIS.
    ``angle_indices`` are the measurement's angle components (their residual is wrapped),
    ``state_angle_indices`` the state's (wrapped after the update).
    """
    xa = np.asarray(x, dtype=np.float64)
    Pa = np.asarray(P, dtype=np.float64)
    Ha = np.atleast_2d(np.asarray(H, dtype=np.float64))
    Ra = np.atleast_2d(np.asarray(R, dtype=np.float64))
    y = residual(z, h(xa), angle_indices)                          # innovation
    S = Ha @ Pa @ Ha.T + Ra                                         # its covariance
    K = np.linalg.solve(S.T, (Pa @ Ha.T).T).T                       # P Hᵀ S⁻¹
    x_new = xa + K @ y
    for i in state_angle_indices:
        x_new[i] = float(geometry.wrap_angle(x_new[i]))
    I_KH = np.eye(len(xa)) - K @ Ha
    P_new = I_KH @ Pa @ I_KH.T + K @ Ra @ K.T                       # Joseph form
    return x_new, 0.5 * (P_new + P_new.T), y, S


def nis(y: ArrayLike, S: ArrayLike) -> float:
    """Normalised innovation squared ``yᵀ S⁻¹ y`` (χ² with dim(y) degrees of freedom)."""
    ya = np.asarray(y, dtype=np.float64)
    return float(ya @ np.linalg.solve(np.asarray(S, dtype=np.float64), ya))


def nees(x_true: ArrayLike, x: ArrayLike, P: ArrayLike,
         angle_indices: Sequence[int] = ()) -> float:
    """Normalised estimation error squared ``eᵀ P⁻¹ e`` with ``e = x_true ⊖ x``."""
    e = residual(x_true, x, angle_indices)
    return float(e @ np.linalg.solve(np.asarray(P, dtype=np.float64), e))


class EKF:
    """Thin stateful wrapper for notebooks: holds ``x`` and ``P`` and calls the pure
    functions; the last update's NIS is kept."""

    def __init__(self, x: ArrayLike, P: ArrayLike) -> None:
        self.x = np.asarray(x, dtype=np.float64).copy()
        self.P = np.asarray(P, dtype=np.float64).copy()
        self.last_nis = math.nan

    def predict(self, f: Callable[[FloatArray], FloatArray], F: ArrayLike, Q: ArrayLike) -> None:
        self.x, self.P = predict(self.x, self.P, f, F, Q)

    def update(self, z: ArrayLike, h: Callable[[FloatArray], FloatArray], H: ArrayLike,
               R: ArrayLike, angle_indices: Sequence[int] = (),
               state_angle_indices: Sequence[int] = ()) -> None:
        self.x, self.P, y, S = update(self.x, self.P, z, h, H, R, angle_indices,
                                      state_angle_indices)
        self.last_nis = nis(y, S)


@dataclass(frozen=True)
class PlanarModel:
    """Constant-acceleration planar motion of ``[x, y, yaw, vx, vyaw, ax]`` (robot frame
    velocities, world-frame position):

    .. math:: x' = x + (v_x Δt + ½ a_x Δt²)\\cos ψ,\\; y' = y + (v_x Δt + ½ a_x Δt²)\\sin ψ,
              \\; ψ' = ψ + ω Δt,\\; v_x' = v_x + a_x Δt

    with white process noise of the given spectral densities on ``vyaw`` and ``ax`` (and a
    little on every state, as robot_localization's process_noise_covariance has).
    """

    accel_noise: float = 0.6
    """m²/s⁵: spectral density of the jerk driving ax."""
    yaw_rate_noise: float = 0.4
    """rad²/s³: of the yaw acceleration driving vyaw. (These two defaults were tuned on the
    simulated Uiabot until 50 seeded runs gave NEES and NIS inside their 95 % bounds; see
    tests/test_estimation.py.)"""
    floor: FloatArray = field(default_factory=lambda: np.array(
        [1e-4, 1e-4, 1e-4, 1e-3, 1e-3, 1e-3]))
    """per-second variance added to each state."""

    def f(self, x: FloatArray, dt: float) -> FloatArray:
        px, py, yaw, vx, w, ax = x
        s = vx * dt + 0.5 * ax * dt * dt
        return np.array([px + s * math.cos(yaw), py + s * math.sin(yaw),
                         float(geometry.wrap_angle(yaw + w * dt)), vx + ax * dt, w, ax])

    def F_x(self, x: FloatArray, dt: float) -> FloatArray:
        _, _, yaw, vx, _, ax = x
        s = vx * dt + 0.5 * ax * dt * dt
        c, sn = math.cos(yaw), math.sin(yaw)
        return np.array([[1, 0, -s * sn, dt * c, 0, 0.5 * dt * dt * c],
                         [0, 1, s * c, dt * sn, 0, 0.5 * dt * dt * sn],
                         [0, 0, 1, 0, dt, 0],
                         [0, 0, 0, 1, 0, dt],
                         [0, 0, 0, 0, 1, 0],
                         [0, 0, 0, 0, 0, 1]], dtype=np.float64)

    def Q(self, dt: float) -> FloatArray:
        q = np.diag(self.floor * dt)
        q[4, 4] += self.yaw_rate_noise * dt
        q[2, 2] += self.yaw_rate_noise * dt**3 / 3
        q[2, 4] += self.yaw_rate_noise * dt**2 / 2
        q[4, 2] = q[2, 4]
        q[5, 5] += self.accel_noise * dt
        q[3, 3] += self.accel_noise * dt**3 / 3
        q[3, 5] += self.accel_noise * dt**2 / 2
        q[5, 3] = q[3, 5]
        return q


@dataclass(frozen=True)
class SensorConfig:
    """One input of the fusion filter, as robot_localization's ``odom0``/``imu0`` parameters.

    ``config`` is the 15-element boolean vector (:data:`CONFIG_FIELDS` order).
    ``differential``: pose inputs are turned into velocities (the change since the previous
    message over the time between them). ``relative``: pose inputs are taken relative to the
    sensor's first message.
    """

    config: tuple[bool, ...]
    differential: bool = False
    relative: bool = False

    def __post_init__(self) -> None:
        if len(self.config) != 15 or not all(isinstance(b, bool) for b in self.config):
            raise ValueError(f"a sensor config is 15 booleans in the order {CONFIG_FIELDS}; "
                             f"got {self.config!r}")

    def fused(self) -> list[str]:
        """The configured fields the planar state can take (two_d_mode drops the others)."""
        return [name for name, on in zip(CONFIG_FIELDS, self.config, strict=True)
                if on and name in STATE]


def _diag(cov: NDArray[np.float64], index: int, size: int) -> float:
    return max(float(cov.reshape(size, size)[index, index]), 1e-9)


class FusionFilter:
    """robot_localization's ``ekf_node`` in two_d_mode, in miniature.

    Parameters
    ----------
    sensors : mapping of name → SensorConfig
        e.g. ``{"odom0": SensorConfig(odom0_config), "imu0": SensorConfig(imu0_config)}``.
    frequency : float
        Output rate [Hz] of :meth:`outputs`.
    model : PlanarModel
        Process model and noise.
    initial_covariance : float
        Variance on each state's diagonal at the start.
    initial_pose : array_like, shape (3,)
        (x, y, yaw) in ``odom`` [m, m, rad] where the robot starts; the velocities and the
        acceleration start at zero.

    Feed messages with :meth:`add_odometry` / :meth:`add_imu` in time order; each is fused at
    its own stamp (the filter predicts up to it first). Read the estimate with
    :meth:`odometry` and :meth:`transform`.
    """

    def __init__(self, sensors: dict[str, SensorConfig], frequency: float = 30.0,
                 model: PlanarModel | None = None, initial_covariance: float = 1e-6,
                 two_d_mode: bool = True, odom_frame: str = "odom",
                 base_frame: str = "base_link",
                 initial_pose: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        if not two_d_mode:
            raise ValueError("the kit's fusion filter is planar: two_d_mode must be True")
        if not frequency > 0:
            raise ValueError(f"frequency must be positive Hz; got {frequency}")
        self.sensors = dict(sensors)
        self.frequency = float(frequency)
        self.model = model or PlanarModel()
        pose = geometry.check_pose(initial_pose, "initial_pose")
        if pose.shape != (3,):
            raise ValueError(f"initial_pose is one pose (x [m], y [m], yaw [rad]); got shape "
                             f"{pose.shape}")
        self._initial = (pose.copy(), float(initial_covariance))
        self.odom_frame, self.base_frame = odom_frame, base_frame
        self.reset()

    def reset(self) -> None:
        """Back to the initial pose and covariance, with no time and no sensor history."""
        pose, variance = self._initial
        self.x: FloatArray = np.zeros(6)
        self.x[:3] = pose
        self.P: FloatArray = np.eye(6) * variance
        self.time: float | None = None
        self._first_pose: dict[str, FloatArray] = {}
        self._last_pose: dict[str, tuple[float, FloatArray, FloatArray]] = {}
        self.nis_log: list[tuple[str, float, int]] = []

    # ---------------------------------------------------------------- time
    def predict_to(self, t: float) -> None:
        """Run the process model up to time ``t`` [s] (never backwards)."""
        if self.time is None:
            self.time = t
            return
        dt = t - self.time
        if dt < 0:
            raise ValueError(f"measurement at t={t} is older than the filter's time "
                             f"{self.time}: feed messages in time order")
        if dt > 0:
            m = self.model
            self.x, self.P = predict(self.x, self.P, lambda s: m.f(s, dt), m.F_x(self.x, dt),
                                     m.Q(dt))
            self.time = t

    def _fuse(self, name: str, t: float, fields: list[str], z: list[float],
              variances: list[float]) -> None:
        if not fields:
            return
        self.predict_to(t)
        idx = [STATE.index(f) for f in fields]
        H = np.zeros((len(idx), 6))
        H[np.arange(len(idx)), idx] = 1.0
        angles = [i for i, f in enumerate(fields) if f == "yaw"]
        self.x, self.P, y, S = update(self.x, self.P, np.array(z), lambda s: H @ s, H,
                                      np.diag(variances), angles, [2])
        self.nis_log.append((name, nis(y, S), len(idx)))

    def _pose_inputs(self, name: str, cfg: SensorConfig, t: float, pose: FloatArray,
                     pose_var: FloatArray) -> tuple[list[str], list[float], list[float]]:
        wanted = [f for f in cfg.fused() if f in ("x", "y", "yaw")]
        if not wanted:
            return [], [], []
        if cfg.differential:
            previous = self._last_pose.get(name)
            self._last_pose[name] = (t, pose, pose_var)
            if previous is None or t <= previous[0]:
                return [], [], []
            dt = t - previous[0]
            delta = geometry.relative(previous[1], pose)
            fields, z, var = [], [], []
            if "x" in wanted or "y" in wanted:
                fields.append("vx")
                z.append(float(delta[0]) / dt)
                var.append(float(previous[2][0] + pose_var[0]) / dt**2)
            if "yaw" in wanted:
                fields.append("vyaw")
                z.append(float(delta[2]) / dt)
                var.append(float(previous[2][2] + pose_var[2]) / dt**2)
            return fields, z, var
        if cfg.relative:
            first = self._first_pose.setdefault(name, pose)
            pose = geometry.relative(first, pose)
        values = {"x": float(pose[0]), "y": float(pose[1]), "yaw": float(pose[2])}
        variances = {"x": float(pose_var[0]), "y": float(pose_var[1]), "yaw": float(pose_var[2])}
        return wanted, [values[f] for f in wanted], [variances[f] for f in wanted]

    # ---------------------------------------------------------------- inputs
    def add_odometry(self, name: str, message: msgs.Odometry) -> None:
        """Fuse a ``nav_msgs/Odometry`` from sensor ``name``."""
        cfg = self.sensors[name]
        t = message.header.stamp.to_sec()
        p = message.pose.pose
        pose = np.array([p.position.x, p.position.y, float(geometry.quaternion_to_yaw(
            [p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w]))])
        pc = message.pose.covariance
        pose_var = np.array([_diag(pc, 0, 6), _diag(pc, 1, 6), _diag(pc, 5, 6)])
        fields, z, var = self._pose_inputs(name, cfg, t, pose, pose_var)
        tw = message.twist.twist
        tc = message.twist.covariance
        twist = {"vx": (tw.linear.x, _diag(tc, 0, 6)), "vyaw": (tw.angular.z, _diag(tc, 5, 6))}
        for f in cfg.fused():
            if f in twist and f not in fields:
                fields.append(f)
                z.append(float(twist[f][0]))
                var.append(twist[f][1])
        self._fuse(name, t, fields, z, var)

    def add_imu(self, name: str, message: msgs.Imu) -> None:
        """Fuse a ``sensor_msgs/Imu`` from sensor ``name`` (covariance −1: not provided)."""
        cfg = self.sensors[name]
        t = message.header.stamp.to_sec()
        fields: list[str] = []
        z: list[float] = []
        var: list[float] = []
        wanted = cfg.fused()
        if "yaw" in wanted and message.orientation_covariance[0] != -1:
            o = message.orientation
            yaw = float(geometry.quaternion_to_yaw([o.x, o.y, o.z, o.w]))
            yaw_var = _diag(message.orientation_covariance, 2, 3)
            if cfg.differential or cfg.relative:
                pose_fields, pz, pv = self._pose_inputs(
                    name, SensorConfig(tuple(f == "yaw" for f in CONFIG_FIELDS),
                                       cfg.differential, cfg.relative),
                    t, np.array([0.0, 0.0, yaw]), np.array([1.0, 1.0, yaw_var]))
                fields += pose_fields
                z += pz
                var += pv
            else:
                fields.append("yaw")
                z.append(yaw)
                var.append(yaw_var)
        if "vyaw" in wanted and message.angular_velocity_covariance[0] != -1 \
                and "vyaw" not in fields:
            fields.append("vyaw")
            z.append(message.angular_velocity.z)
            var.append(_diag(message.angular_velocity_covariance, 2, 3))
        if "ax" in wanted and message.linear_acceleration_covariance[0] != -1:
            fields.append("ax")
            z.append(message.linear_acceleration.x)
            var.append(_diag(message.linear_acceleration_covariance, 0, 3))
        self._fuse(name, t, fields, z, var)

    # ---------------------------------------------------------------- outputs
    def odometry(self) -> msgs.Odometry:
        """The estimate as ``nav_msgs/Odometry``: pose in ``odom``, twist in ``base_link``."""
        t = self.time if self.time is not None else 0.0
        P = self.P
        pose_cov = P[np.ix_([0, 1, 2], [0, 1, 2])]
        twist_cov = np.zeros((3, 3))
        twist_cov[0, 0], twist_cov[2, 2], twist_cov[0, 2] = P[3, 3], P[4, 4], P[3, 4]
        twist_cov[2, 0] = P[4, 3]
        twist_cov[1, 1] = odometry.UNUSED_VARIANCE
        return odometry.odometry_message(self.x[:3], self.x[3:5], msgs.Time.from_sec(t),
                                         pose_cov, twist_cov, self.odom_frame, self.base_frame)

    def transform(self) -> msgs.TransformStamped:
        t = self.time if self.time is not None else 0.0
        return odometry.odom_transform(self.x[:3], msgs.Time.from_sec(t), self.odom_frame,
                                       self.base_frame)

    def outputs(self, messages: Sequence[tuple[str, msgs.Message]]
                ) -> list[msgs.Odometry]:
        """Run over time-ordered ``(sensor name, message)`` pairs and publish at
        ``frequency``, as the ROS node does: each output predicts to its tick after fusing
        every message stamped before it."""
        published = []
        period = 1.0 / self.frequency
        next_tick: float | None = None
        for name, message in messages:
            t = message.header.stamp.to_sec()  # type: ignore[attr-defined]
            if next_tick is None:
                next_tick = math.ceil(t / period) * period
            while next_tick <= t and self.time is not None:
                self.predict_to(next_tick)
                published.append(self.odometry())
                next_tick += period
            if isinstance(message, msgs.Odometry):
                self.add_odometry(name, message)
            elif isinstance(message, msgs.Imu):
                self.add_imu(name, message)
            else:
                raise TypeError(f"the fusion filter takes Odometry and Imu, not "
                                f"{type(message).__name__}")
        return published
