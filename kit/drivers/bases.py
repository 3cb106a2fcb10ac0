"""Robot bases: the drivers of a robot's motors, its kinematics and its odometry as one
object — ``Twist`` in, wheel commands out; encoder feedback in, ``Odometry`` + TF out.

* :class:`UiabotBase`: the Uiabot's oDrive, odometry and twist nodes in one class, and its
  bring-up sequence (connect → full calibration → closed loop) with the waits of the
  paper's launch file, each step failing with a :class:`BringUpError` that names it.
* :class:`IgvBase`: the IGV's two AMC drives on one RS-485 bus.

**Motors that stop.** A base that can move the robot (after ``bring_up()`` / ``start()``)
arms the motor controllers' own watchdogs — the ODrive's ``axis*.config`` watchdog, the
drives' communication watchdog ``04.01`` — with ``watchdog_timeout`` seconds (0.5 by
default; 0 turns them off), so the motors stop when the host goes silent: killed, crashed,
frozen, unplugged. Every command feeds them; while a command is held (``drive()`` once,
the robot keeps going) a background keep-alive feeds them every quarter of the time-out, as
long as the program runs. ``hold=`` seconds bounds how long a command is held without a new
one (a deadman: the keep-alive then commands zero speed). On the host side the base stops
its motors on ``close()`` (or leaving a ``with`` block), and :mod:`kit.drivers.safety` stops
every base at the program's exit, on an uncaught exception, on SIGTERM and SIGHUP, when a
notebook kernel shuts down, and halts them (zero speed) on SIGINT.

On an emulator's logical clock nothing runs in the background (time passes only inside
your calls): a command is held for as long as the loop that sends it keeps sending.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np

from kit import kinematics, msgs
from kit.drivers import dpralte
from kit.drivers._motor_base import KeepAlive, MotorBase
from kit.drivers.dpralte import COMMS_ERROR, DpralteDrive
from kit.drivers.errors import DriverError, PortError
from kit.drivers.odrive import (
    CLOSED_LOOP_CONTROL,
    FULL_CALIBRATION_SEQUENCE,
    IDLE,
    ODrive,
)
from kit.drivers.port import Link
from kit.odometry import WheelOdometry
from kit.robots import RobotDescription
from kit.robots import load as load_robot

__all__ = ["WHEEL_JOINTS", "BringUpError", "IgvBase", "KeepAlive", "UiabotBase"]

WHEEL_JOINTS = ("right_wheel_joint", "left_wheel_joint")
"""the wheel joints of the robots' URDFs, in the kit's (right, left) order."""


def _wheel_state(stamp: float, positions: list[float],
                 velocities: list[float]) -> msgs.JointState:
    return msgs.JointState(msgs.Header(msgs.Time.from_sec(stamp), ""), WHEEL_JOINTS,
                           np.asarray(positions, dtype=np.float64),
                           np.asarray(velocities, dtype=np.float64))


class BringUpError(DriverError):
    """A bring-up step failed; ``step`` is its name, ``__cause__`` the driver's error."""

    def __init__(self, device: str, step: str, message: str) -> None:
        super().__init__(device, f"bring-up failed at '{step}': {message}")
        self.step = step


def _twist(cmd: msgs.Twist | tuple[float, float]) -> tuple[float, float]:
    if isinstance(cmd, msgs.Twist):
        v, w = float(cmd.linear.x), float(cmd.angular.z)
    else:
        v, w = (float(x) for x in cmd)
    if not (math.isfinite(v) and math.isfinite(w)):
        raise ValueError(f"a twist must be finite (v [m/s], ω [rad/s]); got {v}, {w}")
    return v, w


def _midpoint(*exchanges: tuple[float, float]) -> float:
    """When readings taken during these request/reply exchanges were taken, best guess: the
    middle of each exchange, averaged (seconds, stamping clock)."""
    return sum(0.5 * (sent + answered) for sent, answered in exchanges) / len(exchanges)


