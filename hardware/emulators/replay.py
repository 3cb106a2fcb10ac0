"""A recorded RPLidar byte stream played back as the device: the real bytes through the
real driver, over a pseudo-terminal, at the pace the link carries them.

:func:`read_capture` reads the formats the captures in ``shared/data/device-captures``
come in (raw binary; one ``0xNN`` per line as a pyserial logger writes them; RealTerm hex
dumps annotated with ``-> comment``). :class:`CaptureReplay` answers ``GET_HEALTH`` with the
capture's own health reply (or a good one) and, on ``SCAN``/``FORCE_SCAN``, sends the whole
capture — whatever the relay put before its scan descriptor included — at 115200 baud,
until ``STOP``.
"""

from __future__ import annotations

import re
from pathlib import Path

from hardware.emulators.core import Device, Faults
from kit.drivers.rplidar import FORCE_SCAN, GET_HEALTH, SCAN, STOP

__all__ = ["CaptureReplay", "read_capture"]

HEALTH = bytes.fromhex("A55A0300000006")
_HEX = re.compile(r"^(?:0x)?[0-9A-Fa-f]{2}$")


def read_capture(path: str | Path) -> bytes:
    """The bytes of a capture file: raw binary (``.bin``), or text with one hex byte per
    token (``0x3e`` or ``3E``), where anything after ``->`` on a line is a comment.

    Raises
    ------
    ValueError
        A text capture holding a token that is not a hex byte.
    """
    path = Path(path)
    raw = path.read_bytes()
    if path.suffix.lower() == ".bin":
        return raw
    out = bytearray()
    for number, line in enumerate(raw.decode("ascii", "replace").splitlines(), start=1):
        for token in line.split("->", 1)[0].split():
            if not _HEX.match(token):
                raise ValueError(f"{path.name}, line {number}: {token!r} is not a hex byte "
                                 f"(expected 3E or 0x3e)")
            out.append(int(token, 16))
    return bytes(out)


class CaptureReplay(Device):
    """An RPLidar that sends a recorded stream when asked to scan.

    Parameters
    ----------
    capture : bytes
        What the device (or the relay in front of it) sent.
    chunk : int
        Bytes handed to the port at a time (each leaves when its last byte would have, at
        115200 baud).
    """

    name = "rplidar-replay"
    baudrate = 115200

    def __init__(self, capture: bytes, chunk: int = 32, faults: Faults | None = None) -> None:
        super().__init__(faults)
        if not capture:
            raise ValueError("an empty capture has nothing to replay")
        if chunk < 1:
            raise ValueError(f"chunk must be at least one byte; got {chunk}")
        self.capture = capture
        self.chunk = chunk
        at = capture.find(HEALTH)
        self.health_reply = capture[at:at + 10] if at >= 0 and len(capture) >= at + 10 \
            else HEALTH + bytes(3)
        self._buffer = bytearray()
        self._position: int | None = None  # next byte of the capture to send while scanning
        self._next = 0.0
        self.replays = 0

    @property
    def done(self) -> bool:
        """The whole capture has been sent (and nothing is being replayed)."""
        return self.replays > 0 and self._position is None

    def receive(self, data: bytes, now: float) -> None:
        buf = self._buffer
        buf += data
        while len(buf) >= 2:
            if buf[0] != 0xA5:
                del buf[:1]
                continue
            command = buf[1]
            del buf[:2]
            if command == GET_HEALTH:
                self.send(self.health_reply, now)
            elif command in (SCAN, FORCE_SCAN):
                self._position, self._next = 0, max(now + self.latency, self._line_free)
                self.replays += 1
            elif command == STOP:
                self._position = None
                self.flush_output()

    def stream(self, now: float) -> None:
        while self._position is not None and self._next <= now:
            piece = self.capture[self._position:self._position + self.chunk]
            self.send(piece, self._next, reply=False)
            self._next = self._line_free
            self._position += len(piece)
            if self._position >= len(self.capture):
                self._position = None
