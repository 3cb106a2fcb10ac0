"""Lab 04 — motor control (act): the exercises, their cases and their known mistakes."""

from __future__ import annotations

from typing import Any

import numpy as np

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


transfer_coefficients = Exercise(
    id="lab04.transfer_coefficients", function="transfer_coefficients",
    title="The motor's transfer function", reference=ctl.transfer_coefficients, points=2,
    public=(Case("the IGV motor", IGV), Case("no gearbox", (2.0, 2e-3, 0.05, 0.05, 1e-4,
                                                            1e-5, 1.0))),
    hidden=_motor_hidden, rtol=1e-9, atol=1e-15,
    diagnostics=(Diagnostic("forgetting the gearbox", _motor_no_gear,
                            "the output is the wheel: divide the motor speed by N"),
                 Diagnostic("the denominator lowest power first", _motor_lowest_first,
                            "python-control wants the highest power of s first: "
                            "[J L, J R + b L, b R + K_t K_e]")),
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


def _pi_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(5):
        cases.append(Case(f"random {i}", (float(rng.uniform(1, 30)), float(rng.uniform(10, 300)),
                                          0.001, float(rng.uniform(-20, 20)),
                                          float(rng.uniform(-10, 10)), float(rng.uniform(-10, 10)),
                                          -24.0, 24.0)))
    return cases


pi_step = Exercise(
    id="lab04.pi_step", function="pi_step", title="A discrete PI with anti-windup",
    reference=_pi_reference, points=3,
    public=(Case("small error", (20.0, 250.0, 0.001, 0.5, 5.0, 4.9, -24.0, 24.0)),
            Case("saturated, error pushing on", (20.0, 250.0, 0.001, 10.0, 5.0, 0.0, -24.0,
                                                 24.0)),
            Case("saturated, error coming back", (20.0, 250.0, 0.001, 30.0, 5.0, 5.2, -24.0,
                                                  24.0)),
            Case("negative limit", (20.0, 250.0, 0.001, -10.0, -5.0, 0.0, -24.0, 24.0))),
    hidden=_pi_hidden,
    diagnostics=(Diagnostic("no anti-windup", _pi_windup,
                            "while the output is saturated and the error pushes further, "
                            "keep the integral where it was"),
                 Diagnostic("the integral without dt", _pi_no_dt,
                            "the integral grows by K_i e Δt per step: multiply by dt")),
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
    return [_figures_case(f"system {i}", float(rng.uniform(2, 30)), float(rng.uniform(0.2, 1.5)),
                          float(rng.uniform(0.5, 2)), 1.0) for i in range(3)]


def _figures_0_100(time: Any, response: Any, setpoint: float) -> Any:
    _rise, over, settle, err = _figures(time, response, setpoint)
    t = np.asarray(time)
    y = np.asarray(response)
    reach = float(t[int(np.argmax(y >= y[-1]))] - t[0])
    return reach, over, settle, err


def _figures_fraction(time: Any, response: Any, setpoint: float) -> Any:
    rise, over, settle, err = _figures(time, response, setpoint)
    return rise, over / 100, settle, err


step_figures = Exercise(
    id="lab04.step_figures", function="step_figures", title="Step-response figures",
    reference=_figures, points=3,
    public=(_figures_case("underdamped", 10.0, 0.3, 1.0, 1.0),
            _figures_case("overdamped", 5.0, 1.2, 1.0, 1.0),
            _figures_case("with a steady-state error", 8.0, 0.6, 0.9, 1.0)),
    hidden=_figures_hidden, rtol=1e-6, atol=1e-9,
    diagnostics=(Diagnostic("0 → 100 % rise time", _figures_0_100,
                            "the rise time runs from 10 % to 90 % of the final value"),
                 Diagnostic("the overshoot as a fraction", _figures_fraction,
                            "the overshoot is in percent: (max − final) / final × 100")),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- tuning

def _placement(gain: float, tau: float, wn: float, zeta: float) -> Any:
    g = ctl.pole_placement_pi(gain, tau, wn, zeta)
    return g.kp, g.ki


def _placement_no_one(gain: float, tau: float, wn: float, zeta: float) -> Any:
    return 2 * zeta * wn * tau / gain, wn * wn * tau / gain


pole_placement = Exercise(
    id="lab04.pole_placement", function="pole_placement", title="PI by pole placement",
    reference=_placement, points=2,
    public=(Case("the IGV motor", (0.4655, 0.2975, 20.0, 0.9)),
            Case("a slow plant", (2.0, 1.5, 3.0, 0.7))),
    hidden=lambda rng: [Case(f"plant {i}", (float(rng.uniform(0.1, 5)),
                                             float(rng.uniform(0.05, 2)),
                                             float(rng.uniform(2, 40)),
                                             float(rng.uniform(0.5, 1.2)))) for i in range(4)],
    diagnostics=(Diagnostic("dropping the plant's own damping", _placement_no_one,
                            "the loop polynomial is τ s² + (1 + K Kp) s + K Ki: Kp = "
                            "(2ζω_n τ − 1) / K"),),
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


ziegler_nichols = Exercise(
    id="lab04.ziegler_nichols", function="ziegler_nichols_pid",
    title="Ziegler–Nichols PID", reference=_zn, points=2,
    public=(Case("textbook", (2.0, 1.0)), Case("the sampled IGV loop", (57.0, 0.058))),
    hidden=lambda rng: [Case(f"loop {i}", (float(rng.uniform(0.5, 100)),
                                            float(rng.uniform(0.01, 5)))) for i in range(3)],
    diagnostics=(Diagnostic("the PI row", _zn_pi_row,
                            "the PID row: Kp = 0.6 Ku, Ti = Tu / 2, Td = Tu / 8"),
                 Diagnostic("T_i and T_d in place of K_i and K_d", _zn_time_constants,
                            "the gains are K_i = K_p / T_i and K_d = K_p T_d, not the times")),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- cascade

def _cascade_unlimited(setpoint: float, speed: float, gain: float, max_acc: float) -> float:
    return gain * (setpoint - speed)


def _cascade_sign(setpoint: float, speed: float, gain: float, max_acc: float) -> float:
    return float(ctl.cascade_acceleration(speed, setpoint, gain, max_acc))


cascade_acceleration = Exercise(
    id="lab04.cascade_acceleration", function="cascade_acceleration",
    title="The cascade's outer loop", reference=ctl.cascade_acceleration, points=2,
    public=(Case("small error", (0.5, 0.45, 4.0, 0.5)), Case("start", (0.5, 0.0, 4.0, 0.5)),
            Case("braking", (0.0, 0.6, 4.0, 0.5))),
    hidden=lambda rng: [Case(f"random {i}", (float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)),
                                              float(rng.uniform(1, 10)),
                                              float(rng.uniform(0.2, 2)))) for i in range(4)],
    diagnostics=(Diagnostic("no acceleration limit", _cascade_unlimited,
                            "limit the desired acceleration to ±max_acceleration"),
                 Diagnostic("the error the wrong way round", _cascade_sign,
                            "the error is set-point minus speed: a robot slower than asked "
                            "must accelerate")),
    blocked=_BLOCKED,
)


SPEC = LabSpec(
    name="lab04",
    title="Lab 04 — Motor control",
    exercises=(transfer_coefficients, pi_step, step_figures, pole_placement, ziegler_nichols,
               cascade_acceleration),
)
