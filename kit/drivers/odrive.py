"""ODrive v3.x (firmware 0.5.x) over its ASCII protocol: properties, velocity commands,
feedback, optional checksums and the axis states of each firmware version.

A request is one line (``r vbus_voltage``, ``v 0 1.5``, ``f 0``); replies are lines ending
in ``\\r\\n``. With ``checksum=True`` every request carries ``*<decimal XOR>`` and every
reply must carry a correct one; a reply is believed only when it is the one reply its bytes
can hold (:mod:`kit.drivers._odrive_replies`: noise before a line, a byte damaged in it), so
a corrupted reply is refused rather than believed. Units are turns and turns/s (0.5.x).
Facts and vectors: ``protocols.md`` §4.

**The first command gets through.** :meth:`ODrive.connect` first sends a bare line end,
which ends whatever partial line an earlier program left in the firmware's buffer (``f 0``
without its end would swallow the next request), reads what that line answers, and only
then asks for ``vbus_voltage`` — once more if the first exchange fails.

**Watchdog.** The firmware stops an axis whose watchdog is not fed within
``config.watchdog_timeout`` (error ``WATCHDOG_TIMER_EXPIRED``, 0x800, and IDLE):
:meth:`ODrive.set_watchdog` sets it up as each firmware wants it (0.5.x: the time-out, a
feed with ``u``, then ``enable_watchdog``; 0.4.x: the time-out alone, which feeds and
enables it); ``v``, ``p``, ``q``, ``c``, ``t`` and ``u`` feed it.

Erratum 9: the axis-state numbers changed at firmware 0.5.2 — the Uiabot paper's table
(5 = SENSORLESS_CONTROL) is the 0.5.1 numbering. :func:`axis_state_name` knows both.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from kit.drivers._odrive_replies import (
    CR_FLIPPED,
    DEVICE,
    ERROR_REPLIES,
    FORMS,
    ReplyLines,
    ReplySplitter,
    judge_line,
    parse_reply,
)
from kit.drivers.checksums import odrive_checksum
from kit.drivers.errors import (
    ChecksumError,
    DeviceError,
    DeviceTimeout,
    ProtocolError,
    failed_twice,
)
from kit.drivers.port import Link

__all__ = ["AXIS_STATES", "CR_FLIPPED", "DEVICE", "ERROR_REPLIES", "FORMS",
           "WATCHDOG_TIMER_EXPIRED", "ODrive", "ReplyLines", "ReplySplitter", "axis_state_name",
           "encode_line", "judge_line", "parse_reply"]

IDLE, FULL_CALIBRATION_SEQUENCE, CLOSED_LOOP_CONTROL = 1, 3, 8
VELOCITY_CONTROL = 2
WATCHDOG_TIMER_EXPIRED = 0x800
"""``axis.error`` bit 11, the same in 0.4.12 and 0.5.x."""

_COMMON = {0: "UNDEFINED", 1: "IDLE", 2: "STARTUP_SEQUENCE", 3: "FULL_CALIBRATION_SEQUENCE",
           4: "MOTOR_CALIBRATION", 6: "ENCODER_INDEX_SEARCH", 7: "ENCODER_OFFSET_CALIBRATION",
           8: "CLOSED_LOOP_CONTROL", 9: "LOCKIN_SPIN", 10: "ENCODER_DIR_FIND"}
AXIS_STATES: dict[str, dict[int, str]] = {
    "0.5.1": {**_COMMON, 5: "SENSORLESS_CONTROL"},
    "0.5.2": {**_COMMON, 11: "HOMING", 12: "ENCODER_HALL_POLARITY_CALIBRATION",
              13: "ENCODER_HALL_PHASE_CALIBRATION"},
}
"""axis states by firmware: ``"0.5.1"`` (also 0.4.x) and ``"0.5.2"`` (0.5.2 – 0.5.6)."""


def _version(firmware: str | tuple[int, ...]) -> tuple[int, ...]:
    if isinstance(firmware, str):
        parts = tuple(int(p) for p in firmware.lstrip("v").split(".")[:3])
    else:
        parts = tuple(firmware)
    if len(parts) < 2 or parts[:2] > (0, 5):
        raise ValueError(f"only firmware 0.4.x and 0.5.x are known; got {firmware!r}")
    return parts


def _numbering(firmware: str | tuple[int, ...]) -> str:
    parts = _version(firmware)
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


class ODrive:
    """An ODrive on a serial port (``/dev/ttyACM0``, a pseudo-terminal, a logical port).

    Parameters
    ----------
    timeout : float
        Seconds to wait for a reply before :class:`DeviceTimeout`.
    checksum : bool
        Checksum every request and require checksummed replies (the default: without
        checksums a damaged reply cannot be told from a good one).
    firmware : str
        Which axis-state numbering to use (``"0.5.6"``); :meth:`info` reads it from the
        device.

    Every exchange holds the port's lock, so a keep-alive thread feeding the watchdog and
    the program never interleave. ``last_exchange`` is ``(sent, answered)`` of the last
    reply on the stamping clock: a reading was taken between the two.
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
        self.ambiguous = 0
        self.last_exchange = (0.0, 0.0)

    # ------------------------------------------------------------------ lines
    def send(self, command: str) -> None:
        """A command that has no reply (``v``, ``w``, ``u``, ``sc`` …)."""
        self.link.write(encode_line(command, self.checksum), command)

    def clear_line(self, quiet: float = 0.05) -> bytes:
        """End whatever partial line the firmware holds (a bare line end: an earlier
        program's ``f 0`` without its end is then answered, a damaged one dropped) and read
        what answers until the line has been quiet for ``quiet`` s; returns those bytes."""
        with self.link.lock:
            self.link.write(b"\n", "clear the line")
            return self.link.drain(quiet, self.timeout, "clear the line")

    def _exchange(self, command: str, lines: int, form: str
                  ) -> list[tuple[frozenset[str], frozenset[str]]]:
        link = self.link
        with link.lock:
            link.clear(command)
            self.replies = ReplyLines(self.checksum, form=form)
            sent = link.stamp()
            self.send(command)
            deadline = link.clock() + self.timeout
            got: list[tuple[frozenset[str], frozenset[str]]] = []
            while True:
                before, ambiguous = self.replies.rejected, self.replies.ambiguous
                got += self.replies.feed_sets(link.read_some(command))
                self.rejected += self.replies.rejected - before
                self.ambiguous += self.replies.ambiguous - ambiguous
                if len(got) >= lines:
                    self.last_exchange = (sent, link.stamp())
                    return got[:lines]
                if link.clock() >= deadline:
                    raise DeviceTimeout(DEVICE, f"{command}: no reply within {self.timeout:g} s")

    def query(self, command: str, lines: int = 1, form: str = "reply") -> list[str]:
        """Send ``command`` and return its ``lines`` reply lines (texts), each the one reply
        its bytes can hold in ``form`` (:data:`FORMS`); stale bytes are dropped first. A
        reply that could be more than one raises :class:`ProtocolError`."""
        out = []
        for candidates, literal in self._exchange(command, lines, form):
            if len(candidates) != 1 or candidates != literal:
                raise ProtocolError(DEVICE, f"{command}: a damaged reply that could be any of "
                                            f"{sorted(candidates)[:4]}")
            out.append(next(iter(candidates)))
        return out

    def read(self, path: str) -> float:
        """``r <path>`` as a number (the firmware cuts replies to 9 characters)."""
        text = self.query(f"r {path}", form="number")[0]
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
    def connect(self) -> float:
        """Clear the line (:meth:`clear_line`), then ``r vbus_voltage``, asked once more
        (after clearing again) if the first exchange fails; returns the bus voltage [V]."""
        self.clear_line()
        try:
            return self.vbus_voltage()
        except (DeviceTimeout, ChecksumError, ProtocolError) as exc:
            if self.link.failure is not None:
                raise
            first = exc
        self.clear_line()
        try:
            return self.vbus_voltage()
        except (DeviceTimeout, ChecksumError, ProtocolError) as exc:
            raise failed_twice(exc, first) from None

    def reopen(self) -> float:
        """Open the port again (the device back after an unplug) and :meth:`connect`."""
        self.link.reopen()
        return self.connect()

    def info(self) -> dict[str, str]:
        """``i``: hardware version, firmware version, serial number; sets ``firmware``."""
        out = {}
        for line in self.query("i", 3, form="info"):
            key, _, value = line.partition(":")
            out[key.strip()] = value.strip()
        if "Firmware version" in out:
            self.firmware = out["Firmware version"].lstrip("v")
        return out

    def vbus_voltage(self) -> float:
        return self.read("vbus_voltage")

    def feedback(self, axis: int) -> tuple[float, float]:
        """``f <axis>``: encoder position [turns] and velocity [turns/s], full resolution.

        A reply whose bytes could hold more than one (``115.2…`` is also ``5.2…`` after two
        characters whose XOR is zero) is told apart by ``r axis<n>.encoder.pos_estimate``
        (and ``vel_estimate`` if need be): the one candidate they agree with is taken, and
        ``last_exchange`` spans both readings."""
        candidates, literal = self._exchange(f"f {axis}", 1, "feedback")[0]
        values = []
        for text in candidates:
            try:
                pos, vel = (float(t) for t in text.split())
            except ValueError:
                continue
            values.append((pos, vel))
        if len(candidates) == 1 and candidates == literal and values:
            return values[0]
        sent, t0 = self.last_exchange
        position = self.read(f"axis{axis}.encoder.pos_estimate")
        dt = self.last_exchange[1] - t0
        agree = [(p, v) for p, v in values if abs(p - position) <= 0.5 + abs(v) * 2 * dt]
        if len(agree) > 1:
            velocity = self.read(f"axis{axis}.encoder.vel_estimate")
            agree = [(p, v) for p, v in agree if abs(v - velocity) <= 0.5 + 0.05 * abs(v)]
        self.last_exchange = (sent, self.last_exchange[1])
        if len(agree) != 1 or f"{agree[0][0]:f} {agree[0][1]:f}" not in literal:
            raise ProtocolError(DEVICE, f"f {axis}: a damaged reply that could be any of "
                                        f"{sorted(candidates)[:4]}")
        return agree[0]

    def set_velocity(self, axis: int, turns_per_second: float) -> None:
        """``v <axis> <turns/s>`` (velocity control; feeds the watchdog)."""
        if not math.isfinite(turns_per_second):
            raise ValueError(f"a velocity must be finite; got {turns_per_second}")
        self.send(f"v {axis} {turns_per_second:.6f}")

    def feed(self, axis: int) -> None:
        """``u <axis>``: feed the axis's watchdog (nothing else)."""
        self.send(f"u {axis}")

    def set_watchdog(self, axis: int, timeout: float) -> None:
        """The firmware's own watchdog on ``axis``: the axis stops (IDLE, error 0x800) when
        nothing feeds it for ``timeout`` s; 0 turns it off. 0.5.x: the time-out, a feed
        (the counter is only reloaded by a feed), then ``enable_watchdog``; 0.4.x has no
        ``enable_watchdog``: setting the time-out feeds and enables it."""
        if not (math.isfinite(timeout) and timeout >= 0):
            raise ValueError(f"the watchdog time-out is seconds >= 0; got {timeout}")
        if _version(self.firmware)[:2] < (0, 5):
            self.write(f"axis{axis}.config.watchdog_timeout", float(timeout))
            return
        if timeout > 0:
            self.write(f"axis{axis}.config.watchdog_timeout", float(timeout))
            self.feed(axis)
            self.write(f"axis{axis}.config.enable_watchdog", True)
        else:
            self.write(f"axis{axis}.config.enable_watchdog", False)

    def axis_state(self, axis: int) -> int:
        return self.read_int(f"axis{axis}.current_state")

    def axis_state_name(self, axis: int) -> str:
        return _state_name(self.axis_state(axis), self.firmware)

    def axis_error(self, axis: int) -> int:
        return self.read_int(f"axis{axis}.error")

    def request_state(self, axis: int, state: int) -> None:
        _state_name(state, self.firmware)  # refuses a state this firmware does not have
        self.write(f"axis{axis}.requested_state", state)

    def wait_for_state(self, axis: int, state: int, timeout: float, poll: float = 0.1,
                       feed: bool = False) -> None:
        """Poll until the axis is in ``state``; an axis error or the time-out raises.
        ``feed`` feeds the axis's watchdog at every poll."""
        clock = self.link.clock
        deadline = clock() + timeout
        while True:
            if feed:
                self.feed(axis)
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
