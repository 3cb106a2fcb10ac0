"""What sits behind an emulated device: ideal wheels on their own, or a ``sim`` robot.

A backend offers the devices one small interface, all on the emulators' clock:

* ``advance(now)``: bring the world up to time ``now`` [s];
* ``set_wheel_speed(k, rad_s)`` and ``wheel_angle(k)`` / ``wheel_speed(k)`` for wheel
  ``k`` (0 right, 1 left), at the wheel (a motor controller applies its gearing);
* ``subscribe(kind, callback)`` for ``"scan"`` and ``"imu"`` messages as they are made;
* ``pose()`` and ``yaw()``: where the body is (IMUs and compasses read this);
* ``at(time, callback)``: call ``callback(time)`` when the world reaches ``time``, before it
  goes on: a motor controller's watchdog stops the wheels at the instant it expires, even
  when another device (a lidar streaming) is what moves the world on.

With :class:`SimBackend` the ODrive's encoders are the simulated wheels, the lidar scans
the simulated world and the IMU reads the simulated body, so the real driver stack drives
the simulated robot.
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable
from typing import Any

import numpy as np

from kit import geometry, msgs

__all__ = ["IdealWheels", "SimBackend", "imu_yaw", "room_ranges"]


def room_ranges(angles: np.ndarray) -> np.ndarray:
    """Ranges [m] from the centre of an empty 8 m × 8 m room to its walls, at ``angles``
    [rad] counter-clockwise from x: what an emulated lidar sees with no simulator behind it."""
    c, s = np.abs(np.cos(angles)), np.abs(np.sin(angles))
    return np.minimum(4.0 / np.maximum(c, 1e-12), 4.0 / np.maximum(s, 1e-12))


def imu_yaw(message: msgs.Imu) -> float:
    """REP-103 yaw of a simulated IMU reading (what an emulated IMU or compass reports)."""
    q = message.orientation
    return float(geometry.quaternion_to_yaw((q.x, q.y, q.z, q.w)))


class _Timed:
    """Callbacks due at given times, run in time order while a world advances."""

    def __init__(self) -> None:
        self._due: list[tuple[float, int, Callable[[float], None]]] = []
        self._order = itertools.count()

    def at(self, time: float, callback: Callable[[float], None]) -> None:
        """Call ``callback(time)`` when the world reaches ``time`` (at once if it has)."""
        heapq.heappush(self._due, (float(time), next(self._order), callback))

    def _advance(self, now: float, step: Callable[[float], None]) -> None:
        while self._due and self._due[0][0] <= now:
            when, _, callback = heapq.heappop(self._due)
            step(when)
            callback(when)
        step(now)


class IdealWheels(_Timed):
    """Two wheels that take the commanded speed at once and integrate it exactly; no world
    (scans and IMU readings never come)."""

    def __init__(self) -> None:
        super().__init__()
        self.time = 0.0
        self.speeds = [0.0, 0.0]
        self.angles = [0.0, 0.0]

    def advance(self, now: float) -> None:
        self._advance(now, self._integrate)

    def _integrate(self, now: float) -> None:
        dt = now - self.time
        if dt > 0:
            for k in (0, 1):
                self.angles[k] += self.speeds[k] * dt
            self.time = now

    def set_wheel_speed(self, k: int, rad_s: float) -> None:
        self.speeds[k] = float(rad_s)

    def wheel_angle(self, k: int) -> float:
        return self.angles[k]

    def wheel_speed(self, k: int) -> float:
        return self.speeds[k]

    def subscribe(self, kind: str, callback: Callable[[Any], None]) -> None:
        if kind not in ("scan", "imu"):
            raise ValueError(f"unknown message kind {kind!r}")

    def pose(self) -> np.ndarray:
        return np.zeros(3)

    def yaw(self) -> float:
        return 0.0


class SimBackend(_Timed):
    """A robot of a :class:`sim.Simulation`, stepped in lock-step with the emulators' clock.

    Each ``advance(now)`` steps the simulation (its own fixed step) until its clock reaches
    ``now``, with the wheel speeds the motor controllers last set. The simulation's own
    encoders (``sim.encoder_ticks``) stay the reference the drivers are compared with.
    """

    def __init__(self, sim: Any, robot: int = 0) -> None:
        super().__init__()
        self.sim = sim
        self.robot = robot
        self._command = np.zeros(2)
        self._listeners: dict[str, list[Callable[[Any], None]]] = {"scan": [], "imu": []}
        self.steps = 0

    @classmethod
    def create(cls, robot: str = "uiabot", world: str = "office", seed: int = 0,
               **options: Any) -> SimBackend:
        from sim import Simulation

        return cls(Simulation(world=world, robot=robot, seed=seed, **options))

    @property
    def description(self) -> Any:
        return self.sim.descriptions[self.robot]

    def advance(self, now: float) -> None:
        self._advance(now, self._step)

    def _step(self, now: float) -> None:
        sim = self.sim
        half = 0.5 * sim.physics.dt
        while sim.time + half <= now:
            out = sim.step({self.robot: self._command.copy()})
            self.steps += 1
            for _, message in out:
                if isinstance(message, msgs.LaserScan):
                    kind = "scan"
                elif isinstance(message, msgs.Imu):
                    kind = "imu"
                else:
                    continue
                for callback in self._listeners[kind]:
                    callback(message)

    def set_wheel_speed(self, k: int, rad_s: float) -> None:
        self._command[k] = float(rad_s)

    def wheel_angle(self, k: int) -> float:
        return float(self.sim.robots[self.robot].wheel_angle[k])

    def wheel_speed(self, k: int) -> float:
        return float(self.sim.robots[self.robot].wheel_speed[k])

    def subscribe(self, kind: str, callback: Callable[[Any], None]) -> None:
        if kind not in self._listeners:
            raise ValueError(f"unknown message kind {kind!r}")
        self._listeners[kind].append(callback)

    def pose(self) -> np.ndarray:
        return np.asarray(self.sim.ground_truth(self.robot).pose)

    def yaw(self) -> float:
        return float(self.pose()[2])
