"""Emulators against the protocol spec's test vectors, driven by the real drivers: over
logical-clock ports, over pseudo-terminals, with faults injected, and backed by the sim."""

from __future__ import annotations

import math
import subprocess
import sys
import time

import numpy as np
import pytest
import serial

from hardware.emulators import Clock, Faults, LogicalPort, PtyServer
from hardware.emulators.backends import IdealWheels
from hardware.emulators.bno055 import BNO055Emulator
from hardware.emulators.dpralte import DpralteBusEmulator
from hardware.emulators.lms2xx import LMS2xxEmulator
from hardware.emulators.odrive import ODriveEmulator
from hardware.emulators.os5000 import Os5000Emulator
from hardware.emulators.rplidar import RPLidarEmulator
from kit import msgs
from kit.drivers import (
    ChecksumError,
    DeviceError,
    DeviceTimeout,
    ProtocolError,
    bno055,
    dpralte,
    lms2xx,
    odrive,
    os5000,
    rplidar,
)

# A happy path's replies over a pseudo-terminal are awaited for up to REPLY s, not the
# devices' own 0.1-1 s: the emulator's thread can be kept off a loaded machine's CPU for
# longer than a device takes (tests of the time-outs pass their own).
REPLY = 10.0


def exchange(device, request: bytes, after: float = 1.0, at: float = 0.0) -> bytes:
    """Feed one request at ``at`` and collect everything sent by ``at + after``."""
    device.feed(request, at)
    return device.read(at + after)


def h(text: str) -> bytes:
    return bytes.fromhex(text.replace(" ", ""))


# ------------------------------------------------------------------ DPRALTE (§1.8)

def test_dpralte_emulator_answers_the_specs_frames():
    wheels = IdealWheels()
    bus = DpralteBusEmulator(wheels)
    write_velocity = h("A5 3F 02 45 02 02 96 2B B5 01 00 00 7A A4")          # A1
    assert exchange(bus, write_velocity) == h("A5 FF 01 06 00 00 3C 92")      # R4: no access
    assert exchange(bus, h("A5 3F 02 07 00 01 B3 E7 0F 00 10 3E")) == \
        h("A5 FF 01 01 00 00 B9 02")                                          # A5 → R1
    assert exchange(bus, h("A5 3F 02 01 00 01 01 47 00 00 00 00")) == \
        h("A5 FF 01 01 00 00 B9 02")                                          # A7 enable
    assert exchange(bus, dpralte.encode_read(0x3F, 0x02, 0x00, 2)) == \
        h("A5 FF 02 01 00 02 02 9C 01 00 00 00 76 B4")                       # R7
    wheels.angles[0] = 10000.5 / 400 * 2 * math.pi
    assert exchange(bus, h("A5 3F 01 12 00 02 B0 CB")) == \
        h("A5 FF 02 01 00 02 02 9C 10 27 00 00 18 F1")                       # A9 → R2
    wheels.speeds[0] = -437 / dpralte.UNITS_PER_COUNT_PER_SECOND / 400 * 2 * math.pi
    assert exchange(bus, h("A5 3F 01 11 02 02 8F F9")) == \
        h("A5 FF 02 01 00 02 02 9C 4B FE FF FF 95 DF")                       # A11 → R3
    assert exchange(bus, dpralte.encode_read(0x3F, 0x99, 0x00, 1)) == \
        h("A5 FF 01 04 00 00 52 F2")                                          # R5 unknown index
    bad = bytearray(h("A5 3F 01 12 00 02 B0 CB"))
    bad[7] ^= 0x01
    assert exchange(bus, bytes(bad)) == h("A5 FF 01 08 00 00 27 93")          # R6 CRC error
    # A12: the sequence number is echoed
    assert exchange(bus, h("A5 3F 15 12 00 02 61 9D"))[2] >> 2 & 0x0F == 5
    # the other drive (and broadcast) is not 0x3F's business
    assert exchange(bus, dpralte.encode_read(0x00, 0x12, 0x00, 2)) == b""
    # the velocity command drives the wheel: 437 units = 10 RPM
    assert exchange(bus, write_velocity) == h("A5 FF 01 01 00 00 B9 02")
    assert wheels.speeds[0] == pytest.approx(10 * 2 * math.pi / 60, rel=1e-3)


def test_the_dpralte_driver_runs_both_drives_on_one_emulated_bus():
    from kit.drivers.bases import IgvBase

    clock = Clock()
    wheels = IdealWheels()
    port = LogicalPort(DpralteBusEmulator(wheels), clock)
    base = IgvBase(port, clock=clock)
    with pytest.raises(DeviceError, match="no write access") as info:
        base.right.enable()
    assert info.value.code == 6
    base.start()
    base.drive((1.0, 0.0))
    assert [round(wheels.speeds[k] * 60 / (2 * math.pi), 1) for k in (0, 1)] == [59.7, 59.7]
    t0 = clock.now
    while clock.now < t0 + 10.0:  # a 20 Hz control loop: each command feeds the watchdogs
        clock.sleep(0.05)
        base.drive((1.0, 0.0))
    odom = base.update()
    # v = 1 m/s through the paper's equations: 1 m per second driven, give or take the
    # rounding of 59.70 RPM to 2608 drive units and of the 400-count encoder
    driven = odom.header.stamp.to_sec() - t0
    assert driven > 10.0 and odom.pose.pose.position.x == pytest.approx(driven, rel=2e-3)
    base.stop()
    assert wheels.speeds == [0.0, 0.0]


