"""Slamtec RPLidar A1 (``protocols.md`` §6): the device side.

Answers GET_INFO, GET_HEALTH and GET_SAMPLERATE with a descriptor and payload; streams
5-byte standard-scan nodes only after SCAN (or FORCE_SCAN), paced at ``samples_per_second``,
until STOP; RESET ends the stream and prints a boot banner; SET_MOTOR_PWM is ignored (the
A1's motor follows DTR, which a pseudo-terminal cannot carry, so the motor is taken to be
running). ``health=2`` makes the device report an error until it is reset. Only 115200
baud: at any other rate the host hears noise.

The head behaves as the real A1's does in the captured streams
(``shared/data/device-captures``):

* the start flag comes on the first sample after the head passes its index mark, at
  357.8°–359.7° of head angle (the captures' range), not at 0°;
* the angle reported with a return is the head angle corrected for the triangulation
  geometry, ``atan(a (b − d) / (b d))`` with ``a`` = 23.5 mm and ``b`` = 171.6 mm fitted to
  the captures (7,863 returns; residual 0.43° rms): about −7° for a return at 2 m, so the
  start node of a turn reads 351°–352° and angles step back a few degrees where near and
  far returns alternate; a sample without a return keeps the head angle;
* the head's speed varies a little from turn to turn (σ = 0.5 %: the captures' turns hold
  314–322 samples).

Ranges come from the backend's lidar: each simulated scan (counter-clockwise beams, the
turn's motion distortion included) is sent as one turn of clockwise nodes, each beam's
bearing exact and its place in the turn where the head took it, one sample time (the
simulated lidar's beam time, which ``GET_SAMPLERATE`` then reports) after the other. On its
own the emulator stands in an 8 m × 8 m room that returns no echo from about a third of its
samples, as the real capture's room (3,703 of 10,436 nodes, 35.5 %): a glass window the beam passes
through (190°–250° clockwise, no return), an open door onto space beyond the A1's 12 m
(100°–130°), and a dark wall that returns too little light at 60 % of its samples
(280°–340°) — :data:`ROOM` — so a driver meets the no-return nodes (quality 0, distance 0)
it meets on a real robot.
"""

from __future__ import annotations

import math
import random
from typing import Any

import numpy as np

from hardware.emulators.backends import room_ranges
from hardware.emulators.core import Device, Faults
from kit.drivers.checksums import xor_checksum
from kit.drivers.rplidar import (
    EXPRESS_DESCRIPTOR,
    EXPRESS_SCAN,
    FORCE_SCAN,
    GET_HEALTH,
    GET_INFO,
    GET_SAMPLERATE,
    RESET,
    SCAN,
    SCAN_DESCRIPTOR,
    STOP,
    encode_capsule,
    encode_node,
)

__all__ = ["RPLidarEmulator"]

INFO = bytes.fromhex("A55A1400000004") + bytes([0x18, 0x1D, 0x01, 0x07]) + \
    bytes.fromhex("6A9C9AF0C5E09ED2A0EAFBF7C3554A1D")
BANNER = b"RP LIDAR System.\r\nFirmware Ver 1.29 - rc9, HW Ver 7\r\nModel: 18\r\n"
TRIANGULATION_MM = (23.5, 171.6)
"""(a, b) of the angle correction ``atan(a (b − d) / (b d))``, fitted to the captures."""
INDEX_MARK_DEG = 357.8
"""the lowest head angle at which a captured start flag came."""
INDEX_JITTER_DEG = 0.75
"""how far past the mark the index is sensed (so the flag's head angle spans 357.8–359.7°,
one sample step wider, as in the captures)."""
SPEED_JITTER = 0.005
"""turn-to-turn spread of the head's speed."""
ROOM = {"door": ((100.0, 130.0), 1.0), "glass": ((190.0, 250.0), 1.0),
        "dark wall": ((280.0, 340.0), 0.6)}
"""the emulator's own room: (clockwise bearings [deg], share of samples with no return)."""


def no_return(bearing_cw_deg: np.ndarray, draws: np.ndarray) -> np.ndarray:
    """Which samples of the emulator's own room come back without an echo (:data:`ROOM`),
    given uniform draws in [0, 1) for each.

    >>> no_return(np.array([0.0, 115.0, 220.0, 300.0, 300.0]), np.array([0.0, 0.9, 0.9,
    ...                                                                    0.5, 0.7])).tolist()
    [False, True, True, True, False]
    """
    b = np.mod(bearing_cw_deg, 360.0)
    out = np.zeros(b.shape, dtype=bool)
    for (low, high), share in ROOM.values():
        out |= (b >= low) & (b < high) & (draws < share)
    return out


