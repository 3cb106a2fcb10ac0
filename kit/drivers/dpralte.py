"""AMC DPRALTE-060B080 servo drive over RS-485: frames, parsing, and a driver.

Request (host → drive)::

    A5 | address | control | index | offset | N | header CRC (MSB first) | data (2N, LE) | data CRC

``control`` holds the command in bits 1..0 (1 = read, 2 = write) and a sequence number in
bits 5..2 that the reply echoes. Both CRCs are CRC-16/XMODEM, sent high byte first; the
header CRC covers bytes 0–5, the data CRC the data alone. A reply has the same shape with
``FF`` as address, status bytes in place of index and offset, and data only when its
command bits are 2. Facts and test vectors: ``shared/specs/protocols.md`` §1.

**Safety.** ``04.01`` is the drive's communication watchdog (ms, 0 = off; libamc's
``--wdt``): a drive that hears nothing for that long faults — it latches the *comms error*
(system protection status ``02.02`` bit 10, libamc's ``AMC_SS_COMMERR``) and inhibits its
bridge, until the latched events are reset (``01.00`` bit 12). Which frames feed it is not
documented; the kit talks to each drive at least every third of the time-out, and the
emulator takes any frame addressed to the drive as a feed. **[inferred]**: confirm the
fault on blocks with your drives' configuration (AMC's DriveWare sets the response to a
communication error) before relying on it.

**The first exchange gets through.** A frame an earlier program left unfinished in the
drive's receiver would take the next request as its own bytes. :meth:`DpralteDrive.clear_line`
sends 520 bytes of ``FF`` — enough to complete the longest frame (8 header bytes, 255 words,
the CRC), and never a start byte — so whatever the drive held is finished and refused by its
CRC; the drive's answers and the bus's echo are read away; :meth:`DpralteDrive.connect` then
reads the bridge status, once more if the first exchange fails.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from kit.drivers.checksums import crc16_xmodem
from kit.drivers.errors import DeviceError, DeviceTimeout, ProtocolError, failed_twice
from kit.drivers.port import Link

__all__ = ["COMMS_ERROR", "DEVICE", "DpralteDrive", "Frame", "FrameParser", "encode_read",
           "encode_write", "int32_words", "rpm_to_units", "units_to_rpm"]

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
WATCHDOG = (0x04, 0x01)
COMMS_ERROR = 1 << 10
"""``02.02`` (system protection status) bit 10: the comms watchdog ran out (libamc)."""
RESET_EVENTS, INHIBIT, ENABLE = 0x1000, 0x0001, 0x0000
FILL = b"\xff" * (8 + 2 * 255 + 2)
"""what :meth:`DpralteDrive.clear_line` sends: the longest frame, with no start byte."""


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
    alternatives: tuple[Frame, ...] = field(default=(), compare=False, repr=False)
    """another reading of the same bytes: a frame whose data and data CRC are themselves
    whole frames (their CRC residues are zero too) is also those frames, if the frame was
    in fact a header cut short before them. On a clean line the frame is what was sent; a
    reader that knows what it waits for (:meth:`DpralteDrive.transact`) takes the reading
    that fits."""

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

    Bytes are buffered until a whole frame is there. A candidate whose header fails its CRC
    or the protocol (:meth:`_header_at`: a read or write control byte, a node's or the
    master's address, a reply status drives send) is dropped by one byte, and so is one
    whose data CRC fails once its data is complete — the search for the next ``A5`` starts
    again one byte after the candidate's start, so no byte a later frame may own is skipped.

    A frame whose header and data check is what was sent — unless it is a header cut short
    whose announced data happened to be filled by the frames after it: a header followed by
    its own CRC leaves a zero CRC residue, as does any run of whole frames (a 3-word header
    and one 8-byte frame are 16 bytes that check). The tell is a valid header starting inside
    the frame's data. Then:

    * the inner frame ends inside the outer one: the frame comes out with the inner frames
      as its ``alternatives`` (both readings take the same bytes);
    * the inner frame runs on past the outer's end: the parser waits for its bytes (the
      outer is ``held`` meanwhile); if the inner frame checks whole, it is what was sent
      (the outer as its alternative), else the outer is.

    On a clean line no frame is lost and none is made up; :meth:`DpralteDrive.transact`,
    which knows the sequence number and word count it waits for, takes the reading that fits
    (a held frame included). ``dropped`` counts the bytes thrown away, ``errors`` the
    reasons, ``ambiguous`` the frames given with another reading.
    """

    def __init__(self) -> None:
        self._buffer = bytearray()
        self.dropped = 0
        self.ambiguous = 0
        self.errors: list[str] = []
        self.held: Frame | None = None
        """a complete, checked frame waiting for the bytes that tell whether it is one."""

    def reset(self) -> None:
        """Forget any bytes held (a new transaction: stale or partial replies go)."""
        self.dropped += len(self._buffer)
        self._buffer.clear()
        self.held = None

    @staticmethod
    def _header_at(buf: bytes | bytearray, k: int) -> bool:
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

    @staticmethod
    def _size(buf: bytes | bytearray, k: int) -> int:
        command, words = buf[k + 2] & 0x03, buf[k + 5]
        return 8 + (2 * words + 2 if command == WRITE and words else 0)

    @classmethod
    def _frame_at(cls, buf: bytes | bytearray, k: int) -> Frame | None:
        """The whole, checked frame at ``k``, or None."""
        if not cls._header_at(buf, k):
            return None
        size = cls._size(buf, k)
        if k + size > len(buf) or (size > 8 and crc16_xmodem(bytes(buf[k + 8:k + size]))):
            return None
        return _frame(bytes(buf[k:k + size]))

    def _drop(self, why: str) -> None:
        self.errors.append(why)
        self.dropped += 1
        del self._buffer[:1]

    def _judge(self, size: int) -> tuple[Frame, int] | None:
        """The checked frame at the buffer's start (``size`` bytes) as the reading to give
        and the bytes it takes, or None to wait for more bytes."""
        buf = self._buffer
        outer = _frame(bytes(buf[:size]))
        k = buf.find(SOF, 8, size)
        while k >= 0:
            if k + 8 > len(buf):
                return None  # a header may start here: wait for its bytes
            if self._header_at(buf, k):
                break
            k = buf.find(SOF, k + 1, size)
        if k < 0:
            return outer, size
        end = k + self._size(buf, k)
        if end <= size:  # inner frames inside: both readings take the same bytes
            inner = []
            j = k
            while j < size and (frame := self._frame_at(buf, j)) is not None:
                inner.append(frame)
                j += self._size(buf, j)
            if not inner:
                return outer, size
            self.ambiguous += 1
            return _with(outer, tuple(inner)), size
        if len(buf) < end:
            return None  # the inner frame runs on: wait to see whether it checks
        inner_frame = self._frame_at(buf, k)
        if inner_frame is None:
            return outer, size
        self.ambiguous += 1
        self.dropped += k
        return _with(inner_frame, (outer,)), end

    def feed(self, data: bytes) -> list[Frame]:
        self._buffer += data
        frames: list[Frame] = []
        buf = self._buffer
        self.held = None
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
            size = self._size(buf, 0)
            if len(buf) < size:
                return frames
            if size > 8 and crc16_xmodem(bytes(buf[8:size])) != 0:
                self._drop("data CRC mismatch")
                continue
            judged = self._judge(size)
            if judged is None:
                self.held = _frame(bytes(buf[:size]))
                return frames
            frame, taken = judged
            frames.append(frame)
            del buf[:taken]

    def flush(self) -> list[Frame]:
        """The end of the stream: a held frame is what was sent (nothing came after it)."""
        out: list[Frame] = []
        while self.held is not None:
            out.append(self.held)
            self.held = None
            del self._buffer[:self._size(self._buffer, 0)]
            out += self.feed(b"")
        return out


