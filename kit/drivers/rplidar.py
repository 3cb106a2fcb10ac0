"""Slamtec RPLidar A1: requests, response descriptors, standard-scan nodes and full-turn
``LaserScan`` messages.

A node is 5 bytes: ``quality<<2 | !S<<1 | S``, then ``angle_q6<<1 | 1`` (u16 LE), then
``distance_q2`` (u16 LE). The angle (degrees = q6/64) grows **clockwise** seen from above;
ROS scans are counter-clockwise, so a turn is mirrored into the ``LaserScan``. The stream
is resynchronised as the SDK does: a 5-byte window is a node only if ``S != !S`` and the
check bit is 1; otherwise one byte is skipped. Facts and vectors: ``protocols.md`` §6.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from kit import msgs
from kit.drivers.checksums import xor_checksum
from kit.drivers.errors import DeviceError, DeviceTimeout, ProtocolError
from kit.drivers.port import Link

__all__ = ["DEVICE", "Capsule", "CapsuleParser", "Node", "NodeParser", "RPLidar",
           "decode_capsule", "decode_node", "encode_capsule", "encode_node", "encode_request",
           "parse_descriptor", "revolution_to_scan", "split_revolutions"]

DEVICE = "RPLidar"
STOP, RESET, SCAN, FORCE_SCAN, GET_INFO, GET_HEALTH, GET_SAMPLERATE = (
    0x25, 0x40, 0x20, 0x21, 0x50, 0x52, 0x59)
SCAN_DESCRIPTOR = bytes.fromhex("A55A0500004081")


def encode_request(command: int, payload: bytes | None = None) -> bytes:
    """``A5 cmd`` or, with a payload, ``A5 cmd len payload chk`` (XOR of all before).

    >>> encode_request(0xF0, (660).to_bytes(2, "little")).hex(" ").upper()
    'A5 F0 02 94 02 C1'
    """
    if not 0 <= command <= 0xFF:
        raise ValueError(f"command must be a byte; got {command}")
    if payload is None:
        return bytes([0xA5, command])
    if len(payload) > 255:
        raise ValueError("payload longer than 255 bytes")
    frame = bytes([0xA5, command, len(payload)]) + payload
    return frame + bytes([xor_checksum(frame)])


def parse_descriptor(data: bytes) -> tuple[int, int, int]:
    """``A5 5A | u32 LE (length bits 0..29, mode bits 30..31) | type`` → (length, mode, type).

    >>> parse_descriptor(bytes.fromhex("A55A0500004081"))
    (5, 1, 129)
    """
    if len(data) != 7 or data[:2] != b"\xa5\x5a":
        raise ProtocolError(DEVICE, f"not a response descriptor: {data.hex(' ')}")
    word = int.from_bytes(data[2:6], "little")
    return word & 0x3FFFFFFF, word >> 30, data[6]


@dataclass(frozen=True)
class Node:
    start: bool
    """the first node of a new revolution."""
    quality: int
    angle_deg: float
    """clockwise from the sensor's front, [0, 360)."""
    distance_mm: float
    """0 means no return."""


def decode_node(raw: bytes) -> Node | None:
    """One 5-byte node, or ``None`` when its check bits say it is not a node here.

    >>> decode_node(bytes.fromhex("3D012DA00F"))
    Node(start=True, quality=15, angle_deg=90.0, distance_mm=1000.0)
    """
    b0, b1 = raw[0], raw[1]
    if not ((b0 ^ (b0 >> 1)) & 1) or not (b1 & 1):
        return None
    angle_q6 = (b1 >> 1) | (raw[2] << 7)
    return Node(bool(b0 & 1), b0 >> 2, angle_q6 / 64.0,
                int.from_bytes(raw[3:5], "little") / 4.0)


def encode_node(start: bool, quality: int, angle_deg: float, distance_mm: float) -> bytes:
    """The 5 bytes of a node (the device side; emulators and tests use it).

    >>> encode_node(True, 15, 90.0, 1000.0).hex(" ").upper()
    '3D 01 2D A0 0F'
    """
    if not 0 <= quality <= 63:
        raise ValueError(f"quality is 0..63; got {quality}")
    angle_q6 = round(angle_deg * 64.0) % (360 * 64)
    distance_q2 = min(max(round(distance_mm * 4.0), 0), 0xFFFF)
    b0 = (quality << 2) | (0 if start else 2) | int(start)
    return bytes([b0]) + ((angle_q6 << 1) | 1).to_bytes(2, "little") + \
        distance_q2.to_bytes(2, "little")