def test_a_silent_drive_times_out_in_logical_time():
    clock = Clock()
    port = LogicalPort(DpralteBusEmulator(faults=Faults(silence=1.0, silence_s=1e9)), clock)
    drive = dpralte.DpralteDrive(port, 0x3E, timeout=0.2, clock=clock)
    with pytest.raises(DeviceTimeout, match=r"DPRALTE: read position: no reply from 0x3E"):
        drive.read_position()
    assert clock.now == pytest.approx(0.2, abs=0.02)  # the deadline, on the logical clock


# ------------------------------------------------------------------ OS5000 (§2.6)

def test_os5000_emulator_streams_checked_sentences_the_driver_turns_into_yaw():
    device = Os5000Emulator(temperature=25.0)
    clock = Clock()
    port = LogicalPort(device, clock, timeout=0.5)
    assert port.read(200).split(b"\r\n")[0] == b"$C90.0P0.0R0.0T25.0*1B"     # spec vector
    compass = os5000.Os5000(port, clock=clock)
    compass.set_rate(40)
    reading = compass.read()  # the emulator's "CMD:R40" text line is skipped
    assert reading.heading_deg == 90.0 and reading.yaw == pytest.approx(0.0)
    t0 = clock.now
    for _ in range(40):
        compass.read()
    assert clock.now - t0 == pytest.approx(1.0, abs=0.05)  # 40 Hz as commanded
    compass.set_rate(0)
    with pytest.raises(DeviceTimeout, match=r"OS5000: no valid sentence within 0\.5 s"):
        compass.read()
        compass.read()


# ------------------------------------------------------------------ SICK (§3.8)

SICK_EXCHANGES = [
    ("02 00 02 00 20 24 34 08", "06 02 80 03 00 A0 00 10 16 0A"),
    ("02 00 02 00 20 25 35 08", "06 02 80 03 00 A0 00 10 16 0A"),
    ("02 00 05 00 3B B4 00 32 00 3B 1F", "06 02 80 07 00 BB 01 B4 00 32 00 10 03 9D"),
    ("02 00 0A 00 20 00 53 49 43 4B 5F 4C 4D 53 BE C5", "06 02 80 03 00 A0 00 10 16 0A"),
    ("02 00 01 00 3A 1E 12", None),
]


@pytest.mark.parametrize(("request_", "reply"), SICK_EXCHANGES)
def test_sick_emulator_answers_the_specs_telegrams(request_, reply):
    got = exchange(LMS2xxEmulator(), h(request_), after=0.05)
    if reply is not None:
        assert got == h(reply)
    else:
        t = lms2xx.TelegramParser().feed(got[1:])[0]
        assert got[0] == 0x06 and t.payload[1:-1].startswith(b"LMS291;S05")


def test_sick_emulator_rejects_and_naks():
    assert exchange(LMS2xxEmulator(), lms2xx.encode_telegram(b"\x55")) == \
        h("06 02 80 02 00 92 10 7F 33")
    bad = bytearray(h("02 00 01 00 31 15 12"))
    bad[-1] ^= 0xFF
    assert exchange(LMS2xxEmulator(), bytes(bad)) == b"\x15"


class _Flat:
    """A backend whose lidar sees every beam at one range."""

    def __init__(self, r: float) -> None:
        self.r = r
        self.callbacks = []

    def subscribe(self, kind, callback):
        if kind == "scan":
            self.callbacks.append(callback)

    def advance(self, now):
        scan = msgs.LaserScan(angle_min=-math.pi, angle_increment=math.radians(0.5),
                              ranges=np.full(721, self.r))
        for cb in self.callbacks:
            cb(scan)


@pytest.mark.parametrize(("unit_mm", "r", "expected"), [
    (False, 10.0, "02 80 6E 01 B0 B5 00" + " E8 03" * 181 + " 10 A0 F1"),
    (True, 1.234, "02 80 6E 01 B0 B5 40" + " D2 04" * 181 + " 10 2F 05"),
])
def test_sick_scan_telegram_is_the_specs_and_decodes(unit_mm, r, expected):
    device = LMS2xxEmulator(_Flat(r), unit_mm=unit_mm)
    got = exchange(device, h("02 00 02 00 30 01 31 18"))
    assert got == b"\x06" + h(expected)
    t = lms2xx.TelegramParser().feed(got)[0]
    scan = lms2xx.decode_scan(t.payload)
    assert scan.unit_mm == unit_mm and np.allclose(scan.ranges, r)


