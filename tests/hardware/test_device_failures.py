"""Devices that freeze, vanish or die mid-stream: every driver gives its own error — on ports
it opened and on ports the user opened (pyserial's default ``timeout=None``, made into read
slices, so the driver's own deadline ends every read) — and nothing hangs. (How long the
failing call takes is measured in ``benchmarks/bench_drivers.py``: no test here depends on
the machine's speed.)"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from typing import Any

import pytest
import serial

from hardware.emulators import PtyServer
from hardware.emulators.bno055 import BNO055Emulator
from hardware.emulators.dpralte import DpralteBusEmulator
from hardware.emulators.lms2xx import LMS2xxEmulator
from hardware.emulators.odrive import ODriveEmulator
from hardware.emulators.os5000 import Os5000Emulator
from hardware.emulators.rplidar import RPLidarEmulator
from kit.drivers import DeviceTimeout, PortError, bno055, dpralte, lms2xx, odrive, os5000, rplidar

BAUD = {"odrive": 115200, "bno055": 115200, "rplidar": 115200, "dpralte": 115200,
        "os5000": 19200, "lms2xx": 9600}


def start(name: str, port: Any) -> tuple[Callable[[], Any], float]:
    """A started driver's reading and its deadline [s] (a reply, or a whole turn/scan)."""
    if name == "odrive":
        drive = odrive.ODrive(port, timeout=0.3)
        return drive.vbus_voltage, 0.3
    if name == "bno055":
        imu = bno055.BNO055(port, timeout=0.05, retries=3)
        imu.begin()
        return imu.read_imu, 0.2
    if name == "rplidar":
        lidar = rplidar.RPLidar(port, timeout=0.5)
        lidar.start()
        return lidar.read_scan, 0.5
    if name == "dpralte":
        drive = dpralte.DpralteDrive(port, 0x3F, timeout=0.25)
        return drive.read_position, 0.25
    if name == "os5000":
        compass = os5000.Os5000(port, timeout=0.3)
        return compass.read, 0.3
    scanner = lms2xx.LMS2xx(port, timeout=0.5, tries=1)
    scanner.connect(38400, 180, 1.0)
    scanner.start()
    return scanner.read_scan, 0.5


def open_port(path: str, name: str, opened_by: str) -> Any:
    # the user's own port: pyserial's defaults, no read time-out at all
    return path if opened_by == "driver" else serial.Serial(path, BAUD[name])


def until_error(read: Callable[[], Any], tries: int = 100) -> BaseException:
    """Read until a reading fails; the error. Bytes already on their way may still give a
    reading or two first."""
    for _ in range(tries):
        try:
            read()
        except Exception as exc:
            return exc
    raise AssertionError("the reading never failed")


def reads(read: Callable[[], Any], name: str, tries: int = 10) -> None:
    """A reading succeeds within ``tries`` (a healthy device's): the first may still meet
    stale bytes, and on a loaded machine the emulator's thread or process can be kept from
    serving a whole reply, turn or scan within the driver's deadline."""
    for _ in range(tries):
        try:
            read()
            return
        except DeviceTimeout:
            continue
    raise AssertionError(f"{name} gave no reading in {tries} tries")


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
            read, deadline = start(name, open_port(path, name, opened_by))
            reads(read, name)  # it works
            readings[name] = (read, deadline)
        if fault == "freeze":
            server.freeze()  # hung firmware: the port stays, nothing comes
        else:
            server.stop()  # the adapter is gone
        for name, (read, _deadline) in readings.items():
            error = until_error(read)
            expected = DeviceTimeout if fault == "freeze" else PortError
            assert isinstance(error, expected), (name, repr(error))
            assert str(error).startswith({"odrive": "ODrive", "bno055": "BNO055",
                                          "rplidar": "RPLidar", "dpralte": "DPRALTE",
                                          "os5000": "OS5000", "lms2xx": "LMS2xx"}[name])
    finally:
        server.stop()


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
                read, deadline = start(name, open_port(path, name, opened_by))
                reads(read, name)
                readings[name] = (read, deadline)
        assert set(readings) == set(BAUD)
        for proc in procs:
            os.kill(proc.pid, signal.SIGSTOP)
        for name, (read, _deadline) in readings.items():
            error = until_error(read)
            assert isinstance(error, DeviceTimeout), (name, error)
        for proc in procs:
            os.kill(proc.pid, signal.SIGCONT)
        time.sleep(0.3)
        for name, (read, _) in readings.items():
            reads(read, name)  # it came back
        for proc in procs:
            proc.kill()
            proc.wait(5)
        for name, (read, _deadline) in readings.items():
            error = until_error(read)
            assert isinstance(error, PortError), (name, error)
            assert any(w in str(error) for w in ("input/output error", "disconnected", "closed"))
            # reported once: the port is not touched again, the same failure comes back
            again = until_error(read)
            assert isinstance(again, PortError) and "reopen()" in str(again), again
    finally:
        for proc in procs:
            if proc.poll() is None:
                os.kill(proc.pid, signal.SIGCONT)
                proc.kill()
                proc.wait(5)
