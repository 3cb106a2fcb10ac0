"""A first command that always gets through: an earlier program left a partial request in
each device's receiver (it was killed mid-write); the next program's connect succeeds the
first time — and, to show the leftover is a real obstacle, the same first request without
the driver's line clearing does not get through."""

from __future__ import annotations

import pytest
import serial

from hardware.emulators import PtyServer
from hardware.emulators.bno055 import BNO055Emulator
from hardware.emulators.dpralte import DpralteBusEmulator
from hardware.emulators.lms2xx import LMS2xxEmulator
from hardware.emulators.odrive import ODriveEmulator
from hardware.emulators.os5000 import Os5000Emulator
from hardware.emulators.rplidar import RPLidarEmulator
from kit.drivers import DeviceTimeout, bno055, dpralte, lms2xx, odrive, os5000, rplidar
from kit.drivers.bases import IgvBase, UiabotBase

# A happy path's replies are awaited for up to REPLY s, not the devices' own 0.1-1 s: the
# emulator's thread can be kept off a loaded machine's CPU for longer than a device takes
# (tests of the time-outs pass their own).
REPLY = 10.0


def leave(path: str, leftover: bytes, baudrate: int = 115200) -> None:
    """An earlier program: it opens the port, sends part of a request and is gone."""
    with serial.Serial(path, baudrate, timeout=0.01) as port:
        port.write(leftover)
        port.flush()


@pytest.mark.parametrize("leftover", [b"f 0", b"r vbus_voltage *9", b"w axis0.requested_st"])
def test_the_odrive_connects_after_a_leftover_partial_line(leftover):
    with PtyServer(ODriveEmulator(calibration_time=0.2, vbus_voltage=24.0)) as server:
        leave(server.path, leftover)
        assert odrive.ODrive(server.path, timeout=REPLY).connect() == pytest.approx(24.0)
        leave(server.path, leftover)
        with UiabotBase(odrive.ODrive(server.path, timeout=REPLY)) as base:
            base.bring_up()  # the case: no retry needed by the caller
            assert [s for s, _ in base.steps_done] == ["connect", "calibrate", "closed loop"]


def test_a_leftover_partial_odrive_line_swallows_a_request_sent_without_clearing():
    with PtyServer(ODriveEmulator()) as server:
        leave(server.path, b"f 0")
        with pytest.raises(DeviceTimeout, match="r vbus_voltage: no reply"):
            odrive.ODrive(server.path, timeout=0.3).vbus_voltage()


@pytest.mark.parametrize("leftover", [
    bytes.fromhex("A53F0245020296"),  # a header cut short
    bytes.fromhex("A53F0245FFFF"),  # ...announcing 255 words
    dpralte.encode_write(0x3E, 0x45, 0x00, dpralte.int32_words(437))[:11],  # data cut
])
def test_the_igv_drives_connect_after_a_leftover_partial_frame(leftover):
    if leftover[5:6] == b"\xff":  # complete that header with a valid CRC
        leftover = leftover + dpralte.crc16_xmodem(leftover).to_bytes(2, "big")
    with PtyServer(DpralteBusEmulator()) as server:
        leave(server.path, leftover)
        with IgvBase(server.path, timeout=REPLY) as base:
            base.start()
            assert all(d.enabled for d in server.device.drives.values())


def test_a_leftover_dpralte_header_swallows_a_request_sent_without_clearing():
    head = bytes.fromhex("A53F0245FFFF")
    with PtyServer(DpralteBusEmulator()) as server:
        leave(server.path, head + dpralte.crc16_xmodem(head).to_bytes(2, "big"))
        drive = dpralte.DpralteDrive(server.path, 0x3F, timeout=0.3)
        with pytest.raises(DeviceTimeout, match="no reply from 0x3F"):
            drive.read((0x02, 0x00), 1, "read bridge status")


@pytest.mark.parametrize("leftover", [b"\xaa\x00\x3d", b"\xaa\x01\x1a", b"\xaa"])
def test_the_bno055_begins_after_a_leftover_partial_frame(leftover):
    with PtyServer(BNO055Emulator()) as server:
        leave(server.path, leftover)
        # the leftover can swallow the first request, whose reply is then awaited in vain:
        # 1 s, not REPLY (the second try is the one that must get through)
        imu = bno055.BNO055(server.path, timeout=1.0)
        imu.begin()
        assert imu.read_imu().linear_acceleration.z == pytest.approx(9.81, abs=0.01)


@pytest.mark.parametrize("leftover", [b"\xa5", bytes.fromhex("A5820500"),
                                      bytes.fromhex("A5F0FF")])
def test_the_rplidar_starts_after_a_leftover_partial_request(leftover):
    with PtyServer(RPLidarEmulator()) as server:
        leave(server.path, leftover)
        lidar = rplidar.RPLidar(server.path, timeout=REPLY)
        lidar.start()
        assert len(lidar.read_revolution()) > 300
        lidar.stop()
        lidar.close()


def test_a_leftover_rplidar_request_swallows_a_request_sent_without_clearing():
    with PtyServer(RPLidarEmulator()) as server:
        leave(server.path, bytes.fromhex("A5F0FF"))  # SET_MOTOR_PWM announcing 255 bytes
        with pytest.raises(DeviceTimeout, match="get health: no reply"):
            rplidar.RPLidar(server.path, timeout=0.3).health()


def test_the_lms2xx_connects_after_a_leftover_partial_telegram():
    with PtyServer(LMS2xxEmulator()) as server:
        leave(server.path, bytes.fromhex("02000A0020"), 9600)
        scanner = lms2xx.LMS2xx(server.path, timeout=REPLY)
        scanner.connect(38400, 180, 1.0)
        scanner.start()
        assert len(scanner.read_scan().ranges) == 181
        scanner.stop()


def test_the_os5000_takes_its_first_command_after_a_leftover_partial_one():
    """``<ESC>`` begins every command, so a command left without its end is dropped by the
    next one instead of taking its digits."""
    with PtyServer(Os5000Emulator()) as server:
        leave(server.path, b"\x1bR2", 19200)
        compass = os5000.Os5000(server.path, timeout=REPLY)
        compass.set_rate(10)
        compass.read()
        assert server.device.rate == 10.0