def test_sick_driver_finds_the_baud_switches_and_streams():
    device = LMS2xxEmulator()
    device.baudrate = 38400  # left at 38400 by the last session
    clock = Clock()
    port = LogicalPort(device, clock, baudrate=9600)
    scanner = lms2xx.LMS2xx(port, clock=clock, sleep=clock.sleep)
    assert scanner.find_baudrate() == 38400
    scanner.set_baudrate(500000)
    assert (port.baudrate, device.baudrate) == (500000, 500000)
    scanner.set_variant(180, 0.5)
    with pytest.raises(DeviceError, match="refused"):
        scanner.set_variant(180, 0.25)  # not an LMS291 variant
    scanner.start()
    t0 = clock.now
    scans = [scanner.read_scan() for _ in range(30)]
    rate = 30 / (clock.now - t0)
    assert rate == pytest.approx(75 / 2, rel=0.05)  # 0.5°: two interlaced mirror turns
    s = scans[-1]
    assert len(s.ranges) == 361 and s.angle_min == pytest.approx(-math.pi / 2)
    assert s.ranges[180] == pytest.approx(4.0) and s.ranges[90] == pytest.approx(4 * 2 ** 0.5,
                                                                                 abs=0.01)
    scanner.stop()
    assert device.mode == 0x25


# ------------------------------------------------------------------ ODrive (§4.8)

ODRIVE_VECTORS = [
    ("r vbus_voltage", "24.087744"),
    ("r vbus_voltage *93", "24.087744*32"),
    ("v 0 1.5", None),
    ("v 0 1.5*108", None),
    ("v 0 1.5*107", None),
    ("f 0", "1.250000 0.500000"),
    ("f 0*118", "1.250000 0.500000*35"),
    ("w axis0.requested_state 8", None),
    ("r axis0.current_state", "8"),
    ("f 2", "invalid motor 2"),
    ("r axis0.nonexistent", "invalid property"),
    ("x", "unknown command"),
]


def test_odrive_emulator_answers_the_specs_lines():
    wheels = IdealWheels()
    device = ODriveEmulator(wheels, gear_ratio=1.0, axis_signs=(1, 1), vbus_voltage=24.087744,
                            calibration_time=0.0)
    device.feed(b"w axis0.requested_state 3\n", 0.0)
    device.read(1.0)
    wheels.angles[0], wheels.speeds[0] = 1.25 * 2 * math.pi, 0.5 * 2 * math.pi
    t = 1.0
    for request, reply in ODRIVE_VECTORS:
        if request.startswith("v"):
            wheels.speeds[0] = 0.5 * 2 * math.pi  # keep the 'f' vectors' state
        wheels.time = t  # hold the wheel where the vector has it
        got = exchange(device, request.encode() + b"\n", at=t, after=0.1)
        t += 0.2
        assert got == (b"" if reply is None else reply.encode() + b"\r\n"), request
        wheels.speeds[0], wheels.angles[0] = 0.5 * 2 * math.pi, 1.25 * 2 * math.pi


def test_odrive_emulator_truncates_reads_and_drops_long_lines():
    device = ODriveEmulator(vbus_voltage=-1234.56789)
    assert exchange(device, b"r vbus_voltage\n") == b"-1234.567\r\n"
    assert exchange(device, b"x" * 300 + b"\nr axis1.error\n") == b"0\r\n"


def test_odrive_driver_reads_writes_and_checks_checksums():
    clock = Clock()
    od = odrive.ODrive(LogicalPort(ODriveEmulator(), clock), clock=clock, sleep=clock.sleep)
    assert od.vbus_voltage() == pytest.approx(12.1)
    assert od.info()["Firmware version"] == "0.5.6"
    with pytest.raises(DeviceError, match="ODrive: invalid property"):
        od.read("axis0.nonexistent")
    with pytest.raises(ValueError, match=r"not an axis state in firmware 0\.5\.6"):
        od.request_state(0, 5)
    assert odrive.parse_reply("24.087744*32", checksum=True) == "24.087744"
    with pytest.raises(ChecksumError):
        odrive.parse_reply("24.087744*33", checksum=True)


def test_axis_states_follow_the_firmware_version():
    """Erratum 9: 5 is SENSORLESS_CONTROL only up to 0.5.1; 11–13 exist from 0.5.2."""
    assert odrive.axis_state_name(5, "0.5.1") == "SENSORLESS_CONTROL"
    assert odrive.axis_state_name(5, "0.4.12") == "SENSORLESS_CONTROL"
    with pytest.raises(ValueError):
        odrive.axis_state_name(5, "0.5.6")
    assert odrive.axis_state_name(13, "0.5.2") == "ENCODER_HALL_PHASE_CALIBRATION"
    with pytest.raises(ValueError):
        odrive.axis_state_name(11, "0.5.1")
    clock = Clock()
    old = ODriveEmulator(firmware="0.5.1", calibration_time=0.0)
    od = odrive.ODrive(LogicalPort(old, clock), clock=clock, sleep=clock.sleep)
    od.info()
    assert od.firmware == "0.5.1"
    od.request_state(0, 5)
    assert od.axis_state_name(0) == "SENSORLESS_CONTROL"