def triangulation_offset_deg(distance_mm: np.ndarray) -> np.ndarray:
    """The A1's bearing correction [deg] for returns at ``distance_mm`` (0 where there is no
    return): the reported angle is the head angle plus this.

    >>> triangulation_offset_deg(np.array([0.0, 171.6, 2000.0])).round(2).tolist()
    [0.0, 0.0, -7.14]
    """
    d = np.asarray(distance_mm, dtype=np.float64)
    a, b = TRIANGULATION_MM
    safe = np.where(d > 0, d, b)
    return np.where(d > 0, np.degrees(np.arctan(a * (b - safe) / (b * safe))), 0.0)


def _simulated_lidar(backend: Any) -> Any:
    """The simulated lidar behind a ``SimBackend`` (None for any other backend)."""
    try:
        return backend.sim.robots[backend.robot].lidar
    except (AttributeError, IndexError, TypeError):
        return None


class RPLidarEmulator(Device):
    name = "rplidar"
    baudrate = 115200

    def __init__(self, backend: Any = None, samples_per_second: float = 2000.0,
                 turns_per_second: float = 5.5, health: int = 0,
                 express_samples_per_second: float = 4000.0,
                 faults: Faults | None = None, seed: int = 0) -> None:
        super().__init__(faults)
        self.backend = backend
        self.head_rng = random.Random(seed)  # the head's own jitter, apart from the faults'
        self._head = 0.0  # head angle of the next sample [deg, clockwise, unwrapped]
        self._turn = 0
        self.sample_time = 1.0 / samples_per_second
        # legacy capsules take 84 bytes per 32 samples: at 115200 baud the link carries at most
        # about 4400 samples/s, so the emulator's express mode gives 4000 (the paper's 8000
        # samples/s, erratum 11, would need a denser capsule format)
        self.express_sample_time = 1.0 / express_samples_per_second
        self.express = False
        self._capsule_angle = 0.0
        self._first_capsule = True
        self._last_scan: Any = None
        self.turns_per_second = turns_per_second
        self.health = health
        self.scanning = False
        self._buffer = bytearray()
        self._pending: list[bytes] = []  # nodes of the turn being sent
        self._next_node = 0.0
        self._turn_from_sim: list[bytes] | None = None
        self.turns_sent = 0
        if backend is not None and hasattr(backend, "subscribe"):
            backend.subscribe("scan", self._on_scan)
            lidar = _simulated_lidar(backend)
            if lidar is not None and lidar.time_increment > 0:
                # the simulated head's own timing: its beams one sample each, its turn rate
                self.sample_time = float(lidar.time_increment)
                self.turns_per_second = float(lidar.rate)

    # ------------------------------------------------------------------ requests
    def receive(self, data: bytes, now: float) -> None:
        buf = self._buffer
        buf += data
        while buf:
            if buf[0] != 0xA5:
                del buf[:1]
                continue
            if len(buf) < 2:
                return
            cmd = buf[1]
            if cmd & 0x80:  # a request with a payload: A5 cmd len payload chk
                if len(buf) < 3 or len(buf) < 4 + buf[2]:
                    return
                size = 4 + buf[2]
                ok = xor_checksum(bytes(buf[:size - 1])) == buf[size - 1]
                del buf[:size]
                if ok and cmd == EXPRESS_SCAN and self.health != 2:
                    self.send(EXPRESS_DESCRIPTOR, now)
                    self.scanning, self.express = True, True
                    self._pending = []
                    self._first_capsule = True
                    self._next_node = self._line_free
                continue  # SET_MOTOR_PWM, ACC_BOARD_FLAG: the A1 ignores them
            del buf[:2]
            self._command(cmd, now)

    def _command(self, cmd: int, now: float) -> None:
        if cmd == STOP:
            self._stop()
        elif cmd == RESET:
            self._stop()
            self.health = 0
            self.send(BANNER, now + 0.5, reply=False)
        elif cmd == GET_INFO:
            self.send(INFO, now)
        elif cmd == GET_HEALTH:
            code = 0x8000 if self.health == 2 else 0
            self.send(bytes.fromhex("A55A0300000006") + bytes([self.health]) +
                      code.to_bytes(2, "little"), now)
        elif cmd == GET_SAMPLERATE:
            us = round(self.sample_time * 1e6)
            self.send(bytes.fromhex("A55A0400000015") + us.to_bytes(2, "little") +
                      (us // 4).to_bytes(2, "little"), now)
        elif cmd in (SCAN, FORCE_SCAN):
            if self.health == 2 and cmd == SCAN:
                return  # a device in error does not scan
            self.send(SCAN_DESCRIPTOR, now)
            self.scanning, self.express = True, False
            self._pending = []
            self._next_node = self._line_free
            step = 360.0 * self.turns_per_second * self.sample_time
            self._turn = 0
            self._head = self._mark(0) + self.head_rng.uniform(0.0, step)

    def error_reply(self, reply: bytes) -> bytes | None:
        if reply.startswith(bytes.fromhex("A55A0300000006")):
            return bytes.fromhex("A55A0300000006") + bytes([2, 0x00, 0x80])
        return None

    def _stop(self) -> None:
        self.scanning = self.express = False
        self._pending = []
        self._out.clear()  # what was queued but not yet sent never goes out

    # ------------------------------------------------------------------ the turning head
    def _mark(self, turn: int) -> float:
        """Head angle [deg, unwrapped] where turn ``turn`` begins: its index mark."""
        return 360.0 * turn + INDEX_MARK_DEG + self.head_rng.uniform(0.0, INDEX_JITTER_DEG)

    def _on_scan(self, message: Any) -> None:
        """A simulated scan (counter-clockwise beams) → one turn of clockwise nodes, in the
        order the head takes them from its index mark on."""
        ranges = np.asarray(message.ranges, dtype=np.float64)
        n = len(ranges)
        angles = message.angle_min + message.angle_increment * np.arange(n)
        bearing = np.degrees(-angles) % 360.0
        ok = np.isfinite(ranges) & (ranges > 0)
        distance = np.where(ok, ranges * 1000.0, 0.0)
        head = bearing - triangulation_offset_deg(distance)
        order = np.argsort((head - self._mark(0)) % 360.0, kind="stable")
        self._turn_from_sim = [encode_node(k == 0, 47 if ok[i] else 0, float(bearing[i]),
                                           float(distance[i])) for k, i in enumerate(order)]
        self._last_scan = message

    def _room_turn(self) -> list[bytes]:
        """One turn of the head in the room: samples from this turn's index mark up to the
        next one, each at its corrected bearing."""
        step = 360.0 * self.turns_per_second * self.sample_time * \
            (1.0 + self.head_rng.gauss(0.0, SPEED_JITTER))
        end = self._mark(self._turn + 1)
        count = max(math.ceil((end - self._head) / step), 1)
        head = self._head + step * np.arange(count)
        self._head = float(head[-1] + step)
        self._turn += 1
        bearing = head % 360.0
        dark = no_return(bearing, np.array([self.head_rng.random() for _ in range(count)]))
        for _ in range(3):  # the bearing depends on the range it finds there
            distance = np.where(dark, 0.0, room_ranges(np.radians(-bearing)) * 1000.0)
            bearing = (head + triangulation_offset_deg(distance)) % 360.0
        return [encode_node(k == 0, 0 if dark[k] else 47, float(bearing[k]),
                            float(distance[k])) for k in range(count)]

    def _ranges_mm(self, cw_deg: np.ndarray) -> np.ndarray:
        """What the head sees at clockwise angles (the latest simulated turn, or the room)."""
        scan = self._last_scan
        if scan is None:
            dark = no_return(cw_deg, np.array([self.head_rng.random() for _ in cw_deg]))
            return np.where(dark, 0.0, room_ranges(np.radians(-cw_deg)) * 1000.0)
        ranges = np.asarray(scan.ranges, dtype=np.float64)
        ccw = np.radians(-cw_deg)
        index = np.rint((np.remainder(ccw - scan.angle_min, 2 * math.pi)) /
                        scan.angle_increment).astype(int) % len(ranges)
        r = ranges[index]
        return np.where(np.isfinite(r) & (r > 0), r * 1000.0, 0.0)

    def _stream_capsules(self, now: float) -> None:
        period = 32 * self.express_sample_time
        step = 360.0 * self.turns_per_second * period
        while self._next_node <= now:
            if self.backend is not None:
                self.backend.advance(self._next_node)
            angles = (self._capsule_angle + step * np.arange(32) / 32.0) % 360.0
            capsule = encode_capsule(self._first_capsule, self._capsule_angle,
                                     self._ranges_mm(angles).tolist())
            self.send(capsule, self._next_node, reply=False)
            self._first_capsule = False
            self._capsule_angle = (self._capsule_angle + step) % 360.0
            self._next_node += period
            if now - self._next_node > 1.0:
                self._next_node = now

    def stream(self, now: float) -> None:
        if not self.scanning:
            return
        if self.express:
            self._stream_capsules(now)
            return
        while self._next_node <= now:
            if not self._pending:
                if self.backend is not None:
                    self.backend.advance(self._next_node)
                    turn, self._turn_from_sim = self._turn_from_sim, None
                    if turn is None:
                        # no complete simulated turn yet: the head turns, nothing to send
                        self._next_node += self.sample_time
                        continue
                    self._pending = turn
                else:
                    self._pending = self._room_turn()
                self._pending.reverse()
                self.turns_sent += 1
                self.event("turn", self._next_node)  # its first sample's time
            node_time = self.byte_time(5)
            while self._pending and self._next_node <= now:
                # each node leaves as it is measured, never before
                if self.faults.any:
                    self.send(self._pending.pop(), self._next_node, reply=False)
                else:  # (the same, without the fault injector's per-call work)
                    start = max(self._next_node, self._line_free)
                    self._line_free = start + node_time
                    self._out.append((self._line_free, self._pending.pop(), self.baudrate))
                self._next_node += self.sample_time
            if now - self._next_node > 1.0:
                self._next_node = now  # nobody read for a long time: do not backlog
