"""SICK LMS291-S05 (``protocols.md`` §3): the device side.

Every request is acknowledged with ``06`` and answered with a telegram from address
``0x80`` (``15`` for a telegram whose CRC fails); the state machine: power-up at 9600 baud
in monitoring mode; baud switches answered at the old rate and then required at the new
one (a host at another rate hears noise); the variant (angle, resolution); installation
mode before a configuration write; ``20 24`` streams ``B0`` telegrams, paced to the mirror's
75 Hz and to what the baud rate can carry, until ``20 25``; ``10`` resets to 9600.

Ranges come from the backend's lidar (a ``SimBackend`` robot with an LMS291) or, on its
own, from an 8 m × 8 m room around the scanner.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from hardware.emulators.backends import room_ranges
from hardware.emulators.core import Device, Faults
from kit.drivers.lms2xx import BAUD_COMMANDS, TelegramParser, encode_telegram

__all__ = ["LMS2xxEmulator"]

BAUDS = {code: baud for baud, code in BAUD_COMMANDS.items()}
STATUS_OK = 0x10
PASSWORD = b"SICK_LMS"


class LMS2xxEmulator(Device):
    name = "lms2xx"
    baudrate = 9600

    def __init__(self, backend: Any = None, unit_mm: bool = False,
                 faults: Faults | None = None) -> None:
        super().__init__(faults)
        self.backend = backend
        self.unit_mm = unit_mm
        self.parser = TelegramParser(replies=False)
        self.angle, self.resolution = 180, 100  # degrees, 0.01°
        self.mode = 0x25
        self.installation = False
        self.config = bytearray(32)
        self.config[6] = 1 if unit_mm else 0
        self._next_scan = 0.0
        self._scan: Any = None
        self.scans_sent = 0
        if backend is not None and hasattr(backend, "subscribe"):
            backend.subscribe("scan", self._on_scan)

    def _on_scan(self, message: Any) -> None:
        self._scan = message

    # ------------------------------------------------------------------ replies
    def _reply(self, payload: bytes, now: float) -> None:
        self.send(bytes([0x06]), now)
        self.send(encode_telegram(payload + bytes([STATUS_OK]), 0x80), now, reply=False)

    def error_reply(self, reply: bytes) -> bytes | None:
        if reply == b"\x06":
            return b"\x15"  # a NAK in place of the ACK
        return None

    def receive(self, data: bytes, now: float) -> None:
        errors = len(self.parser.errors)
        telegrams = self.parser.feed(data)
        if len(self.parser.errors) > errors:
            self.send(bytes([0x15]), now)  # NAK: a telegram whose CRC failed
        for t in telegrams:
            self._handle(t.payload, now)

    def _handle(self, p: bytes, now: float) -> None:
        cmd = p[0]
        if cmd == 0x31:
            self._reply(b"\xb1" + self._status_data(), now)
        elif cmd == 0x3A:
            self._reply(b"\xba" + b"LMS291;S05    ", now)
        elif cmd == 0x20 and len(p) >= 2:
            self._mode_change(p, now)
        elif cmd == 0x30 and p[1:2] == b"\x01":
            self.send(b"\x06", now)
            self.backend_advance(now)
            self.send(self._scan_telegram(), now, reply=False)
        elif cmd == 0x3B and len(p) == 5:
            angle, res = int.from_bytes(p[1:3], "little"), int.from_bytes(p[3:5], "little")
            ok = (angle, res) in ((180, 100), (180, 50), (100, 100), (100, 50), (100, 25))
            if ok:
                self.angle, self.resolution = angle, res
            self._reply(bytes([0xBB, int(ok)]) + self.angle.to_bytes(2, "little") +
                        self.resolution.to_bytes(2, "little"), now)
        elif cmd == 0x74:
            self._reply(b"\xf4" + bytes(self.config), now)
        elif cmd == 0x77:
            if not self.installation:
                self._reply(b"\x92", now)
            else:
                data = p[1:1 + len(self.config)]
                self.config[:len(data)] = data  # the block keeps its size
                self.unit_mm = self.config[6] == 1
                self._reply(b"\xf7\x01" + bytes(self.config), now + 7.0)
        elif cmd == 0x10:
            self._reply(b"\x91", now)
            self.mode, self.installation = 0x25, False
            self.baudrate = 9600
            self.send(encode_telegram(b"\x90LMS291 restart\x10", 0x80), now + 1.0, reply=False)
        else:
            self._reply(b"\x92", now)

    def _mode_change(self, p: bytes, now: float) -> None:
        mode = p[1]
        if mode == 0x00:
            ok = p[2:10] == PASSWORD
            self.installation = ok
            self._reply(bytes([0xA0, 0 if ok else 1]), now)
        elif mode in BAUDS:
            self._reply(b"\xa0\x00", now)
            self.baudrate = BAUDS[mode]  # the reply went out at the old rate
        elif mode in (0x24, 0x25):
            self._reply(b"\xa0\x00", now)
            self.mode = mode
            self._next_scan = self._line_free
        else:
            self._reply(b"\xa0\x01", now)

    def _status_data(self) -> bytes:
        data = bytearray(152)
        data[0:7] = b"V02.10 "
        data[7] = self.mode
        data[8] = 0
        data[101] = 0
        data[106:108] = self.angle.to_bytes(2, "little")
        data[108:110] = self.resolution.to_bytes(2, "little")
        data[115:117] = {9600: 0x8067, 19200: 0x8033, 38400: 0x8019,
                         500000: 0x8001}[self.baudrate].to_bytes(2, "little")
        data[119] = 0
        data[121] = 1 if self.unit_mm else 0
        data[122] = 1
        data[123:130] = b"V01.10 "
        return bytes(data)

    # ------------------------------------------------------------------ scans
    def backend_advance(self, now: float) -> None:
        if self.backend is not None:
            self.backend.advance(now)

    def ranges(self) -> np.ndarray:
        """Ranges [m] of the current variant, counter-clockwise from the scanner's right."""
        res = self.resolution / 100.0
        start = 0.0 if self.angle == 180 else 40.0
        n = round(self.angle / res) + 1
        angles = np.radians(start - 90.0 + res * np.arange(n))  # laser_link, x forward
        scan = self._scan
        if scan is None:
            return room_ranges(angles)
        beams = np.asarray(scan.ranges, dtype=np.float64)
        index = np.rint((angles - scan.angle_min) / scan.angle_increment).astype(int)
        inside = (index >= 0) & (index < len(beams))
        out = np.full(n, np.inf)
        out[inside] = beams[index[inside]]
        return out

    def _scan_telegram(self) -> bytes:
        r = self.ranges()
        scale = 1000.0 if self.unit_mm else 100.0
        raw = np.where(np.isfinite(r), np.rint(r * scale), 0x1FFF)
        raw = np.clip(raw, 0, 0x1FFF).astype("<u2")
        raw[raw >= 0x1FF7] = 0x1FFF
        count = len(raw) | ((1 << 14) if self.unit_mm else 0)
        payload = b"\xb0" + count.to_bytes(2, "little") + raw.tobytes() + bytes([STATUS_OK])
        self.scans_sent += 1
        return encode_telegram(payload, 0x80)

    def stream(self, now: float) -> None:
        if self.mode != 0x24:
            return
        n = round(self.angle * 100 / self.resolution) + 1
        interlace = {100: 1, 50: 2, 25: 4}[self.resolution]
        period = max(interlace / 75.0, 10.0 * (2 * n + 10) / self.baudrate)
        while self._next_scan <= now:
            self.backend_advance(self._next_scan)
            self.event("scan", self._next_scan)  # measured, then sent
            self.send(self._scan_telegram(), self._next_scan, reply=False)
            self._next_scan += period
            if now - self._next_scan > 1.0:  # nobody read for a long time: do not backlog
                self._next_scan = now
        if math.isinf(self._next_scan):
            self._next_scan = now