def test_uiabot_bring_up_on_the_logical_clock():
    from kit.drivers.bases import UiabotBase

    clock = Clock()
    device = ODriveEmulator(calibration_time=12.0)
    base = UiabotBase(LogicalPort(device, clock), clock=clock, sleep=clock.sleep)
    base.bring_up()
    assert [s for s, _ in base.steps_done] == ["connect", "calibrate", "closed loop"]
    assert 12.0 <= clock.now < 12.5  # the calibration's 12 s, on the logical clock
    assert [a.current_state for a in device.axes] == [8, 8]
    # the firmware's watchdog on both axes, with the base's time-out, not yet run out
    assert [(a.watchdog_enabled, a.watchdog_timeout, a.error) for a in device.axes] == \
        [(True, 0.5, 0), (True, 0.5, 0)]
    base.drive((0.5, 0.0))
    right, left = device.axes[0].input_vel, device.axes[1].input_vel
    # 0.5 m/s → 0.5/r rad/s at the wheel → × 20 / 2π turns/s at the motor; left mirrored
    expected = 0.5 / base.robot.wheel_radius * 20 / (2 * math.pi)
    assert right == pytest.approx(expected, rel=1e-6) and left == pytest.approx(-expected,
                                                                                rel=1e-6)
    # the odometry started from the encoders at the end of the bring-up: the first
    # update() after drive() already gives the motion since (0.5 m/s for 0.2 s)
    driving = clock.now
    clock.sleep(0.2)
    odom = base.update()
    moved = 0.5 * (odom.header.stamp.to_sec() - driving)
    assert odom.pose.pose.position.x == pytest.approx(moved, abs=2e-3) and moved > 0.09


@pytest.mark.parametrize(("device", "step", "message"), [
    (ODriveEmulator(faults=Faults(silence=1.0, silence_s=1e9)), "connect", "no reply"),
    (ODriveEmulator(calibration_time=60.0), "calibrate", "still FULL_CALIBRATION_SEQUENCE"),
    (ODriveEmulator(vbus_voltage=0.4), "connect", "bus voltage 0.4 V"),
])
def test_bring_up_names_the_step_that_fails(device, step, message):
    from kit.drivers.bases import BringUpError, UiabotBase

    clock = Clock()
    base = UiabotBase(LogicalPort(device, clock), clock=clock, sleep=clock.sleep)
    with pytest.raises(BringUpError, match=f"at '{step}'.*{message}") as info:
        base.bring_up()
    assert info.value.step == step


def test_closed_loop_is_refused_before_calibration():
    clock = Clock()
    device = ODriveEmulator()
    od = odrive.ODrive(LogicalPort(device, clock), clock=clock, sleep=clock.sleep)
    od.request_state(0, 8)
    with pytest.raises(DeviceError, match=r"axis0: error 0x1 while waiting for CLOSED_LOOP"):
        od.wait_for_state(0, 8, 1.0)
    od.clear_errors()
    assert od.axis_error(0) == 0


def test_odrive_watchdog_stops_an_axis_nobody_feeds():
    """As firmware 0.5.x's ``watchdog_check``: a feed reloads the counter, which runs down
    while the watchdog is enabled; at zero the axis gets 0x800 and falls to IDLE, at that
    instant. The driver's order — time-out, ``u``, enable — is the one that works."""
    clock = Clock()
    wheels = IdealWheels()
    device = ODriveEmulator(wheels, calibration_time=0.0)
    od = odrive.ODrive(LogicalPort(device, clock), clock=clock, sleep=clock.sleep)
    od.request_state(0, 3)
    od.wait_for_state(0, 1, 1.0)
    od.set_watchdog(0, 0.5)
    od.request_state(0, 8)
    od.set_velocity(0, 1.0)
    fed = clock.now
    clock.sleep(0.3)
    assert od.axis_state(0) == 8 and od.axis_error(0) == 0
    clock.sleep(1.0)
    assert od.axis_state(0) == 1 and od.axis_error(0) == odrive.WATCHDOG_TIMER_EXPIRED
    axis = device.axes[0]
    assert axis.watchdog_expired_at == pytest.approx(fed + 0.5, abs=1e-3)
    # the wheel turned until then and not after: 1 turn/s of the motor, 20:1 to the wheel
    assert wheels.angles[0] == pytest.approx(2 * math.pi / 20 * (axis.watchdog_expired_at -
                                                                   fed), abs=1e-3)
    od.clear_errors()  # a spent counter sets the error again at once...
    assert od.axis_error(0) == odrive.WATCHDOG_TIMER_EXPIRED
    od.feed(0)  # ...until it is fed
    od.clear_errors()
    assert od.axis_error(0) == 0


def test_an_odrive_watchdog_enabled_without_a_feed_stops_at_once():
    """The firmware's counter holds 0 after power-up: enabling the watchdog before a feed
    expires it on the next tick (what the driver's feed before enabling avoids)."""
    clock = Clock()
    device = ODriveEmulator(calibration_time=0.0)
    od = odrive.ODrive(LogicalPort(device, clock), clock=clock, sleep=clock.sleep)
    od.write("axis0.config.watchdog_timeout", 0.5)
    od.write("axis0.config.enable_watchdog", True)
    assert od.axis_error(0) == odrive.WATCHDOG_TIMER_EXPIRED


