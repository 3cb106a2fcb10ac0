"""The simulator's wheel motor is kit.control.DCMotor's model (quasi-static current)."""

from __future__ import annotations

import numpy as np
import pytest

from kit import msgs
from kit.control import IGV_MOTOR, DCMotor, transfer_coefficients
from sim import Physics, Simulation


def test_quasi_static_step_is_python_controls_forward_euler_of_the_motor_without_inductance():
    """Below the current limit, L → 0 leaves the first-order plant
    (K_t/N) / (J R s + b R + K_t K_e); python-control's forward-Euler discretisation of it
    steps exactly as DCMotor.quasi_static_step does."""
    import control

    m = IGV_MOTOR
    dt = 0.01
    num, den = transfer_coefficients(m.resistance, 0.0, m.k_t, m.k_e, m.inertia, m.friction,
                                     m.gear_ratio)
    plant = control.c2d(control.tf(num, den[1:]), dt, method="euler")
    volts = np.r_[np.full(30, 2.0), np.full(30, -1.5), np.zeros(20)]  # currents stay < 6.6 A
    _, expected = control.forced_response(plant, T=np.arange(len(volts)) * dt, U=volts)
    speed, ours = 0.0, []
    for v in volts:
        ours.append(speed)
        speed = m.quasi_static_step(speed, float(v), dt)
    np.testing.assert_allclose(ours, expected, rtol=1e-9, atol=1e-12)


def test_quasi_static_current_is_where_the_full_model_has_no_current_change():
    m = DCMotor()
    wheel, volts, dt = 3.0, 12.0, 1e-3
    omega = wheel * m.gear_ratio
    current = (volts - m.k_e * omega) / m.resistance
    assert m.derivatives(np.array([omega, current]), volts)[1] == pytest.approx(0.0, abs=1e-9)
    expected = omega + m.derivatives(np.array([omega, current]), volts)[0] * dt
    assert m.quasi_static_step(wheel, volts, dt) * m.gear_ratio == pytest.approx(expected)
    # the drive's current limit caps the torque
    stalled = m.quasi_static_step(0.0, 24.0, dt) * m.gear_ratio
    assert stalled == pytest.approx(m.k_t * m.peak_current / m.inertia * dt)


def _old_motor_step(motor, controller, target, speed, dt):
    """Simulation._motor_step as it was before the simulator used DCMotor's model."""
    volts = min(max(float(controller(target, speed)), -motor.voltage), motor.voltage)
    omega = speed * motor.gear_ratio
    current = (volts - motor.k_e * omega) / motor.resistance
    current = min(max(current, -motor.peak_current), motor.peak_current)
    omega += (motor.k_t * current - motor.friction * omega) / motor.inertia * dt
    return omega / motor.gear_ratio


def test_the_simulated_igv_wheels_follow_the_same_motor_as_before():
    def make_p(gain=4.0):
        return lambda setpoint, measured: gain * (setpoint - measured)

    sim = Simulation(world="square", robot="igv", seed=1, start=[1.0, 5.0, 0.0], sensors=False,
                     physics=Physics(wheel_motor=IGV_MOTOR), wheel_controllers=make_p)
    cmd = msgs.Twist(msgs.Vector3(0.8, 0, 0), msgs.Vector3(0, 0, 0.4))
    speeds, expected = np.zeros(2), []
    controller = make_p()
    for k in range(150):
        sim.step(cmd if k == 0 else None)
        targets = sim.robots[0].wheel_target  # (right, left) rad/s the servo loop aims at
        speeds = np.array([_old_motor_step(IGV_MOTOR, controller, float(t), float(s), 0.01)
                           for t, s in zip(targets, speeds, strict=True)])
        expected.append(speeds)
        np.testing.assert_array_equal(sim.joint_state().velocity, speeds)
    assert np.all(expected[-1] > 0.5 * targets)  # a P loop: short of the target, but driving
