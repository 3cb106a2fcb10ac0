"""SICK LMS291-S05 (LMS2xx) laser scanner: telegrams with SICK's CRC, the baud and mode
switches, and ``B0`` measurement telegrams turned into ``LaserScan`` messages.

Telegram: ``02 | ADR | LEN (u16 LE) | CMD DATA… [STATUS] | CRC (u16 LE)``; LEN counts CMD up
to the status byte; the CRC (SICK's own) covers STX to the last payload byte. Requests go
to address 00; replies come from ``0x80 | address`` with the request code + 0x80 and a
status byte, each announced by a single ACK byte (``06``; ``15`` is a NAK). Facts and
vectors: ``protocols.md`` §3.

Geometry: value ``i`` lies at ``start + i × resolution`` counter-clockwise with 0° on the
scanner's right and 90° straight ahead, so in ``laser_link`` (x forward) the scan starts at
``start − 90°``: −90° … +90° for the 180° variants, −50° … +50° for the 100° ones.

A scan is stamped when it was measured: the arrival of its telegram (telegrams read together
came back to back, so each ended where the next began) less the telegram's own transmission
time at the link's rate and the mirror's turns it took (1/75 s per turn, two for 0.5°, four
for 0.25°); stamps increase strictly. (Telegrams that waited on the port before a read are
dated from that read: late by as long as they waited, at most.) The first exchange at each
rate is asked twice (a telegram an earlier program left unfinished in the scanner costs the
first one).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from kit import msgs
from kit.drivers.checksums import crc16_sick
from kit.drivers.errors import ChecksumError, DeviceError, DeviceTimeout, ProtocolError
from kit.drivers.port import Link

__all__ = ["BAUD_COMMANDS", "DEVICE", "LMS2xx", "Scan", "Telegram", "TelegramParser",
           "decode_scan", "encode_telegram", "scan_to_laserscan"]

DEVICE = "LMS2xx"
STX, ACK, NAK = 0x02, 0x06, 0x15
MAX_PAYLOAD = 812
BAUD_COMMANDS = {9600: 0x42, 19200: 0x41, 38400: 0x40, 500000: 0x48}
MODE_STREAM, MODE_MONITOR = 0x24, 0x25
SEVERITY = {0: "no error", 1: "information", 2: "warning", 3: "error", 4: "fatal error"}


def encode_telegram(payload: bytes, address: int = 0x00) -> bytes:
    """``02 ADR LEN payload CRC``.

    >>> encode_telegram(bytes([0x20, 0x24])).hex(" ").upper()
    '02 00 02 00 20 24 34 08'
    """
    if not 1 <= len(payload) <= MAX_PAYLOAD:
        raise ValueError(f"a telegram carries 1..{MAX_PAYLOAD} payload bytes; got {len(payload)}")
    body = bytes([STX, address]) + len(payload).to_bytes(2, "little") + bytes(payload)
    return body + crc16_sick(body).to_bytes(2, "little")


@dataclass(frozen=True)
class Telegram:
    address: int
    payload: bytes
    """CMD … STATUS (replies) or CMD … DATA (requests)."""

    @property
    def command(self) -> int:
        return self.payload[0]

    @property
    def is_reply(self) -> bool:
        return bool(self.address & 0x80)

    @property
    def status(self) -> int:
        """The status byte of a reply (its last payload byte)."""
        return self.payload[-1]


class TelegramParser:
    """Bytes → checked telegrams, resynchronising after corruption.

    ACK and NAK bytes between telegrams are counted (``acks``, ``naks``); a candidate
    telegram is taken only when its STX, address, length and CRC all check, otherwise one
    byte is dropped and the search goes on one byte after the candidate's start — so a
    valid telegram after corrupted bytes is never lost. SICK's framing has no header check,
    so a corrupted length could hold back the telegrams behind it until up to 818 bytes
    have come; a candidate is therefore dropped as soon as a whole valid telegram is seen
    starting inside it (a genuine telegram holding one by chance: about 2⁻¹⁶ × its
    framing's odds). ``replies=True`` accepts only reply addresses (bit 7 set), as a host
    does.
    """

    def __init__(self, replies: bool = True) -> None:
        self.replies = replies
        self._buffer = bytearray()
        self.acks = self.naks = self.dropped = 0
        self.errors: list[str] = []

    def _size(self, buf: bytearray, k: int) -> int | None:
        """The whole size of a plausible telegram header at ``k``, or ``None``."""
        if buf[k] != STX or len(buf) < k + 4:
            return None
        address, length = buf[k + 1], buf[k + 2] | buf[k + 3] << 8
        if (self.replies and not address & 0x80) or not 1 <= length <= MAX_PAYLOAD:
            return None
        return 4 + length + 2

    def _valid_at(self, buf: bytearray, k: int) -> bool:
        size = self._size(buf, k)
        if size is None or len(buf) < k + size:
            return False
        crc = buf[k + size - 2] | buf[k + size - 1] << 8
        return crc16_sick(bytes(buf[k:k + size - 2])) == crc

    def _telegram_inside(self, buf: bytearray, size: int) -> bool:
        k = buf.find(STX, 1, size)
        while k >= 0:
            if self._valid_at(buf, k):
                return True
            k = buf.find(STX, k + 1, size)
        return False

    def _drop(self, why: str | None) -> None:
        if why:
            self.errors.append(why)
        self.dropped += 1
        del self._buffer[:1]

    def feed(self, data: bytes) -> list[Telegram]:
        buf = self._buffer
        buf += data
        out: list[Telegram] = []
        while buf:
            if buf[0] != STX:
                if buf[0] == ACK:
                    self.acks += 1
                elif buf[0] == NAK:
                    self.naks += 1
                else:
                    self.dropped += 1
                del buf[:1]
                continue
            if len(buf) < 4:
                break
            size = self._size(buf, 0)
            if size is None:
                self._drop(None)
                continue
            if len(buf) < size:
                if self._telegram_inside(buf, len(buf)):
                    self._drop("a telegram cut short: another telegram inside it")
                    continue
                break
            crc = buf[size - 2] | buf[size - 1] << 8
            if crc16_sick(bytes(buf[:size - 2])) != crc:
                self._drop("CRC mismatch")
                continue
            out.append(Telegram(buf[1], bytes(buf[4:size - 2])))
            del buf[:size]
        return out


@dataclass(frozen=True)
class Scan:
    """A decoded ``B0`` telegram."""

    ranges: np.ndarray
    """metres; ``inf`` where the value is a no-echo/dazzle/error code (≥ 0x1FF7)."""
    flags: np.ndarray
    """the value word's top bits (field A, field B, dazzle)."""
    unit_mm: bool
    partial: bool
    status: int


def decode_scan(payload: bytes, range_bits: int = 13) -> Scan:
    """A ``B0`` reply payload (``B0 count values… STATUS``) → ranges in metres.

    >>> s = decode_scan(bytes([0xB0, 0x02, 0x00, 0xE8, 0x03, 0xFF, 0x1F, 0x10]))
    >>> s.ranges.tolist(), s.unit_mm
    ([10.0, inf], False)
    """
    if len(payload) < 4 or payload[0] != 0xB0:
        raise ProtocolError(DEVICE, "not a B0 measurement telegram")
    count = payload[1] | payload[2] << 8
    n = count & 0x3FF
    unit_mm = (count >> 14) & 0x3 == 1
    body = payload[3:-1]
    if len(body) < 2 * n or len(body) > 2 * n + 2:
        raise ProtocolError(DEVICE, f"B0 telegram says {n} values but carries "
                                    f"{len(body)} data bytes")
    words = np.frombuffer(body[:2 * n], dtype="<u2")
    mask = (1 << range_bits) - 1
    raw = (words & mask).astype(np.float64)
    invalid = raw >= (0x1FF7 if range_bits == 13 else mask - 8)
    ranges = raw / (1000.0 if unit_mm else 100.0)
    ranges[invalid | (raw == 0)] = np.inf
    return Scan(ranges, (words >> range_bits).astype(np.uint8), unit_mm,
                bool(count & (1 << 13)), payload[-1])


def scan_to_laserscan(scan: Scan, angle_deg: int, resolution: float, stamp: msgs.Time,
                      frame_id: str = "laser_link", scan_time: float = 1 / 75) -> msgs.LaserScan:
    """Counter-clockwise ``LaserScan`` in ``laser_link`` (x forward) for a variant."""
    start = 0.0 if angle_deg == 180 else 40.0
    increment = math.radians(resolution)
    n = len(scan.ranges)
    angle_min = math.radians(start - 90.0)
    range_max = 8.191 if scan.unit_mm else 81.91
    return msgs.LaserScan(
        header=msgs.Header(stamp, frame_id), angle_min=angle_min,
        angle_max=angle_min + increment * (n - 1), angle_increment=increment,
        time_increment=scan_time / 360.0 * resolution, scan_time=scan_time, range_min=0.0,
        range_max=range_max, ranges=scan.ranges.astype(np.float32),
        intensities=np.zeros(0, np.float32))


class LMS2xx:
    """An LMS2xx on a serial port (RS-232/RS-422 adapter, pseudo-terminal, logical port).

    ``baudrate`` is the rate the port is opened at (9600, the scanner's power-on rate);
    :meth:`connect` finds the scanner's rate (9600, then 38400, 19200, 500000), switches to
    the rate asked for and sets the variant; :meth:`start` streams; :meth:`read_scan` returns the
    next scan as a ``LaserScan``; :meth:`stop` goes back to monitoring mode.
    """

    def __init__(self, port: Any, timeout: float = 1.0, tries: int = 3,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep,
                 frame_id: str = "laser_link", *, baudrate: int = 9600,
                 stamp: Callable[[], float] | None = None) -> None:
        if baudrate not in BAUD_COMMANDS:
            raise ValueError(f"the LMS2xx runs at {sorted(BAUD_COMMANDS)} baud; got {baudrate}")
        self.link = Link(DEVICE, port, baudrate, 0.01, clock, sleep, stamp)
        self.timeout = timeout
        self.tries = tries
        self.frame_id = frame_id
        self.parser = TelegramParser()
        self.angle, self.resolution = 180, 1.0
        self.unit_mm = False
        self.warnings: list[str] = []
        self._queue: list[Telegram] = []
        self._ended: list[float] = []  # when each queued telegram's last byte came, best guess
        self.streaming = False
        self._connected: tuple[int, int, float] | None = None
        self._last_stamp = -float("inf")
        self._last_end = 0.0

    # ------------------------------------------------------------------ telegrams
    def _await(self, code: int, what: str, timeout: float) -> Telegram:
        link = self.link
        deadline = link.clock() + timeout
        naks = self.parser.naks
        while True:
            while self._queue:
                t = self._queue.pop(0)
                self._last_end = self._ended.pop(0)
                if t.command == code:
                    return t
                if t.command == 0x92:
                    raise DeviceError(DEVICE, f"{what}: command rejected (92)", 0x92)
            if self.parser.naks > naks:
                raise ChecksumError(DEVICE, f"{what}: the scanner answered NAK")
            if link.clock() >= deadline:
                raise DeviceTimeout(DEVICE, f"{what}: no reply within {timeout:g} s")
            telegrams = self.parser.feed(link.read_some(what))
            arrived, ends = link.stamp(), []
            for t in reversed(telegrams):  # back to back: each ended as the next began
                ends.append(arrived)
                arrived -= 10 * (len(t.payload) + 6) / link.baudrate
            self._queue.extend(telegrams)
            self._ended.extend(reversed(ends))

    def request(self, payload: bytes, what: str, timeout: float | None = None) -> Telegram:
        """Send a request and return its checked reply (code + 0x80), trying ``tries``
        times; a reply whose status says error or fatal raises :class:`DeviceError`."""
        code = (payload[0] + 0x80) & 0xFF
        last: Exception | None = None
        for attempt in range(self.tries):
            if attempt:
                self.link.sleep(0.03)  # at least 30 ms after a NAK
            self.link.clear(what)
            self._queue.clear()
            self._ended.clear()
            self.parser = TelegramParser()
            self.link.write(encode_telegram(payload), what)
            try:
                reply = self._await(code, what, timeout or self.timeout)
            except (ChecksumError, DeviceTimeout) as exc:
                last = exc
                continue
            self._check_status(reply, what)
            return reply
        assert last is not None
        raise last

    def _check_status(self, reply: Telegram, what: str) -> None:
        severity = reply.status & 0x07
        if severity >= 3:
            raise DeviceError(DEVICE, f"{what}: the scanner reports "
                                      f"{SEVERITY.get(severity, 'an unknown state')} "
                                      f"(status 0x{reply.status:02X})", reply.status)
        if severity == 2:
            self.warnings.append(f"{what}: warning (status 0x{reply.status:02X})")

    # ------------------------------------------------------------------ sequence
    def status(self) -> bytes:
        """The status telegram's data (B1 … before the status byte)."""
        return self.request(b"\x31", "status").payload[:-1]

    def device_type(self) -> str:
        return self.request(b"\x3a", "type").payload[1:-1].decode("ascii", "replace").strip()

    def find_baudrate(self) -> int:
        """Try 9600, 38400, 19200, 500000 until the status request is answered."""
        for baud in (9600, 38400, 19200, 500000):
            self.link.set_baudrate(baud, "find baud rate")
            self.link.sleep(0.01)
            try:
                tries, self.tries = self.tries, 2  # the first exchange, once more
                try:
                    self.request(b"\x31", f"status at {baud} baud", timeout=0.25)
                finally:
                    self.tries = tries
                return baud
            except (DeviceTimeout, ChecksumError):
                continue
        raise DeviceTimeout(DEVICE, "no answer to the status request at 9600, 38400, 19200 "
                                    "or 500000 baud")

    def set_baudrate(self, baud: int) -> None:
        """``20 4x``: the scanner answers at the old rate; then the host switches."""
        if baud not in BAUD_COMMANDS:
            raise ValueError(f"the LMS2xx runs at {sorted(BAUD_COMMANDS)} baud; got {baud}")
        reply = self.request(bytes([0x20, BAUD_COMMANDS[baud]]), f"switch to {baud} baud",
                             timeout=3.0)
        if reply.payload[1] != 0:
            raise DeviceError(DEVICE, f"switch to {baud} baud refused ({reply.payload[1]})",
                              reply.payload[1])
        self.link.set_baudrate(baud, f"switch to {baud} baud")
        self.link.sleep(0.25)
        self.request(b"\x31", f"status at {baud} baud")

    def set_variant(self, angle: int, resolution: float) -> None:
        """``3B``: scanning angle (100 or 180 degrees) and resolution (0.25, 0.5, 1)."""
        res = round(resolution * 100)
        reply = self.request(b"\x3b" + angle.to_bytes(2, "little") + res.to_bytes(2, "little"),
                             f"set variant {angle}°/{resolution}°")
        if reply.payload[1] != 1:
            raise DeviceError(DEVICE, f"variant {angle}°/{resolution}° refused", reply.payload[1])
        self.angle, self.resolution = angle, res / 100.0

    def connect(self, baudrate: int = 38400, angle: int = 180, resolution: float = 1.0) -> None:
        """Find the scanner, switch to ``baudrate``, set the variant."""
        found = self.find_baudrate()
        if found != baudrate:
            self.set_baudrate(baudrate)
        self.set_variant(angle, resolution)
        self._connected = (baudrate, angle, resolution)

    def reopen(self) -> None:
        """Open the port again after it failed (the scanner unplugged and back, maybe at
        its power-on rate) and connect and stream again as before."""
        streaming = self.streaming
        self.link.reopen()
        if self._connected is not None:
            self.connect(*self._connected)
        if streaming:
            self.start()

    def _mode(self, mode: int, what: str) -> None:
        reply = self.request(bytes([0x20, mode]), what, timeout=3.0)
        if reply.payload[1] != 0:
            raise DeviceError(DEVICE, f"{what}: refused ({reply.payload[1]})", reply.payload[1])

    def start(self) -> None:
        """``20 24``: stream every scan."""
        self._mode(MODE_STREAM, "start streaming")
        self.streaming = True

    def stop(self) -> None:
        """``20 25``: back to monitoring mode (B0 telegrams still queued are skipped)."""
        self.streaming = False
        self._mode(MODE_MONITOR, "stop streaming")

    def read_scan(self, stamp: msgs.Time | None = None) -> msgs.LaserScan:
        """The next streamed scan (``B0``), as a ``LaserScan`` stamped when it was measured
        (see the module)."""
        reply = self._await(0xB0, "read scan", self.timeout)
        arrived = self._last_end
        self._check_status(reply, "read scan")
        scan = decode_scan(reply.payload)
        self.unit_mm = scan.unit_mm
        scan_time = round(1.0 / self.resolution) / 75.0
        sent = 10 * (len(reply.payload) + 6) / self.link.baudrate  # the frame and its CRC
        measured = max(arrived - sent - scan_time, self._last_stamp + 1e-6)
        self._last_stamp = measured
        t = stamp if stamp is not None else msgs.Time.from_sec(measured)
        return scan_to_laserscan(scan, self.angle, self.resolution, t, self.frame_id,
                                 scan_time)

    def close(self) -> None:
        self.link.close()
