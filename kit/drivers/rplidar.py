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
from dataclasses import dataclass

import numpy as np

from kit import msgs
from kit.drivers.checksums import xor_checksum
from kit.drivers.errors import ProtocolError

__all__ = ["DEVICE", "Node", "NodeParser", "decode_node", "encode_request",
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


class NodeParser:
    """Bytes → nodes, resynchronising by one byte over anything that is not a node."""

    def __init__(self) -> None:
        self._buffer = bytearray()
        self.skipped = 0

    def feed(self, data: bytes) -> list[Node]:
        buf = self._buffer
        buf += data
        nodes: list[Node] = []
        i = 0
        while len(buf) - i >= 5:
            node = decode_node(bytes(buf[i:i + 5]))
            if node is None:
                i += 1
                self.skipped += 1
                continue
            nodes.append(node)
            i += 5
        del buf[:i]
        return nodes


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
