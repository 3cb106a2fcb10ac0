"""Motor model, PID and tuning against python-control and the textbook behaviours."""

from __future__ import annotations

import math
from dataclasses import replace

import control
import numpy as np
import pytest

from kit.control import (
    IGV_MOTOR,
    PID,
    CascadeController,
    PIDGains,
    PIDState,
    pid_step,
    pole_placement_pi,
    simulate_motor,
    step_info,
    with_limits,
    ziegler_nichols,
)


def first_order(motor=IGV_MOTOR):
    G = motor.transfer_function()
    return float(control.dcgain(G)), 1.0 / abs(max(control.poles(G).real))


def test_transfer_function_and_state_space_are_the_same_motor():
    G = IGV_MOTOR.transfer_function()
    S = IGV_MOTOR.state_space()
    t = np.linspace(0, 2, 2001)
    _, y1 = control.step_response(G, t)
    _, y2 = control.step_response(S, t)
    np.testing.assert_allclose(y1, y2, atol=1e-9)
    # 24 V give the paper's 110 RPM at the wheel, less what friction takes
    no_load_rpm = 24 * float(control.dcgain(G)) * 60 / (2 * math.pi)
    assert no_load_rpm == pytest.approx(110, rel=0.05)
    assert IGV_MOTOR.no_load_wheel_speed == pytest.approx(24 * float(control.dcgain(G)))


def test_step_figures_agree_with_python_control():
    G = IGV_MOTOR.transfer_function()
    t = np.linspace(0, 3, 30001)
    _, y = control.step_response(G, t)
    theirs = control.step_info(y, T=t)
    ours = step_info(t, y)
    dt = t[1] - t[0]
    assert ours.rise_time == pytest.approx(theirs["RiseTime"], abs=2 * dt)
    assert ours.settling_time == pytest.approx(theirs["SettlingTime"], abs=2 * dt)
    assert ours.overshoot == pytest.approx(theirs["Overshoot"], abs=1e-6)
    # and on an underdamped second-order system
    H = control.tf([100.0], [1.0, 4.0, 100.0])
    _, y = control.step_response(H, t)
    theirs, ours = control.step_info(y, T=t), step_info(t, y)
    assert ours.overshoot == pytest.approx(theirs["Overshoot"], rel=1e-6)
    assert ours.rise_time == pytest.approx(theirs["RiseTime"], abs=2 * dt)
    assert ours.settling_time == pytest.approx(theirs["SettlingTime"], abs=2 * dt)


def test_pole_placement_pi_meets_the_labs_step_specs_on_the_motor():
    K, tau = first_order()
    gains = with_limits(pole_placement_pi(K, tau, natural_frequency=20, damping=0.9), -24, 24,
                        dt=0.001)
    run = simulate_motor(IGV_MOTOR, PID(gains), np.full(1000, 5.0), 0.001,
                         current_limit=IGV_MOTOR.peak_current)
    info = step_info(run["time"], run["speed"], setpoint=5.0)
    # Lab 04's specification: a 5 rad/s step within the drive's 6.6 A, rise < 0.3 s,
    # overshoot < 5 %, settling < 0.4 s, no steady-state error
    assert info.rise_time < 0.3 and info.overshoot < 5 and info.settling_time < 0.4
    assert abs(info.steady_state_error) < 1e-3
    assert np.max(np.abs(run["current"])) <= IGV_MOTOR.peak_current * 1.001


def test_anti_windup_prevents_the_overshoot_of_a_saturated_integrator():
    K, tau = first_order()
    base = with_limits(pole_placement_pi(K, tau, 30, 0.8), -24, 24, dt=0.001)
    overshoot = {}
    for mode in ("none", "clamp", "back-calculation"):
        gains = replace(base, anti_windup=mode, tracking=50.0)
        run = simulate_motor(IGV_MOTOR, PID(gains), np.full(2000, 8.0), 0.001)
        assert np.max(np.abs(run["voltage"])) == pytest.approx(24.0)  # it does saturate
        overshoot[mode] = step_info(run["time"], run["speed"], 8.0).overshoot
    assert overshoot["none"] > 20
    assert overshoot["clamp"] < 2 and overshoot["back-calculation"] < 2


def test_derivative_acts_on_the_measurement_so_setpoint_steps_do_not_kick():
    gains = PIDGains(kp=1.0, kd=0.5, dt=0.01)
    _, state = pid_step(gains, PIDState(), 0.0, 0.0)
    out, _ = pid_step(gains, state, 10.0, 0.0)  # set-point jumps, measurement does not
    assert out == pytest.approx(10.0)  # P only
    out, _ = pid_step(gains, state, 0.0, 1.0)  # measurement jumps
    assert out == pytest.approx(-1.0 - 0.5 * 1.0 / 0.01)


def test_derivative_filter_tames_measurement_noise():
    rng = np.random.default_rng(0)
    noise = rng.normal(0, 0.01, 500)
    spread = {}
    for tf in (0.0, 0.05):
        pid = PID(PIDGains(kp=0.0, kd=1.0, dt=0.01, derivative_filter=tf))
        spread[tf] = np.std([pid(0.0, n) for n in noise])
    assert spread[0.05] < spread[0.0] / 3


@pytest.mark.filterwarnings("ignore:stability_margins")
def test_ziegler_nichols_from_the_sampled_loop_gives_a_stable_controller():
    dt = 0.01
    Gd = control.c2d(IGV_MOTOR.transfer_function(), dt) * control.tf([1], [1, 0], dt)
    gm, _, wcg, _ = control.margin(Gd)  # one sample of computation delay in the loop
    ku, tu = float(gm), 2 * math.pi / float(wcg)
    gains = ziegler_nichols(ku, tu, "PI")
    C = control.tf([gains.kp + gains.ki * dt, -gains.kp], [1, -1], dt)  # backward-Euler PI
    closed = control.feedback(C * Gd, 1)
    assert np.all(np.abs(control.poles(closed)) < 1.0)
    assert ziegler_nichols(2.0, 1.0, "PID") == PIDGains(kp=1.2, ki=2.4, kd=0.15)
    with pytest.raises(ValueError, match="kind"):
        ziegler_nichols(1.0, 1.0, "PD")


def test_cascade_limits_acceleration_and_reaches_the_speed():
    """Eddie's cascade on a wheel modelled as motor power → acceleration (with drag)."""
    dt = 0.01
    cascade = CascadeController(speed_gain=4.0, max_acceleration=0.5,
                                inner=PIDGains(kp=0.8, ki=4.0, dt=dt,
                                               output_limits=(-1.0, 1.0)))
    v, speeds = 0.0, []
    for _ in range(800):
        power = cascade(0.6, v)
        v += (2.0 * power - 0.5 * v) * dt  # acceleration = 2 m/s² per unit power, drag
        speeds.append(v)
    accel = np.diff(speeds) / dt
    assert speeds[-1] == pytest.approx(0.6, abs=0.01)
    assert np.max(accel) < 0.5 * 1.25  # the limited acceleration, with the loop's lag


def test_bad_gains_are_refused():
    with pytest.raises(ValueError, match="anti_windup"):
        PIDGains(kp=1.0, anti_windup="magic")
    with pytest.raises(ValueError, match="low < high"):
        PIDGains(kp=1.0, output_limits=(1.0, -1.0))
    with pytest.raises(ValueError, match="ends at zero"):
        step_info([0, 1, 2], [0, 0, 0])