# ------------------------------------------------------------------ BNO055 (§5.6)

@pytest.mark.parametrize(("reply", "method", "expected"), [
    ("BB 06 A0 05 60 FF 58 00", "euler", (90.0, -10.0, 5.5)),
    ("BB 08 00 40 00 00 00 00 00 00", "quaternion", (1.0, 0.0, 0.0, 0.0)),
    ("BB 08 21 3B 00 00 00 00 7E 18", "quaternion", (0.9239, 0.0, 0.0, 0.3827)),
    ("BB 06 96 00 E7 FF D5 03", "gravity", (1.5, -0.25, 9.81)),
    ("BB 06 96 00 E7 FF 00 00", "linear_acceleration", (1.5, -0.25, 0.0)),
    ("BB 06 E0 01 00 00 60 FA", "gyroscope", (math.radians(30), 0.0, math.radians(-90))),
])
def test_bno055_driver_decodes_the_specs_replies(reply, method, expected):
    port = serial.serial_for_url("loop://", timeout=0.01)

    class Once:  # answers the driver's request with the vector's bytes
        def __getattr__(self, name):
            return getattr(port, name)

        def write(self, data):
            port.write(h(reply))
            return len(data)

    imu = bno055.BNO055(Once())
    assert getattr(imu, method)() == pytest.approx(expected, abs=1e-4)


def test_bno055_emulator_answers_the_specs_frames_and_refuses_as_the_chip_does():
    device = BNO055Emulator(IdealWheels(), calibration_time=1.0)
    assert exchange(device, h("AA 01 00 01")) == h("BB 01 A0")
    assert exchange(device, h("AA 01 1A 06")) == h("EE 02")      # CONFIG mode: sensors off
    assert exchange(device, h("AA 00 00 01 12")) == h("EE 05")   # CHIP_ID is read-only
    assert exchange(device, h("AA 00 3B 01 00")) == h("EE 01")   # UNIT_SEL, in CONFIG
    assert exchange(device, h("AA 00 3D 01 0C"), at=1.0) == h("EE 01")  # NDOF
    assert exchange(device, h("AA 01 1A 06"), at=1.001, after=0.005) == h("EE 07")
    assert exchange(device, h("AA 00 3B 01 06"), at=1.2) == h("EE 05")  # not outside CONFIG
    # heading 90° (yaw 0 in REP-103): the Euler vector without its roll and pitch
    assert exchange(device, h("AA 01 1A 06"), at=1.3) == h("BB 06 A0 05 00 00 00 00")
    assert exchange(device, h("AA 01 35 01"), at=3.0) == h("BB 01 FF")  # calibrated


def test_bno055_begin_retries_through_overruns_and_reads_an_imu():
    clock = Clock()
    device = BNO055Emulator(faults=Faults(seed=4, error=0.3))
    imu = bno055.BNO055(LogicalPort(device, clock), clock=clock, sleep=clock.sleep, retries=8)
    imu.begin()
    for _ in range(20):
        assert imu.yaw() == pytest.approx(0.0)
    assert imu.retried > 0  # the injected EE 07 answers were resent
    m = imu.read_imu()
    assert m.linear_acceleration.z == pytest.approx(9.81, abs=0.01)


def test_compass_headings_become_rep103_yaw():
    for heading, yaw in ((0.0, math.pi / 2), (90.0, 0.0), (180.0, -math.pi / 2),
                         (270.0, -math.pi), (359.0, math.pi / 2 + math.radians(1))):
        assert bno055.heading_to_yaw(heading) == pytest.approx(yaw)
        assert os5000.heading_to_yaw(heading) == pytest.approx(yaw)


# ------------------------------------------------------------------ RPLidar (§6.8)

def test_rplidar_emulator_answers_the_specs_requests():
    device = RPLidarEmulator()
    assert exchange(device, h("A5 52")) == h("A5 5A 03 00 00 00 06 00 00 00")
    info = exchange(device, h("A5 50"))
    assert info[:11] == h("A5 5A 14 00 00 00 04 18 1D 01 07") and len(info) == 27
    assert exchange(device, h("A5 F0 02 94 02 C1")) == b""  # the A1 ignores PWM
    got = exchange(device, h("A5 20"), after=0.05)
    assert got[:7] == h("A5 5A 05 00 00 40 81")
    nodes = rplidar.NodeParser().feed(got[7:])
    # 2000 samples/s: 100 measured in 50 ms, each sent once measured (5 bytes: 0.43 ms)
    assert 85 <= len(nodes) <= 100 and nodes[0].start
    device.feed(h("A5 25"), 0.06)
    device.read(0.06)
    assert device.read(1.0) == b""  # STOP ends the stream


