"""The RPLidar's bytes: requests, response descriptors, standard-scan nodes and express-scan
capsules, and the resynchronising parsers (``protocols.md`` §6)."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import Any

from kit.drivers.checksums import xor_checksum
from kit.drivers.errors import ProtocolError

DEVICE = "RPLidar"
BAUDRATE = 115200
STOP, RESET, SCAN, FORCE_SCAN, GET_INFO, GET_HEALTH, GET_SAMPLERATE = (
    0x25, 0x40, 0x20, 0x21, 0x50, 0x52, 0x59)
SCAN_DESCRIPTOR = bytes.fromhex("A55A0500004081")
FULL_TURN_Q6 = 360 * 64


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


def _node_fields(raw: bytes) -> Node | None:
    """The window's fields when its check bits pass (nothing else is checked)."""
    b0, b1 = raw[0], raw[1]
    if not ((b0 ^ (b0 >> 1)) & 1) or not (b1 & 1):
        return None
    angle_q6 = (b1 >> 1) | (raw[2] << 7)
    return Node(bool(b0 & 1), b0 >> 2, angle_q6 / 64.0,
                int.from_bytes(raw[3:5], "little") / 4.0)


def decode_node(raw: bytes) -> Node | None:
    """One 5-byte node, or ``None`` when it is not one: its check bits fail (``S == !S`` or
    the check bit 0), or its angle is outside the format's [0°, 360°).

    >>> decode_node(bytes.fromhex("3D012DA00F"))
    Node(start=True, quality=15, angle_deg=90.0, distance_mm=1000.0)
    >>> decode_node(bytes.fromhex("3EFFFF1027")) is None   # 511.98°: not an angle
    True
    """
    node = _node_fields(raw)
    if node is None or node.angle_deg >= 360.0:
        return None
    return node


def node_problem(node: Node) -> str | None:
    """Why a node whose check bits pass cannot come from the device (``None`` if it can).

    Two things the device never sends: an angle of 360° or more (the q6 field can hold up
    to 511.98°) and a distance measured with no signal at all (quality 0 with a distance;
    in the captured streams every quality-0 node has distance 0).

    >>> node_problem(Node(False, 0, 10.0, 1500.0))
    'a distance without signal'
    """
    if node.angle_deg >= 360.0:
        return "an angle beyond 360°"
    if node.quality == 0 and node.distance_mm > 0:
        return "a distance without signal"
    return None


def encode_node(start: bool, quality: int, angle_deg: float, distance_mm: float) -> bytes:
    """The 5 bytes of a node (the device side; emulators and tests use it).

    >>> encode_node(True, 15, 90.0, 1000.0).hex(" ").upper()
    '3D 01 2D A0 0F'
    """
    if not 0 <= quality <= 63:
        raise ValueError(f"quality is 0..63; got {quality}")
    angle_q6 = round(angle_deg * 64.0) % FULL_TURN_Q6
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
    """Bytes → nodes, resynchronising by one byte over anything that is not a node.

    By default a window is a node when its check bits pass, which is all Slamtec's SDK
    unpacker checks (and what Lab 03 asks for). With ``strict=True`` (the driver's choice) a
    window whose node could not come from the device (:func:`node_problem`) is skipped too,
    and ``refused`` counts such windows by reason.
    """

    def __init__(self, strict: bool = False) -> None:
        super().__init__()
        self.strict = strict
        self.refused: Counter[str] = Counter()

    def _decode(self, raw: bytes) -> Node | None:
        node = _node_fields(raw)
        if node is not None and self.strict:
            problem = node_problem(node)
            if problem is not None:
                self.refused[problem] += 1
                return None
        return node


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
