"""The port layer: every failure of a port is the driver's own error, a user's port without
a time-out cannot hang a driver, stamps are wall-clock on real ports."""

from __future__ import annotations

import errno
import itertools
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
from kit.drivers.port import Link, wall_clock, wall_clock_for

# A happy path's replies are awaited for up to REPLY s, not the devices' own 0.1-1 s: the
# emulator's thread can be kept off a loaded machine's CPU for longer than a device takes
# (tests of the time-outs pass their own).
REPLY = 10.0


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


class _ReadFailed(_Unplugged):
    """pyserial's ``read`` when the pseudo-terminal's other side is gone mid-read (seen with
    a busy machine): the ``OSError`` becomes a ``SerialException`` without an error number."""

    def read(self, size=1):
        try:
            raise OSError(errno.EIO, "Input/output error")  # what os.read raised
        except OSError as e:
            raise serial.SerialException(f"read failed: {e}")  # noqa: B904 - pyserial's way


def test_pyserials_read_failed_keeps_the_error_number_and_its_hint():
    link = Link("BNO055", _ReadFailed(), 115200)
    with pytest.raises(PortError, match=r"read data block: the port failed \(read failed: "
                                        r"\[Errno 5\] Input/output error\): input/output "
                                        r"error: the device was unplugged") as info:
        link.read_some("read data block")
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
        # reads become 10 ms slices, so the driver's own deadline is what ends a read
        assert port.timeout == 0.01 and port.write_timeout == 1.0
        with pytest.raises(DeviceTimeout, match=r"OS5000: no valid sentence within 0\.3 s"):
            compass.read()  # nobody on the other side
    finally:
        os.close(master)
        os.close(slave)


def test_stamps_are_wall_clock_on_a_real_port_and_logical_on_an_emulator():
    assert wall_clock_for(time.monotonic) is wall_clock
    # seconds since the epoch, carried by the monotonic clock: never going back
    readings = [wall_clock() for _ in range(1000)]
    assert all(b >= a for a, b in itertools.pairwise(readings))
    assert abs(readings[-1] - time.time()) < 1.0
    clock = Clock(start=3.0)
    assert wall_clock_for(clock) is clock
    with PtyServer(BNO055Emulator()) as server:
        imu = bno055.BNO055(server.path, timeout=REPLY)
        imu.begin()
        before = time.time()
        stamp = imu.read_imu().header.stamp.to_sec()
        assert before <= stamp <= time.time()  # ROS header stamps: seconds since the epoch
    imu = bno055.BNO055(LogicalPort(BNO055Emulator(), clock), clock=clock, sleep=clock.sleep)
    imu.begin()
    m = imu.read_imu()
    # the middle of the exchange that read it, on the logical clock
    assert m.header.stamp.to_sec() == pytest.approx(0.5 * sum(imu.last_exchange), abs=1e-9)
    assert imu.last_exchange[0] < m.header.stamp.to_sec() < clock.now < 10


def test_a_second_opener_is_told_the_port_is_busy_and_by_whom():
    """Ports are ours alone: a second driver (here, in this program) gets ``busy`` naming
    the holder; the first keeps working, its input untouched by the second's attempt."""
    from hardware.emulators.odrive import ODriveEmulator

    with PtyServer(ODriveEmulator(vbus_voltage=24.0)) as server:
        first = odrive.ODrive(server.path, timeout=REPLY)
        assert first.vbus_voltage() == pytest.approx(24.0)
        with pytest.raises(PortError, match=rf"ODrive: cannot open '{server.path}' at 115200 "
                                            rf"baud: the port is busy \(held by PID "
                                            rf"{os.getpid()} \(this program\)\)") as info:
            odrive.ODrive(server.path)
        assert info.value.errno == errno.EAGAIN
        with pytest.raises(PortError, match=r"RPLidar: .* busy \(held by PID"):
            from kit.drivers import rplidar

            rplidar.RPLidar(server.path)
        assert first.vbus_voltage() == pytest.approx(24.0)  # the holder goes on
        first.close()
        second = odrive.ODrive(server.path, timeout=REPLY)  # free again once closed
        assert second.vbus_voltage() == pytest.approx(24.0)
        second.close()


def test_a_port_held_by_another_program_names_that_process():
    import subprocess
    import sys

    from hardware.emulators.odrive import ODriveEmulator

    holder = "import sys, time\nfrom kit.drivers import odrive\n" \
             f"d = odrive.ODrive(sys.argv[1], timeout={REPLY})\n" \
             "print(d.vbus_voltage(), flush=True)\ntime.sleep(600)\n"
    with PtyServer(ODriveEmulator(vbus_voltage=24.0)) as server:
        proc = subprocess.Popen([sys.executable, "-c", holder, server.path],
                                stdout=subprocess.PIPE, text=True)
        try:
            assert float(proc.stdout.readline()) == pytest.approx(24.0)
            with pytest.raises(PortError, match=rf"busy \(held by PID {proc.pid} \(python"):
                odrive.ODrive(server.path)
        finally:
            proc.kill()
            proc.wait(30)
