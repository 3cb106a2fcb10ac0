"""OceanServer OS5000-S digital compass: its ``$C`` sentences, checked and parsed, and the
heading converted once, here, to REP-103 yaw.

The compass streams ``$C<heading>P<pitch>R<roll>T<temp>…*<cc>\\r\\n`` (checksum: XOR of the
characters between ``$`` and ``*``) and answers commands with free text, which is skipped.
Heading is degrees clockwise from north; REP-103 yaw is counter-clockwise from east:
``yaw = π/2 − heading`` (wrapped to [−π, π)). Facts and vectors: ``protocols.md`` §2.
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass, field
from typing import Any

from kit.drivers.checksums import nmea_checksum
from kit.drivers.errors import ChecksumError, DeviceTimeout, ProtocolError
from kit.drivers.port import Link
from kit.geometry import wrap_angle

__all__ = ["DEVICE", "CompassReading", "LineSplitter", "Os5000", "heading_to_yaw",
           "parse_sentence"]

DEVICE = "OS5000"
TOKEN = re.compile(r"(Mx|My|Mz|Ax|Ay|Az|[CPRTD])(-?\d+(?:\.\d+)?)")
# a sentence's body holds only tags, numbers and commas: anything else (a NUL byte inserted
# by line noise leaves the XOR unchanged) means a corrupted line
SENTENCE = re.compile(r"^\$([A-Za-z0-9.,-]*)\*([0-9A-Fa-f]{2})$")


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
    roll_deg: float
    temperature_c: float | None
    yaw: float
    """REP-103 yaw [rad] of the heading."""
    extra: dict[str, float] = field(default_factory=dict)
    """any other fields present (Mx, My, Mz, Ax, Ay, Az, D)."""


def parse_sentence(line: str) -> CompassReading:
    """One ``$C…*cc`` line (without CR LF) → a reading.

    Raises
    ------
    ChecksumError
        The two hex digits do not match the line.
    ProtocolError
        Not a ``$C`` sentence, or heading/pitch/roll missing.
    """
    match = SENTENCE.match(line.strip())
    if not match:
        raise ProtocolError(DEVICE, f"not a sentence: {line[:60]!r}")
    body, given = match.group(1), match.group(2).upper()
    if nmea_checksum(body) != given:
        raise ChecksumError(DEVICE, f"checksum {given} does not match "
                                    f"{nmea_checksum(body)} for {body[:60]!r}")
    if body.startswith(("HCHDT,", "OHPR,")):
        return _comma_sentence(body)
    if not body.startswith("C"):
        raise ProtocolError(DEVICE, f"not a compass sentence: {body[:20]!r}")
    values: dict[str, float] = {}
    for tag, number in TOKEN.findall(body):
        values[tag] = float(number)
    for needed in ("C", "P", "R"):
        if needed not in values:
            raise ProtocolError(DEVICE, f"sentence without {needed}: {body[:60]!r}")
    heading = values.pop("C")
    pitch, roll = values.pop("P"), values.pop("R")
    if not (0.0 <= heading <= 360.0 and -90.0 <= pitch <= 90.0 and -180.0 <= roll <= 180.0):
        raise ProtocolError(DEVICE, f"angles out of range: {body[:60]!r}")
    return CompassReading(heading, pitch, roll, values.pop("T", None), heading_to_yaw(heading),
                          values)


def _comma_sentence(body: str) -> CompassReading:
    """Format 4 (``HCHDT,<heading>,T``: heading only; pitch and roll NaN, not provided) and
    format 2 (``OHPR,<heading>,<pitch>,<roll>[,<temperature>…]`` with the default fields)."""
    fields = body.split(",")
    try:
        if fields[0] == "HCHDT":
            if len(fields) != 3 or fields[2] != "T":
                raise ValueError
            heading, pitch, roll, temp = float(fields[1]), math.nan, math.nan, None
        else:
            values = [float(v) for v in fields[1:]]
            if len(values) < 3:
                raise ValueError
            heading, pitch, roll = values[:3]
            temp = values[3] if len(values) > 3 else None
    except ValueError:
        raise ProtocolError(DEVICE, f"malformed sentence: {body[:60]!r}") from None
    if not 0.0 <= heading <= 360.0:
        raise ProtocolError(DEVICE, f"heading out of range: {body[:60]!r}")
    return CompassReading(heading, pitch, roll, temp, heading_to_yaw(heading))


class LineSplitter:
    """Bytes → complete lines (CR/LF separated); a line without an end is kept for later,
    and a runaway line longer than ``limit`` is dropped rather than grown forever."""

    def __init__(self, limit: int = 512) -> None:
        self._buffer = b""
        self.limit = limit
        self.dropped = 0

    def feed(self, data: bytes) -> list[str]:
        self._buffer += data
        *lines, self._buffer = re.split(rb"[\r\n]+", self._buffer)
        if len(self._buffer) > self.limit:
            self.dropped += len(self._buffer)
            self._buffer = b""
        out = []
        for raw in lines:
            start = raw.rfind(b"$")
            if start < 0:
                continue  # free text the compass prints in answer to commands
            out.append(raw[start:].decode("ascii", "replace"))
        return out


class Os5000:
    """The compass on a serial port: ``read()`` returns the next valid reading.

    Corrupt sentences are counted in ``rejected`` and skipped; no valid sentence within
    ``timeout`` raises :class:`DeviceTimeout`.
    """

    def __init__(self, port: Any, timeout: float = 0.5, clock: Any = time.monotonic) -> None:
        self.link = Link(DEVICE, port, 19200, 0.01, clock)
        self.timeout = timeout
        self.clock = clock
        self.lines = LineSplitter()
        self.rejected = 0
        self._pending: list[str] = []

    def set_rate(self, hz: int) -> None:
        """``<ESC>R<n><CR>``: sentences per second (0 stops the stream)."""
        self._command("R", hz)

    def _command(self, letter: str, value: int | None = None) -> None:
        text = "\x1b" + letter + ("" if value is None else f"{int(value)}\r")
        self.link.write(text.encode("ascii"), f"<ESC>{letter}")

    def set_fields(self, mask: int = 15) -> None:
        """``<ESC>X<mask>``: 1 heading, 2 pitch, 4 roll, 8 temperature, 64 magnetometer,
        256 accelerometer … (15 = heading, pitch, roll, temperature)."""
        self._command("X", mask)

    def set_format(self, fmt: int = 1) -> None:
        """``<ESC>*<n>``: 1 ``$C…`` (the kit's), 2 ``$OHPR,…``, 4 ``$HCHDT,…``."""
        if fmt not in (1, 2, 4, 8, 16):
            raise ValueError(f"OS5000 formats are 1, 2, 4, 8, 16; got {fmt}")
        self._command("*", fmt)

    def set_declination(self, degrees: float) -> None:
        """``<ESC>Q<n>``: magnetic declination, sent × 10."""
        self._command("Q", round(degrees * 10))

    def read(self) -> CompassReading:
        deadline = self.clock() + self.timeout
        while True:
            while self._pending:
                line = self._pending.pop(0)
                try:
                    return parse_sentence(line)
                except (ChecksumError, ProtocolError):
                    self.rejected += 1
            if self.clock() >= deadline:
                raise DeviceTimeout(DEVICE, f"no valid sentence within {self.timeout:g} s")
            self._pending.extend(self.lines.feed(self.link.read_some("read")))