def _with(frame: Frame, alternatives: tuple[Frame, ...]) -> Frame:
    return Frame(frame.address, frame.command, frame.sequence, frame.a, frame.b, frame.words,
                 frame.data, alternatives)


def _frame(raw: bytes) -> Frame:
    """A checked frame's fields."""
    command = raw[2] & 0x03
    return Frame(raw[1], command, (raw[2] >> 2) & 0x0F, raw[3], raw[4], raw[5],
                 raw[8:-2] if len(raw) > 8 else b"")


class DpralteDrive:
    """One drive on an RS-485 bus (any pyserial port URL, or an open port object).

    Parameters
    ----------
    port : str, serial port or Link
        ``"/dev/ttyUSB0"``, ``"socket://..."``, a pseudo-terminal, an open ``Serial``, or
        the :class:`~kit.drivers.port.Link` of a bus shared with another drive.
    address : int
        Node address (the IGV: 0x3F right, 0x3E left).
    velocity_offset : int
        Word offset of this drive's velocity command in index 0x45 (configuration).
    timeout : float
        Seconds to wait for a reply before :class:`DeviceTimeout`.
    baudrate : int
        The drive's serial rate (a drive setting; 115200 on the IGV).

    Each transaction holds the bus's lock and starts clean: bytes left from an earlier reply
    (stale, cut short) are dropped, then the request goes out and only a reply from the
    master address with this request's sequence number and word count is taken.
    ``last_exchange`` is ``(sent, answered)`` of the last reply on the stamping clock.
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
        self.last_exchange = (0.0, 0.0)

    def transact(self, request: bytes, what: str) -> Frame:
        """Send one request and wait for its reply (sequence and word count echoed, status
        checked); of a frame with two readings (:class:`FrameParser`), the one that fits."""
        sequence = (request[2] >> 2) & 0x0F
        words = request[5] if request[2] & 0x03 == READ else 0
        link = self.link
        with link.lock:
            link.clear(what)
            self.parser.reset()
            sent = link.stamp()
            link.write(request, what)
            deadline = self.clock() + self.timeout
            while self.clock() < deadline:
                got = self.parser.feed(link.read_some(what))
                if self.parser.held is not None:  # checked, waiting to be told apart
                    got.append(self.parser.held)
                for outer in got:
                    for frame in (outer, *outer.alternatives):
                        if not frame.is_reply or frame.sequence != sequence:
                            continue  # our own echo on a shared bus, or a stale reply
                        if frame.status != 1:
                            meaning = STATUS.get(frame.status, "unknown status")
                            raise DeviceError(DEVICE, f"{what}: {meaning} (status "
                                                      f"0x{frame.status:02X})", frame.status)
                        if frame.words != words:
                            continue  # not the reply to this request
                        self.last_exchange = (sent, link.stamp())
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

    def clear_line(self, quiet: float = 0.02) -> None:
        """Finish whatever frame an earlier program left in the drive's receiver (:data:`FILL`)
        and read away what answers (a CRC error reply, the bus's echo)."""
        with self.link.lock:
            self.link.write(FILL, "clear the line")
            self.link.drain(quiet + 10 * len(FILL) / self.link.baudrate, self.timeout,
                            "clear the line")
            self.parser.reset()

    def connect(self, clear: bool = True) -> int:
        """Clear the line (unless ``clear=False``: another drive on the bus just did), then
        read the bridge status (``02.00``), once more (the line cleared) if the first
        exchange fails; returns the status word."""
        if clear:
            self.clear_line()
        try:
            return self.read(BRIDGE_STATUS, 1, "read bridge status").uint16()
        except (DeviceTimeout, DeviceError, ProtocolError) as exc:
            if self.link.failure is not None:
                raise
            first = exc
        self.clear_line()
        try:
            return self.read(BRIDGE_STATUS, 1, "read bridge status").uint16()
        except (DeviceTimeout, DeviceError, ProtocolError) as exc:
            raise failed_twice(exc, first) from None

    def get_write_access(self) -> None:
        self.write(ACCESS, (0x000F).to_bytes(2, "little"), "get write access")

    def status(self) -> tuple[int, int, int]:
        """(bridge status ``02.00``, protection status ``02.01``, system protection status
        ``02.02``); bit 0 of the first: bridge enabled; :data:`COMMS_ERROR` in the last."""
        frame = self.read(BRIDGE_STATUS, 3, "read bridge and protection status")
        return frame.uint16(0), frame.uint16(1), frame.uint16(2)

    def reset_events(self) -> None:
        """Clear latched events (a protection fault, a comms watchdog that ran out)."""
        self.write(CONTROL_WORD, RESET_EVENTS.to_bytes(2, "little"), "reset events")
        self.write(CONTROL_WORD, INHIBIT.to_bytes(2, "little"), "reset events")

    def set_comm_watchdog(self, timeout: float) -> None:
        """The drive faults (bridge off, comms error latched) when it hears nothing for
        ``timeout`` s; 0 turns the watchdog off (``04.01``, in ms, at most 65.535 s)."""
        ms = round(timeout * 1000)
        if not 0 <= ms <= 0xFFFF:
            raise ValueError(f"the drive's watchdog takes 0 to 65.535 s; got {timeout}")
        self.write(WATCHDOG, ms.to_bytes(2, "little"), "set the comms watchdog")

    def enable(self) -> None:
        self.write(CONTROL_WORD, ENABLE.to_bytes(2, "little"), "enable bridge")

    def disable(self) -> None:
        self.write(CONTROL_WORD, INHIBIT.to_bytes(2, "little"), "disable bridge")

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