def test_rplidar_driver_reads_turns_and_a_sick_device_is_reset():
    clock = Clock()
    device = RPLidarEmulator(health=2)
    lidar = rplidar.RPLidar(LogicalPort(device, clock), clock=clock, sleep=clock.sleep)
    lidar.start()  # health 2 → RESET, wait, then scan
    assert device.health == 0
    t0 = clock.now
    scans = [lidar.read_scan() for _ in range(11)]
    assert (clock.now - t0) / 11 == pytest.approx(1 / 5.5, rel=0.05)
    assert np.allclose(scans[-1].ranges[np.isfinite(scans[-1].ranges)], 4.0, atol=1.7)
    lidar.stop()


# ------------------------------------------------------------------ faults

def test_the_same_seed_injects_the_same_faults():
    def run(seed):
        device = RPLidarEmulator(faults=Faults(seed=seed, flip=0.01, drop=0.01, duplicate=0.01))
        device.feed(h("A5 20"), 0.0)
        return device.read(1.0)

    assert run(1) == run(1) != run(2)


def test_drivers_ride_through_corrupted_streams():
    clock = Clock()
    device = RPLidarEmulator()
    lidar = rplidar.RPLidar(LogicalPort(device, clock), clock=clock, sleep=clock.sleep)
    lidar.start()  # a clean start, then line noise: ~1 byte in 170 flipped, dropped or doubled
    device.faults = Faults(seed=3, flip=0.002, drop=0.002, duplicate=0.002)
    for _ in range(15):
        scan = lidar.read_scan()
        # the room returns no echo from about a third of its samples (glass, a door, a
        # dark wall): what is left comes through the noise
        assert np.isfinite(scan.ranges).sum() > 200
    assert lidar.parser.skipped > 0

    clock = Clock()
    device = ODriveEmulator(faults=Faults(seed=5, flip=0.01))
    od = odrive.ODrive(LogicalPort(device, clock), clock=clock, sleep=clock.sleep, timeout=0.05)
    good = 0
    for _ in range(200):
        try:
            assert od.vbus_voltage() == pytest.approx(12.1)  # never a corrupted value
            good += 1
        except DeviceTimeout:
            pass  # the request or its reply was corrupted: the checksum dropped it
        except DeviceError:
            pass  # a corrupted request the firmware did not understand
    assert 100 < good < 200


@pytest.mark.parametrize("name", ["odrive", "bno055", "lms2xx", "rplidar", "os5000"])
def test_a_silent_device_raises_device_timeout_naming_device_and_command(name):
    clock = Clock()
    silent = Faults(silence=1.0, silence_s=1e9)
    opts = {"clock": clock, "sleep": clock.sleep}
    if name == "odrive":
        drv = odrive.ODrive(LogicalPort(ODriveEmulator(faults=silent), clock), **opts)
        call, pattern = drv.vbus_voltage, r"ODrive: r vbus_voltage: no reply within 0.5 s"
    elif name == "bno055":
        drv = bno055.BNO055(LogicalPort(BNO055Emulator(faults=silent), clock), **opts)
        call, pattern = drv.begin, r"BNO055: read chip id: no reply after 6 tries"
    elif name == "lms2xx":
        drv = lms2xx.LMS2xx(LogicalPort(LMS2xxEmulator(faults=silent), clock), **opts)
        call, pattern = drv.status, r"LMS2xx: status: no reply within 1 s"
    elif name == "rplidar":
        drv = rplidar.RPLidar(LogicalPort(RPLidarEmulator(faults=silent), clock), **opts)
        call, pattern = drv.health, r"RPLidar: get health: no reply within 1 s"
    else:
        drv = os5000.Os5000(LogicalPort(Os5000Emulator(faults=silent), clock), clock=clock)
        call, pattern = drv.read, r"OS5000: no valid sentence within 0.5 s"
    with pytest.raises(DeviceTimeout, match=pattern):
        call()
    assert clock.now < 5.0


@pytest.mark.parametrize("name", ["odrive", "bno055", "lms2xx", "rplidar"])
def test_a_port_closed_mid_stream_is_a_clear_error(name):
    clock = Clock()
    opts = {"clock": clock, "sleep": clock.sleep}
    make = {"odrive": (ODriveEmulator, odrive.ODrive, "vbus_voltage"),
            "bno055": (BNO055Emulator, bno055.BNO055, "begin"),
            "lms2xx": (LMS2xxEmulator, lms2xx.LMS2xx, "status"),
            "rplidar": (RPLidarEmulator, rplidar.RPLidar, "health")}[name]
    port = LogicalPort(make[0](), clock)
    drv = make[1](port, **opts)
    port.close()
    with pytest.raises(ProtocolError, match="the port failed"):
        getattr(drv, make[2])()


def test_a_pseudo_terminal_whose_emulator_stops_is_an_error_not_a_hang():
    server = PtyServer(RPLidarEmulator()).start()
    lidar = rplidar.RPLidar(server.path, timeout=REPLY)
    lidar.start()
    lidar.read_scan()
    lidar.timeout = 0.5
    server.stop()
    with pytest.raises((ProtocolError, DeviceTimeout)):
        for _ in range(10):
            lidar.read_scan()


