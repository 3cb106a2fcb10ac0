"""AMC DPRALTE-060B080 drives on one RS-485 bus (``protocols.md`` §1): the device side.

One emulator is the whole bus: by default the IGV's two drives (0x3F right with its velocity
command at 45.02, 0x3E left at 45.00). Each drive keeps a table of words keyed by
(index, offset), answers only its own address (nothing to broadcast 0x00), echoes the
sequence bits, and follows §1.9: a bad header CRC with its address → status 08; a write
before write access (07.00) → 06; an unknown index → 04. The velocity command drives the
backend's wheel (the position register counts its encoder) only while the bridge is
enabled.

The communication watchdog (``04.01``, ms, 0 = off): every frame a drive takes (its address,
both CRCs good) feeds it; a drive that hears nothing for that long faults — the comms
error latched in ``02.02`` (bit 10, libamc's ``AMC_SS_COMMERR``), the bridge inhibited and
the wheel stopped at that instant (``backend.at``), and the bridge cannot be enabled again
until the latched events are reset (``01.00`` bit 12). ``watchdog_expired_at`` keeps when.
This response is the kit's reading of §1.7's "the drive faults if the host stops talking"
(**[inferred]**; real drives set it in their configuration).
"""

from __future__ import annotations

import math
from functools import partial
from typing import Any

from hardware.emulators.backends import IdealWheels
from hardware.emulators.core import Device, Faults
from kit.drivers.checksums import crc16_xmodem
from kit.drivers.dpralte import UNITS_PER_COUNT_PER_SECOND, int32_words

__all__ = ["DpralteBusEmulator"]

KNOWN_INDICES = {0x01, 0x02, 0x04, 0x05, 0x07, 0x0B, 0x10, 0x11, 0x12, 0x3C, 0x45, 0x8C}
COMMS_ERROR = 1 << 10


