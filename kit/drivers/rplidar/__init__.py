"""Slamtec RPLidar A1: requests, response descriptors, standard-scan nodes, whole turns
checked for plausibility, and turns as ``LaserScan`` messages.

A node is 5 bytes: ``quality<<2 | !S<<1 | S``, then ``angle_q6<<1 | 1`` (u16 LE), then
``distance_q2`` (u16 LE). The angle (degrees = q6/64, in [0, 360)) grows **clockwise** seen
from above; ROS scans are counter-clockwise, so a turn is mirrored into the ``LaserScan``.
The stream is resynchronised as Slamtec's SDK does: a 5-byte window is a node only if
``S != !S`` and the check bit is 1; otherwise one byte is skipped. Facts and vectors:
``protocols.md`` §6.

Turns are grouped as the SDK groups them: every node with the start flag S ends the turn
before it and begins the next, wherever it falls. On a real A1 it falls at 351–359°, not at
0°: the flag marks the sample where the head passes its index (about 358° of head angle),
and the angles the device reports are corrected for its triangulation geometry (up to −8°
for far returns), so a turn runs 351° → 359° → 0° → 350° (the captures in
``shared/data/device-captures``). Nodes carry no checksum, so the driver judges what it
decodes: a node with an angle beyond 360° or a distance without any signal is refused, and
a turn with too few or too many nodes, or one that does not go round, is refused with its
reason counted (:class:`TurnAssembler`). Random bytes after a scan descriptor therefore
give no scan, only a :class:`~kit.drivers.errors.DeviceTimeout` that says what was seen.
"""

from __future__ import annotations

from kit.drivers.rplidar._driver import RPLidar
from kit.drivers.rplidar._protocol import (
    BAUDRATE,
    CAPSULE,
    DEVICE,
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
    Capsule,
    CapsuleParser,
    Node,
    NodeParser,
    decode_capsule,
    decode_node,
    encode_capsule,
    encode_node,
    encode_request,
    node_problem,
    parse_descriptor,
)
from kit.drivers.rplidar._turns import (
    Turn,
    TurnAssembler,
    angular_span_deg,
    revolution_to_scan,
    split_revolutions,
)

__all__ = ["BAUDRATE", "CAPSULE", "DEVICE", "EXPRESS_DESCRIPTOR", "EXPRESS_SCAN", "FORCE_SCAN",
           "GET_HEALTH", "GET_INFO", "GET_SAMPLERATE", "RESET", "SCAN", "SCAN_DESCRIPTOR",
           "STOP", "Capsule", "CapsuleParser", "Node", "NodeParser", "RPLidar", "Turn",
           "TurnAssembler", "angular_span_deg", "decode_capsule", "decode_node",
           "encode_capsule", "encode_node", "encode_request", "node_problem", "parse_descriptor",
           "revolution_to_scan", "split_revolutions"]
