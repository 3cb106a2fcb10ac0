"""Devices that freeze, vanish or die mid-stream: every driver gives its own error within its
deadline — on ports it opened and on ports the user opened (pyserial's default
``timeout=None``) — and nothing hangs. The deadline is checked on the logical clock (how long
a real port takes to give up depends on how busy the machine is); on real pseudo-terminals,
that the right error comes at all."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Callable
from typing import Any

import pytest
import serial

from hardware.emulators import Clock, LogicalPort, PtyServer
from hardware.emulators.bno055 import BNO055Emulator
from hardware.emulators.dpralte import DpralteBusEmulator
from hardware.emulators.lms2xx import LMS2xxEmulator
from hardware.emulators.odrive import ODriveEmulator
from hardware.emulators.os5000 import Os5000Emulator
from hardware.emulators.rplidar import RPLidarEmulator
from kit.drivers import DeviceTimeout, PortError, bno055, dpralte, lms2xx, odrive, os5000, rplidar

BAUD = {"odrive": 115200, "bno055": 115200, "rplidar": 115200, "dpralte": 115200,
        "os5000": 19200, "lms2xx": 9600}


# each driver's time-out and the deadline of its reading (a reply, or a whole turn/scan)
TIMEOUT = {"odrive": 0.3, "bno055": 0.05, "rplidar": 0.5, "dpralte": 0.25, "os5000": 0.3,
           "lms2xx": 0.5}
DEADLINE = {"odrive": 0.3, "bno055": 0.2, "rplidar": 0.5, "dpralte": 0.25, "os5000": 0.3,
            "lms2xx": 0.5}
BUSY = 20.0
"""[s] how long the drivers wait while the devices work, on real pseudo-terminals: a busy
machine may leave an emulator's thread unscheduled for longer than a device's deadline."""


def start(name: str, port: Any, timeout: float | None = None,
          **clock: Any) -> tuple[Any, Callable[[], Any]]:
    """A started driver and its reading, with the driver's own time-out unless ``timeout``
    is given; ``clock``: the driver's ``clock`` and ``sleep`` (a logical clock's), if any."""
    t = TIMEOUT[name] if timeout is None else timeout
    if name == "odrive":
        drive = odrive.ODrive(port, timeout=t, **clock)
        return drive, drive.vbus_voltage
    if name == "bno055":
        imu = bno055.BNO055(port, timeout=t, retries=3, **clock)
        imu.begin()
        return imu, imu.read_imu
    if name == "rplidar":
        lidar = rplidar.RPLidar(port, timeout=t, **clock)
        lidar.start()
        return lidar, lidar.read_scan
    if name == "dpralte":
        drive = dpralte.DpralteDrive(port, 0x3F, timeout=t, **clock)
        return drive, drive.read_position
    if name == "os5000":
        compass = os5000.Os5000(port, timeout=t, **clock)
        return compass, compass.read
    scanner = lms2xx.LMS2xx(port, timeout=t, tries=1, **clock)
    scanner.connect(38400, 180, 1.0)
    scanner.start()
    return scanner, scanner.read_scan


def working(name: str, port: Any) -> tuple[Any, Callable[[], Any]]:
    """A driver started on a real port with time to spare, its first reading taken, then
    given back its own time-out for what follows."""
    driver, read = start(name, port, timeout=BUSY)
    read()  # it works
    driver.timeout = TIMEOUT[name]
    return driver, read


def open_port(path: str, name: str, opened_by: str) -> Any:
    # the user's own port: pyserial's defaults, no read time-out at all
    return path if opened_by == "driver" else serial.Serial(path, BAUD[name])


def until_error(read: Callable[[], Any]) -> BaseException:
    """Read until a reading fails; the error. Bytes already on their way may still give a
    few readings first (counted, not timed: how many arrive depends on the machine)."""
    for _ in range(50):
        try:
            read()
        except Exception as exc:
            return exc
    raise AssertionError("the reading never failed")


def emulators() -> dict[str, Any]:
    return {"odrive": ODriveEmulator(), "bno055": BNO055Emulator(),
            "rplidar": RPLidarEmulator(), "dpralte": DpralteBusEmulator(),
            "os5000": Os5000Emulator(), "lms2xx": LMS2xxEmulator()}


@pytest.mark.parametrize("opened_by", ["driver", "user"])
@pytest.mark.parametrize("fault", ["freeze", "unplug"])
def test_a_frozen_or_unplugged_device_is_the_drivers_own_error_within_its_deadline(
        fault, opened_by):
    devices = emulators()
    server = PtyServer(list(devices.values())).start()
    try:
        readings = {}
        for name, path in zip(devices, server.paths, strict=True):
            readings[name] = working(name, open_port(path, name, opened_by))
        if fault == "freeze":
            server.freeze()  # hung firmware: the port stays, nothing comes
        else:
            server.stop()  # the adapter is gone
        for name, (_, read) in readings.items():
            error = until_error(read)
            expected = DeviceTimeout if fault == "freeze" else PortError
            assert isinstance(error, expected), (name, repr(error))
            assert str(error).startswith(DEVICE_NAMES[name])
    finally:
        server.stop()


DEVICE_NAMES = {"odrive": "ODrive", "bno055": "BNO055", "rplidar": "RPLidar",
                "dpralte": "DPRALTE", "os5000": "OS5000", "lms2xx": "LMS2xx"}


class Freezable:
    """A device that can hang (nothing read, nothing sent) while its port stays open."""

    def __init__(self, device: Any) -> None:
        self.device, self.frozen = device, False

    def read(self, now: float, baudrate: int | None) -> bytes:
        return b"" if self.frozen else self.device.read(now, baudrate)

    def feed(self, data: bytes, now: float, baudrate: int | None) -> None:
        if not self.frozen:
            self.device.feed(data, now, baudrate)

    def next_due(self) -> float | None:
        return None if self.frozen else self.device.next_due()

    def __getattr__(self, name: str) -> Any:
        return getattr(self.device, name)


@pytest.mark.parametrize("name", sorted(BAUD))
def test_a_frozen_device_is_a_timeout_within_the_drivers_deadline_on_its_clock(name):
    """On the logical clock, where waiting costs nothing and no machine is too busy: the
    failing call gives up once its deadline has passed (retries included), not much later."""
    clock = Clock()
    device = Freezable(emulators()[name])
    _, read = start(name, LogicalPort(device, clock), clock=clock, sleep=clock.sleep)
    read()                                       # it works
    device.frozen = True
    t0 = clock.now
    error = until_error(read)
    assert isinstance(error, DeviceTimeout) and str(error).startswith(DEVICE_NAMES[name])
    assert clock.now - t0 <= DEADLINE[name] + 0.05, (name, clock.now - t0)


def _serve(robot: str) -> tuple[subprocess.Popen, dict[str, str]]:
    proc = subprocess.Popen([sys.executable, "-m", "hardware.emulators", robot],
                            stdout=subprocess.PIPE, text=True)
    paths = dict(proc.stdout.readline().split() for _ in range(3))
    return proc, paths


@pytest.mark.slow
def test_emulator_processes_stopped_and_killed_mid_stream():
    """SIGSTOP (a frozen device) gives DeviceTimeout, SIGCONT brings the readings back,
    SIGKILL (the device gone) gives PortError: the Uiabot's devices on ports the drivers
    opened, the IGV's on ports the user opened."""
    procs = []
    try:
        readings = {}
        for robot, opened_by in (("uiabot", "driver"), ("igv", "user")):
            proc, paths = _serve(robot)
            procs.append(proc)
            for name, path in paths.items():
                readings[name] = working(name, open_port(path, name, opened_by))
        assert set(readings) == set(BAUD)
        for proc in procs:
            os.kill(proc.pid, signal.SIGSTOP)
        for name, (_, read) in readings.items():
            error = until_error(read)
            assert isinstance(error, DeviceTimeout), (name, error)
        for proc in procs:
            os.kill(proc.pid, signal.SIGCONT)
        for name, (driver, read) in readings.items():
            driver.timeout = BUSY   # the woken emulators may take their time on a busy machine
            for _ in range(3):  # the first reading may still meet the stale ones
                try:
                    read()
                    break
                except DeviceTimeout:
                    continue
            else:
                raise AssertionError(f"{name} did not come back")
        for proc in procs:
            proc.kill()
            proc.wait(5)
        for name, (_, read) in readings.items():
            error = until_error(read)
            assert isinstance(error, PortError), (name, error)
            assert "input/output error" in str(error) or "closed" in str(error), error
    finally:
        for proc in procs:
            if proc.poll() is None:
                os.kill(proc.pid, signal.SIGCONT)
                proc.kill()
                proc.wait(5)
