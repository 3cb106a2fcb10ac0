"""OceanServer OS5000-S digital compass: its sentences, checked and parsed, the heading
converted once, here, to REP-103 yaw, and readings as ``sensor_msgs/Imu``.

The compass streams ``$C<heading>P<pitch>R<roll>T<temp>…*<cc>\\r\\n`` (format 1; format 2
is ``$OHPR,<fields…>``, format 4 ``$HCHDT,<heading>,T``; checksum: XOR of the characters
between ``$`` and ``*``) and answers commands with free text, which is skipped. Heading is
degrees clockwise from north; REP-103 yaw is counter-clockwise from east:
``yaw = π/2 − heading`` (wrapped to [−π, π)). Facts and vectors: ``protocols.md`` §2.

Every format is held to the same ranges (heading 0–360°, pitch ±90°, roll ±180°, the
temperature −55…125 °C, the range of the microcontroller's sensor) and to plain decimals
(``1e5``, ``nan``, ``inf`` are not numbers the compass prints).
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from kit import msgs
from kit.drivers.checksums import nmea_checksum
from kit.drivers.errors import ChecksumError, DeviceTimeout, ProtocolError
from kit.drivers.port import Link
from kit.drivers.timing import SampleClock
from kit.geometry import wrap_angle

__all__ = ["DEVICE", "FIELDS", "CompassReading", "LineSplitter", "Os5000", "heading_to_yaw",
           "parse_sentence", "reading_to_imu"]

DEVICE = "OS5000"
BAUDRATE = 19200
TOKEN = re.compile(r"(Mx|My|Mz|Ax|Ay|Az|[CPRTD])(-?\d+(?:\.\d+)?)")
NUMBER = re.compile(r"-?\d+(?:\.\d+)?")
# a sentence's body holds only tags, numbers and commas: anything else (a NUL byte inserted
# by line noise leaves the XOR unchanged) means a corrupted line; the compass writes its
# checksum in upper case, so a flipped case bit is a corruption too
SENTENCE = re.compile(r"^\$([A-Za-z0-9.,-]*)\*([0-9A-F]{2})$")
FIELDS: tuple[tuple[int, tuple[str, ...]], ...] = (
    (1, ("C",)), (2, ("P",)), (4, ("R",)), (8, ("T",)), (16, ("D",)),
    (64, ("Mx", "My", "Mz")), (256, ("Ax", "Ay", "Az")))
"""``<ESC>X`` mask bits and the fields each adds, in the order the compass sends them
(1 heading, 2 pitch, 4 roll, 8 temperature, 16 depth — OS5500 only — 64 magnetic x, y, z
[mG], 256 acceleration x, y, z [g])."""
LIMITS = {"C": (0.0, 360.0), "P": (-90.0, 90.0), "R": (-180.0, 180.0), "T": (-55.0, 125.0)}
HEADING_STD = math.radians(0.5)
"""the OS5000-S's heading accuracy, level (manual: 0.5° RMS), as the yaw's σ."""
TILT_STD = math.radians(1.0)
"""σ assumed for pitch and roll (not in the protocol notes)."""


def heading_to_yaw(heading_deg: float) -> float:
    """Compass heading (clockwise from north, degrees) → REP-103 yaw (CCW from east, rad).

    >>> round(heading_to_yaw(90.0), 12), round(heading_to_yaw(0.0), 6)
    (0.0, 1.570796)
    """
    return float(wrap_angle(math.pi / 2 - math.radians(heading_deg)))


@dataclass(frozen=True)
class CompassReading:
    heading_deg: float
    pitch_deg: float
    """NaN when the sentence does not carry it."""
    roll_deg: float
    """NaN when the sentence does not carry it."""
    temperature_c: float | None
    yaw: float
    """REP-103 yaw [rad] of the heading."""
    extra: dict[str, float] = field(default_factory=dict)
    """any other fields present (Mx, My, Mz, Ax, Ay, Az, D)."""


def _body(line: str) -> str:
    match = SENTENCE.match(line)
    if not match:
        raise ProtocolError(DEVICE, f"not a sentence: {line[:60]!r}")
    body, given = match.group(1), match.group(2)
    if nmea_checksum(body) != given:
        raise ChecksumError(DEVICE, f"checksum {given} does not match "
                                    f"{nmea_checksum(body)} for {body[:60]!r}")
    return body


def _tagged(body: str) -> dict[str, float]:
    """Format 1: the body must be tags and numbers, nothing else, each tag once."""
    tokens = TOKEN.findall(body)
    if "".join(tag + number for tag, number in tokens) != body:
        raise ProtocolError(DEVICE, f"malformed sentence: {body[:60]!r}")
    values = {tag: float(number) for tag, number in tokens}
    if len(values) != len(tokens):
        raise ProtocolError(DEVICE, f"a field twice: {body[:60]!r}")
    return values


def _comma(body: str, fields: int) -> dict[str, float]:
    """Format 4 (``HCHDT,<heading>,T``) and format 2 (``OHPR,`` + the ``fields`` mask's
    values in order)."""
    parts = body.split(",")
    if parts[0] == "HCHDT":
        if len(parts) != 3 or parts[2] != "T" or not NUMBER.fullmatch(parts[1]):
            raise ProtocolError(DEVICE, f"malformed sentence: {body[:60]!r}")
        return {"C": float(parts[1])}
    tags = [tag for bit, names in FIELDS if fields & bit for tag in names]
    values = parts[1:]
    if len(values) != len(tags) or not all(NUMBER.fullmatch(v) for v in values):
        raise ProtocolError(DEVICE, f"malformed sentence for fields {fields}: {body[:60]!r}")
    return {tag: float(v) for tag, v in zip(tags, values, strict=True)}


def _parse(line: str, fields: int = 15) -> CompassReading:
    body = _body(line)
    if body.startswith(("HCHDT,", "OHPR,")):
        values = _comma(body, fields)
    elif body.startswith("C"):
        values = _tagged(body)
    else:
        raise ProtocolError(DEVICE, f"not a compass sentence: {body[:20]!r}")
    if "C" not in values:
        raise ProtocolError(DEVICE, f"sentence without a heading: {body[:60]!r}")
    for tag, (low, high) in LIMITS.items():
        if tag in values and not low <= values[tag] <= high:
            raise ProtocolError(DEVICE, f"{tag} = {values[tag]:g} out of range "
                                        f"[{low:g}, {high:g}]: {body[:60]!r}")
    heading = values.pop("C")
    return CompassReading(heading, values.pop("P", math.nan), values.pop("R", math.nan),
                          values.pop("T", None), heading_to_yaw(heading), values)


def parse_sentence(line: str, fields: int = 15) -> CompassReading:
    """One sentence (without CR LF) → a reading: format 1 (``$C…``), 2 (``$OHPR,…``, whose
    values are the ``fields`` mask's, the default 15 being heading, pitch, roll and
    temperature) or 4 (``$HCHDT,…``: heading only, pitch and roll NaN).

    Raises
    ------
    ChecksumError
        The two hex digits do not match the line.
    ProtocolError
        Not a compass sentence, malformed, without a heading, or a value out of range.

    >>> parse_sentence("$C320.5P0.2R-18.3T19.0*3C").roll_deg
    -18.3
    """
    return _parse(line, fields)


def reading_to_imu(reading: CompassReading, stamp: msgs.Time,
                   frame_id: str = "imu_link") -> msgs.Imu:
    """A reading as ``sensor_msgs/Imu``: orientation only (REP-103, REP-145).

    The compass gives heading, pitch and roll in the aerospace convention (x forward, y
    right, z down: pitch positive nose up, roll positive right side down; an assumption,
    the protocol notes give no signs); in the REP-103 body frame (y left, z up) that is
    roll = roll, pitch = −pitch, yaw = π/2 − heading, composed as yaw·pitch·roll (ZYX).
    Without pitch and roll (format 4) they are taken as 0 with a variance of π², and
    angular velocity and acceleration are marked "not provided" (covariance[0] = −1).

    >>> r = parse_sentence("$C90.0P0.0R0.0T25.0*1B")
    >>> q = reading_to_imu(r, msgs.Time()).orientation
    >>> round(q.w, 9), round(q.z, 9)
    (1.0, 0.0)
    """
    tilted = math.isfinite(reading.pitch_deg) and math.isfinite(reading.roll_deg)
    roll = math.radians(reading.roll_deg) if tilted else 0.0
    pitch = -math.radians(reading.pitch_deg) if tilted else 0.0
    yaw = reading.yaw
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    orientation = msgs.Quaternion(x=sr * cp * cy - cr * sp * sy, y=cr * sp * cy + sr * cp * sy,
                                  z=cr * cp * sy - sr * sp * cy, w=cr * cp * cy + sr * sp * sy)
    tilt_var = TILT_STD ** 2 if tilted else math.pi ** 2
    not_provided = np.zeros(9)
    not_provided[0] = -1.0
    return msgs.Imu(header=msgs.Header(stamp, frame_id), orientation=orientation,
                    orientation_covariance=np.diag([tilt_var, tilt_var,
                                                    HEADING_STD ** 2]).ravel(),
                    angular_velocity_covariance=not_provided,
                    linear_acceleration_covariance=not_provided.copy())


class LineSplitter:
    """Bytes → complete lines (CR/LF separated); a line without an end is kept for later,
    and a runaway line longer than ``limit`` is dropped rather than grown forever. Each
    line starts at its last ``$`` (text before it is the compass's chatter, or a line end
    lost to noise)."""

    def __init__(self, limit: int = 512) -> None:
        self._buffer = b""
        self.limit = limit
        self.dropped = 0

    def feed(self, data: bytes) -> list[str]:
        return [line for line, _ in self.feed_placed(data)]

    def feed_placed(self, data: bytes) -> list[tuple[str, int]]:
        """As :meth:`feed`, each line with the number of bytes ``data`` holds after the
        line's first byte (its place in what just came, to date it by)."""
        buffer = self._buffer + data
        out = []
        position = 0
        for match in re.finditer(rb"[\r\n]+", buffer):
            raw = buffer[position:match.start()]
            start = raw.rfind(b"$")
            if start >= 0:  # (other lines: free text the compass prints for commands)
                out.append((raw[start:].decode("ascii", "replace"),
                            len(buffer) - (position + start)))
            position = match.end()
        self._buffer = buffer[position:]
        if len(self._buffer) > self.limit:
            self.dropped += len(self._buffer)
            self._buffer = b""
        return out


