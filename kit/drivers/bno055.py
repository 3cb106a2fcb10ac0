"""Bosch BNO055 over its UART register protocol: modes, calibration status, and Euler,
quaternion, gyroscope and acceleration readings turned into a ROS ``Imu``.

Frames: write ``AA 00 reg len data`` → ``EE 01``; read ``AA 01 reg len`` → ``BB len data``
or ``EE status``. There is no checksum, so the driver checks what it can (start byte,
length, a status the chip has) and resends on ``EE 07`` (bus over-run, normal while fusion
starts) and on garbage. Two failures stay apart: the chip **refusing** a request (``EE``
with one of its statuses, such as ``05`` for a read-only register) is a
:class:`~kit.drivers.errors.DeviceError` with the chip's code, while replies **garbled**
on the line (``EE`` followed by a status the chip does not have, a reply of the wrong kind
or length) are resent and, if they never come right, a
:class:`~kit.drivers.errors.ProtocolError`. The first request after a power-up or after
an earlier program left a frame half sent can fail: the chip answers ``EE 0A`` (receive
character time-out) or nothing, and the request is resent, so :meth:`BNO055.begin` gets
through. The heading (clockwise from north, degrees) becomes REP-103 yaw once, here:
``yaw = π/2 − heading``. Facts and vectors: ``protocols.md`` §5.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from kit import msgs
from kit.drivers.errors import DeviceError, DeviceTimeout, ProtocolError, failed_twice
from kit.drivers.port import Link
from kit.geometry import wrap_angle

__all__ = [
    "BNO055",
    "DEVICE",
    "MODES",
    "STATUS",
    "Calibration",
    "decode_reply",
    "encode_read",
    "encode_write",
    "heading_to_yaw",
]

DEVICE = "BNO055"
CHIP_ID, PAGE_ID, ACC_DATA, GYR_DATA, EUL_DATA, QUA_DATA, LIA_DATA, GRV_DATA = (
    0x00, 0x07, 0x08, 0x14, 0x1A, 0x20, 0x28, 0x2E)
CALIB_STAT, SYS_STATUS, SYS_ERR, UNIT_SEL, OPR_MODE, PWR_MODE, SYS_TRIGGER = (
    0x35, 0x39, 0x3A, 0x3B, 0x3D, 0x3E, 0x3F)
MODES = {"CONFIG": 0x00, "ACCONLY": 0x01, "MAGONLY": 0x02, "GYROONLY": 0x03, "ACCMAG": 0x04,
         "ACCGYRO": 0x05, "MAGGYRO": 0x06, "AMG": 0x07, "IMU": 0x08, "COMPASS": 0x09,
         "M4G": 0x0A, "NDOF_FMC_OFF": 0x0B, "NDOF": 0x0C}
STATUS = {0x01: "write success", 0x02: "read fail", 0x03: "write fail",
          0x04: "invalid register address", 0x05: "register write disabled",
          0x06: "wrong start byte", 0x07: "bus over-run", 0x08: "maximum length error",
          0x09: "minimum length error", 0x0A: "receive character time-out"}
RETRY = {0x02, 0x03, 0x06, 0x07, 0x0A}
"""statuses worth resending for (the rest are the host's mistakes)."""


def heading_to_yaw(heading_deg: float) -> float:
    """BNO055 heading (clockwise from north, degrees) → REP-103 yaw [rad] in [−π, π).

    >>> round(heading_to_yaw(90.0), 12), round(heading_to_yaw(180.0), 6)
    (0.0, -1.570796)
    """
    return float(wrap_angle(math.pi / 2 - math.radians(heading_deg)))


def encode_read(register: int, length: int) -> bytes:
    """``AA 01 reg len``.

    >>> encode_read(0x1A, 6).hex(" ").upper()
    'AA 01 1A 06'
    """
    if not (0 <= register <= 0x7F and 1 <= length <= 128):
        raise ValueError(f"register 0..0x7F and length 1..128; got {register:#x}, {length}")
    return bytes([0xAA, 0x01, register, length])


def encode_write(register: int, data: bytes) -> bytes:
    """``AA 00 reg len data``.

    >>> encode_write(0x3D, bytes([0x0C])).hex(" ").upper()
    'AA 00 3D 01 0C'
    """
    if not (0 <= register <= 0x7F and 1 <= len(data) <= 128):
        raise ValueError(f"register 0..0x7F and 1..128 bytes; got {register:#x}, {len(data)}")
    return bytes([0xAA, 0x00, register, len(data)]) + bytes(data)


def decode_reply(buffer: bytes | bytearray) -> tuple[int, bytes | int] | None:
    """The first reply in ``buffer`` as ``(bytes used, data or status)``, or ``None`` if
    more bytes are needed. Leading bytes that cannot start a reply are skipped (counted in
    the bytes used with a status of −1).

    >>> decode_reply(bytes.fromhex("BB06A00560FF5800"))
    (8, b'\\xa0\\x05`\\xffX\\x00')
    >>> decode_reply(bytes.fromhex("EE07"))
    (2, 7)
    """
    skip = 0
    while skip < len(buffer) and buffer[skip] not in (0xBB, 0xEE):
        skip += 1
    if skip:
        return skip, -1
    if len(buffer) < 2:
        return None
    if buffer[0] == 0xEE:
        return 2, buffer[1]
    n = buffer[1]
    if len(buffer) < 2 + n:
        return None
    return 2 + n, bytes(buffer[2:2 + n])


def _s16(data: bytes, i: int) -> int:
    return int.from_bytes(data[2 * i:2 * i + 2], "little", signed=True)


@dataclass(frozen=True)
class Calibration:
    """CALIB_STAT: 0 (uncalibrated) … 3 (fully calibrated) per part."""

    system: int
    gyroscope: int
    accelerometer: int
    magnetometer: int

    @classmethod
    def from_byte(cls, b: int) -> Calibration:
        """CALIB_STAT's byte: bits 7–6 system, 5–4 gyroscope, 3–2 accelerometer, 1–0 magnetometer.

        >>> Calibration.from_byte(0x36)
        Calibration(system=0, gyroscope=3, accelerometer=1, magnetometer=2)
        """
        return cls((b >> 6) & 3, (b >> 4) & 3, (b >> 2) & 3, b & 3)


class BNO055:
    """A BNO055 on a serial port. :meth:`begin` runs the operating sequence (chip id,
    CONFIG, units, NDOF, wait for fusion); :meth:`read_imu` returns an ``Imu``.

    The driver keeps the default units (m/s², °/s, degrees) and converts them. The chip
    runs its UART at 115200 8N1 (``baudrate``); every request starts by dropping stale
    bytes, and readings are stamped with the wall clock on a real port.
    """

    def __init__(self, port: Any, timeout: float = 0.1, retries: int = 5,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep, frame_id: str = "imu_link", *,
                 baudrate: int = 115200, stamp: Callable[[], float] | None = None) -> None:
        self.link = Link(DEVICE, port, baudrate, 0.01, clock, sleep, stamp)
        self.timeout = timeout
        self.retries = retries
        self.frame_id = frame_id
        self.retried = 0
        self.mode: str | None = None
        self._wanted: str | None = None
        self.last_exchange = (0.0, 0.0)

    # ------------------------------------------------------------------ transactions
    def _transact(self, request: bytes, what: str) -> bytes | int:
        link = self.link
        with link.lock:
            link.clear(what)
            sent = link.stamp()
            link.write(request, what)
            deadline = link.clock() + self.timeout
            buffer = bytearray()
            while True:
                reply = decode_reply(buffer)
                while reply is not None and reply[1] == -1:
                    del buffer[:reply[0]]
                    reply = decode_reply(buffer)
                if reply is not None:
                    self.last_exchange = (sent, link.stamp())
                    return reply[1]
                if link.clock() >= deadline:
                    raise DeviceTimeout(DEVICE, f"{what}: no reply within {self.timeout:g} s")
                buffer += link.read_some(what)

    def _retrying(self, request: bytes, what: str, expect: int | None) -> bytes | int:
        """Send ``request`` until its reply comes: data of ``expect`` bytes for a read,
        ``EE 01`` for a write (``expect`` None). Retried: no reply, the chip's "try again"
        statuses (:data:`RETRY`), garbled replies. Raised at once: the chip's refusals."""
        last, code, garbled = "no reply", 0, False
        for attempt in range(self.retries + 1):
            if attempt:
                self.retried += 1
            try:
                reply = self._transact(request, what)
            except DeviceTimeout:
                last, code, garbled = "no reply", 0, False
                continue
            if isinstance(reply, int):
                if reply == 0x01 and expect is None:
                    return reply
                if reply not in STATUS or reply == 0x01:
                    # a status the chip does not have (or a write's "success" to a read)
                    last, code, garbled = f"a garbled reply (EE {reply:02X})", 0, True
                elif reply in RETRY:
                    last, code, garbled = STATUS[reply], reply, False
                else:
                    raise DeviceError(DEVICE, f"{what}: the chip refused: {STATUS[reply]} "
                                              f"(0x{reply:02X})", reply)
                continue
            if expect is not None and len(reply) == expect:
                return reply
            shape = f"{len(reply)} data bytes" + (f" instead of {expect}" if expect else
                                                  " to a write")
            last, code, garbled = f"a garbled reply ({shape})", 0, True
        tries = f"after {self.retries + 1} tries"
        if last == "no reply":
            raise DeviceTimeout(DEVICE, f"{what}: no reply {tries} ({self.timeout:g} s each)")
        if garbled:
            raise ProtocolError(DEVICE, f"{what}: {last} {tries}: line noise, or another "
                                        f"device or baud rate on this port")
        raise DeviceError(DEVICE, f"{what}: {last} (0x{code:02X}) {tries}", code)

    def read_registers(self, register: int, length: int, what: str = "") -> bytes:
        reply = self._retrying(encode_read(register, length),
                               what or f"read 0x{register:02X}", length)
        assert isinstance(reply, bytes)
        return reply

    def write_register(self, register: int, value: int | bytes, what: str = "") -> None:
        data = bytes([value]) if isinstance(value, int) else value
        self._retrying(encode_write(register, data), what or f"write 0x{register:02X}", None)

    # ------------------------------------------------------------------ sequence
    def set_mode(self, mode: str | int) -> None:
        value = MODES[mode] if isinstance(mode, str) else int(mode)
        self.write_register(OPR_MODE, value, f"set mode {mode}")
        self.link.sleep(0.02 if value == 0 else 0.01)

    def connect(self, pause: float = 0.05) -> int:
        """Read CHIP_ID (the spec's "retry once: the first command after power-up can
        fail"): a frame an earlier program left unfinished in the chip's receiver merges
        with the first request (whose answer can even be a refusal of the merged frame), so
        a first exchange that fails in any way is tried once more after ``pause`` seconds of
        silence, longer than the chip's receive character time-out, which abandons any
        partial frame. Returns the chip id."""
        try:
            return self.read_registers(CHIP_ID, 1, "read chip id")[0]
        except (DeviceTimeout, DeviceError, ProtocolError) as exc:
            if self.link.failure is not None:
                raise
            first = exc
        self.link.sleep(pause)
        try:
            return self.read_registers(CHIP_ID, 1, "read chip id")[0]
        except (DeviceTimeout, DeviceError, ProtocolError) as exc:
            raise failed_twice(exc, first) from None

    def begin(self, mode: str = "NDOF", fusion_timeout: float = 1.0) -> None:
        """Chip id → CONFIG → normal power, page 0, default units → ``mode`` → fusion on."""
        self.mode = None
        self._wanted = mode
        chip = self.connect()
        if chip != 0xA0:
            raise ProtocolError(DEVICE, f"chip id 0x{chip:02X} is not a BNO055's 0xA0")
        self.set_mode("CONFIG")
        self.write_register(PWR_MODE, 0x00, "normal power")
        self.write_register(PAGE_ID, 0x00, "page 0")
        self.write_register(SYS_TRIGGER, 0x00, "internal clock")
        self.write_register(UNIT_SEL, 0x00, "units m/s², °/s, degrees")
        self.set_mode(mode)
        if MODES.get(mode, 0) >= 0x08:
            deadline = self.link.clock() + fusion_timeout
            while self.read_registers(SYS_STATUS, 1, "read system status")[0] != 5:
                if self.link.clock() >= deadline:
                    raise DeviceTimeout(DEVICE, f"fusion not running {fusion_timeout:g} s after "
                                                f"switching to {mode}")
                self.link.sleep(0.01)
        self.mode = mode

    def reopen(self) -> None:
        """Open the port again after it failed (the chip unplugged and back, so reset to
        CONFIG mode): :meth:`begin` again in the mode it was in."""
        self.link.reopen()
        if self._wanted is not None:
            self.begin(self._wanted)

    # ------------------------------------------------------------------ readings
    def calibration(self) -> Calibration:
        return Calibration.from_byte(self.read_registers(CALIB_STAT, 1, "read calibration")[0])

    def euler(self) -> tuple[float, float, float]:
        """(heading, roll, pitch) in degrees, as the chip orders them."""
        d = self.read_registers(EUL_DATA, 6, "read Euler angles")
        return _s16(d, 0) / 16.0, _s16(d, 1) / 16.0, _s16(d, 2) / 16.0

    def quaternion(self) -> tuple[float, float, float, float]:
        """(w, x, y, z) as the chip reports it (its own reference frame)."""
        d = self.read_registers(QUA_DATA, 8, "read quaternion")
        return tuple(_s16(d, i) / 16384.0 for i in range(4))  # type: ignore[return-value]

    def gyroscope(self) -> tuple[float, float, float]:
        """Angular rates [rad/s]."""
        d = self.read_registers(GYR_DATA, 6, "read gyroscope")
        return tuple(math.radians(_s16(d, i) / 16.0) for i in range(3))  # type: ignore

    def linear_acceleration(self) -> tuple[float, float, float]:
        """Acceleration with gravity removed [m/s²]."""
        d = self.read_registers(LIA_DATA, 6, "read linear acceleration")
        return tuple(_s16(d, i) / 100.0 for i in range(3))  # type: ignore[return-value]

    def gravity(self) -> tuple[float, float, float]:
        d = self.read_registers(GRV_DATA, 6, "read gravity")
        return tuple(_s16(d, i) / 100.0 for i in range(3))  # type: ignore[return-value]

    def yaw(self) -> float:
        """REP-103 yaw [rad] from the fused heading."""
        return heading_to_yaw(self.euler()[0])

    def read_imu(self, stamp: msgs.Time | None = None) -> msgs.Imu:
        """One ``Imu`` message: orientation from the fused Euler angles (heading converted
        to REP-103 yaw), gyroscope rates, and the acceleration gravity included (REP-145),
        from one block read of 0x08–0x33, stamped in the middle of the exchange that read
        it (the chip sampled it between request and reply)."""
        d = self.read_registers(ACC_DATA, 0x34 - ACC_DATA, "read data block")
        heading, roll, pitch = (_s16(d, 9 + i) / 16.0 for i in range(3))
        yaw = heading_to_yaw(heading)
        r, p = math.radians(roll), math.radians(pitch)
        cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
        cr, sr = math.cos(r / 2), math.sin(r / 2)
        cp, sp = math.cos(p / 2), math.sin(p / 2)
        orientation = msgs.Quaternion(x=sr * cp * cy - cr * sp * sy,
                                      y=cr * sp * cy + sr * cp * sy,
                                      z=cr * cp * sy - sr * sp * cy,
                                      w=cr * cp * cy + sr * sp * sy)
        gyro = [math.radians(_s16(d, 6 + i) / 16.0) for i in range(3)]
        accel = [_s16(d, i) / 100.0 for i in range(3)]
        sent, answered = self.last_exchange
        t = stamp if stamp is not None else msgs.Time.from_sec(0.5 * (sent + answered))
        return msgs.Imu(
            header=msgs.Header(t, self.frame_id), orientation=orientation,
            orientation_covariance=np.diag([0.0025] * 3).ravel(),
            angular_velocity=msgs.Vector3(*gyro),
            angular_velocity_covariance=np.diag([2e-5] * 3).ravel(),
            linear_acceleration=msgs.Vector3(*accel),
            linear_acceleration_covariance=np.diag([0.01] * 3).ravel())