class _Resynchronising:
    """Bytes → records of ``size`` bytes with no frame around them: a window that does not
    decode is skipped by one byte. Subclasses decode a window and turn records into nodes."""

    size = 5

    def __init__(self) -> None:
        self._buffer = bytearray()
        self.skipped = 0

    def _decode(self, raw: bytes) -> Any:
        raise NotImplementedError

    def _record(self, record: Any, nodes: list[Node]) -> None:
        nodes.append(record)

    def _skip(self) -> None:
        self.skipped += 1

    def feed(self, data: bytes) -> list[Node]:
        buf = self._buffer
        buf += data
        nodes: list[Node] = []
        i, size = 0, self.size
        while len(buf) - i >= size:
            record = self._decode(bytes(buf[i:i + size]))
            if record is None:
                i += 1
                self._skip()
                continue
            self._record(record, nodes)
            i += size
        del buf[:i]
        return nodes


class NodeParser(_Resynchronising):
    """Bytes → nodes, resynchronising by one byte over anything that is not a node."""

    def _decode(self, raw: bytes) -> Node | None:
        return decode_node(raw)


def revolution_to_scan(nodes: list[Node], stamp: msgs.Time, frame_id: str = "laser_link",
                       beams: int = 360, scan_time: float = 1 / 5.5, range_min: float = 0.15,
                       range_max: float = 12.0) -> msgs.LaserScan:
    """One turn of nodes → a ``LaserScan`` of ``beams`` counter-clockwise beams over
    [−π, π), each holding the nearest return that falls in it (``inf`` where none does).

    Beam ``i`` looks at ``angle_min + i·increment``; a node at clockwise angle α [deg] is
    at ``wrap(−α)`` in the scan.
    """
    if not nodes:
        raise ValueError("a revolution needs at least one node")
    increment = 2 * math.pi / beams
    ranges = np.full(beams, np.inf)
    intensities = np.zeros(beams)
    for node in nodes:
        if node.distance_mm <= 0:
            continue
        angle = math.remainder(-math.radians(node.angle_deg), 2 * math.pi)
        index = round((angle + math.pi) / increment) % beams
        r = node.distance_mm / 1000.0
        if r < ranges[index]:
            ranges[index], intensities[index] = r, node.quality
    ranges[(ranges < range_min) | (ranges > range_max)] = np.inf
    return msgs.LaserScan(
        header=msgs.Header(stamp, frame_id), angle_min=-math.pi,
        angle_max=-math.pi + increment * (beams - 1), angle_increment=increment,
        time_increment=scan_time / max(len(nodes), 1), scan_time=scan_time,
        range_min=range_min, range_max=range_max, ranges=ranges.astype(np.float32),
        intensities=intensities.astype(np.float32))


def split_revolutions(nodes: list[Node]) -> list[list[Node]]:
    """Group nodes into turns, each starting at a node with ``start`` set (nodes before the
    first start are dropped; the last, unfinished turn is kept)."""
    turns: list[list[Node]] = []
    for node in nodes:
        if node.start:
            turns.append([])
        if turns:
            turns[-1].append(node)
    return turns