class UiabotBase(MotorBase):
    """The Uiabot's drive system on its oDrive (axis 0 right, axis 1 left, mirrored).

    Parameters
    ----------
    odrive : ODrive or port
        An :class:`~kit.drivers.odrive.ODrive`, or a port to open one on.
    robot : str or RobotDescription
        Gearing, encoder, wheel geometry, motor signs and limits (``"uiabot"``).
    watchdog_timeout : float
        Seconds without a feed after which the ODrive stops the axes (0: its watchdog off).
    hold : float, optional
        Seconds a command is held without a new one before the keep-alive stops the robot
        (default: for as long as the program runs).
    keep_alive : bool, optional
        Feed the watchdog from a background thread while a command is held (default: on a
        real port, off on an emulator's logical clock).
    """

    STEPS = ("connect", "calibrate", "closed loop")
    device = "Uiabot"
    _start_name = "bring_up"

    def __init__(self, odrive: ODrive | Any, robot: str | RobotDescription = "uiabot",
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep,
                 log: Callable[[str], None] | None = None, *, baudrate: int = 115200,
                 stamp: Callable[[], float] | None = None, watchdog_timeout: float = 0.5,
                 hold: float | None = None, keep_alive: bool | None = None) -> None:
        self.odrive = odrive if isinstance(odrive, ODrive) else \
            ODrive(odrive, clock=clock, sleep=sleep, baudrate=baudrate, stamp=stamp)
        self.link = self.odrive.link
        self.robot = robot if isinstance(robot, RobotDescription) else load_robot(robot)
        drive = self.robot.parameters["drive"]
        self.signs = (int(drive.get("right_motor_sign", 1)), int(drive.get("left_motor_sign", 1)))
        self.odometry = WheelOdometry.for_robot(self.robot)
        self.log = log or (lambda message: None)
        self.steps_done: list[tuple[str, float]] = []
        self.last_odometry: msgs.Odometry | None = None
        self._init_safety(watchdog_timeout, hold, keep_alive, self.link.clock)

    @property
    def clock(self) -> Callable[[], float]:
        return self.odrive.link.clock

    @property
    def stamp(self) -> Callable[[], float]:
        """The clock odometry is stamped with (wall clock on a real port)."""
        return self.odrive.link.stamp

    def _step(self, step: str, action: Callable[[], None]) -> None:
        self.log(f"{step} …")
        try:
            action()
        except DriverError as exc:
            raise BringUpError("Uiabot", step, str(exc)) from exc
        self.steps_done.append((step, self.clock()))
        self.log(f"{step}: done at t = {self.clock():.2f} s")

    def bring_up(self, connect_wait: float = 10.0, calibration_wait: float = 20.0,
                 closed_loop_wait: float = 1.0) -> None:
        """Connect → full calibration of both axes → closed loop of both axes, watchdogs on.

        The paper's launch file waits 10 s after connecting and starts closed loop 30 s
        after start-up (20 s after the calibration); here those are the time-outs of
        polling the axis states, so the sequence goes on as soon as each step is done and
        fails, naming the step, when it is not done in time. Connecting clears the line
        (:meth:`ODrive.connect`) and turns the watchdogs off, so that one left on by an
        earlier program cannot cut the calibration short; closed loop turns them on with
        ``watchdog_timeout``. The odometry starts from the encoders read at the end, so the
        first :meth:`update` after :meth:`drive` already gives the motion since.
        """
        od = self.odrive
        self._disarmed()

        def connect() -> None:
            voltage = od.connect()
            od.info()
            if not voltage > 5.0:
                raise DriverError("ODrive", f"bus voltage {voltage:.1f} V: is the supply on?")
            for axis in (0, 1):
                od.set_velocity(axis, 0.0)
                od.set_watchdog(axis, 0.0)
            if any(od.axis_error(axis) for axis in (0, 1)):
                od.clear_errors()

        def calibrate() -> None:
            for axis in (0, 1):
                od.request_state(axis, FULL_CALIBRATION_SEQUENCE)
            deadline = self.clock() + calibration_wait
            for axis in (0, 1):
                od.wait_for_state(axis, IDLE, max(deadline - self.clock(), 0.0))
                if not od.read_int(f"axis{axis}.motor.is_calibrated"):
                    raise DriverError("ODrive", f"axis{axis} is back in IDLE but not calibrated")

        def closed_loop() -> None:
            feeding = self.watchdog_timeout > 0
            for axis in (0, 1):
                od.write(f"axis{axis}.controller.config.control_mode", 2)
                od.write(f"axis{axis}.controller.input_vel", 0.0)
                if feeding:
                    od.set_watchdog(axis, self.watchdog_timeout)
                od.request_state(axis, CLOSED_LOOP_CONTROL)
            for axis in (0, 1):
                od.wait_for_state(axis, CLOSED_LOOP_CONTROL, closed_loop_wait, feed=feeding)
            self._armed()
            self.update()  # the odometry's first reading: where the encoders are now

        self._step("connect", connect)
        self._step("calibrate", calibrate)
        self._step("closed loop", closed_loop)

    def motor_speeds(self, cmd: msgs.Twist | tuple[float, float]) -> tuple[float, float]:
        """``Twist`` → (axis 0, axis 1) motor speeds [turns/s]: inverse kinematics, wheel
        speeds saturated together, gearing, and the mirrored left motor's sign."""
        v, w = _twist(cmd)
        d = self.robot
        wheels = kinematics.saturate_wheel_speeds(
            kinematics.twist_to_wheel_speeds(v, w, d.wheel_radius, d.wheel_separation),
            d.max_wheel_speed)
        per = d.gear_ratio / (2 * math.pi)
        return (float(wheels[0]) * per * self.signs[0], float(wheels[1]) * per * self.signs[1])

    def _send(self, right: float, left: float) -> None:
        self.odrive.set_velocity(0, right)
        self.odrive.set_velocity(1, left)

    def _feed(self) -> None:
        self.odrive.feed(0)
        self.odrive.feed(1)

    def _wheel_command(self, cmd: msgs.Twist | tuple[float, float]) -> tuple[float, float]:
        return self.motor_speeds(cmd)

    def encoder_ticks(self) -> tuple[int, int]:
        """(right, left) wheel encoder counts, signs undone, as 32-bit counters."""
        counts = []
        for axis in (0, 1):
            position, _ = self.odrive.feedback(axis)
            ticks = round(self.signs[axis] * position * self.robot.encoder_resolution)
            counts.append(ticks % (1 << self.robot.counter_bits))
        return counts[0], counts[1]

    def update(self) -> msgs.Odometry:
        """Read both encoders and advance the odometry."""
        return self.read_wheels()[1]

    def read_wheels(self) -> tuple[msgs.JointState, msgs.Odometry]:
        """One reading of both encoders (``f 0``, ``f 1``): the wheels' ``JointState``
        (positions [rad] and speeds [rad/s] at the wheel, signs undone) and the odometry it
        advances, stamped in the middle of the two exchanges. Needs no bring-up: the
        encoders count in IDLE too."""
        d = self.robot
        positions, velocities, counts, exchanges = [], [], [], []
        with self.link.lock:
            for axis in (0, 1):
                turns, turns_per_s = self.odrive.feedback(axis)
                exchanges.append(self.odrive.last_exchange)
                sign = self.signs[axis]
                positions.append(sign * turns * 2 * math.pi / d.gear_ratio)
                velocities.append(sign * turns_per_s * 2 * math.pi / d.gear_ratio)
                counts.append(round(sign * turns * d.encoder_resolution) % (1 << d.counter_bits))
        t = _midpoint(*exchanges)
        self.last_odometry = self.odometry.update(counts[0], counts[1], t)
        return _wheel_state(t, positions, velocities), self.last_odometry

    def transform(self) -> msgs.TransformStamped:
        """``odom → base_link`` of the last update."""
        return self.odometry.transform(self.stamp())

    def stop(self) -> None:
        """Zero speed, both axes to IDLE, their watchdogs off (an idle axis needs none),
        the keep-alive ended: :meth:`bring_up` again to drive."""
        od = self.odrive
        self._disarmed()
        with self.link.lock:
            od.link.write(b"\n", "stop")  # ends a line the program left half written
            for axis in (0, 1):
                od.set_velocity(axis, 0.0)
            for axis in (0, 1):
                od.request_state(axis, IDLE)
            for axis in (0, 1):
                od.set_watchdog(axis, 0.0)

    def reopen(self) -> None:
        """Open the port again after it failed (the ODrive unplugged and back) on the same
        object. If both axes are still in closed loop without an error (the link was back
        within the watchdog's time), the base halts (zero speed) and stays ready; otherwise
        the watchdog stopped them and :meth:`bring_up` is needed again. Raises
        :class:`~kit.drivers.errors.PortError` while the ODrive is not back."""
        self._resume = self._resume or self.ready  # (kept while the ODrive is not back)
        self._disarmed()
        self.odrive.reopen()
        od = self.odrive
        if self._resume and all(od.axis_state(a) == CLOSED_LOOP_CONTROL and
                                not od.axis_error(a) for a in (0, 1)):
            self._armed()
            self.halt()
        self._resume = False
        self._restart_odometry()


