"""Lab 04 — motor control (act): the exercises, their cases and their known mistakes."""

from __future__ import annotations

from typing import Any

import numpy as np

from grader.labs._hidden import telling
from grader.spec import Case, Diagnostic, Exercise, LabSpec
from kit import control as ctl

_BLOCKED = tuple(f"kit.control:{name}" for name in (
    "transfer_coefficients", "pid_step", "step_info", "pole_placement_pi", "ziegler_nichols",
    "CascadeController", "cascade_acceleration", "PID"))

IGV = (1.5, 1e-3, 0.0694494, 0.0694494, 9.886667e-4, 1e-4, 30.0)


# ---------------------------------------------------------------- motor model

def _motor_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"motor {i}", (float(rng.uniform(0.3, 3)), float(rng.uniform(1e-4, 5e-3)),
                                float(rng.uniform(0.02, 0.2)), float(rng.uniform(0.02, 0.2)),
                                float(rng.uniform(1e-5, 1e-2)), float(rng.uniform(0, 1e-3)),
                                float(rng.choice([1.0, 10.0, 30.0]))))
            for i in range(4)]


def _motor_no_gear(R: float, L: float, kt: float, ke: float, J: float, b: float,
                   N: float) -> Any:
    return ctl.transfer_coefficients(R, L, kt, ke, J, b, 1.0)


def _motor_lowest_first(R: float, L: float, kt: float, ke: float, J: float, b: float,
                        N: float) -> Any:
    num, den = ctl.transfer_coefficients(R, L, kt, ke, J, b, N)
    return num, den[::-1]


def _motor_gear_multiplied(R: float, L: float, kt: float, ke: float, J: float, b: float,
                           N: float) -> Any:
    return ctl.transfer_coefficients(R, L, kt, ke, J, b, 1.0 / N)


def _motor_no_back_emf(R: float, L: float, kt: float, ke: float, J: float, b: float,
                       N: float) -> Any:
    return ctl.transfer_coefficients(R, L, kt, 0.0, J, b, N)


def _motor_draw(rng: np.random.Generator) -> list[Case]:
    cases = _motor_hidden(rng)
    cases[-1] = Case("motor 3", (*cases[-1].args[:6], float(rng.choice([10.0, 30.0]))))
    return cases


_MOTOR_MISTAKES = (
    Diagnostic("forgetting the gearbox", _motor_no_gear,
               "the output is the wheel: divide the motor speed by N"),
    Diagnostic("the denominator lowest power first", _motor_lowest_first,
               "python-control wants the highest power of s first: "
               "[J L, J R + b L, b R + K_t K_e]"),
    Diagnostic("the gear ratio multiplied", _motor_gear_multiplied,
               "the wheel turns N times slower than the motor: K_t / N in the numerator, "
               "not K_t N"),
    Diagnostic("the back-EMF forgotten", _motor_no_back_emf,
               "the motor's back-EMF K_e ω opposes the voltage: eliminating the current "
               "gives the constant term b R + K_t K_e, not b R"),
)


