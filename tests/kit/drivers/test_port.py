"""The port layer: every failure of a port is the driver's own error, a user's port without
a time-out cannot hang a driver, stamps are wall-clock on real ports."""

from __future__ import annotations

import errno
import os
import pty
import termios
import time
import tty

import pytest
import serial

from hardware.emulators import Clock, LogicalPort, PtyServer
from hardware.emulators.bno055 import BNO055Emulator
from kit.drivers import DeviceTimeout, PortError, ProtocolError, bno055, odrive, os5000
from kit.drivers.bases import IgvBase, UiabotBase
from kit.drivers.port import Link, wall_clock_for


class _Unplugged:
    """A port whose adapter is gone: what pyserial raises on Linux then."""

    timeout = 0.01
    in_waiting = 0

    def reset_input_buffer(self):
        raise termios.error(errno.EIO, "Input/output error")

    def write(self, data):
        raise OSError(errno.EIO, "Input/output error")

    def read(self, size=1):
        raise serial.SerialException("device reports readiness to read but returned no data")

    def close(self):
        raise OSError(errno.EIO, "Input/output error")


@pytest.mark.parametrize("call", ["clear", "write", "read_some"])
def test_every_port_failure_is_a_port_error_naming_device_and_command(call):
    link = Link("ODrive", _Unplugged(), 115200)
    args = {"clear": ("r vbus_voltage",), "write": (b"x", "r vbus_voltage"),
            "read_some": ("r vbus_voltage",)}[call]
    with pytest.raises(PortError, match=r"^ODrive: r vbus_voltage: the port failed") as info:
        getattr(link, call)(*args)
    assert isinstance(info.value, ProtocolError)  # the existing handlers still catch it
    link.close()  # closing a failed port is quiet


def test_termios_error_from_an_unplugged_adapter_says_what_happened():
    drive = odrive.ODrive(_Unplugged())
    with pytest.raises(PortError, match="unplugged or lost power") as info:
        drive.vbus_voltage()
    assert info.value.errno == errno.EIO


def test_a_port_that_does_not_exist_is_a_port_error_with_a_hint():
    with pytest.raises(PortError, match=r"DPRALTE: cannot open '/dev/ttyKIT_NONE' at 115200 "
                                        r"baud.*no such port: is the device plugged in"):
        IgvBase("/dev/ttyKIT_NONE")  # the issue: IgvBase let SerialException out
    with pytest.raises(PortError, match="ODrive: cannot open"):
        UiabotBase("/dev/ttyKIT_NONE")


def test_a_bad_baud_rate_is_refused():
    with pytest.raises(ValueError, match="baudrate must be a positive integer"):
        Link("X", serial.serial_for_url("loop://"), 0)
    with pytest.raises(ValueError, match=r"the LMS2xx runs at \[9600, 19200, 38400, 500000\]"):
        from kit.drivers import lms2xx

        lms2xx.LMS2xx(serial.serial_for_url("loop://"), baudrate=115200)


def test_a_users_port_without_timeout_cannot_hang_the_driver():
    master, slave = pty.openpty()
    tty.setraw(slave)
    try:
        port = serial.Serial(os.ttyname(slave), 19200)  # pyserial's default: timeout=None
        assert port.timeout is None
        compass = os5000.Os5000(port, timeout=0.3)
        # every read and write of the port now returns within its slice: nothing can hang
        assert port.timeout == 0.01 and port.write_timeout == 1.0
        t0 = time.monotonic()
        with pytest.raises(DeviceTimeout, match=r"OS5000: no valid sentence within 0\.3 s"):
            compass.read()  # nobody on the other side
        assert time.monotonic() - t0 >= 0.3   # it waited its whole time-out, never less
    finally:
        os.close(master)
        os.close(slave)


def test_stamps_are_wall_clock_on_a_real_port_and_logical_on_an_emulator():
    assert wall_clock_for(time.monotonic) is time.time
    clock = Clock(start=3.0)
    assert wall_clock_for(clock) is clock
    with PtyServer(BNO055Emulator()) as server:
        imu = bno055.BNO055(server.path, timeout=5.0)  # time to spare on a busy machine
        imu.begin()
        before = time.time()
        stamp = imu.read_imu().header.stamp.to_sec()
        assert before <= stamp <= time.time()  # ROS header stamps: seconds since the epoch
    imu = bno055.BNO055(LogicalPort(BNO055Emulator(), clock), clock=clock, sleep=clock.sleep)
    imu.begin()
    m = imu.read_imu()
    assert m.header.stamp.to_sec() == pytest.approx(clock.now, abs=1e-9) and clock.now < 10
