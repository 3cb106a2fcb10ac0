"""OceanServer OS5000-S compass (``protocols.md`` §2): the device side.

Streams ``$C…*cc`` sentences at the programmed rate (20 Hz by default) with every field
the ``<ESC>X`` mask selects that an OS5000-S has (1 heading, 2 pitch, 4 roll, 8
temperature, 64 magnetic x, y, z, 256 acceleration x, y, z; 16, depth, is the OS5500's), in
format 1, 2 (the same fields, comma-separated) or 4 (``<ESC>*``); obeys ``<ESC>R`` (0
stops the stream), answers each command with a short text line a driver must skip, and
ignores other ESC commands. It runs at one baud rate (19200, the factory's): a host at any
other rate hears noise. The heading is the backend body's (clockwise from north: ``90° − yaw``) plus
the configured declination; backed by the simulator, it is the simulated compass's reading
(the robot's IMU model, with its noise and drift), never the ground truth.
"""

from __future__ import annotations

import math
from typing import Any

from hardware.emulators.backends import imu_yaw
from hardware.emulators.core import Device, Faults
from kit.drivers.checksums import nmea_checksum

__all__ = ["Os5000Emulator", "sentence"]


def sentence(body: str) -> bytes:
    """``$body*cc\\r\\n``."""
    return f"${body}*{nmea_checksum(body)}\r\n".encode("ascii")


class Os5000Emulator(Device):
    name = "os5000"
    baudrate = 19200

    def __init__(self, backend: Any = None, rate: float = 20.0, heading_noise_deg: float = 0.0,
                 temperature: float = 24.5, faults: Faults | None = None,
                 baudrate: int = 19200) -> None:
        super().__init__(faults)
        self.baudrate = baudrate
        self.backend = backend
        self.rate = rate
        self.fields = 15
        self.format = 1
        self.declination = 0.0
        self.heading_noise_deg = heading_noise_deg
        self.temperature = temperature
        self._command = bytearray()
        self._next = 0.0
        self.sentences_sent = 0
        self._imu: Any = None
        if backend is not None and hasattr(backend, "subscribe"):
            backend.subscribe("imu", self._on_imu)

    def _on_imu(self, message: Any) -> None:
        self._imu = message  # the simulated compass's reading (its noise, bias and drift)

    def heading(self, now: float) -> float:
        yaw = 0.0
        if self.backend is not None:
            self.backend.advance(now)
            if self._imu is not None:
                yaw = imu_yaw(self._imu)
            else:
                yaw = float(self.backend.yaw())
        noise = self.rng.gauss(0.0, self.heading_noise_deg) if self.heading_noise_deg else 0.0
        return (90.0 - math.degrees(yaw) + self.declination + noise) % 360.0

    def values(self, heading: float) -> list[tuple[str, str]]:
        """(tag, text) of every field the mask selects, in the compass's order. The body
        is level (a 2-D world); the field is the Earth's, about 200 mG horizontal and
        450 mG down, seen from a body whose x points ``heading`` clockwise from north."""
        h = math.radians(heading)
        out: list[tuple[str, str]] = []
        if self.fields & 1:
            out.append(("C", f"{heading:.1f}"))
        if self.fields & 2:
            out.append(("P", "0.0"))
        if self.fields & 4:
            out.append(("R", "0.0"))
        if self.fields & 8:
            out.append(("T", f"{self.temperature:.1f}"))
        if self.fields & 64:
            out += [("Mx", f"{200.0 * math.cos(h):.2f}"), ("My", f"{-200.0 * math.sin(h):.2f}"),
                    ("Mz", "450.00")]
        if self.fields & 256:
            out += [("Ax", "0.000"), ("Ay", "0.000"), ("Az", "1.000")]
        return out

    def body(self, now: float) -> str:
        h = self.heading(now)
        if self.format == 4:
            return f"HCHDT,{h:.1f},T"
        values = self.values(h)
        if self.format == 2:
            return "OHPR," + ",".join(text for _, text in values)
        return "".join(tag + text for tag, text in values)

    def receive(self, data: bytes, now: float) -> None:
        for b in data:
            if b == 0x1B:
                self._command = bytearray(b"\x1b")
                continue
            if not self._command:
                continue  # bytes outside a command are ignored
            if b in (0x0D, 0x20) and len(self._command) > 2:
                self._execute(bytes(self._command[1:]), now)
                self._command = bytearray()
            else:
                self._command.append(b)
                if len(self._command) == 2 and chr(b) in "V&FCZ$":
                    self._execute(bytes((b,)), now)
                    self._command = bytearray()
                elif len(self._command) > 16:
                    self._command = bytearray()

    def _execute(self, command: bytes, now: float) -> None:
        """Run one command (the bytes after ESC) and echo it back, byte for byte."""
        text = command.decode("ascii", "replace")
        letter, value = text[0], text[1:]
        try:
            number = int(value) if value else None
        except ValueError:
            number = None
        if letter == "R" and number is not None:
            self.rate = float(number) if number >= 0 else 1.0 / -number
            self._next = now
        elif letter == "X" and number is not None:
            self.fields = number
        elif letter == "*" and number in (1, 2, 4):
            self.format = number
        elif letter == "Q" and number is not None:
            self.declination = number / 10.0
        elif letter == "V":
            self.send(b"OS5000 Ver 2.0\r\n", now)
            return
        self.send(b"CMD:" + command + b"\r\n", now)  # a byte that is not ASCII echoes as it came

    def stream(self, now: float) -> None:
        if self.rate <= 0:
            return
        period = 1.0 / self.rate
        while self._next <= now:
            self.send(sentence(self.body(self._next)), self._next, reply=False)
            self.sentences_sent += 1
            self.event("sentence", self._next)
            self._next += period
            if now - self._next > 1.0:
                self._next = now
