"""ODrive v3.x (firmware 0.5.x) over its ASCII protocol: properties, velocity commands,
feedback, optional checksums and the axis states of each firmware version.

A request is one line (``r vbus_voltage``, ``v 0 1.5``, ``f 0``); replies are lines ending
in ``\\r\\n``. With ``checksum=True`` every request carries ``*<decimal XOR>`` and every
reply must carry a correct one, so a corrupted reply is rejected rather than believed.
Units are turns and turns/s (0.5.x). Facts and vectors: ``protocols.md`` §4.

Erratum 9: the axis-state numbers changed at firmware 0.5.2 — the Uiabot paper's table
(5 = SENSORLESS_CONTROL) is the 0.5.1 numbering. :func:`axis_state_name` knows both.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from kit.drivers.checksums import odrive_checksum
from kit.drivers.errors import ChecksumError, DeviceError, DeviceTimeout, ProtocolError
from kit.drivers.port import Link

__all__ = ["AXIS_STATES", "DEVICE", "ERROR_REPLIES", "ODrive", "ReplyLines", "ReplySplitter",
           "axis_state_name", "encode_line", "parse_reply"]

DEVICE = "ODrive"
IDLE, FULL_CALIBRATION_SEQUENCE, CLOSED_LOOP_CONTROL = 1, 3, 8
VELOCITY_CONTROL = 2

_COMMON = {0: "UNDEFINED", 1: "IDLE", 2: "STARTUP_SEQUENCE", 3: "FULL_CALIBRATION_SEQUENCE",
           4: "MOTOR_CALIBRATION", 6: "ENCODER_INDEX_SEARCH", 7: "ENCODER_OFFSET_CALIBRATION",
           8: "CLOSED_LOOP_CONTROL", 9: "LOCKIN_SPIN", 10: "ENCODER_DIR_FIND"}
AXIS_STATES: dict[str, dict[int, str]] = {
    "0.5.1": {**_COMMON, 5: "SENSORLESS_CONTROL"},
    "0.5.2": {**_COMMON, 11: "HOMING", 12: "ENCODER_HALL_POLARITY_CALIBRATION",
              13: "ENCODER_HALL_PHASE_CALIBRATION"},
}
"""axis states by firmware: ``"0.5.1"`` (also 0.4.x) and ``"0.5.2"`` (0.5.2 – 0.5.6)."""

LF_FLIPPED = (b"*", b"J")
"""the printable bytes one flipped bit makes of LF (0x0A ^ 0x20, 0x0A ^ 0x40)."""
CR_FLIPPED = (b"-", b"M")
"""the printable bytes one flipped bit makes of CR (0x0D ^ 0x20, 0x0D ^ 0x40)."""
ERROR_REPLIES = ("invalid command format", "invalid motor", "invalid property",
                 "not implemented", "unknown command")


def _numbering(firmware: str | tuple[int, ...]) -> str:
    if isinstance(firmware, str):
        parts = tuple(int(p) for p in firmware.lstrip("v").split(".")[:3])
    else:
        parts = tuple(firmware)
    if len(parts) < 2 or parts[:2] > (0, 5):
        raise ValueError(f"only firmware 0.4.x and 0.5.x are known; got {firmware!r}")
    return "0.5.1" if parts[:2] < (0, 5) or parts[:3] <= (0, 5, 1) else "0.5.2"


def axis_state_name(value: int, firmware: str | tuple[int, ...] = "0.5.6") -> str:
    """The name of axis state ``value`` under ``firmware``.

    >>> axis_state_name(8), axis_state_name(5, "0.5.1"), axis_state_name(11, "0.5.6")
    ('CLOSED_LOOP_CONTROL', 'SENSORLESS_CONTROL', 'HOMING')
    """
    return _state_name(value, firmware)


def _state_name(value: int, firmware: str | tuple[int, ...]) -> str:
    table = AXIS_STATES[_numbering(firmware)]
    if value not in table:
        raise ValueError(f"{value} is not an axis state in firmware {firmware}")
    return table[value]


def encode_line(command: str, checksum: bool = False) -> bytes:
    """One request line; with ``checksum`` the XOR of every character before ``*``.

    >>> encode_line("v 0 1.5", checksum=True)
    b'v 0 1.5*108\\n'
    """
    if any(c in command for c in "\r\n!*"):
        raise ValueError(f"a command cannot contain line ends, '!' or '*': {command!r}")
    if checksum:
        return f"{command}*{odrive_checksum(command)}\n".encode("ascii")
    return f"{command}\n".encode("ascii")


def _printable(raw: bytes) -> bool:
    return all(0x20 <= b <= 0x7E for b in raw)


def parse_reply(line: str | bytes, checksum: bool = False) -> str:
    """A reply line (without CR LF) → its text, the checksum checked when expected.

    The line is judged as the bytes that came: the firmware's replies are printable ASCII,
    so any other byte (or character) means line noise, and the checksum is the XOR of those
    bytes (two bytes that would both decode to U+FFFD cannot cancel out).

    Raises :class:`ChecksumError` for a missing or wrong checksum, :class:`ProtocolError`
    for a line that is not printable ASCII, and :class:`DeviceError` for the firmware's
    error replies (``invalid property`` …).

    >>> parse_reply(b"24.087744*32", checksum=True)
    '24.087744'
    """
    if isinstance(line, str):
        try:
            raw = line.encode("ascii")
        except UnicodeEncodeError:
            raise ProtocolError(DEVICE, f"reply is not ASCII: {line[:60]!r}") from None
    else:
        raw = bytes(line)
    if not _printable(raw):
        raise ProtocolError(DEVICE, f"reply holds bytes the firmware never sends: {raw[:60]!r}")
    text = raw.decode("ascii")
    if checksum:
        body, star, given = text.rpartition("*")
        if not star or not given.isdigit():
            raise ChecksumError(DEVICE, f"reply without a checksum: {text[:60]!r}")
        if odrive_checksum(body) != int(given):
            raise ChecksumError(DEVICE, f"checksum {given} does not match "
                                        f"{odrive_checksum(body)} for {body[:60]!r}")
        text = body
    for code, error in enumerate(ERROR_REPLIES, start=1):
        if text.startswith(error):
            raise DeviceError(DEVICE, text, code)
    return text


class ReplySplitter:
    """Bytes → reply lines, cut on the raw bytes.

    The firmware ends every reply line with CR LF and sends nothing but printable ASCII in
    between, so a line is a run of printable bytes, and anything else (CR, LF, a byte the
    firmware never sends) ends it: a line end damaged by noise splits two replies instead
    of merging them. Each line comes with ``clean``: whether a CR LF comes right before it
    (or it is the first line). A line that does not start clean may be
    the tail of a line cut by noise, and the XOR checksum cannot tell (a cut-off prefix
    such as ``11`` XORs to zero), so :class:`ODrive` trusts it only after a good line.
    A line longer than ``limit`` bytes (the firmware's 256) is dropped, counted in
    ``dropped``.

    >>> ReplySplitter().feed(b"1.5*31\\r\\n2.0 0.0\\r*31\\r\\n")
    [(b'1.5*31', True), (b'2.0 0.0', True), (b'*31', False)]
    """

    def __init__(self, limit: int = 256) -> None:
        self.limit = limit
        self.dropped = 0
        self._line = bytearray()
        self._gap = bytearray()  # the bytes between the last line and the one coming
        self._first = True

    def feed(self, data: bytes) -> list[tuple[bytes, bool]]:
        out: list[tuple[bytes, bool]] = []
        line, gap = self._line, self._gap
        for b in data:
            if 0x20 <= b <= 0x7E:
                line.append(b)
                if len(line) > self.limit:
                    self.dropped += len(line)
                    line.clear()
                continue
            if line:
                gap_ok = (self._first and not gap) or gap.endswith(b"\r\n")
                out.append((bytes(line), gap_ok))
                line.clear()
                gap.clear()
                self._first = False
            gap.append(b)
        return out


class ReplyLines:
    """Bytes → checked reply texts: :class:`ReplySplitter`'s lines through
    :func:`parse_reply`. Corrupted lines and the firmware's debug prints are counted in
    ``rejected`` and skipped; the firmware's error replies raise :class:`DeviceError`.

    A line that did not start clean is taken only after a good line (junk between the two
    aside): then what damaged the line end was the good line's LF — dropped, or turned by
    one flipped bit into this line's first byte (``*`` or ``J``, which no reply starts
    with), so such a line is also tried without that byte; likewise a line ending in what a
    flipped bit makes of CR (``-`` or ``M``, which no checksum ends with).

    >>> ReplyLines(checksum=True).feed(b"24.087744*32\\r\\n1.0*3\\r\\n")
    ['24.087744']
    """

    def __init__(self, checksum: bool = True, limit: int = 256) -> None:
        self.checksum = checksum
        self.splitter = ReplySplitter(limit)
        self.rejected = 0
        self._good = False

    def _accept(self, raw: bytes, clean: bool) -> str | None:
        text: str | None = None
        if clean or self._good:
            candidates = [raw]
            if not clean and raw[:1] in LF_FLIPPED and len(raw) > 1:
                candidates.append(raw[1:])
            if raw[-1:] in CR_FLIPPED and len(raw) > 1:  # this line's own CR, flipped
                candidates.append(raw[:-1])
            for candidate in candidates:
                try:
                    text = parse_reply(candidate, self.checksum)
                    break
                except (ChecksumError, ProtocolError):
                    continue
        if text is not None:
            self._good = True
        elif clean:
            self._good = False  # a damaged line: what follows it unclean may be its tail
        if text is None:
            self.rejected += 1
        return text

    def feed(self, data: bytes) -> list[str]:
        out = []
        for raw, clean in self.splitter.feed(data):
            text = self._accept(raw, clean)
            if text is not None:
                out.append(text)
        return out


class ODrive:
    """An ODrive on a serial port (``/dev/ttyACM0``, a pseudo-terminal, a logical port).

    Parameters
    ----------
    timeout : float
        Seconds to wait for a reply before :class:`DeviceTimeout`.
    checksum : bool
        Checksum every request and require checksummed replies.
    firmware : str
        Which axis-state numbering to use (``"0.5.6"``); :meth:`connect` reads it from the
        device.
    """

    def __init__(self, port: Any, timeout: float = 0.5, checksum: bool = True,
                 firmware: str = "0.5.6", clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep, *, baudrate: int = 115200,
                 stamp: Callable[[], float] | None = None) -> None:
        self.link = Link(DEVICE, port, baudrate, 0.01, clock, sleep, stamp)
        self.timeout = timeout
        self.checksum = checksum
        self.firmware = firmware
        self.replies = ReplyLines(checksum)
        self.rejected = 0

    # ------------------------------------------------------------------ lines
    def send(self, command: str) -> None:
        """A command that has no reply (``v``, ``w``, ``sc`` …)."""
        self.link.write(encode_line(command, self.checksum), command)

    def _lines(self, what: str, count: int) -> list[str]:
        link = self.link
        deadline = link.clock() + self.timeout
        lines: list[str] = []
        while True:
            before = self.replies.rejected
            lines += self.replies.feed(link.read_some(what))
            self.rejected += self.replies.rejected - before
            if len(lines) >= count:
                return lines[:count]
            if link.clock() >= deadline:
                raise DeviceTimeout(DEVICE, f"{what}: no reply within {self.timeout:g} s")

    def query(self, command: str, lines: int = 1) -> list[str]:
        """Send ``command`` and return its ``lines`` reply lines (texts); stale bytes are
        dropped first."""
        self.link.clear(command)
        self.replies = ReplyLines(self.checksum)
        self.send(command)
        return self._lines(command, lines)

    def read(self, path: str) -> float:
        """``r <path>`` as a number (the firmware cuts replies to 9 characters)."""
        text = self.query(f"r {path}")[0]
        try:
            return float(text)
        except ValueError:
            raise ProtocolError(DEVICE, f"r {path}: not a number: {text!r}") from None

    def read_int(self, path: str) -> int:
        return round(self.read(path))

    def write(self, path: str, value: float | int | bool) -> None:
        text = str(int(value)) if isinstance(value, (bool, int)) else repr(float(value))
        self.send(f"w {path} {text}")

    # ------------------------------------------------------------------ device
    def info(self) -> dict[str, str]:
        """``i``: hardware version, firmware version, serial number; sets ``firmware``."""
        out = {}
        for line in self.query("i", 3):
            key, _, value = line.partition(":")
            out[key.strip()] = value.strip()
        if "Firmware version" in out:
            self.firmware = out["Firmware version"].lstrip("v")
        return out

    def vbus_voltage(self) -> float:
        return self.read("vbus_voltage")

    def feedback(self, axis: int) -> tuple[float, float]:
        """``f <axis>``: encoder position [turns] and velocity [turns/s], full resolution."""
        text = self.query(f"f {axis}")[0]
        try:
            pos, vel = (float(t) for t in text.split())
        except ValueError:
            raise ProtocolError(DEVICE, f"f {axis}: expected two numbers, got {text!r}") from None
        return pos, vel

    def set_velocity(self, axis: int, turns_per_second: float) -> None:
        """``v <axis> <turns/s>`` (velocity control; feeds the watchdog)."""
        self.send(f"v {axis} {turns_per_second:.6f}")

    def axis_state(self, axis: int) -> int:
        return self.read_int(f"axis{axis}.current_state")

    def axis_state_name(self, axis: int) -> str:
        return _state_name(self.axis_state(axis), self.firmware)

    def axis_error(self, axis: int) -> int:
        return self.read_int(f"axis{axis}.error")

    def request_state(self, axis: int, state: int) -> None:
        _state_name(state, self.firmware)  # refuses a state this firmware does not have
        self.write(f"axis{axis}.requested_state", state)

    def wait_for_state(self, axis: int, state: int, timeout: float, poll: float = 0.1) -> None:
        """Poll until the axis is in ``state``; an axis error or the time-out raises."""
        clock = self.link.clock
        deadline = clock() + timeout
        while True:
            current = self.axis_state(axis)
            if current == state:
                return
            error = self.axis_error(axis)
            if error:
                raise DeviceError(DEVICE, f"axis{axis}: error 0x{error:X} while waiting for "
                                          f"{_state_name(state, self.firmware)}", error)
            if clock() >= deadline:
                raise DeviceTimeout(DEVICE, f"axis{axis}: still "
                                            f"{_state_name(current, self.firmware)} after "
                                            f"{timeout:g} s, waiting for "
                                            f"{_state_name(state, self.firmware)}")
            self.link.sleep(poll)

    def clear_errors(self) -> None:
        self.send("sc")

    def close(self) -> None:
        self.link.close()
