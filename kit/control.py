"""Motor control: a DC gear-motor model, a discrete PID, the cascaded speed controller,
step-response figures and tuning helpers.

The IGV's motor, from its paper: 24 V, 110 RPM at the wheel, 6.6 A peak, 3.3 A continuous.
The paper gives nothing else, so :data:`IGV_MOTOR` assumes (and says why):

* gear ratio N = 30 — a typical spur gear-motor; it puts the motor's no-load speed at
  3300 RPM, usual for a 24 V brushed motor of this size;
* back-EMF constant K_e = 24 V / (110 RPM · N) at the motor = 0.0694 V·s/rad, and torque
  constant K_t = K_e (SI units, an ideal motor);
* armature resistance R = 1.5 Ω (a stall current of 16 A, which the drive's 6.6 A limit
  keeps it well away from) and inductance L = 1 mH (electrical time constant 0.7 ms);
* rotor inertia 5e-5 kg·m² plus the robot's share carried by one wheel, half of 66 kg at
  0.16 m, reflected through N²: J = 5e-5 + 33 · 0.16² / 30² = 9.9e-4 kg·m²;
* viscous friction b = 1e-4 N·m·s/rad at the motor.

With ``ω`` the motor speed and ``i`` the current::

    J dω/dt = K_t i − b ω,        L di/dt = V − R i − K_e ω,        ω_wheel = ω / N

Everything here is a pure function or a small class whose methods call them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "IGV_MOTOR",
    "PID",
    "CascadeController",
    "DCMotor",
    "PIDGains",
    "PIDState",
    "StepInfo",
    "cascade_acceleration",
    "pid_step",
    "pole_placement_pi",
    "simulate_motor",
    "step_info",
    "transfer_coefficients",
    "with_limits",
    "ziegler_nichols",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class DCMotor:
    """A permanent-magnet DC motor with a gearbox; SI units at the motor shaft."""

    resistance: float = 1.5
    inductance: float = 1e-3
    k_t: float = 24.0 / (110.0 * 30 * 2 * math.pi / 60)
    k_e: float = 24.0 / (110.0 * 30 * 2 * math.pi / 60)
    inertia: float = 5e-5 + 33.0 * 0.16**2 / 30**2
    friction: float = 1e-4
    gear_ratio: float = 30.0
    voltage: float = 24.0
    peak_current: float = 6.6
    continuous_current: float = 3.3

    def state_space(self) -> Any:
        """python-control ``StateSpace``: states (ω_motor, i), input V, output ω_wheel."""
        import control

        A = [[-self.friction / self.inertia, self.k_t / self.inertia],
             [-self.k_e / self.inductance, -self.resistance / self.inductance]]
        B = [[0.0], [1.0 / self.inductance]]
        C = [[1.0 / self.gear_ratio, 0.0]]
        return control.ss(A, B, C, [[0.0]])

    def transfer_function(self) -> Any:
        """python-control ``TransferFunction`` from voltage to wheel speed [rad/s per V]
        (see :func:`transfer_coefficients`)."""
        import control

        return control.tf(*transfer_coefficients(
            self.resistance, self.inductance, self.k_t, self.k_e, self.inertia, self.friction,
            self.gear_ratio))

    def derivatives(self, state: FloatArray, voltage: float, load_torque: float = 0.0
                    ) -> FloatArray:
        """d/dt of (ω_motor, i) at ``state`` for an applied ``voltage`` [V]."""
        omega, current = state
        return np.array([(self.k_t * current - self.friction * omega - load_torque)
                         / self.inertia,
                         (voltage - self.resistance * current - self.k_e * omega)
                         / self.inductance])

    def quasi_static_step(self, wheel_speed: float, voltage: float, dt: float,
                          current_limit: float | None = None) -> float:
        """The wheel speed [rad/s] after ``dt`` [s] at ``voltage`` [V], inductance neglected.

        When the electrical time constant L/R is far below ``dt``, the current settles within
        the step at ``i = (V − K_e ω) / R`` (where :meth:`derivatives` gives di/dt = 0),
        limited to ±``current_limit`` [A] (the drive's limit, ``peak_current`` by default);
        then one explicit Euler step of ``J ω̇ = K_t i − b ω`` at the motor shaft.
        """
        limit = self.peak_current if current_limit is None else current_limit
        omega = wheel_speed * self.gear_ratio
        current = (voltage - self.k_e * omega) / self.resistance
        current = min(max(current, -limit), limit)
        omega += (self.k_t * current - self.friction * omega) / self.inertia * dt
        return omega / self.gear_ratio

    @property
    def no_load_wheel_speed(self) -> float:
        """ω at the wheel with the full voltage and no load [rad/s]."""
        return float(self.voltage * self.k_t / (self.friction * self.resistance +
                                                self.k_t * self.k_e) / self.gear_ratio)


def transfer_coefficients(resistance: float, inductance: float, k_t: float, k_e: float,
                          inertia: float, friction: float, gear_ratio: float
                          ) -> tuple[FloatArray, FloatArray]:
    """Numerator and denominator (highest power first) of voltage → wheel speed:

    .. math:: \\frac{K_t / N}{(J s + b)(L s + R) + K_t K_e}
              = \\frac{K_t / N}{J L s^2 + (J R + b L) s + (b R + K_t K_e)}
    """
    J, b, L, R = inertia, friction, inductance, resistance
    return (np.array([k_t / gear_ratio]),
            np.array([J * L, J * R + b * L, b * R + k_t * k_e]))


IGV_MOTOR = DCMotor()
"""The IGV's drive motor with the assumptions in this module's docstring."""


@dataclass(frozen=True)
class PIDGains:
    """Gains and limits of a discrete PID.

    ``kp``, ``ki`` [1/s], ``kd`` [s]; ``output_limits`` clamp the output; ``anti_windup``
    is ``"clamp"`` (stop integrating while saturated in the same direction) or
    ``"back-calculation"`` (bleed the integrator by ``tracking`` · (saturated − raw)), or
    ``"none"``; ``derivative_filter`` is the time constant [s] of the first-order filter on
    the derivative, which acts on the measurement (no kick on set-point steps).
    """

    kp: float
    ki: float = 0.0
    kd: float = 0.0
    dt: float = 0.01
    output_limits: tuple[float, float] = (-math.inf, math.inf)
    anti_windup: str = "clamp"
    tracking: float = 1.0
    derivative_filter: float = 0.0

    def __post_init__(self) -> None:
        if not self.dt > 0:
            raise ValueError(f"dt must be positive seconds; got {self.dt}")
        if self.anti_windup not in ("clamp", "back-calculation", "none"):
            raise ValueError(f"anti_windup must be 'clamp', 'back-calculation' or 'none'; "
                             f"got {self.anti_windup!r}")
        low, high = self.output_limits
        if not low < high:
            raise ValueError(f"output_limits must be (low, high) with low < high; got "
                             f"{self.output_limits}")


@dataclass(frozen=True)
class PIDState:
    integral: float = 0.0
    previous_measurement: float | None = None
    derivative: float = 0.0


def pid_step(gains: PIDGains, state: PIDState, setpoint: float, measurement: float
             ) -> tuple[float, PIDState]:
    """One controller update; returns (output, new state).

    .. math:: u = K_p e + I + K_d \\dot{d},\\quad e = r - y,\\quad
              \\dot d = -\\mathrm{filtered}(\\Delta y / \\Delta t)
    """
    g = gains
    error = setpoint - measurement
    if state.previous_measurement is None:
        raw_derivative = 0.0
    else:
        raw_derivative = -(measurement - state.previous_measurement) / g.dt
    alpha = g.dt / (g.derivative_filter + g.dt)  # 1 when unfiltered
    derivative = state.derivative + alpha * (raw_derivative - state.derivative)
    integral = state.integral + g.ki * error * g.dt
    raw = g.kp * error + integral + g.kd * derivative
    low, high = g.output_limits
    output = min(max(raw, low), high)
    if g.anti_windup == "clamp" and output != raw and (raw - output) * error > 0:
        integral = state.integral  # saturated and the error pushes further: hold
        raw = g.kp * error + integral + g.kd * derivative
        output = min(max(raw, low), high)
    elif g.anti_windup == "back-calculation":
        integral += g.tracking * (output - raw) * g.dt
    return output, PIDState(integral, measurement, derivative)


class PID:
    """Stateful wrapper of :func:`pid_step`."""

    def __init__(self, gains: PIDGains) -> None:
        self.gains = gains
        self.state = PIDState()

    def __call__(self, setpoint: float, measurement: float) -> float:
        output, self.state = pid_step(self.gains, self.state, setpoint, measurement)
        return output

    def reset(self) -> None:
        self.state = PIDState()


def cascade_acceleration(speed_setpoint: float, speed: float, speed_gain: float,
                         max_acceleration: float) -> float:
    """The cascade's outer loop: P on the speed error, limited to ±``max_acceleration``.

    >>> cascade_acceleration(0.5, 0.0, 4.0, 0.5)
    0.5
    """
    wanted = speed_gain * (speed_setpoint - speed)
    return float(min(max(wanted, -max_acceleration), max_acceleration))


class CascadeController:
    """Eddie's board: P on the speed error gives a desired acceleration, which is limited and
    followed by a PID (on the acceleration error) whose output is the motor power.

    Parameters
    ----------
    speed_gain : float
        P gain from speed error [m/s] to desired acceleration [m/s²].
    max_acceleration : float
        Limit on the desired acceleration [m/s²].
    inner : PIDGains
        The acceleration loop; its output is the motor command.
    """

    def __init__(self, speed_gain: float, max_acceleration: float, inner: PIDGains) -> None:
        if not max_acceleration > 0:
            raise ValueError("max_acceleration must be positive")
        self.speed_gain = float(speed_gain)
        self.max_acceleration = float(max_acceleration)
        self.inner = PID(inner)
        self._last_speed: float | None = None
        self.acceleration = 0.0

    def __call__(self, speed_setpoint: float, speed: float) -> float:
        dt = self.inner.gains.dt
        wanted = cascade_acceleration(speed_setpoint, speed, self.speed_gain,
                                      self.max_acceleration)
        if self._last_speed is not None:  # acceleration from the differentiated speed
            self.acceleration += 0.5 * ((speed - self._last_speed) / dt - self.acceleration)
        self._last_speed = speed
        return self.inner(wanted, self.acceleration)


def simulate_motor(motor: DCMotor, controller: Any, setpoint: ArrayLike, dt: float,
                   substeps: int = 20, voltage_limit: float | None = None,
                   current_limit: float | None = None) -> dict[str, FloatArray]:
    """Run ``controller(setpoint, wheel_speed) -> voltage`` against ``motor`` at ``dt``.

    The motor is integrated with RK4 in ``substeps`` per control period (zero-order hold).
    ``current_limit`` [A] models a servo drive's current limit: the applied voltage is
    clipped to ``K_e ω ± R I_limit`` (what drives that current at the present speed).
    Returns ``time``, ``speed`` (wheel, rad/s), ``voltage`` and ``current``.
    """
    r = np.asarray(setpoint, dtype=np.float64)
    limit = motor.voltage if voltage_limit is None else voltage_limit
    state: FloatArray = np.zeros(2)
    h = dt / substeps
    speed, volts, amps = np.empty(len(r)), np.empty(len(r)), np.empty(len(r))
    for k, target in enumerate(r):
        wheel = state[0] / motor.gear_ratio
        v = float(np.clip(controller(float(target), float(wheel)), -limit, limit))
        speed[k], volts[k], amps[k] = wheel, v, state[1]
        for _ in range(substeps):
            if current_limit is not None:
                emf = motor.k_e * state[0]
                v = min(max(v, emf - motor.resistance * current_limit),
                        emf + motor.resistance * current_limit)
            k1 = motor.derivatives(state, v)
            k2 = motor.derivatives(state + 0.5 * h * k1, v)
            k3 = motor.derivatives(state + 0.5 * h * k2, v)
            k4 = motor.derivatives(state + h * k3, v)
            state = state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return {"time": np.arange(len(r), dtype=np.float64) * dt, "speed": speed, "voltage": volts,
            "current": amps}


@dataclass(frozen=True)
class StepInfo:
    rise_time: float
    """10 % → 90 % of the final value [s]."""
    overshoot: float
    """peak above the final value, percent of the final value."""
    settling_time: float
    """last time outside ±2 % of the final value [s]."""
    steady_state_error: float
    """set-point minus final value."""
    final_value: float


def step_info(time: ArrayLike, response: ArrayLike, setpoint: float | None = None,
              settling_band: float = 0.02) -> StepInfo:
    """Step-response figures of a sampled response starting at rest at ``time[0]``.

    Conventions follow python-control's ``step_info`` (10–90 % rise time, overshoot over the
    final value, 2 % settling band), so the two agree on the same response. The final value
    is the last sample; pass ``setpoint`` for the steady-state error.
    """
    t = np.asarray(time, dtype=np.float64)
    y = np.asarray(response, dtype=np.float64)
    if t.shape != y.shape or t.ndim != 1 or len(t) < 3:
        raise ValueError("time and response must be 1-D arrays of the same length (3 or more)")
    final = float(y[-1])
    if final == 0.0:
        raise ValueError("a response that ends at zero has no step figures")
    sign = math.copysign(1.0, final)
    yy = y * sign
    ff = abs(final)

    def crossing(level: float) -> float:
        i = int(np.argmax(yy >= level))
        if i == 0:
            return float(t[0])
        return float(t[i - 1] + (level - yy[i - 1]) * (t[i] - t[i - 1]) / (yy[i] - yy[i - 1]))

    rise = crossing(0.9 * ff) - crossing(0.1 * ff)
    overshoot = max(0.0, (float(np.max(yy)) - ff) / ff * 100.0)
    outside = np.flatnonzero(np.abs(yy - ff) > settling_band * ff)
    settling = float(t[outside[-1] + 1] - t[0]) if len(outside) and outside[-1] + 1 < len(t) \
        else (0.0 if not len(outside) else float(t[-1] - t[0]))
    error = (setpoint - final) if setpoint is not None else 0.0
    return StepInfo(rise, overshoot, settling, error, final)


def ziegler_nichols(ultimate_gain: float, ultimate_period: float, kind: str = "PID"
                    ) -> PIDGains:
    """Classic Ziegler–Nichols gains from the ultimate gain K_u and period T_u.

    P: 0.5 K_u; PI: 0.45 K_u, T_i = T_u / 1.2; PID: 0.6 K_u, T_i = T_u / 2, T_d = T_u / 8.
    (``ki = kp / T_i``, ``kd = kp T_d``.)
    """
    ku, tu = float(ultimate_gain), float(ultimate_period)
    if not (ku > 0 and tu > 0):
        raise ValueError("ultimate gain and period must be positive")
    if kind == "P":
        return PIDGains(kp=0.5 * ku)
    if kind == "PI":
        kp = 0.45 * ku
        return PIDGains(kp=kp, ki=kp / (tu / 1.2))
    if kind == "PID":
        kp = 0.6 * ku
        return PIDGains(kp=kp, ki=kp / (tu / 2), kd=kp * tu / 8)
    raise ValueError(f"kind must be 'P', 'PI' or 'PID'; got {kind!r}")


def pole_placement_pi(gain: float, time_constant: float, natural_frequency: float,
                      damping: float) -> PIDGains:
    """PI gains that place the closed-loop poles of a first-order plant K/(τ s + 1) at
    ``s² + 2ζω_n s + ω_n² = 0``.

    The loop's characteristic polynomial is τ s² + (1 + K K_p) s + K K_i, so
    K_p = (2 ζ ω_n τ − 1)/K and K_i = ω_n² τ / K.
    """
    K, tau, wn, z = map(float, (gain, time_constant, natural_frequency, damping))
    if not (K != 0 and tau > 0 and wn > 0 and z > 0):
        raise ValueError("need a non-zero gain and positive τ, ω_n, ζ")
    return PIDGains(kp=(2 * z * wn * tau - 1) / K, ki=wn**2 * tau / K)


def with_limits(gains: PIDGains, low: float, high: float, dt: float | None = None) -> PIDGains:
    """The same gains with output limits (and optionally another period)."""
    return replace(gains, output_limits=(low, high), dt=gains.dt if dt is None else dt)