class RPLidar:
    """An RPLidar A1 on a serial port: health, info, the standard scan, and full turns as
    counter-clockwise ``LaserScan`` messages (:meth:`read_scan`).

    The A1's motor runs while DTR is low; a pseudo-terminal cannot set DTR (the ``OSError``
    is caught), and its emulator keeps the motor running.
    """

    def __init__(self, port: Any, timeout: float = 1.0,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep,
                 frame_id: str = "laser_link", beams: int = 360) -> None:
        self.link = Link(DEVICE, port, 115200, 0.01, clock, sleep)
        self.timeout = timeout
        self.frame_id = frame_id
        self.beams = beams
        self.parser: _Resynchronising = NodeParser()
        self.scanning = False
        self._turn: list[Node] = []
        self._nodes: list[Node] = []
        self._turn_started = self._last_start = 0.0

    def _motor(self, run: bool) -> None:
        try:
            self.link.port.dtr = not run
        except (OSError, AttributeError):
            pass  # a pseudo-terminal cannot set DTR (protocols.md §0)

    def _read_exact(self, n: int, what: str) -> bytes:
        return self.link.read_exact(n, self.timeout, what)

    def _command(self, command: int, what: str, expect_type: int | None,
                 payload: bytes | None = None) -> bytes:
        self.link.clear(what)
        self.link.write(encode_request(command, payload), what)
        if expect_type is None:
            return b""
        length, mode, kind = parse_descriptor(self._read_exact(7, what))
        if kind != expect_type:
            raise ProtocolError(DEVICE, f"{what}: reply type 0x{kind:02X}, expected "
                                        f"0x{expect_type:02X}")
        if mode == 1:
            return b""  # a stream follows
        return self._read_exact(length, what)

    def health(self) -> tuple[int, int]:
        """(status 0 good / 1 warning / 2 error, error code)."""
        data = self._command(GET_HEALTH, "get health", 0x06)
        return data[0], int.from_bytes(data[1:3], "little")

    def info(self) -> dict[str, Any]:
        data = self._command(GET_INFO, "get info", 0x04)
        return {"model": data[0], "firmware": (data[2], data[1]), "hardware": data[3],
                "serial": data[4:20].hex().upper()}

    def sample_time_us(self) -> tuple[int, int]:
        """Microseconds per sample: (standard scan, express scan)."""
        data = self._command(GET_SAMPLERATE, "get sample rate", 0x15)
        return int.from_bytes(data[0:2], "little"), int.from_bytes(data[2:4], "little")

    def reset(self, wait: float = 2.0) -> None:
        self._command(RESET, "reset", None)
        self.link.sleep(wait)
        self.link.clear("reset")

    def start(self) -> None:
        """Motor on, health checked (a device in error is reset once), standard scan on."""
        self._motor(True)
        status, code = self.health()
        if status == 2:
            self.reset()
            status, code = self.health()
            if status == 2:
                raise DeviceError(DEVICE, f"health: error 0x{code:04X} after a reset", code)
        self._command(STOP, "stop", None)
        self.link.sleep(0.002)
        self.link.clear("stop")
        self.link.write(encode_request(SCAN), "scan")
        descriptor = self._read_exact(7, "scan")
        if descriptor != SCAN_DESCRIPTOR:
            raise ProtocolError(DEVICE, f"scan: descriptor {descriptor.hex(' ')} is not "
                                        f"{SCAN_DESCRIPTOR.hex(' ')}")
        self.parser = NodeParser()
        self._turn, self._nodes = [], []
        self.scanning = True

    def start_express(self) -> None:
        """Like :meth:`start`, in express mode (legacy capsules, ``A5 82 05 00 00 00 00 00``):
        more samples per second; the kit's A1 normally uses the standard scan."""
        self._motor(True)
        self._command(STOP, "stop", None)
        self.link.sleep(0.002)
        self.link.clear("stop")
        self.link.write(encode_request(EXPRESS_SCAN, bytes(5)), "express scan")
        descriptor = self._read_exact(7, "express scan")
        if descriptor != EXPRESS_DESCRIPTOR:
            raise ProtocolError(DEVICE, f"express scan: descriptor {descriptor.hex(' ')} is not "
                                        f"{EXPRESS_DESCRIPTOR.hex(' ')}")
        self.parser = CapsuleParser()
        self._turn, self._nodes = [], []
        self.scanning = True

    def stop(self) -> None:
        self._command(STOP, "stop", None)
        self.link.sleep(0.002)
        self.link.clear("stop")
        self.scanning = False
        self._motor(False)

    def read_revolution(self) -> list[Node]:
        """The nodes of the next complete turn (from one start flag to the next)."""
        if not self.scanning:
            raise ProtocolError(DEVICE, "read: call start() first")
        link = self.link
        deadline = link.clock() + self.timeout
        while True:
            while self._nodes:
                node = self._nodes.pop(0)
                # a start flag begins a turn only where the head has come round (a flag
                # flipped by line noise in mid-turn does not cut the turn in two)
                if node.start and (not self._turn or (node.angle_deg < 45.0 and max(
                        n.angle_deg for n in self._turn[-8:]) > 315.0)):
                    turn, self._turn = self._turn, [node]
                    started, self._turn_started = self._turn_started, link.clock()
                    if turn and turn[0].start:
                        self._last_start = started
                        return turn
                elif self._turn:
                    self._turn.append(node)
            if link.clock() >= deadline:
                raise DeviceTimeout(DEVICE, f"read scan: no complete turn within "
                                            f"{self.timeout:g} s")
            self._nodes.extend(self.parser.feed(link.read_some("read scan")))

    def read_scan(self) -> msgs.LaserScan:
        """The next complete turn as a counter-clockwise ``LaserScan``."""
        turn = self.read_revolution()
        scan_time = max(self._turn_started - self._last_start, 1e-3)
        return revolution_to_scan(turn, msgs.Time.from_sec(self._last_start), self.frame_id,
                                  self.beams, scan_time)

    def close(self) -> None:
        self.link.close()


