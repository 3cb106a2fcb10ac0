"""Robot bases: the drivers of a robot's motors, its kinematics and its odometry as one
object — ``Twist`` in, wheel commands out; encoder feedback in, ``Odometry`` + TF out.

* :class:`UiabotBase`: the Uiabot's oDrive, odometry and twist nodes in one class, and its
  bring-up sequence (connect → full calibration → closed loop) with the waits of the
  paper's launch file, each step failing with a :class:`BringUpError` that names it.
* :class:`IgvBase`: the IGV's two AMC drives on one RS-485 bus.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from kit import kinematics, msgs
from kit.drivers import dpralte
from kit.drivers.dpralte import DpralteDrive
from kit.drivers.errors import DriverError
from kit.drivers.odrive import CLOSED_LOOP_CONTROL, FULL_CALIBRATION_SEQUENCE, IDLE, ODrive
from kit.drivers.port import Link
from kit.odometry import WheelOdometry
from kit.robots import RobotDescription
from kit.robots import load as load_robot

__all__ = ["WHEEL_JOINTS", "BringUpError", "IgvBase", "UiabotBase"]

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
        return float(cmd.linear.x), float(cmd.angular.z)
    v, w = cmd
    return float(v), float(w)


class UiabotBase:
    """The Uiabot's drive system on its oDrive (axis 0 right, axis 1 left, mirrored).

    Parameters
    ----------
    odrive : ODrive or port
        An :class:`~kit.drivers.odrive.ODrive`, or a port to open one on.
    robot : str or RobotDescription
        Gearing, encoder, wheel geometry, motor signs and limits (``"uiabot"``).
    """

    STEPS = ("connect", "calibrate", "closed loop")

    def __init__(self, odrive: ODrive | Any, robot: str | RobotDescription = "uiabot",
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep,
                 log: Callable[[str], None] | None = None, *, baudrate: int = 115200,
                 stamp: Callable[[], float] | None = None) -> None:
        self.odrive = odrive if isinstance(odrive, ODrive) else \
            ODrive(odrive, clock=clock, sleep=sleep, baudrate=baudrate, stamp=stamp)
        self.robot = robot if isinstance(robot, RobotDescription) else load_robot(robot)
        drive = self.robot.parameters["drive"]
        self.signs = (int(drive.get("right_motor_sign", 1)), int(drive.get("left_motor_sign", 1)))
        self.odometry = WheelOdometry.for_robot(self.robot)
        self.log = log or (lambda message: None)
        self.steps_done: list[tuple[str, float]] = []
        self.last_odometry: msgs.Odometry | None = None

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
        """Connect → full calibration of both axes → closed loop of both axes.

        The paper's launch file waits 10 s after connecting and starts closed loop 30 s
        after start-up (20 s after the calibration); here those are the time-outs of
        polling the axis states, so the sequence goes on as soon as each step is done and
        fails, naming the step, when it is not done in time.
        """
        od = self.odrive

        def connect() -> None:
            od.info()
            voltage = od.vbus_voltage()
            if not voltage > 5.0:
                raise DriverError("ODrive", f"bus voltage {voltage:.1f} V: is the supply on?")
            for axis in (0, 1):
                if od.axis_error(axis):
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
            for axis in (0, 1):
                od.write(f"axis{axis}.controller.config.control_mode", 2)
                od.write(f"axis{axis}.controller.input_vel", 0.0)
                od.request_state(axis, CLOSED_LOOP_CONTROL)
            for axis in (0, 1):
                od.wait_for_state(axis, CLOSED_LOOP_CONTROL, closed_loop_wait)

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

    def drive(self, cmd: msgs.Twist | tuple[float, float]) -> None:
        right, left = self.motor_speeds(cmd)
        self.odrive.set_velocity(0, right)
        self.odrive.set_velocity(1, left)

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
        right, left = self.encoder_ticks()
        self.last_odometry = self.odometry.update(right, left, self.stamp())
        return self.last_odometry

    def read_wheels(self) -> tuple[msgs.JointState, msgs.Odometry]:
        """One reading of both encoders (``f 0``, ``f 1``): the wheels' ``JointState``
        (positions [rad] and speeds [rad/s] at the wheel, signs undone) and the odometry it
        advances. Needs no bring-up: the encoders count in IDLE too."""
        d = self.robot
        positions, velocities, counts = [], [], []
        for axis in (0, 1):
            turns, turns_per_s = self.odrive.feedback(axis)
            sign = self.signs[axis]
            positions.append(sign * turns * 2 * math.pi / d.gear_ratio)
            velocities.append(sign * turns_per_s * 2 * math.pi / d.gear_ratio)
            counts.append(round(sign * turns * d.encoder_resolution) % (1 << d.counter_bits))
        t = self.stamp()
        self.last_odometry = self.odometry.update(counts[0], counts[1], t)
        return _wheel_state(t, positions, velocities), self.last_odometry

    def transform(self) -> msgs.TransformStamped:
        """``odom → base_link`` of the last update."""
        return self.odometry.transform(self.stamp())

    def stop(self) -> None:
        """Zero speed, then both axes to IDLE."""
        for axis in (0, 1):
            self.odrive.set_velocity(axis, 0.0)
        for axis in (0, 1):
            self.odrive.request_state(axis, IDLE)


class IgvBase:
    """The IGV's two AMC DPRALTE drives on one RS-485 bus (0x3F right at 45.02, 0x3E left
    at 45.00), with the paper's command equations and the drives' position registers as
    encoders."""

    def __init__(self, port: Any, robot: str | RobotDescription = "igv", timeout: float = 0.25,
                 clock: Callable[[], float] = time.monotonic, *,
                 baudrate: int = dpralte.BAUDRATE, sleep: Callable[[float], None] = time.sleep,
                 stamp: Callable[[], float] | None = None) -> None:
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

    def start(self) -> None:
        """Write access, protection events cleared, velocity 0, bridge enabled (§1.7)."""
        for drive in (self.right, self.left):
            drive.get_write_access()
            status = drive.read((0x02, 0x00), 2, "read bridge and protection status")
            if status.uint16(1):
                drive.write((0x01, 0x00), (0x1000).to_bytes(2, "little"), "reset events")
            drive.set_velocity_rpm(0.0)
            drive.enable()

    def wheel_rpm(self, cmd: msgs.Twist | tuple[float, float]) -> tuple[float, float]:
        """(right, left) RPM by the paper's eq. 7, scaled down together to the 110 RPM limit."""
        v, w = _twist(cmd)
        u_right, u_left = (float(u) for u in kinematics.igv_wheel_rpm(v, w))
        limit = self.robot.max_wheel_speed * 60.0 / (2 * math.pi)
        scale = max(abs(u_left), abs(u_right)) / limit
        if scale > 1.0:
            u_left, u_right = u_left / scale, u_right / scale
        return u_right, u_left

    def drive(self, cmd: msgs.Twist | tuple[float, float]) -> None:
        right, left = self.wheel_rpm(cmd)
        self.right.set_velocity_rpm(right)
        self.left.set_velocity_rpm(left)

    def update(self) -> msgs.Odometry:
        right = self.right.read_position() % (1 << self.robot.counter_bits)
        left = self.left.read_position() % (1 << self.robot.counter_bits)
        return self.odometry.update(right, left, self.link.stamp())

    def read_wheels(self) -> tuple[msgs.JointState, msgs.Odometry]:
        """Both drives' position registers: the wheels' ``JointState`` (positions [rad]; no
        speeds, which would take two more transactions) and the odometry they advance.
        Needs no write access and moves nothing."""
        d = self.robot
        raw = [self.right.read_position(), self.left.read_position()]
        t = self.link.stamp()
        odometry = self.odometry.update(raw[0] % (1 << d.counter_bits),
                                        raw[1] % (1 << d.counter_bits), t)
        positions = [c * 2 * math.pi / d.ticks_per_wheel_turn for c in raw]
        return _wheel_state(t, positions, []), odometry

    def stop(self) -> None:
        for drive in (self.right, self.left):
            drive.set_velocity_rpm(0.0)
            drive.disable()
