"""OceanServer OS5000-S compass (``protocols.md`` §2): the device side.

Streams ``$C…*cc`` sentences at the programmed rate (20 Hz by default) with the fields the
``<ESC>X`` mask selects, in format 1, 2 or 4 (``<ESC>*``); obeys ``<ESC>R`` (0 stops the
stream), answers each command with a short text line a driver must skip, and ignores other
ESC commands. The heading is the backend body's (clockwise from north: ``90° − yaw``) plus
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
                 temperature: float = 24.5, faults: Faults | None = None) -> None:
        super().__init__(faults)
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

    def body(self, now: float) -> str:
        h = self.heading(now)
        if self.format == 4:
            return f"HCHDT,{h:.1f},T"
        if self.format == 2:
            return f"OHPR,{h:.1f},0.0,0.0,{self.temperature:.1f}"
        parts = [f"C{h:.1f}"]
        if self.fields & 2:
            parts.append("P0.0")
        if self.fields & 4:
            parts.append("R0.0")
        if self.fields & 8:
            parts.append(f"T{self.temperature:.1f}")
        if self.fields & 256:
            parts.append("Ax0.000Ay0.000Az1.000")
        return "".join(parts)

    def receive(self, data: bytes, now: float) -> None:
        for b in data:
            if b == 0x1B:
                self._command = bytearray(b"\x1b")
                continue
            if not self._command:
                continue  # bytes outside a command are ignored
            if b in (0x0D, 0x20) and len(self._command) > 2:
                self._execute(self._command[1:].decode("ascii", "replace"), now)
                self._command = bytearray()
            else:
                self._command.append(b)
                if len(self._command) == 2 and chr(b) in "V&FCZ$":
                    self._execute(chr(b), now)
                    self._command = bytearray()
                elif len(self._command) > 16:
                    self._command = bytearray()

    def _execute(self, text: str, now: float) -> None:
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
        self.send(f"CMD:{letter}{value}\r\n".encode("ascii"), now)

    def stream(self, now: float) -> None:
        if self.rate <= 0:
            return
        period = 1.0 / self.rate
        while self._next <= now:
            self.send(sentence(self.body(self._next)), self._next, reply=False)
            self.sentences_sent += 1
            self._next += period
            if now - self._next > 1.0:
                self._next = now
