"""A kinematic differential-drive model with imperfect wheels, for the labs until the pymunk
simulator lands.

Each wheel is a velocity servo with a first-order lag and a speed limit. The ground does not
take each wheel exactly at its word: a wheel of nominal radius ``r`` moves the robot by
``r (1 + e) Δφ``, where ``e`` is a fixed per-wheel radius error (worn or unevenly loaded
tyres, the systematic error UMBmark measures) plus a random slip drawn every step. The
encoders count the wheels' rotation ``Δφ`` in ticks, quantised, in counters that roll over
— so odometry built on them drifts the way a real robot's does. Inside an ``oil`` rectangle
the slip is ten times larger.

Randomness comes only from the ``seed``: the same seed gives the same run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from kit import geometry, kinematics
from kit.robots import RobotDescription
from sim.sensors import encoder_counts

__all__ = ["DiffDriveModel", "WheelErrors", "drive_square"]


@dataclass(frozen=True)
class WheelErrors:
    """How far the wheels are from ideal (dimensionless fractions of the wheel radius)."""

    radius_error_right: float = 0.002
    radius_error_left: float = -0.002
    slip_std: float = 0.01
    """standard deviation of the random slip per step."""
    oil: tuple[float, float, float, float] | None = None
    """(x_min, y_min, x_max, y_max) of a slippery patch [m], or None."""
    oil_factor: float = 10.0
    servo_time_constant: float = 0.05
    """s, first-order lag of each wheel's speed servo."""


class DiffDriveModel:
    """A robot driving on a plane; ``step`` advances it by ``dt`` seconds.

    Parameters
    ----------
    robot : RobotDescription
        Wheel radius, separation, encoder resolution, counter width, speed limit.
    seed : int
        Seeds every random draw.
    dt : float
        Step [s].
    errors : WheelErrors
        The imperfections.
    initial_ticks : (int, int), optional
        The (right, left) counters' readings at the start; random when not given.
    """

    def __init__(self, robot: RobotDescription, seed: int = 0, dt: float = 0.01,
                 errors: WheelErrors | None = None,
                 initial_ticks: tuple[int, int] | None = None) -> None:
        if not dt > 0:
            raise ValueError(f"dt must be positive seconds; got {dt}")
        self.robot = robot
        self.dt = float(dt)
        self.errors = errors or WheelErrors()
        self.rng = np.random.default_rng(seed)
        self.time = 0.0
        self.pose = np.zeros(3)
        self.wheel_speeds: NDArray[np.float64] = np.zeros(2)  # actual (right, left) [rad/s]
        self._wheel_angle = np.zeros(2)  # total rotation [rad]
        modulus = 1 << robot.counter_bits
        self._tick_offset = (np.array(initial_ticks, dtype=np.int64) % modulus
                             if initial_ticks is not None
                             else self.rng.integers(0, modulus, 2, dtype=np.int64))

    def in_oil(self) -> bool:
        box = self.errors.oil
        return box is not None and box[0] <= self.pose[0] <= box[2] and \
            box[1] <= self.pose[1] <= box[3]

    def step(self, linear: float, angular: float) -> None:
        """Command (v [m/s], ω [rad/s]) for one step: inverse kinematics, saturation, servos."""
        r = self.robot
        target = kinematics.twist_to_wheel_speeds(linear, angular, r.wheel_radius,
                                                  r.wheel_separation)
        self.step_wheels(kinematics.saturate_wheel_speeds(target, r.max_wheel_speed))

    def step_wheels(self, wheel_speeds: NDArray[np.float64]) -> None:
        """Command (right, left) wheel speeds [rad/s] for one step."""
        e = self.errors
        alpha = 1.0 - math.exp(-self.dt / e.servo_time_constant)
        self.wheel_speeds = self.wheel_speeds + alpha * (np.asarray(wheel_speeds) -
                                                         self.wheel_speeds)
        dphi = self.wheel_speeds * self.dt
        self._wheel_angle += dphi
        slip_std = e.slip_std * (e.oil_factor if self.in_oil() else 1.0)
        scale = 1.0 + np.array([e.radius_error_right, e.radius_error_left]) + \
            self.rng.normal(0.0, slip_std, 2)
        travel = self.robot.wheel_radius * dphi * scale
        ds = 0.5 * (travel[0] + travel[1])
        dtheta = (travel[0] - travel[1]) / self.robot.wheel_separation
        heading = self.pose[2] + 0.5 * dtheta
        chord = ds * np.sinc(dtheta / (2 * np.pi))
        self.pose = np.array([self.pose[0] + chord * math.cos(heading),
                              self.pose[1] + chord * math.sin(heading),
                              float(geometry.wrap_angle(self.pose[2] + dtheta))])
        self.time += self.dt

    def encoder_ticks(self) -> tuple[int, int]:
        """Raw (right, left) counter readings: wheel rotation in ticks, wrapped to the counter."""
        return encoder_counts(self._wheel_angle, self.robot.ticks_per_wheel_turn,
                              self._tick_offset, self.robot.counter_bits)


def drive_square(model: Any, side: float = 2.0, speed: float | None = None,
                 turn_rate: float | None = None, laps: int = 1,
                 counter_clockwise: bool = True, robot: int = 0
                 ) -> dict[str, NDArray[np.float64]]:
    """Drive ``laps`` squares: straight ``side`` metres, turn 90° in place, four times a lap.

    ``model`` is a :class:`DiffDriveModel` or a :class:`sim.Simulation` (its robot ``robot``).
    The commands are open loop (timed), like the UMBmark test. Returns the samples at every
    step: ``time`` (N,), ``true_pose`` (N, 3), ``ticks`` (N, 2) raw counters, ``command``
    (N, 2) as (v, ω).
    """
    from kit import msgs
    from sim.simulation import Simulation

    if isinstance(model, Simulation):
        description, dt = model.robots[robot].description, model.physics.dt

        def step(linear: float, angular: float) -> None:
            model.step({robot: msgs.Twist(msgs.Vector3(linear, 0.0, 0.0),
                                          msgs.Vector3(0.0, 0.0, angular))})

        def pose() -> NDArray[np.float64]:
            return model.ground_truth(robot).pose

        def ticks() -> tuple[int, int]:
            return model.encoder_ticks(robot)
    else:
        description, dt, step = model.robot, model.dt, model.step

        def pose() -> NDArray[np.float64]:
            return np.asarray(model.pose.copy())

        ticks = model.encoder_ticks
    v = speed if speed is not None else 0.8 * description.max_linear_velocity
    w = turn_rate if turn_rate is not None else 0.5 * description.max_angular_velocity
    w = w if counter_clockwise else -w
    segments = []
    for _ in range(4 * laps):
        segments.append((v, 0.0, side / v))
        segments.append((0.0, w, (math.pi / 2) / abs(w)))
    times, poses, counts, commands = [model.time], [pose()], [ticks()], [(0.0, 0.0)]
    for linear, angular, duration in segments:
        for _ in range(round(duration / dt)):
            step(linear, angular)
            times.append(model.time)
            poses.append(pose())
            counts.append(ticks())
            commands.append((linear, angular))
    return {"time": np.array(times), "true_pose": np.array(poses),
            "ticks": np.array(counts, dtype=np.int64), "command": np.array(commands)}