# ------------------------------------------------------------------ express scan (§6.6)

EXPRESS_SCAN = 0x82
EXPRESS_DESCRIPTOR = bytes.fromhex("A55A5400004082")
CAPSULE = 84


@dataclass(frozen=True)
class Capsule:
    """One checked express-scan capsule: its start angle and 32 (distance, offset) samples."""

    start: bool
    angle_deg: float
    distances_mm: tuple[float, ...]
    offsets_deg: tuple[float, ...]
    """each sample's angle correction (subtracted from the interpolated angle)."""


def decode_capsule(raw: bytes) -> Capsule | None:
    """An 84-byte capsule, or ``None`` when its sync nibbles or checksum do not match."""
    if len(raw) != CAPSULE or raw[0] >> 4 != 0xA or raw[1] >> 4 != 0x5:
        return None
    if xor_checksum(raw[2:]) != ((raw[0] & 0x0F) | ((raw[1] & 0x0F) << 4)):
        return None
    word = raw[2] | raw[3] << 8
    distances, offsets = [], []
    for c in range(16):
        base = 4 + 5 * c
        d1 = raw[base] | raw[base + 1] << 8
        d2 = raw[base + 2] | raw[base + 3] << 8
        off = raw[base + 4]
        for d, low in ((d1, off & 0x0F), (d2, off >> 4)):
            distances.append((d & 0xFFFC) / 4.0)
            offset = ((d & 0x3) << 4) | low
            offsets.append(offset / 8.0)
    return Capsule(bool(word & 0x8000), (word & 0x7FFF) / 64.0, tuple(distances),
                   tuple(offsets))


def encode_capsule(start: bool, angle_deg: float, distances_mm: list[float],
                   offsets_deg: list[float] | None = None) -> bytes:
    """The device side of :func:`decode_capsule` (emulators and tests)."""
    if len(distances_mm) != 32:
        raise ValueError("a capsule carries 32 samples")
    offsets = [round(o * 8) & 0x3F for o in (offsets_deg or [0.0] * 32)]
    body = bytearray(((round(angle_deg * 64) % (360 * 64)) | (0x8000 if start else 0))
                     .to_bytes(2, "little"))
    for c in range(16):
        words = []
        for k in (2 * c, 2 * c + 1):
            q2 = min(max(round(distances_mm[k] * 4), 0), 0xFFFF) & 0xFFFC
            words.append(q2 | (offsets[k] >> 4))
        body += words[0].to_bytes(2, "little") + words[1].to_bytes(2, "little")
        body.append((offsets[2 * c] & 0x0F) | ((offsets[2 * c + 1] & 0x0F) << 4))
    checksum = xor_checksum(bytes(body))
    return bytes([0xA0 | (checksum & 0x0F), 0x50 | (checksum >> 4)]) + bytes(body)


class CapsuleParser(_Resynchronising):
    """Bytes → nodes of the express scan. A capsule's samples are placed between its start
    angle and the next capsule's, so nodes come out one capsule late; a capsule that fails
    its sync or checksum is skipped byte by byte (and the one before it loses its end angle,
    so its samples are dropped rather than guessed)."""

    size = CAPSULE

    def __init__(self) -> None:
        super().__init__()
        self._previous: Capsule | None = None
        self._last_angle = 360.0  # so that the first node starts a turn

    def _decode(self, raw: bytes) -> Capsule | None:
        return decode_capsule(raw)

    def _skip(self) -> None:
        self.skipped += 1
        self._previous = None

    def _record(self, capsule: Capsule, nodes: list[Node]) -> None:
        prev, self._previous = self._previous, capsule
        if prev is None or capsule.start:  # the start bit marks a (re)started scan
            return
        span = (capsule.angle_deg - prev.angle_deg) % 360.0
        for k in range(32):
            angle = (prev.angle_deg + span * k / 32.0 - prev.offsets_deg[k]) % 360.0
            # a new turn where the angle wraps round, as the SDK marks it
            wrapped = self._last_angle - angle > 180.0
            self._last_angle = angle
            nodes.append(Node(wrapped, 0, angle, prev.distances_mm[k]))