class Os5000:
    """The compass on a serial port: ``read()`` returns the next valid reading,
    ``read_imu()`` the same as ``sensor_msgs/Imu``.

    Corrupt sentences are counted in ``rejected`` and skipped; no valid sentence within
    ``timeout`` raises :class:`DeviceTimeout`. ``baudrate`` is the compass's (19200 from the
    factory; firmware 1.0: 9600). ``fields`` is the output mask the compass is set to
    (:meth:`set_fields` keeps it), which format 2 needs to name its values.
    """

    def __init__(self, port: Any, timeout: float = 0.5,
                 clock: Callable[[], float] = time.monotonic, *, baudrate: int = BAUDRATE,
                 sleep: Callable[[float], None] = time.sleep,
                 stamp: Callable[[], float] | None = None, frame_id: str = "imu_link",
                 fields: int = 15) -> None:
        self.link = Link(DEVICE, port, baudrate, 0.01, clock, sleep, stamp)
        self.timeout = timeout
        self.clock = clock
        self.frame_id = frame_id
        self.fields = fields
        self.lines = LineSplitter()
        self.rejected = 0
        self.rate: float | None = None
        """sentences per second, once :meth:`set_rate` set it: then lines are dated by the
        compass's own pace (:class:`~kit.drivers.timing.SampleClock`)."""
        self._pending: list[tuple[str, float]] = []
        self._last_stamp = -float("inf")
        self._pace: SampleClock | None = None
        self._lines_seen = 0

    def set_rate(self, hz: int) -> None:
        """``<ESC>R<n><CR>``: sentences per second (0 stops the stream; a negative n is n
        seconds per sentence)."""
        self._command("R", hz)
        self.rate = float(hz) if hz > 0 else (1.0 / -hz if hz < 0 else None)
        self._pace = None

    def _command(self, letter: str, value: int | None = None) -> None:
        text = "\x1b" + letter + ("" if value is None else f"{int(value)}\r")
        self.link.write(text.encode("ascii"), f"<ESC>{letter}")

    def set_fields(self, mask: int = 15) -> None:
        """``<ESC>X<mask>``: 1 heading, 2 pitch, 4 roll, 8 temperature, 64 magnetometer,
        256 accelerometer … (15 = heading, pitch, roll, temperature)."""
        if not 0 < mask < 4096:
            raise ValueError(f"the field mask is 1..4095; got {mask}")
        self._command("X", mask)
        self.fields = mask

    def set_format(self, fmt: int = 1) -> None:
        """``<ESC>*<n>``: 1 ``$C…`` (the kit's), 2 ``$OHPR,…``, 4 ``$HCHDT,…``."""
        if fmt not in (1, 2, 4, 8, 16):
            raise ValueError(f"OS5000 formats are 1, 2, 4, 8, 16; got {fmt}")
        self._command("*", fmt)

    def set_declination(self, degrees: float) -> None:
        """``<ESC>Q<n>``: magnetic declination, sent × 10."""
        self._command("Q", round(degrees * 10))

    def read_stamped(self) -> tuple[CompassReading, float]:
        """The next valid reading and when the compass sent its line [s, stamping clock]:
        by the compass's own pace once :meth:`set_rate` has set it (lines counted, their
        arrivals bounding when the count began); otherwise the arrival of what came with it
        less the time the bytes from the line's first one on took at the link's rate. Never
        closer to the line before than that line took to send."""
        deadline = self.clock() + self.timeout
        byte_time = 10.0 / self.link.baudrate
        while True:
            while self._pending:
                line, sent = self._pending.pop(0)
                try:
                    reading = _parse(line, self.fields)
                except (ChecksumError, ProtocolError):
                    self.rejected += 1
                    continue
                sent = max(sent, self._last_stamp + (len(line) + 2) * byte_time)
                self._last_stamp = sent
                return reading, sent
            if self.clock() >= deadline:
                raise DeviceTimeout(DEVICE, f"no valid sentence within {self.timeout:g} s")
            data = self.link.read_some("read")
            arrived = self.link.stamp()
            placed = self.lines.feed_placed(data)
            if self.rate is None or not placed:
                self._pending.extend((line, arrived - after * byte_time) for line, after in placed)
                continue
            if self._pace is None:
                self._pace = SampleClock(1.0 / self.rate)
            first = self._lines_seen
            self._lines_seen += len(placed)
            after = placed[-1][1]  # the last line's first byte came this long before:
            self._pace.observe(self._lines_seen, arrived - after * byte_time)
            self._pending.extend((line, self._pace.time_of(first + k))
                                 for k, (line, _) in enumerate(placed))

    def reopen(self) -> None:
        """Open the port again after it failed (the compass unplugged and back)."""
        self.link.reopen()
        self._pending.clear()

    def read(self) -> CompassReading:
        return self.read_stamped()[0]

    def read_imu(self) -> msgs.Imu:
        """The next reading as ``sensor_msgs/Imu`` (:func:`reading_to_imu`), stamped when
        the compass sent it (:meth:`read_stamped`)."""
        reading, arrived = self.read_stamped()
        return reading_to_imu(reading, msgs.Time.from_sec(arrived), self.frame_id)

    def close(self) -> None:
        self.link.close()