def reply_frame(control: int, status: int, data: bytes = b"") -> bytes:
    command = 2 if data else 1
    head = bytes([0xA5, 0xFF, command | (control & 0x3C), status, 0x00, len(data) // 2])
    out = head + crc16_xmodem(head).to_bytes(2, "big")
    if data:
        out += data + crc16_xmodem(data).to_bytes(2, "big")
    return out


class _Drive:
    def __init__(self, address: int, wheel: int, velocity_offset: int) -> None:
        self.address = address
        self.wheel = wheel
        self.velocity_offset = velocity_offset
        self.words: dict[tuple[int, int], int] = {(0x01, 0x00): 0x0001, (0x02, 0x00): 0x0000,
                                                  (0x02, 0x01): 0x0000, (0x02, 0x02): 0x0000,
                                                  (0x04, 0x01): 0x0000}
        self.access = False
        self.heard = 0.0  # when a frame last fed the watchdog
        self.watchdog_expired_at: float | None = None

    @property
    def enabled(self) -> bool:
        return not self.words.get((0x01, 0x00), 1) & 0x0001

    @property
    def watchdog_timeout(self) -> float:
        return self.words.get((0x04, 0x01), 0) / 1000.0

    @property
    def watchdog_deadline(self) -> float:
        return self.heard + self.watchdog_timeout


class DpralteBusEmulator(Device):
    """The IGV's RS-485 bus: two drives, ``counts_per_rev`` encoder counts per wheel turn."""

    name = "dpralte"
    baudrate = 115200

    def __init__(self, backend: Any = None, drives: tuple[tuple[int, int, int], ...] =
                 ((0x3F, 0, 0x02), (0x3E, 1, 0x00)), counts_per_rev: int = 400,
                 wheel_signs: tuple[int, int] = (1, 1), faults: Faults | None = None) -> None:
        super().__init__(faults)
        self.backend = backend or IdealWheels()
        self.drives = {a: _Drive(a, w, off) for a, w, off in drives}
        self.counts_per_rev = counts_per_rev
        self.wheel_signs = wheel_signs
        self._buffer = bytearray()

    def error_reply(self, reply: bytes) -> bytes | None:
        return reply_frame(reply[2], 0x02)  # "command incomplete"

    def stream(self, now: float) -> None:
        self.backend.advance(now)  # runs a watchdog that ran out before now, at its time
        for drive in self.drives.values():
            self._check_watchdog(drive, now)

    def _heard(self, drive: _Drive, now: float) -> None:
        drive.heard = now
        if drive.watchdog_timeout > 0 and hasattr(self.backend, "at"):
            self.backend.at(drive.watchdog_deadline, partial(self._check_watchdog, drive))

    def _check_watchdog(self, drive: _Drive, now: float) -> None:
        if drive.watchdog_timeout <= 0 or now < drive.watchdog_deadline or \
                drive.words[(0x02, 0x02)] & COMMS_ERROR:
            return
        drive.words[(0x02, 0x02)] |= COMMS_ERROR
        drive.words[(0x01, 0x00)] |= 0x0001  # bridge inhibited
        drive.words[(0x02, 0x00)] = 0
        drive.watchdog_expired_at = drive.watchdog_deadline
        self._command_wheel(drive)

    def _counts(self, drive: _Drive) -> int:
        angle = self.backend.wheel_angle(drive.wheel) * self.wheel_signs[drive.wheel]
        return math.floor(angle / (2 * math.pi) * self.counts_per_rev)

    def _velocity_units(self, drive: _Drive) -> int:
        rad_s = self.backend.wheel_speed(drive.wheel) * self.wheel_signs[drive.wheel]
        return round(rad_s / (2 * math.pi) * self.counts_per_rev * UNITS_PER_COUNT_PER_SECOND)

    def _command_wheel(self, drive: _Drive) -> None:
        lo = drive.words.get((0x45, drive.velocity_offset), 0)
        hi = drive.words.get((0x45, drive.velocity_offset + 1), 0)
        units = int.from_bytes((lo | hi << 16).to_bytes(4, "little"), "little", signed=True)
        counts_per_s = units / UNITS_PER_COUNT_PER_SECOND if drive.enabled else 0.0
        rad_s = counts_per_s / self.counts_per_rev * 2 * math.pi
        self.backend.set_wheel_speed(drive.wheel, rad_s * self.wheel_signs[drive.wheel])

    def receive(self, data: bytes, now: float) -> None:
        buf = self._buffer
        buf += data
        while True:
            start = buf.find(0xA5)
            if start < 0:
                buf.clear()
                return
            del buf[:start]
            if len(buf) < 8:
                return
            address, control = buf[1], buf[2]
            if address == 0xFF:  # another device's reply on the shared bus
                del buf[:1]
                continue
            if crc16_xmodem(bytes(buf[:8])) != 0:
                if address in self.drives:
                    self.send(reply_frame(control, 0x08), now)
                del buf[:1]
                continue
            command, words = control & 0x03, buf[5]
            size = 8 + (2 * words + 2 if command == 2 and words else 0)
            if len(buf) < size:
                return
            frame = bytes(buf[:size])
            if size > 8 and crc16_xmodem(frame[8:]) != 0:
                if address in self.drives:
                    self.send(reply_frame(control, 0x08), now)
                del buf[:1]
                continue
            del buf[:size]
            drive = self.drives.get(address)
            if drive is not None:
                self.backend.advance(now)
                self._check_watchdog(drive, now)  # (ran out before this frame came)
                self._heard(drive, now)
                self._handle(drive, frame, now)

    def _handle(self, drive: _Drive, frame: bytes, now: float) -> None:
        self.backend.advance(now)
        control, index, offset, words = frame[2], frame[3], frame[4], frame[5]
        command = control & 0x03
        if index not in KNOWN_INDICES or command not in (1, 2):
            self.send(reply_frame(control, 0x04), now)
            return
        if command == 2:
            if (index, offset) != (0x07, 0x00) and not drive.access:
                self.send(reply_frame(control, 0x06), now)
                return
            if index in (0x02, 0x10, 0x11, 0x12, 0x0B, 0x8C):
                self.send(reply_frame(control, 0x04), now)  # read-only
                return
            data = frame[8:-2]
            for k in range(words):
                drive.words[(index, offset + k)] = int.from_bytes(data[2 * k:2 * k + 2], "little")
            if (index, offset) == (0x07, 0x00):
                drive.access = drive.words[(0x07, 0x00)] != 0
            if index == 0x01:
                value = drive.words[(0x01, 0x00)]
                if value & 0x1000:  # reset latched events
                    drive.words[(0x02, 0x01)] = drive.words[(0x02, 0x02)] = 0
                if drive.words[(0x02, 0x01)] or drive.words[(0x02, 0x02)]:
                    drive.words[(0x01, 0x00)] |= 0x0001  # a latched fault keeps it off
                drive.words[(0x02, 0x00)] = 0 if drive.words[(0x01, 0x00)] & 0x0001 else 0x0001
            if (index, offset) == (0x04, 0x01):
                self._heard(drive, now)  # the new time-out counts from now
            self._command_wheel(drive)
            self.send(reply_frame(control, 0x01), now)
            return
        if (index, offset) == (0x12, 0x00):
            self.event(f"position{drive.address:02X}", now)
            data = int32_words(self._counts(drive))
        elif (index, offset) == (0x11, 0x02):
            data = int32_words(self._velocity_units(drive))
        else:
            data = b"".join(drive.words.get((index, offset + k), 0).to_bytes(2, "little")
                            for k in range(words))
        self.send(reply_frame(control, 0x01, data[:2 * words].ljust(2 * words, b"\0")), now)