transfer_coefficients = Exercise(
    id="lab04.transfer_coefficients", function="transfer_coefficients",
    title="The motor's transfer function", reference=ctl.transfer_coefficients, points=2,
    public=(Case("the IGV motor", IGV), Case("no gearbox", (2.0, 2e-3, 0.05, 0.05, 1e-4,
                                                            1e-5, 1.0))),
    hidden=telling(_motor_draw, ctl.transfer_coefficients, _MOTOR_MISTAKES, 1e-9, 1e-15),
    rtol=1e-9, atol=1e-15,
    diagnostics=_MOTOR_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- PI with clamping

def _pi_reference(kp: float, ki: float, dt: float, integral: float, setpoint: float,
                  measurement: float, low: float, high: float) -> Any:
    gains = ctl.PIDGains(kp=kp, ki=ki, dt=dt, output_limits=(low, high), anti_windup="clamp")
    out, state = ctl.pid_step(gains, ctl.PIDState(integral=integral), setpoint, measurement)
    return out, state.integral


def _pi_windup(kp: float, ki: float, dt: float, integral: float, setpoint: float,
               measurement: float, low: float, high: float) -> Any:
    gains = ctl.PIDGains(kp=kp, ki=ki, dt=dt, output_limits=(low, high), anti_windup="none")
    out, state = ctl.pid_step(gains, ctl.PIDState(integral=integral), setpoint, measurement)
    return out, state.integral


def _pi_no_dt(kp: float, ki: float, dt: float, integral: float, setpoint: float,
              measurement: float, low: float, high: float) -> Any:
    return _pi_reference(kp, ki, 1.0, integral, setpoint, measurement, low, high)


def _pi_error_reversed(kp: float, ki: float, dt: float, integral: float, setpoint: float,
                       measurement: float, low: float, high: float) -> Any:
    return _pi_reference(kp, ki, dt, integral, measurement, setpoint, low, high)


def _pi_hidden(rng: np.random.Generator) -> list[Case]:
    """Speeds in rad/s under a 1 kHz loop and ±24 V: three anywhere (mostly saturated), one
    with a small error well inside the limits (where a missing dt shows), one saturated with
    the error bringing the output back (where the clamp must let the integral move)."""
    cases = []
    for i in range(3):
        cases.append(Case(f"random {i}", (float(rng.uniform(1, 30)), float(rng.uniform(10, 300)),
                                          0.001, float(rng.uniform(-20, 20)),
                                          float(rng.uniform(-10, 10)), float(rng.uniform(-10, 10)),
                                          -24.0, 24.0)))
    setpoint = float(rng.uniform(-10, 10))
    cases.append(Case("random 3", (float(rng.uniform(1, 30)), float(rng.uniform(10, 300)), 0.001,
                                   float(rng.uniform(-5, 5)),
                                   setpoint, setpoint + float(rng.uniform(-0.3, 0.3)),
                                   -24.0, 24.0)))
    side = float(rng.choice([-1.0, 1.0]))
    kp, setpoint = float(rng.uniform(5, 30)), float(rng.uniform(-10, 10))
    error = -side * float(rng.uniform(0.05, 0.2))         # against the saturated side
    integral = side * float(rng.uniform(26, 40)) - kp * error
    cases.append(Case("random 4", (kp, float(rng.uniform(10, 300)), 0.001, integral, setpoint,
                                   setpoint - error, -24.0, 24.0)))
    return cases


_PI_MISTAKES = (
    Diagnostic("no anti-windup", _pi_windup,
               "while the output is saturated and the error pushes further, "
               "keep the integral where it was"),
    Diagnostic("the integral without dt", _pi_no_dt,
               "the integral grows by K_i e Δt per step: multiply by dt"),
    Diagnostic("the error as measurement − set-point", _pi_error_reversed,
               "the error is e = setpoint − measurement: a wheel slower than asked needs "
               "more voltage"),
)


pi_step = Exercise(
    id="lab04.pi_step", function="pi_step", title="A discrete PI with anti-windup",
    reference=_pi_reference, points=3,
    public=(Case("small error", (20.0, 250.0, 0.001, 0.5, 5.0, 4.9, -24.0, 24.0)),
            Case("saturated, error pushing on", (20.0, 250.0, 0.001, 10.0, 5.0, 0.0, -24.0,
                                                 24.0)),
            Case("saturated, error coming back", (20.0, 250.0, 0.001, 30.0, 5.0, 5.2, -24.0,
                                                  24.0)),
            Case("negative limit", (20.0, 250.0, 0.001, -10.0, -5.0, 0.0, -24.0, 24.0))),
    hidden=telling(_pi_hidden, _pi_reference, _PI_MISTAKES),
    diagnostics=_PI_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- step figures

def _figures(time: Any, response: Any, setpoint: float) -> Any:
    info = ctl.step_info(time, response, setpoint)
    return info.rise_time, info.overshoot, info.settling_time, info.steady_state_error


def _second_order(wn: float, zeta: float, gain: float, n: int = 2001) -> tuple[Any, Any]:
    import control

    t = np.linspace(0.0, 10.0 / (zeta * wn), n)
    _, y = control.step_response(control.tf([gain * wn * wn], [1, 2 * zeta * wn, wn * wn]), t)
    return t, y


def _figures_case(name: str, wn: float, zeta: float, gain: float, setpoint: float) -> Case:
    t, y = _second_order(wn, zeta, gain)
    return Case(name, (t, y, setpoint))


def _figures_hidden(rng: np.random.Generator) -> list[Case]:
    """Three second-order loops with a steady-state error, one of them clearly underdamped."""
    dampings = [float(rng.uniform(0.2, 0.7)), *rng.uniform(0.2, 1.5, 2)]
    return [_figures_case(f"system {i}", float(rng.uniform(2, 30)), float(zeta),
                          float(rng.uniform(0.5, 2)), 1.0) for i, zeta in enumerate(dampings)]


def _figures_0_100(time: Any, response: Any, setpoint: float) -> Any:
    _rise, over, settle, err = _figures(time, response, setpoint)
    t = np.asarray(time)
    y = np.asarray(response)
    reach = float(t[int(np.argmax(y >= y[-1]))] - t[0])
    return reach, over, settle, err


def _figures_fraction(time: Any, response: Any, setpoint: float) -> Any:
    rise, over, settle, err = _figures(time, response, setpoint)
    return rise, over / 100, settle, err


def _figures_overshoot_from_setpoint(time: Any, response: Any, setpoint: float) -> Any:
    rise, _over, settle, err = _figures(time, response, setpoint)
    return rise, max(0.0, (float(np.max(response)) - setpoint) / setpoint * 100), settle, err


def _figures_error_reversed(time: Any, response: Any, setpoint: float) -> Any:
    rise, over, settle, err = _figures(time, response, setpoint)
    return rise, over, settle, -err


def _figures_sampled_crossings(time: Any, response: Any, setpoint: float) -> Any:
    """The rise time between the first samples at or above 10 % and 90 %."""
    _rise, over, settle, err = _figures(time, response, setpoint)
    t, y = np.asarray(time, float), np.asarray(response, float)
    first = [t[int(np.argmax(y >= level * y[-1]))] for level in (0.1, 0.9)]
    return float(first[1] - first[0]), over, settle, err


_FIGURE_MISTAKES = (
    Diagnostic("0 → 100 % rise time", _figures_0_100,
               "the rise time runs from 10 % to 90 % of the final value"),
    Diagnostic("the overshoot as a fraction", _figures_fraction,
               "the overshoot is in percent: (max − final) / final × 100"),
    Diagnostic("the overshoot over the set-point", _figures_overshoot_from_setpoint,
               "the overshoot is measured from the final value y∞ (the last sample), not "
               "from the set-point"),
    Diagnostic("the steady-state error as y∞ − set-point", _figures_error_reversed,
               "the steady-state error is set-point minus final value: positive when the "
               "response stops short"),
    Diagnostic("crossings at sample times", _figures_sampled_crossings,
               "find each crossing between the two samples around it by linear "
               "interpolation, not at the first sample past it"),
)


step_figures = Exercise(
    id="lab04.step_figures", function="step_figures", title="Step-response figures",
    reference=_figures, points=3,
    public=(_figures_case("underdamped", 10.0, 0.3, 1.0, 1.0),
            _figures_case("overdamped", 5.0, 1.2, 1.0, 1.0),
            _figures_case("with a steady-state error", 8.0, 0.6, 0.9, 1.0)),
    hidden=telling(_figures_hidden, _figures, _FIGURE_MISTAKES), rtol=1e-6, atol=1e-9,
    diagnostics=_FIGURE_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- tuning

def _placement(gain: float, tau: float, wn: float, zeta: float) -> Any:
    g = ctl.pole_placement_pi(gain, tau, wn, zeta)
    return g.kp, g.ki


def _placement_no_one(gain: float, tau: float, wn: float, zeta: float) -> Any:
    return 2 * zeta * wn * tau / gain, wn * wn * tau / gain


def _placement_ki_without_tau(gain: float, tau: float, wn: float, zeta: float) -> Any:
    return _placement(gain, tau, wn, zeta)[0], wn * wn / gain


_PLACEMENT_MISTAKES = (
    Diagnostic("dropping the plant's own damping", _placement_no_one,
               "the loop polynomial is τ s² + (1 + K Kp) s + K Ki: Kp = "
               "(2ζω_n τ − 1) / K"),
    Diagnostic("K_i without τ", _placement_ki_without_tau,
               "match τ s² + (1 + K Kp) s + K Ki with τ (s² + 2ζω_n s + ω_n²): the constant "
               "terms give K Ki = τ ω_n²"),
)


pole_placement = Exercise(
    id="lab04.pole_placement", function="pole_placement", title="PI by pole placement",
    reference=_placement, points=2,
    public=(Case("the IGV motor", (0.4655, 0.2975, 20.0, 0.9)),
            Case("a slow plant", (2.0, 1.5, 3.0, 0.7))),
    hidden=telling(lambda rng: [Case(f"plant {i}", (float(rng.uniform(0.1, 5)),
                                                     float(rng.uniform(0.05, 2)),
                                                     float(rng.uniform(2, 40)),
                                                     float(rng.uniform(0.5, 1.2))))
                                for i in range(4)], _placement, _PLACEMENT_MISTAKES),
    diagnostics=_PLACEMENT_MISTAKES,
    blocked=_BLOCKED,
)


def _zn(ku: float, tu: float) -> Any:
    g = ctl.ziegler_nichols(ku, tu, "PID")
    return g.kp, g.ki, g.kd


def _zn_pi_row(ku: float, tu: float) -> Any:
    g = ctl.ziegler_nichols(ku, tu, "PI")
    return g.kp, g.ki, 0.0


def _zn_time_constants(ku: float, tu: float) -> Any:
    return 0.6 * ku, tu / 2, tu / 8


def _zn_ki_times_ti(ku: float, tu: float) -> Any:
    kp, _ki, kd = _zn(ku, tu)
    return kp, kp * tu / 2, kd


_ZN_MISTAKES = (
    Diagnostic("the PI row", _zn_pi_row,
               "the PID row: Kp = 0.6 Ku, Ti = Tu / 2, Td = Tu / 8"),
    Diagnostic("T_i and T_d in place of K_i and K_d", _zn_time_constants,
               "the gains are K_i = K_p / T_i and K_d = K_p T_d, not the times"),
    Diagnostic("K_i = K_p T_i", _zn_ki_times_ti,
               "the integral gain divides by the integral time: K_i = K_p / T_i (a longer "
               "T_i integrates more slowly)"),
)


ziegler_nichols = Exercise(
    id="lab04.ziegler_nichols", function="ziegler_nichols_pid",
    title="Ziegler–Nichols PID", reference=_zn, points=2,
    public=(Case("textbook", (2.0, 1.0)), Case("the sampled IGV loop", (57.0, 0.058))),
    hidden=telling(lambda rng: [Case(f"loop {i}", (float(rng.uniform(0.5, 100)),
                                                    float(rng.uniform(0.01, 5))))
                                for i in range(3)], _zn, _ZN_MISTAKES),
    diagnostics=_ZN_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- cascade

def _cascade_unlimited(setpoint: float, speed: float, gain: float, max_acc: float) -> float:
    return gain * (setpoint - speed)


def _cascade_sign(setpoint: float, speed: float, gain: float, max_acc: float) -> float:
    return float(ctl.cascade_acceleration(speed, setpoint, gain, max_acc))


def _cascade_hidden(rng: np.random.Generator) -> list[Case]:
    """Two anywhere, one braking hard and one starting (each beyond the limit), and one
    small correction within it (Eddie's speeds, m/s)."""
    cases = [Case(f"random {i}", (float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)),
                                  float(rng.uniform(1, 10)), float(rng.uniform(0.2, 2))))
             for i in range(2)]
    gain, limit = float(rng.uniform(4, 10)), float(rng.uniform(0.2, 0.6))
    speed = float(rng.uniform(0.3, 1.0))
    cases.append(Case("random 2", (speed - float(rng.uniform(0.2, 0.3)), speed, gain, limit)))
    cases.append(Case("random 3", (speed, speed - float(rng.uniform(0.2, 0.3)), gain, limit)))
    gain, limit = float(rng.uniform(1, 10)), float(rng.uniform(0.2, 2))
    speed = float(rng.uniform(-1, 1))
    cases.append(Case("random 4", (speed + float(rng.uniform(-0.9, 0.9)) * limit / gain, speed,
                                   gain, limit)))
    return cases


_CASCADE_MISTAKES = (
    Diagnostic("no acceleration limit", _cascade_unlimited,
               "limit the desired acceleration to ±max_acceleration"),
    Diagnostic("the error the wrong way round", _cascade_sign,
               "the error is set-point minus speed: a robot slower than asked "
               "must accelerate"),
)


cascade_acceleration = Exercise(
    id="lab04.cascade_acceleration", function="cascade_acceleration",
    title="The cascade's outer loop", reference=ctl.cascade_acceleration, points=2,
    public=(Case("small error", (0.5, 0.45, 4.0, 0.5)), Case("start", (0.5, 0.0, 4.0, 0.5)),
            Case("braking", (0.0, 0.6, 4.0, 0.5))),
    hidden=telling(_cascade_hidden, ctl.cascade_acceleration, _CASCADE_MISTAKES),
    diagnostics=_CASCADE_MISTAKES,
    blocked=_BLOCKED,
)


SPEC = LabSpec(
    name="lab04",
    title="Lab 04 — Motor control",
    exercises=(transfer_coefficients, pi_step, step_figures, pole_placement, ziegler_nichols,
               cascade_acceleration),
)
