"""What both robot bases share: the command they hold, the keep-alive that feeds the motor
controllers' watchdogs while a command is held, their place among the bases
:mod:`kit.drivers.safety` stops, and ``with``. (:mod:`kit.drivers.bases` has the robots.)"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from types import TracebackType
from typing import Any

from kit import msgs
from kit.drivers import safety
from kit.drivers.errors import DriverError, PortError
from kit.drivers.port import Link
from kit.odometry import WheelOdometry
from kit.robots import RobotDescription

__all__ = ["KeepAlive", "MotorBase"]


class KeepAlive:
    """Call ``tick()`` every ``period`` seconds in a daemon thread until :meth:`stop`; an
    error ends the thread and is kept in ``error`` (the motor controller's own watchdog
    then stops the motors)."""

    def __init__(self, name: str, period: float, tick: Callable[[], None]) -> None:
        if not period > 0:
            raise ValueError(f"period must be > 0 s; got {period}")
        self.period = period
        self.tick = tick
        self.ticks = 0
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"keep-alive-{name}",
                                        daemon=True)

    def start(self) -> KeepAlive:
        self._thread.start()
        return self

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def _run(self) -> None:
        while not self._stop.wait(self.period):
            try:
                self.tick()
            except Exception as exc:  # the port failed: nothing left to feed
                self.error = exc
                return
            self.ticks += 1

    def stop(self, wait: bool = True) -> None:
        """End the thread (``wait``: and wait up to 2 s for it to end)."""
        self._stop.set()
        if wait and self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)


class MotorBase:
    """What both bases share: the held command, the keep-alive, the registry of bases to
    stop, and ``with``."""

    device = "base"
    link: Link

    def _init_safety(self, watchdog_timeout: float, hold: float | None,
                     keep_alive: bool | None, clock: Callable[[], float]) -> None:
        if not (math.isfinite(watchdog_timeout) and watchdog_timeout >= 0):
            raise ValueError(f"watchdog_timeout is seconds >= 0 (0: off); got "
                             f"{watchdog_timeout}")
        if hold is not None and not (math.isfinite(hold) and hold > 0):
            raise ValueError(f"hold is seconds > 0, or None to hold a command for ever; "
                             f"got {hold}")
        self.watchdog_timeout = float(watchdog_timeout)
        self.hold = hold
        self.keep_alive = (clock is time.monotonic) if keep_alive is None else keep_alive
        self.ready = False
        self._resume = False
        self.held: tuple[float, float] = (0.0, 0.0)
        self._commanded_at = 0.0
        self._keeper: KeepAlive | None = None

    def _armed(self) -> None:
        """The motors can move now: register for stopping, start the keep-alive."""
        self.ready = True
        self.held = (0.0, 0.0)
        self._commanded_at = time.monotonic()
        safety.register(self)
        if self.keep_alive and self.watchdog_timeout > 0 and self._keeper is None:
            self._keeper = KeepAlive(self.device, max(self.watchdog_timeout / 4, 0.01),
                                     self._tick).start()

    def _disarmed(self) -> None:
        self.ready = False  # a keep-alive tick that comes now sends nothing
        if self._keeper is not None:
            self._keeper.stop(wait=False)  # (it may be waiting for the lock a caller holds)
            self._keeper = None
        safety.unregister(self)

    def _tick(self) -> None:
        with self.link.lock:
            if not self.ready:
                return
            if self.hold is not None and self.held != (0.0, 0.0) and \
                    time.monotonic() - self._commanded_at > self.hold:
                self._send(0.0, 0.0)  # held too long without a new command: stop
                self.held = (0.0, 0.0)
            else:
                self._feed()

    def _require_ready(self, what: str) -> None:
        if not self.ready:
            raise DriverError(self.device, f"{what}: the motors are not under control — "
                                           f"{self._start_name}() first (after a stop, a port "
                                           f"failure or a watchdog stop, again)")

    _start_name = "start"

    def _send(self, right: float, left: float) -> None:
        raise NotImplementedError

    def _feed(self) -> None:
        raise NotImplementedError

    def _restart_odometry(self) -> None:
        """Go on from the pose so far, from where the encoders are now (a rebooted motor
        controller counts from 0 again)."""
        old = self.odometry
        self.odometry = WheelOdometry.for_robot(self.robot, initial_pose=old.pose)
        self.odometry.covariance = old.covariance
        self.update()

    odometry: WheelOdometry
    robot: RobotDescription

    def update(self) -> msgs.Odometry:
        raise NotImplementedError

    def _wheel_command(self, cmd: msgs.Twist | tuple[float, float]) -> tuple[float, float]:
        """The two wheels' command for a twist, in the motor controllers' units."""
        raise NotImplementedError

    def drive(self, cmd: msgs.Twist | tuple[float, float]) -> None:
        """Command a twist (m/s, rad/s); held until the next command (see
        :mod:`kit.drivers.bases`)."""
        command = self._wheel_command(cmd)
        with self.link.lock:
            self._require_ready("drive")
            self._send(*command)
            self.held = command
            self._commanded_at = time.monotonic()

    def halt(self) -> None:
        """Zero speed; the motors stay under control, ready for the next command."""
        with self.link.lock:
            self._send(0.0, 0.0)
            self.held = (0.0, 0.0)

    def stop(self) -> None:
        raise NotImplementedError

    def emergency_stop(self) -> None:
        """:meth:`stop` without raising (the program is ending; a port already gone is left
        to the motor controllers' watchdogs), tried twice if it fails otherwise."""
        for _ in range(2):
            try:
                self.stop()
                return
            except PortError:
                break
            except DriverError:
                continue
        self._disarmed()

    def close(self) -> None:
        """Stop the motors (if this base started them) and close the port."""
        if self.ready:
            self.emergency_stop()
        self._disarmed()
        self.link.close()

    def __enter__(self) -> Any:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