def test_what_a_host_that_stops_reading_cannot_take_is_counted_as_lost():
    """The lidar streams on while its host reads nothing: once the pseudo-terminal's buffer
    is full, the rest is lost, as on a UART, and each device's stats count it (the server's
    ``overrun`` sums them). Waited for by count, not by time (the wait only guards a hang)."""
    device = RPLidarEmulator()
    with PtyServer([ODriveEmulator(), device]) as server:
        lidar = rplidar.RPLidar(server.paths[1], timeout=REPLY)
        lidar.start()
        for _ in range(3000):  # 30 s at most; the buffer fills within seconds at 115200
            if device.lost:
                break
            time.sleep(0.01)
        lidar.close()
    stats = device.stats()  # the server stopped: nothing sent since
    assert stats["lost"] == device.lost > 0 and stats["sent"] > stats["lost"]
    assert server.devices[0].lost == 0 and server.overrun == device.lost


# ------------------------------------------------------------------ real pseudo-terminals

def test_every_emulator_serves_its_driver_on_a_pseudo_terminal():
    devices = [ODriveEmulator(), BNO055Emulator(), RPLidarEmulator(), DpralteBusEmulator()]
    with PtyServer(devices) as server:
        od = odrive.ODrive(server.paths[0], timeout=REPLY)
        assert od.vbus_voltage() == pytest.approx(12.1)
        imu = bno055.BNO055(server.paths[1], timeout=REPLY)
        imu.begin()
        assert imu.yaw() == pytest.approx(0.0)
        lidar = rplidar.RPLidar(server.paths[2], timeout=REPLY)
        assert lidar.health() == (0, 0)
        drive = dpralte.DpralteDrive(server.paths[3], 0x3F, timeout=REPLY)
        drive.get_write_access()
        assert drive.read_position() == 0


def test_the_command_line_prints_the_port_and_serves_until_stopped():
    proc = subprocess.Popen([sys.executable, "-m", "hardware.emulators", "odrive"],
                            stdout=subprocess.PIPE, text=True)
    try:
        path = proc.stdout.readline().strip()
        assert path.startswith("/dev/")
        assert odrive.ODrive(path, timeout=REPLY).vbus_voltage() == pytest.approx(12.1)
    finally:
        proc.terminate()
        assert proc.wait(10) == 0


def test_the_sick_emulator_switches_baud_on_a_real_pseudo_terminal():
    with PtyServer(LMS2xxEmulator()) as server:
        scanner = lms2xx.LMS2xx(server.path, timeout=REPLY)
        scanner.connect(38400, 180, 1.0)
        assert server.device.baudrate == 38400 and scanner.link.port.baudrate == 38400
        scanner.start()
        assert len(scanner.read_scan().ranges) == 181
        scanner.stop()


# ------------------------------------------------------------------ backed by the sim

def test_the_real_drivers_drive_the_simulated_uiabot_20_m_within_1_percent():
    """End to end on the logical clock: ODrive driver → emulator → sim wheels, and back."""
    from hardware.emulators.rigs import uiabot_rig
    from kit.drivers.bases import UiabotBase
    from kit.odometry import WheelOdometry

    rig = uiabot_rig(start=(5.0, 4.0, 0.0), seed=2)
    base = UiabotBase(rig.ports["odrive"], **rig.driver_options())
    base.bring_up()
    reference = WheelOdometry.for_robot(rig.sim.descriptions[0])
    base.update()
    reference.update(*rig.sim.encoder_ticks(), rig.sim.time)
    travelled, last = 0.0, rig.sim.ground_truth().pose
    route = [(0.4, 0.2)] * 500 + [(0.45, -0.25)] * 240 + [(0.3, 0.0)] * 150
    for cmd in route:
        base.drive(cmd)
        rig.clock.sleep(0.05)
        base.update()
        reference.update(*rig.sim.encoder_ticks(), rig.sim.time)
        pose = rig.sim.ground_truth().pose
        travelled += math.hypot(*(pose[:2] - last[:2]))
        last = pose
    assert travelled > 20.0
    error = np.hypot(*(base.odometry.pose[:2] - reference.pose[:2]))
    assert error / travelled < 0.01
    assert abs(base.odometry.pose[2] - reference.pose[2]) < 0.01


def test_sim_backed_lidar_and_imu_see_the_simulated_world():
    from hardware.emulators.rigs import uiabot_rig

    rig = uiabot_rig(start=(2.0, 5.0, math.pi / 3), seed=1)
    imu = bno055.BNO055(rig.ports["bno055"], **rig.driver_options())
    imu.begin()
    assert imu.yaw() == pytest.approx(math.pi / 3, abs=0.03)
    simulated = []
    rig.backend.subscribe("scan", simulated.append)
    lidar = rplidar.RPLidar(rig.ports["rplidar"], **rig.driver_options())
    lidar.start()
    lidar.read_scan()
    scan = lidar.read_scan()
    # the turn the driver got is one the simulator made, beam for beam (q2: 0.25 mm)
    def mismatch(s):
        both = np.isfinite(s.ranges) & np.isfinite(scan.ranges)
        return np.abs(s.ranges[both] - scan.ranges[both]).sum()

    best = min(simulated, key=mismatch)
    both = np.isfinite(best.ranges) & np.isfinite(scan.ranges)
    assert both.sum() > 300
    assert np.abs(best.ranges[both] - scan.ranges[both]).max() <= 0.0003
    assert scan.angle_min == best.angle_min and len(scan.ranges) == len(best.ranges)


