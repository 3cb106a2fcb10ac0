"""AMC DPRALTE-060B080 servo drive over RS-485: frames, parsing, and a driver.

Request (host → drive)::

    A5 | address | control | index | offset | N | header CRC (MSB first) | data (2N, LE) | data CRC

``control`` holds the command in bits 1..0 (1 = read, 2 = write) and a sequence number in
bits 5..2 that the reply echoes. Both CRCs are CRC-16/XMODEM, sent high byte first; the
header CRC covers bytes 0–5, the data CRC the data alone. A reply has the same shape with
``FF`` as address, status bytes in place of index and offset, and data only when its
command bits are 2. Facts and test vectors: ``shared/specs/protocols.md`` §1.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from kit.drivers.checksums import crc16_xmodem
from kit.drivers.errors import DeviceError, DeviceTimeout, ProtocolError
from kit.drivers.port import Link

__all__ = ["DEVICE", "DpralteDrive", "Frame", "FrameParser", "encode_read", "encode_write",
           "int32_words", "rpm_to_units", "units_to_rpm"]

DEVICE = "DPRALTE"
BAUDRATE = 115200
SOF = 0xA5
MASTER = 0xFF
READ, WRITE = 1, 2
UNITS_PER_COUNT_PER_SECOND = 2**17 / 20000  # 2^17 / the drive's 20 kHz switching frequency
STATUS = {1: "command complete", 2: "command incomplete", 3: "invalid command",
          4: "invalid command", 6: "no write access", 8: "frame or CRC error"}

# parameters (index, offset) of §1.5
ACCESS = (0x07, 0x00)
CONTROL_WORD = (0x01, 0x00)
BRIDGE_STATUS = (0x02, 0x00)
POSITION = (0x12, 0x00)
VELOCITY = (0x11, 0x02)


def _control(command: int, sequence: int) -> int:
    if command not in (READ, WRITE):
        raise ValueError(f"command must be 1 (read) or 2 (write); got {command}")
    if not 0 <= sequence <= 15:
        raise ValueError(f"sequence must be 0..15; got {sequence}")
    return command | (sequence << 2)


def _header(address: int, control: int, a: int, b: int, words: int) -> bytes:
    for name, value in (("address", address), ("index/status", a), ("offset/status", b),
                        ("words", words)):
        if not 0 <= value <= 0xFF:
            raise ValueError(f"{name} must fit in a byte; got {value}")
    head = bytes([SOF, address, control, a, b, words])
    return head + crc16_xmodem(head).to_bytes(2, "big")


def int32_words(value: int) -> bytes:
    """A signed 32-bit value as the two data words the drive expects (4 bytes LE)."""
    if not -(2**31) <= value < 2**31:
        raise ValueError(f"{value} does not fit a signed 32-bit value")
    return int(value).to_bytes(4, "little", signed=True)


def encode_write(address: int, index: int, offset: int, data: bytes, sequence: int = 0) -> bytes:
    """A write request: header, ``data`` (whole 16-bit words, LE) and its CRC.

    >>> encode_write(0x3F, 0x45, 0x02, int32_words(437)).hex(" ").upper()
    'A5 3F 02 45 02 02 96 2B B5 01 00 00 7A A4'
    """
    if len(data) % 2 or not data:
        raise ValueError(f"data must be one or more 16-bit words; got {len(data)} bytes")
    head = _header(address, _control(WRITE, sequence), index, offset, len(data) // 2)
    return head + data + crc16_xmodem(data).to_bytes(2, "big")


def encode_read(address: int, index: int, offset: int, words: int, sequence: int = 0) -> bytes:
    """A read request for ``words`` 16-bit words.

    >>> encode_read(0x3F, 0x12, 0x00, 2).hex(" ").upper()
    'A5 3F 01 12 00 02 B0 CB'
    """
    return _header(address, _control(READ, sequence), index, offset, words)


def rpm_to_units(rpm: float, counts_per_rev: int = 400) -> int:
    """Velocity command units: counts/s × 2¹⁷/20000, rounded (10 RPM → 437)."""
    return round(rpm * counts_per_rev / 60.0 * UNITS_PER_COUNT_PER_SECOND)


def units_to_rpm(units: int, counts_per_rev: int = 400) -> float:
    return units / UNITS_PER_COUNT_PER_SECOND * 60.0 / counts_per_rev


@dataclass(frozen=True)
class Frame:
    """One checked frame. For a request ``a, b`` are index and offset; for a reply they are
    the two status bytes."""

    address: int
    command: int
    sequence: int
    a: int
    b: int
    words: int
    data: bytes

    @property
    def is_reply(self) -> bool:
        return self.address == MASTER

    @property
    def status(self) -> int:
        return self.a

    def int32(self, word: int = 0) -> int:
        """The signed 32-bit value starting at data word ``word``."""
        chunk = self.data[2 * word:2 * word + 4]
        if len(chunk) != 4:
            raise ProtocolError(DEVICE, f"reply has {len(self.data)} data bytes, not a 32-bit "
                                        f"value at word {word}")
        return int.from_bytes(chunk, "little", signed=True)

    def uint16(self, word: int = 0) -> int:
        return int.from_bytes(self.data[2 * word:2 * word + 2], "little")


class FrameParser:
    """Turns any byte stream into checked frames, resynchronising after corruption.

    Bytes are buffered until a whole frame is there. A candidate that fails its header CRC
    or data CRC is dropped by one byte — the search for the next ``A5`` starts again one
    byte after the candidate's start, so no byte a later frame may own is skipped.

    One more rule makes truncated frames harmless: a frame never holds a whole valid header
    inside it. A reply cut short after its header (say one announcing 3 words) would
    otherwise take the next frame as its data, and because a header followed by its own
    CRC leaves a zero CRC residue (as does any run of whole frames), its data CRC would
    pass: a phantom frame, and the real one lost. So a candidate with a valid header
    starting inside its span is dropped as soon as that header is seen (even before the
    candidate's announced length has arrived).

    A header is also held to the protocol (:meth:`_header_at`: a read or write control
    byte, a node's or the master's address, a reply status drives send). That matters for
    3-word data: its 6 bytes and their CRC are 8 bytes with a zero CRC residue, exactly
    like a header, so a 3-word frame whose data starts with ``A5`` carries a header-shaped
    block; it passes for one only if its next bytes also follow the protocol (about 1 in
    8000 such blocks), and only then is the frame around it refused or a phantom taken.
    ``dropped`` counts the bytes thrown away, ``errors`` the reasons.
    """

    def __init__(self) -> None:
        self._buffer = bytearray()
        self.dropped = 0
        self.errors: list[str] = []

    def reset(self) -> None:
        """Forget any bytes held (a new transaction: stale or partial replies go)."""
        self.dropped += len(self._buffer)
        self._buffer.clear()

    @staticmethod
    def _header_at(buf: bytearray, k: int) -> bool:
        """Whether a whole header that could be real starts at ``k``: its CRC checks, its
        control byte is a read or a write with bits 7..6 clear, its address is a node's
        (0x00–0x3F) or the master's (0xFF), and a reply's status is one drives send."""
        if k + 8 > len(buf) or crc16_xmodem(bytes(buf[k:k + 8])) != 0:
            return False
        address, control = buf[k + 1], buf[k + 2]
        if control & 0xC0 or (control & 0x03) not in (READ, WRITE):
            return False
        if address == MASTER:
            return buf[k + 3] in STATUS
        return address <= 0x3F

    def _header_inside(self, buf: bytearray, size: int) -> bool:
        """Whether a whole valid header starts within ``buf[8:size]``."""
        k = buf.find(SOF, 8, size)
        while k >= 0:
            if self._header_at(buf, k):
                return True
            k = buf.find(SOF, k + 1, size)
        return False

    def _drop(self, why: str) -> None:
        self.errors.append(why)
        self.dropped += 1
        del self._buffer[:1]

    def feed(self, data: bytes) -> list[Frame]:
        self._buffer += data
        frames: list[Frame] = []
        buf = self._buffer
        while True:
            start = buf.find(SOF)
            if start < 0:
                self.dropped += len(buf)
                buf.clear()
                return frames
            if start:
                self.dropped += start
                del buf[:start]
            if len(buf) < 8:
                return frames
            if crc16_xmodem(bytes(buf[:8])) != 0:  # header plus its CRC leaves no residue
                self._drop("header CRC mismatch")
                continue
            if not self._header_at(buf, 0):
                self._drop("not a header: control, address or status out of the protocol")
                continue
            command, words = buf[2] & 0x03, buf[5]
            size = 8 + (2 * words + 2 if command == WRITE and words else 0)
            if size > 8 and self._header_inside(buf, size):
                self._drop("a frame cut short: another frame's header inside it")
                continue
            if len(buf) < size:
                return frames
            if size > 8 and crc16_xmodem(bytes(buf[8:size])) != 0:
                self._drop("data CRC mismatch")
                continue
            frames.append(Frame(buf[1], command, (buf[2] >> 2) & 0x0F, buf[3], buf[4], words,
                                bytes(buf[8:size - 2]) if size > 8 else b""))
            del buf[:size]


class DpralteDrive:
    """One drive on an RS-485 bus (any pyserial port URL, or an open port object).

    Parameters
    ----------
    port : str or serial port
        ``"/dev/ttyUSB0"``, ``"socket://..."``, a pseudo-terminal, or an open ``Serial``.
    address : int
        Node address (the IGV: 0x3F right, 0x3E left).
    velocity_offset : int
        Word offset of this drive's velocity command in index 0x45 (configuration).
    timeout : float
        Seconds to wait for a reply before :class:`DeviceTimeout`.
    baudrate : int
        The drive's serial rate (a drive setting; 115200 on the IGV).

    Each transaction starts clean: bytes left from an earlier reply (stale, cut short) are
    dropped, then the request goes out and only a reply from the master address with this
    request's sequence number and word count is taken.
    """

    def __init__(self, port: Any, address: int, velocity_offset: int = 0,
                 timeout: float = 0.25, counts_per_rev: int = 400,
                 clock: Callable[[], float] = time.monotonic, *, baudrate: int = BAUDRATE,
                 sleep: Callable[[float], None] = time.sleep,
                 stamp: Callable[[], float] | None = None) -> None:
        self.link = port if isinstance(port, Link) else \
            Link(DEVICE, port, baudrate, 0.01, clock, sleep, stamp)
        self.address = address
        self.velocity_offset = velocity_offset
        self.timeout = timeout
        self.counts_per_rev = counts_per_rev
        self.clock = self.link.clock
        self.sequence = 0
        self.parser = FrameParser()

    def transact(self, request: bytes, what: str) -> Frame:
        """Send one request and wait for its reply (sequence and word count echoed, status
        checked)."""
        sequence = (request[2] >> 2) & 0x0F
        words = request[5] if request[2] & 0x03 == READ else 0
        self.link.clear(what)
        self.parser.reset()
        self.link.write(request, what)
        deadline = self.clock() + self.timeout
        while self.clock() < deadline:
            for frame in self.parser.feed(self.link.read_some(what)):
                if not frame.is_reply or frame.sequence != sequence:
                    continue  # our own echo on a shared bus, or a stale reply
                if frame.status != 1:
                    meaning = STATUS.get(frame.status, "unknown status")
                    raise DeviceError(DEVICE, f"{what}: {meaning} (status "
                                              f"0x{frame.status:02X})", frame.status)
                if frame.words != words:
                    continue  # not the reply to this request
                return frame
        raise DeviceTimeout(DEVICE, f"{what}: no reply from 0x{self.address:02X} within "
                                    f"{self.timeout:g} s")

    def _next(self) -> int:
        self.sequence = (self.sequence + 1) % 16
        return self.sequence

    def write(self, parameter: tuple[int, int], data: bytes, what: str) -> None:
        self.transact(encode_write(self.address, *parameter, data, self._next()), what)

    def read(self, parameter: tuple[int, int], words: int, what: str) -> Frame:
        return self.transact(encode_read(self.address, *parameter, words, self._next()), what)

    def get_write_access(self) -> None:
        self.write(ACCESS, (0x000F).to_bytes(2, "little"), "get write access")

    def enable(self) -> None:
        self.write(CONTROL_WORD, (0x0000).to_bytes(2, "little"), "enable bridge")

    def disable(self) -> None:
        self.write(CONTROL_WORD, (0x0001).to_bytes(2, "little"), "disable bridge")

    def set_velocity_rpm(self, rpm: float) -> int:
        """Command a wheel speed; returns the drive units sent."""
        units = rpm_to_units(rpm, self.counts_per_rev)
        self.write((0x45, self.velocity_offset), int32_words(units), "set velocity")
        return units

    def read_position(self) -> int:
        """Measured position [encoder counts]."""
        return self.read(POSITION, 2, "read position").int32()

    def read_velocity_rpm(self) -> float:
        return units_to_rpm(self.read(VELOCITY, 2, "read velocity").int32(),
                            self.counts_per_rev)