class IgvBase(MotorBase):
    """The IGV's two AMC DPRALTE drives on one RS-485 bus (0x3F right at 45.02, 0x3E left
    at 45.00), with the paper's command equations and the drives' position registers as
    encoders. ``watchdog_timeout``, ``hold`` and ``keep_alive`` as for :class:`UiabotBase`;
    the watchdog is each drive's own (``04.01``)."""

    device = "IGV"
    _start_name = "start"

    def __init__(self, port: Any, robot: str | RobotDescription = "igv", timeout: float = 0.25,
                 clock: Callable[[], float] = time.monotonic, *,
                 baudrate: int = dpralte.BAUDRATE, sleep: Callable[[float], None] = time.sleep,
                 stamp: Callable[[], float] | None = None, watchdog_timeout: float = 0.5,
                 hold: float | None = None, keep_alive: bool | None = None) -> None:
        # one port, one link: both drives share the bus (a port that cannot be opened is a
        # PortError naming the DPRALTE, as for every other driver)
        self.link = Link(dpralte.DEVICE, port, baudrate, 0.01, clock, sleep, stamp)
        self.port = self.link.port
        self.robot = robot if isinstance(robot, RobotDescription) else load_robot(robot)
        drive = self.robot.parameters["drive"]
        counts = self.robot.encoder_resolution
        self.right = DpralteDrive(self.link, int(drive["right_drive_address"]), 0x02, timeout,
                                  counts)
        self.left = DpralteDrive(self.link, int(drive["left_drive_address"]), 0x00, timeout,
                                 counts)
        self.clock = clock
        self.odometry = WheelOdometry.for_robot(self.robot)
        self._init_safety(watchdog_timeout, hold, keep_alive, clock)

    @property
    def drives(self) -> tuple[DpralteDrive, DpralteDrive]:
        return self.right, self.left

    def start(self) -> None:
        """Per drive: clear the line, write access, latched events reset (a protection
        fault, a comms watchdog that ran out), velocity 0, the comms watchdog armed with
        ``watchdog_timeout``, bridge enabled (§1.7). The odometry starts from the encoders
        read at the end."""
        self._disarmed()
        for drive in self.drives:
            drive.connect(clear=drive is self.right)  # one bus: one line to clear
            drive.get_write_access()
            _, protection, system = drive.status()
            if protection or system:
                drive.reset_events()
            drive.set_velocity_rpm(0.0)
            drive.set_comm_watchdog(self.watchdog_timeout)
            drive.enable()
        self._armed()
        self.update()

    def wheel_rpm(self, cmd: msgs.Twist | tuple[float, float]) -> tuple[float, float]:
        """(right, left) RPM by the paper's eq. 7, scaled down together to the 110 RPM limit."""
        v, w = _twist(cmd)
        u_right, u_left = (float(u) for u in kinematics.igv_wheel_rpm(v, w))
        limit = self.robot.max_wheel_speed * 60.0 / (2 * math.pi)
        scale = max(abs(u_left), abs(u_right)) / limit
        if scale > 1.0:
            u_left, u_right = u_left / scale, u_right / scale
        return u_right, u_left

    def _send(self, right: float, left: float) -> None:
        self.right.set_velocity_rpm(right)
        self.left.set_velocity_rpm(left)

    def _feed(self) -> None:
        self._send(*self.held)  # the held command again: a frame each drive answers

    def _wheel_command(self, cmd: msgs.Twist | tuple[float, float]) -> tuple[float, float]:
        return self.wheel_rpm(cmd)

    def update(self) -> msgs.Odometry:
        return self.read_wheels()[1]

    def read_wheels(self) -> tuple[msgs.JointState, msgs.Odometry]:
        """Both drives' position registers: the wheels' ``JointState`` (positions [rad]; no
        speeds, which would take two more transactions) and the odometry they advance,
        stamped in the middle of the two exchanges. Needs no write access and moves
        nothing."""
        d = self.robot
        with self.link.lock:
            raw = [self.right.read_position(), self.left.read_position()]
            t = _midpoint(self.right.last_exchange, self.left.last_exchange)
        odometry = self.odometry.update(raw[0] % (1 << d.counter_bits),
                                        raw[1] % (1 << d.counter_bits), t)
        positions = [c * 2 * math.pi / d.ticks_per_wheel_turn for c in raw]
        return _wheel_state(t, positions, []), odometry

    def stop(self) -> None:
        """Velocity 0, bridges off, comms watchdogs off, keep-alive ended: :meth:`start`
        again to drive."""
        self._disarmed()
        with self.link.lock:
            for drive in self.drives:
                drive.set_velocity_rpm(0.0)
                drive.disable()
            for drive in self.drives:
                drive.set_comm_watchdog(0.0)

    def emergency_stop(self) -> None:
        """:meth:`stop`, each step on its own and asked twice if it fails (the program may
        have been stopped half-way through a frame, which costs the first one), without
        raising."""
        self._disarmed()
        steps: list[Callable[[], Any]] = []
        for drive in self.drives:
            steps += [partial(drive.set_velocity_rpm, 0.0), drive.disable]
        steps += [partial(drive.set_comm_watchdog, 0.0) for drive in self.drives]
        for step in steps:
            for _ in range(2):
                try:
                    step()
                    break
                except PortError:
                    return  # the port is gone: the drives' watchdogs stop them
                except DriverError:
                    continue

    def reopen(self) -> None:
        """Open the bus again after the port failed, on the same object. If both bridges are
        still enabled without a comms error (back within the watchdog's time), the base
        halts (zero speed) and stays ready; otherwise :meth:`start` is needed again."""
        self._resume = self._resume or self.ready  # (kept while the drives are not back)
        self._disarmed()
        self.link.reopen()
        healthy = True
        for drive in self.drives:
            drive.connect(clear=drive is self.right)
            bridge, _, system = drive.status()
            healthy = healthy and bool(bridge & 1) and not system & COMMS_ERROR
        if self._resume and healthy:
            self._armed()
            self.halt()
        self._resume = False
        self._restart_odometry()