def test_the_real_drivers_drive_the_simulated_igv_and_read_its_compass_and_scanner():
    from hardware.emulators.rigs import igv_rig
    from kit.drivers.bases import IgvBase
    from kit.odometry import WheelOdometry

    rig = igv_rig(world="aisle", seed=4, start=(1.0, 0.75, 0.0))
    base = IgvBase(rig.ports["dpralte"], clock=rig.clock)
    base.start()
    reference = WheelOdometry.for_robot(rig.sim.descriptions[0])
    base.update()
    reference.update(*rig.sim.encoder_ticks(), rig.sim.time)
    t0 = rig.clock.now
    for _ in range(180):  # 9 s at 20 Hz, 1 m/s down the aisle, a little weave about it
        base.drive((1.0, 0.05 * math.cos(rig.clock.now - t0)))
        rig.clock.sleep(0.05)
        base.update()
        reference.update(*rig.sim.encoder_ticks(), rig.sim.time)
    pose, ref = base.odometry.pose, reference.pose
    assert ref[0] > 8.0 and not rig.sim.collisions
    assert np.hypot(*(pose[:2] - ref[:2])) / ref[0] < 0.01
    compass = os5000.Os5000(rig.ports["os5000"], clock=rig.clock)
    truth = rig.sim.ground_truth().pose[2]
    # heading → yaw, once; the simulated compass's noise is 0.5° (0.0087 rad): 4σ
    assert compass.read().yaw == pytest.approx(truth, abs=0.035)
    scanner = lms2xx.LMS2xx(rig.ports["lms2xx"], **rig.driver_options())
    scanner.connect(38400, 180, 1.0)
    scanner.start()
    scan = scanner.read_scan()
    # the aisle is 1.5 m wide: the scanner sees both walls, left and right (between doors)
    left, right = scan.ranges[-1], scan.ranges[0]
    assert 0.3 < left < 1.5 and 0.3 < right < 1.5 and left + right == pytest.approx(1.5, abs=0.2)
    base.stop()


def test_compass_formats_and_commands_round_trip_through_the_emulator():
    assert os5000.parse_sentence("$HCHDT,212.4,T*2C").heading_deg == 212.4  # spec vector
    clock = Clock()
    device = Os5000Emulator()
    compass = os5000.Os5000(LogicalPort(device, clock), clock=clock)
    compass.set_declination(12.5)
    compass.set_format(4)
    reading = compass.read()
    while reading.heading_deg != 102.5:  # sentences already on the way in format 1
        reading = compass.read()
    assert math.isnan(reading.pitch_deg) and reading.yaw == pytest.approx(math.radians(-12.5))
    compass.set_format(2)
    while not compass.read().temperature_c:
        pass
    assert (device.format, device.declination) == (2, 12.5)
    compass.set_fields(7)
    compass.set_format(1)
    clock.sleep(0.2)
    compass.link.clear("drop what came before")
    assert compass.read().temperature_c is None  # the T field is off


def test_rplidar_express_scan_capsules_round_trip_and_stream():
    distances = [float(4 * k + 150) for k in range(32)]
    offsets = [(k % 64) / 8.0 for k in range(32)]
    raw = rplidar.encode_capsule(False, 123.5, distances, offsets)
    assert len(raw) == 84 and raw[0] >> 4 == 0xA and raw[1] >> 4 == 0x5
    checksum = 0
    for b in raw[2:]:
        checksum ^= b
    assert checksum == (raw[0] & 0x0F) | (raw[1] & 0x0F) << 4  # §6.6's rule
    capsule = rplidar.decode_capsule(raw)
    assert capsule.angle_deg == 123.5 and list(capsule.distances_mm) == distances
    assert list(capsule.offsets_deg) == offsets
    bad = bytearray(raw)
    bad[40] ^= 0x04
    assert rplidar.decode_capsule(bytes(bad)) is None

    clock = Clock()
    device = RPLidarEmulator()
    port = LogicalPort(device, clock)
    port.write(h("A5 82 05 00 00 00 00 00 22"))  # the spec's legacy express request
    assert port.read(7) == h("A5 5A 54 00 00 40 82")
    lidar = rplidar.RPLidar(LogicalPort(RPLidarEmulator(), clock), clock=clock,
                            sleep=clock.sleep)
    lidar.start_express()
    t0 = clock.now
    turns = [lidar.read_revolution() for _ in range(5)]
    assert (clock.now - t0) / 5 == pytest.approx(1 / 5.5, rel=0.05)
    assert all(abs(len(t) - 4000 / 5.5) < 3 for t in turns)  # 4000 samples/s
    scan = lidar.read_scan()
    assert scan.ranges[180] == pytest.approx(4.0, abs=0.01)  # the room's wall ahead
    lidar.stop()
