"""Bosch BNO055 in UART mode (``protocols.md`` §5): the device side.

A 128-byte page-0 register file behind ``AA 00 reg len data`` writes (``EE 01``) and
``AA 01 reg len`` reads (``BB len data``). The state machine: CONFIG mode at power-up;
sensor data registers refused in CONFIG mode (``EE 02``, read fail: the sensors are off);
writes to read-only registers, and to ``UNIT_SEL`` and the calibration offsets outside
CONFIG, refused with ``EE 05``; after a switch into a fusion mode (8–12) the fusion output
is not ready for ``fusion_start`` seconds and reads answer ``EE 07`` (bus over-run, "retry");
calibration status climbs to 3 over the first seconds of fusion; ``SYS_TRIGGER = 20``
resets the chip, which answers nothing for 650 ms.

Readings come from the backend's body: heading is clockwise from north (``90° − yaw``);
the quaternion register holds the same orientation as a rotation by −heading about z (an
assumption of the emulator: the kit's driver takes orientation from the Euler heading).
"""

from __future__ import annotations

import math
from typing import Any

from hardware.emulators.backends import IdealWheels, imu_yaw
from hardware.emulators.core import Device, Faults

__all__ = ["BNO055Emulator"]

CHIP_ID, PAGE_ID, CALIB_STAT, ST_RESULT, SYS_STATUS, SYS_ERR = 0x00, 0x07, 0x35, 0x36, 0x39, 0x3A
UNIT_SEL, OPR_MODE, PWR_MODE, SYS_TRIGGER = 0x3B, 0x3D, 0x3E, 0x3F
DATA = range(0x08, 0x35)          # ACC … TEMP
FUSION = range(0x1A, 0x34)        # EUL, QUA, LIA, GRV
OFFSETS = range(0x55, 0x6B)
WRITABLE = {PAGE_ID, UNIT_SEL, OPR_MODE, PWR_MODE, SYS_TRIGGER, 0x40, 0x41, 0x42, *OFFSETS}
CONFIG_ONLY = {UNIT_SEL, 0x41, 0x42, *OFFSETS}
GRAVITY = 9.80665


def _s16(value: float) -> bytes:
    return int(max(-32768, min(32767, round(value)))).to_bytes(2, "little", signed=True)


