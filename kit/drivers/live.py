"""A live robot's devices as message sources: open a device, start it the way its driver
says, and read it as ROS messages — what ``kit record`` runs in one
:class:`~kit.drivers.reader.Reader` thread per device.

============  ======================================================  ===============
device        messages                                                read
============  ======================================================  ===============
``rplidar``   ``/scan`` (``LaserScan``, one per turn)                 as it streams
``lms2xx``    ``/scan`` (switched to 38400 baud, 180° at 1°)          as it streams
``bno055``    ``/imu`` (``Imu``: fused orientation, rates, accel.)     100 Hz
``os5000``    ``/imu`` (``Imu``: orientation only)                    as it streams
``odrive``    ``/joint_states``, ``/odom``, ``/tf`` (odom→base_link)   50 Hz
``dpralte``   ``/joint_states``, ``/odom``, ``/tf`` (both drives)      50 Hz
============  ======================================================  ===============

Nothing here moves a motor: the motor controllers are only read (their encoders count in
IDLE and with the bridges off). Every source can ``reopen()`` its device after the port
failed (the device unplugged and back): the same driver object opens the same path again
and starts the device as :func:`open_source` did.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from kit import msgs
from kit.drivers.errors import DriverError
from kit.robots import RobotDescription
from kit.robots import load as load_robot

__all__ = ["DEVICES", "Source", "open_source"]

DEVICES = ("rplidar", "bno055", "odrive", "os5000", "lms2xx", "dpralte")


@dataclass
class Source:
    """One started device: ``read()`` gives ``(topic, message)`` pairs; ``period`` [s] is
    how often to poll it (0 for a device that streams); ``close()`` stops it; ``reopen()``
    brings it back after its port failed (raising while it is not back)."""

    device: str
    read: Callable[[], list[tuple[str, msgs.Message]]]
    period: float
    close: Callable[[], None]
    description: str
    reopen: Callable[[], Any] | None = None
    health: Callable[[], str | None] | None = None
    """What went wrong that the messages do not show (``None`` when all is well)."""


def _wheels(base: Any) -> Callable[[], list[tuple[str, msgs.Message]]]:
    def read() -> list[tuple[str, msgs.Message]]:
        joints, odometry = base.read_wheels()
        transform = base.odometry.transform(odometry.header.stamp.to_sec())
        return [("/joint_states", joints), ("/odom", odometry),
                ("/tf", msgs.TFMessage((transform,)))]
    return read


def _closing(*steps: Callable[[], Any]) -> Callable[[], None]:
    def close() -> None:
        for step in steps:
            try:
                step()
            except DriverError:  # a device already gone: still close the rest
                pass
    return close


def _stalled(lidar: Any) -> str | None:
    stalls, clock = lidar.stalls, lidar.clock_of_samples
    if not stalls or clock is None:
        return None
    return (f"{stalls} time{'s' if stalls > 1 else ''} nothing came for over {clock.window:g} s "
            f"(a host that read nothing, or a head that sent nothing): the scans just after "
            f"may be stamped late until the stream caught up, and what the port's buffer "
            f"could not hold is lost")


def open_source(device: str, port: Any, robot: str | RobotDescription = "uiabot",
                baudrate: int | None = None, clock: Callable[[], float] = time.monotonic,
                sleep: Callable[[float], None] = time.sleep) -> Source:
    """Open ``device`` on ``port`` (a path or an open port), start it, and return it as a
    :class:`Source`. ``baudrate`` overrides the device's default rate; ``robot`` gives the
    wheel geometry of the motor controllers' odometry.

    Raises
    ------
    ValueError
        An unknown device name.
    DriverError
        The device does not start (its own error: no answer, wrong protocol, port failed).
    """
    from kit.drivers import bases, bno055, lms2xx, odrive, os5000, rplidar

    rate: dict[str, Any] = {} if baudrate is None else {"baudrate": baudrate}
    waits: dict[str, Any] = {"clock": clock, "sleep": sleep}
    if device == "rplidar":
        lidar = rplidar.RPLidar(port, **waits, **rate)
        lidar.start()
        return Source(device, lambda: [("/scan", lidar.read_scan())], 0.0,
                      _closing(lidar.stop, lidar.close), "RPLidar, standard scan", lidar.reopen,
                      lambda: _stalled(lidar))
    if device == "lms2xx":
        scanner = lms2xx.LMS2xx(port, **waits, **rate)
        scanner.connect(38400, 180, 1.0)
        scanner.start()
        return Source(device, lambda: [("/scan", scanner.read_scan())], 0.0,
                      _closing(scanner.stop, scanner.close), "LMS2xx at 38400 baud, 180°/1°",
                      scanner.reopen)
    if device == "bno055":
        imu = bno055.BNO055(port, **waits, **rate)
        imu.begin()
        return Source(device, lambda: [("/imu", imu.read_imu())], 0.01,
                      _closing(imu.link.close), "BNO055 in NDOF", imu.reopen)
    if device == "os5000":
        compass = os5000.Os5000(port, **waits, **rate)
        return Source(device, lambda: [("/imu", compass.read_imu())], 0.0,
                      _closing(compass.close), "OS5000 compass", compass.reopen)
    description = robot if isinstance(robot, RobotDescription) else load_robot(robot)
    if device == "odrive":
        uiabot = bases.UiabotBase(odrive.ODrive(port, **waits, **rate), description, **waits)
        uiabot.odrive.connect()  # the line cleared, the link answers
        return Source(device, _wheels(uiabot), 0.02, _closing(uiabot.odrive.close),
                      f"ODrive encoders of the {description.name}", uiabot.reopen)
    if device == "dpralte":
        igv = bases.IgvBase(port, description, clock=clock, sleep=sleep, **rate)
        for drive in igv.drives:
            drive.connect(clear=drive is igv.right)  # the line cleared, both drives answer
        return Source(device, _wheels(igv), 0.02, _closing(igv.link.close),
                      f"DPRALTE drives of the {description.name}", igv.reopen)
    raise ValueError(f"unknown device {device!r}; known: {', '.join(DEVICES)}")