class BNO055Emulator(Device):
    """A BNO055 whose body is the backend's (a ``SimBackend`` robot, or at rest)."""

    name = "bno055"
    baudrate = 115200

    def __init__(self, backend: Any = None, fusion_start: float = 0.05,
                 calibration_time: float = 2.0, faults: Faults | None = None) -> None:
        super().__init__(faults)
        self.backend = backend or IdealWheels()
        self.fusion_start = fusion_start
        self.calibration_time = calibration_time
        self._frame = bytearray()
        self._frame_time = 0.0
        self._power_up()
        self._mute_until = -1.0
        self._imu: Any = None
        if hasattr(self.backend, "subscribe"):
            self.backend.subscribe("imu", self._on_imu)

    def _power_up(self) -> None:
        regs = bytearray(128)
        regs[0:7] = bytes([0xA0, 0xFB, 0x32, 0x0F, 0x11, 0x03, 0x15])
        regs[ST_RESULT] = 0x0F
        regs[SYS_STATUS] = 0
        self.regs = regs
        self._fusion_since: float | None = None

    def _on_imu(self, message: Any) -> None:
        self._imu = message  # the simulated IMU's latest reading (noise, bias, drift)

    @property
    def mode(self) -> int:
        return self.regs[OPR_MODE] & 0x0F

    # ------------------------------------------------------------------ register contents
    def _refresh(self, now: float) -> None:
        self.backend.advance(now)
        regs = self.regs
        mode = self.mode
        if mode == 0:
            return
        units = regs[UNIT_SEL]
        fusion = 8 <= mode <= 12
        if self._imu is not None:
            yaw = imu_yaw(self._imu)
            rate = self._imu.angular_velocity.z
            ax, ay = self._imu.linear_acceleration.x, self._imu.linear_acceleration.y
        else:
            yaw = float(self.backend.yaw())
            rate = 0.0
            ax = ay = 0.0
        heading = (90.0 - math.degrees(yaw)) % 360.0
        acc_scale = 100.0 if not units & 0x01 else 1000.0 / GRAVITY
        regs[0x08:0x0E] = _s16(ax * acc_scale) + _s16(ay * acc_scale) + _s16(GRAVITY * acc_scale)
        regs[0x0E:0x14] = _s16(0.0) + _s16(20.0 * 16) + _s16(-40.0 * 16)
        gyro_scale = 16.0 * 180.0 / math.pi if not units & 0x02 else 900.0
        regs[0x14:0x1A] = _s16(0.0) + _s16(0.0) + _s16(rate * gyro_scale)
        regs[0x34] = 25
        if fusion and self._fusion_since is not None:
            euler_scale = 16.0 if not units & 0x04 else 900.0 * math.pi / 180.0
            regs[0x1A:0x20] = _s16(heading * euler_scale) + _s16(0) + _s16(0)
            half = -math.radians(heading) / 2.0
            regs[0x20:0x28] = (_s16(math.cos(half) * 16384) + _s16(0) + _s16(0) +
                               _s16(math.sin(half) * 16384))
            regs[0x28:0x2E] = _s16(ax * acc_scale) + _s16(ay * acc_scale) + _s16(0.0)
            regs[0x2E:0x34] = _s16(0.0) + _s16(0.0) + _s16(GRAVITY * acc_scale)
            level = min(3, int(3 * (now - self._fusion_since) / self.calibration_time))
            regs[CALIB_STAT] = (level << 6) | (3 << 4) | (min(3, level + 1) << 2) | level
            regs[SYS_STATUS] = 5 if now - self._fusion_since >= self.fusion_start else 3
        else:
            regs[FUSION.start:FUSION.stop] = bytes(len(FUSION))
            regs[SYS_STATUS] = 6

    # ------------------------------------------------------------------ frames
    def error_reply(self, reply: bytes) -> bytes | None:
        return b"\xee\x07"

    def receive(self, data: bytes, now: float) -> None:
        if now < self._mute_until:
            return
        if self._frame and now - self._frame_time > 0.02:
            self._frame.clear()  # the host paused mid-frame: receive character time-out
            self.send(b"\xee\x0a", now)
        for b in data:
            if not self._frame and b != 0xAA:
                self.send(b"\xee\x06", now)  # wrong start byte
                continue
            self._frame.append(b)
            self._frame_time = now
            frame = self._frame
            if len(frame) >= 4 and frame[1] == 0x01:
                self._read(frame[2], frame[3], now)
                frame.clear()
            elif len(frame) >= 2 and frame[1] not in (0x00, 0x01):
                frame.clear()
                self.send(b"\xee\x06", now)
            elif len(frame) >= 4 and frame[1] == 0x00 and len(frame) == 4 + frame[3]:
                self._write(frame[2], bytes(frame[4:]), now)
                frame.clear()
            elif len(frame) == 4 and frame[1] == 0x00 and frame[3] == 0:
                frame.clear()
                self.send(b"\xee\x09", now)

    def _read(self, reg: int, length: int, now: float) -> None:
        if length == 0:
            self.send(b"\xee\x09", now)
            return
        if reg + length > 128:
            self.send(b"\xee\x04", now)
            return
        self._refresh(now)
        span = range(reg, reg + length)
        touches_data = any(r in DATA for r in span)
        if touches_data and self.mode == 0:
            self.send(b"\xee\x02", now)
            return
        if any(r in FUSION for r in span) and 8 <= self.mode <= 12 and \
                self._fusion_since is not None and now - self._fusion_since < self.fusion_start:
            self.send(b"\xee\x07", now)
            return
        if reg == 0x08 and length >= 0x34 - 0x08:
            self.event("imu", now)  # the data block an Imu is made of
        self.send(bytes([0xBB, length]) + bytes(self.regs[reg:reg + length]), now)

    def _write(self, reg: int, data: bytes, now: float) -> None:
        if reg + len(data) > 128:
            self.send(b"\xee\x04", now)
            return
        span = range(reg, reg + len(data))
        if any(r not in WRITABLE for r in span) or \
                (self.mode != 0 and any(r in CONFIG_ONLY for r in span)):
            self.send(b"\xee\x05", now)
            return
        if reg == SYS_TRIGGER and data[0] & 0x20:
            self._power_up()
            self._mute_until = now + 0.65  # rebooting: no reply, nothing heard
            return
        self.regs[reg:reg + len(data)] = data
        if OPR_MODE in span:
            self._fusion_since = now if 8 <= self.mode <= 12 else None
            self.regs[SYS_STATUS] = 0 if self.mode == 0 else 3
            self.regs[CALIB_STAT] = 0
        self.send(b"\xee\x01", now)
