"""Lab 03 — drivers and bring-up (act/see): the exercises, their cases and their known
mistakes. References are the kit's drivers; the cases are the protocol spec's vectors."""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

from grader.labs._hidden import telling
from grader.spec import Case, Diagnostic, Exercise, LabSpec
from kit import kinematics
from kit.drivers import checksums, dpralte, os5000, rplidar
from kit.drivers import odrive as odrive_driver
from kit.drivers.errors import DriverError
from kit.geometry import wrap_angle
from kit.robots import load as load_robot

_BLOCKED = (
    "kit.drivers.checksums:crc16_xmodem", "kit.drivers.dpralte:encode_write",
    "kit.drivers.dpralte:rpm_to_units", "kit.drivers.dpralte:int32_words",
    "kit.drivers.os5000:parse_sentence", "kit.drivers.os5000:heading_to_yaw",
    "kit.drivers.rplidar:decode_node", "kit.drivers.rplidar:NodeParser",
    "kit.drivers.odrive:axis_state_name", "kit.drivers.bases:UiabotBase.motor_speeds",
)
"""the references a student could call. They refuse only while an exercise runs, so the
notebook's own bring-up (ODrive, ``UiabotBase.drive``) keeps working around them."""


# ---------------------------------------------------------------- CRC-16/XMODEM

def _crc_init_ffff(data: bytes) -> Any:
    return checksums.crc16_xmodem(data, 0xFFFF)


def _crc_swapped(data: bytes) -> Any:
    c = checksums.crc16_xmodem(data)
    return ((c & 0xFF) << 8) | (c >> 8)


def _crc_reflected(data: bytes) -> Any:  # CRC-16/KERMIT: the same polynomial, bits reflected
    crc = 0
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0x8408 if crc & 1 else crc >> 1
    return crc


def _crc_unmasked(data: bytes) -> Any:
    """The shifts never cut back to 16 bits: the right low 16 bits under a growing top."""
    crc = 0
    for b in data:
        crc ^= b << 8
        for _ in range(8):
            crc = (crc << 1) ^ 0x1021 if crc & 0x8000 else crc << 1
    return crc


def _crc_low_byte(data: bytes) -> Any:
    """Each byte XORed into the low 8 bits, then shifted most-significant bit first."""
    crc = 0
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def _crc_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (bytes(rng.integers(0, 256, int(rng.integers(1, 40)),
                                                    dtype=np.uint8).tolist()),))
            for i in range(5)]


_CRC_MISTAKES = (
    Diagnostic("CRC-16/CCITT-FALSE (initial value 0xFFFF)", _crc_init_ffff,
               "XMODEM starts from 0x0000, not 0xFFFF"),
    Diagnostic("the two result bytes swapped", _crc_swapped,
               "return the CRC as one number; the byte order belongs to the frame"),
    Diagnostic("CRC-16/KERMIT (bits reflected)", _crc_reflected,
               "XMODEM shifts most-significant bit first (no reflection): poly 0x1021"),
    Diagnostic("the CRC not kept to 16 bits", _crc_unmasked,
               "Python's integers do not overflow: keep 16 bits with & 0xFFFF after each "
               "shift (or once at the end)"),
    Diagnostic("each byte XORed into the low 8 bits", _crc_low_byte,
               "shifting most-significant bit first, each byte goes into the CRC's top 8 "
               "bits: crc ^= byte << 8"),
)

crc16_xmodem = Exercise(
    id="lab03.crc16_xmodem", function="crc16_xmodem", title="The drives' CRC",
    reference=checksums.crc16_xmodem, points=2,
    public=(Case("check value", (b"123456789",)),
            Case("the paper's header", (bytes.fromhex("A53F02450202"),)),
            Case("the paper's data", (bytes.fromhex("B5010000"),)),
            Case("nothing", (b"",))),
    hidden=telling(_crc_hidden, checksums.crc16_xmodem, _CRC_MISTAKES),
    diagnostics=_CRC_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- velocity frame

def _frame(address: int, offset: int, rpm: float, sequence: int = 0) -> bytes:
    return dpralte.encode_write(address, 0x45, offset,
                                dpralte.int32_words(dpralte.rpm_to_units(rpm)), sequence)


def _frame_crc_le(address: int, offset: int, rpm: float, sequence: int = 0) -> Any:
    f = _frame(address, offset, rpm, sequence)
    return f[:6] + f[6:8][::-1] + f[8:12] + f[12:14][::-1]


def _frame_data_be(address: int, offset: int, rpm: float, sequence: int = 0) -> Any:
    data = dpralte.rpm_to_units(rpm).to_bytes(4, "big", signed=True)
    return dpralte.encode_write(address, 0x45, offset, data, sequence)


def _frame_paper_factor(address: int, offset: int, rpm: float, sequence: int = 0) -> Any:
    return dpralte.encode_write(address, 0x45, offset, dpralte.int32_words(round(rpm * 43.7)),
                                sequence)


def _frame_no_sof_in_crc(address: int, offset: int, rpm: float, sequence: int = 0) -> Any:
    f = bytearray(_frame(address, offset, rpm, sequence))
    f[6:8] = checksums.crc16_xmodem(bytes(f[1:6])).to_bytes(2, "big")
    return bytes(f)


def _frame_sequence_unshifted(address: int, offset: int, rpm: float,
                              sequence: int = 0) -> Any:
    """The control byte 2 | sequence: the sequence number in the command's bits."""
    header = bytes([0xA5, address, 2 | sequence, 0x45, offset, 2])
    data = dpralte.int32_words(dpralte.rpm_to_units(rpm))
    return (header + checksums.crc16_xmodem(header).to_bytes(2, "big") + data
            + checksums.crc16_xmodem(data).to_bytes(2, "big"))


def _frame_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (int(rng.choice([0x3E, 0x3F])), int(rng.choice([0, 2])),
                                 float(np.round(rng.uniform(-110, 110), 1)),
                                 int(rng.integers(0, 16))))
            for i in range(5)]


_FRAME_MISTAKES = (
    Diagnostic("CRCs sent low byte first", _frame_crc_le,
               "both CRCs go out high byte first, although the data words are LE"),
    Diagnostic("the velocity sent big-endian", _frame_data_be,
               "a 32-bit value goes out least significant byte first"),
    Diagnostic("RPM × 43.7", _frame_paper_factor,
               "the paper's 43.7 is rounded: units = RPM × 400/60 × 2^17/20000"),
    Diagnostic("header CRC without the A5", _frame_no_sof_in_crc,
               "the header CRC covers bytes 0–5, the A5 included"),
    Diagnostic("the sequence number not shifted", _frame_sequence_unshifted,
               "the sequence number sits in bits 5..2 of the control byte, the command (2) "
               "in bits 1..0: 2 | (sequence << 2)"),
)


velocity_frame = Exercise(
    id="lab03.velocity_frame", function="velocity_frame", title="A velocity command frame",
    reference=_frame, points=3,
    public=(Case("the IGV paper's frame: right drive, 10 RPM", (0x3F, 0x02, 10.0)),
            Case("left drive, 10 RPM", (0x3E, 0x00, 10.0)),
            Case("right drive backwards", (0x3F, 0x02, -10.0)),
            Case("full speed, sequence 5", (0x3F, 0x02, 110.0, 5))),
    hidden=telling(_frame_hidden, _frame, _FRAME_MISTAKES),
    diagnostics=_FRAME_MISTAKES,
    blocked=_BLOCKED,
    uses=("crc16_xmodem",),
)


# ---------------------------------------------------------------- OS5000 sentences

def _compass(line: str) -> Any:
    try:
        r = os5000.parse_sentence(line)
    except DriverError:
        return None
    return (r.heading_deg, r.pitch_deg, r.roll_deg, r.yaw)


def _compass_raw_heading(line: str) -> Any:
    r = _compass(line)
    return None if r is None else (*r[:3], float(wrap_angle(math.radians(r[0]))))


def _compass_negated(line: str) -> Any:
    r = _compass(line)
    return None if r is None else (*r[:3], float(wrap_angle(-math.radians(r[0]))))


def _compass_yaw_degrees(line: str) -> Any:
    r = _compass(line)
    return None if r is None else (*r[:3], math.degrees(r[3]))


def _compass_unwrapped(line: str) -> Any:
    r = _compass(line)
    return None if r is None else (*r[:3], math.pi / 2 - math.radians(r[0]))


def _compass_unchecked(line: str) -> Any:
    """Every well-formed sentence taken, its checksum never compared."""
    m = re.fullmatch(r"\$([^*$]*)\*([0-9A-Fa-f]{2})", line.strip())
    if m is None:
        return None
    body = m.group(1)
    fixed = f"${body}*{checksums.nmea_checksum(body)}"
    return _compass(fixed)


def _compass_refused(line: str) -> Any:
    """Nothing accepted: what a checksum over "$…" (instead of what lies between $ and *)
    gives, or a parser that never matches."""
    return None


def _compass_sentence(rng: np.random.Generator, heading: float, corrupt: bool = False) -> str:
    body = (f"C{heading:.1f}P{rng.uniform(-90, 90):.1f}"
            f"R{rng.uniform(-180, 180):.1f}T{rng.uniform(-10, 40):.1f}")
    cs = checksums.nmea_checksum(body)
    if corrupt:
        cs = f"{(int(cs, 16) ^ 0x11):02X}"
    return f"${body}*{cs}"


def _compass_hidden(rng: np.random.Generator) -> list[Case]:
    """Three headings anywhere, one between west and north (where π/2 − heading passes −π)
    and one sentence whose checksum does not match."""
    cases = [Case(f"random {i}", (_compass_sentence(rng, float(rng.uniform(0, 360))),))
             for i in range(3)]
    cases.append(Case("random 3", (_compass_sentence(rng, float(rng.uniform(270.1, 359.9))),)))
    cases.append(Case("random 4", (_compass_sentence(rng, float(rng.uniform(0, 360)), True),)))
    return cases


_COMPASS_MISTAKES = (
    Diagnostic("the heading as yaw", _compass_raw_heading,
               "heading is clockwise from north; REP-103 yaw is counter-clockwise from "
               "east: yaw = π/2 − heading, wrapped"),
    Diagnostic("yaw = −heading", _compass_negated,
               "clockwise → counter-clockwise is only half of it: 0° heading is north, "
               "which is +π/2 in REP-103"),
    Diagnostic("the yaw in degrees", _compass_yaw_degrees,
               "heading, pitch and roll stay in degrees as the compass sends them, but "
               "the yaw is REP-103's: radians"),
    Diagnostic("an unwrapped yaw", _compass_unwrapped,
               "π/2 − heading reaches −3π/2 for headings past 270°: wrap it to [-π, π)"),
    Diagnostic("the checksum not checked", _compass_unchecked,
               "a sentence whose checksum does not match was corrupted on the line: refuse "
               "it (None) instead of trusting its numbers"),
    Diagnostic("a valid sentence refused", _compass_refused,
               "this sentence is valid: its checksum is the XOR of the characters BETWEEN $ "
               "and *, neither included (a $ in the XOR refuses every sentence); then C, P "
               "and R are numbers, possibly negative"),
)


parse_compass = Exercise(
    id="lab03.parse_compass", function="parse_compass", title="Compass sentences",
    reference=_compass, points=3,
    public=(Case("the manual's example", ("$C320.5P0.2R-18.3T19.0*3C",)),
            Case("rolled over", ("$C335.7P-0.4R-88.4T26.9*1A",)),
            Case("east", ("$C90.0P0.0R0.0T25.0*1B",)),
            Case("with magnetometer fields",
                 ("$C212.4P2.5R-14.0T28.4Mx107977.90My-79422.00Mz173.27Ax0.045Ay-0.245"
                  "Az0.977*3A",)),
            Case("a corrupted checksum", ("$C90.0P0.0R0.0T25.0*1C",)),
            Case("a line of text", ("CMD:R20",))),
    hidden=telling(_compass_hidden, _compass, _COMPASS_MISTAKES), atol=1e-9,
    diagnostics=_COMPASS_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- RPLidar nodes

def _nodes_array(nodes: list[rplidar.Node]) -> np.ndarray:
    if not nodes:
        return np.zeros((0, 4))
    return np.array([(float(n.start), float(n.quality), n.angle_deg, n.distance_mm)
                     for n in nodes])


def _nodes(data: bytes) -> Any:
    return _nodes_array(rplidar.NodeParser().feed(data))


def _nodes_no_resync(data: bytes) -> Any:
    # each 5-byte window judged as the reference judges it (check bits only), never shifted
    out = []
    for i in range(0, len(data) - 4, 5):
        out += rplidar.NodeParser().feed(data[i:i + 5])
    return _nodes_array(out)


def _nodes_raw_units(data: bytes) -> Any:
    a = _nodes(data)
    if len(a):
        a[:, 2] *= 64
        a[:, 3] *= 4
    return a


def _nodes_check_bit_kept(data: bytes) -> Any:
    """angle_q6 read as bytes 1–2 whole, its check bit still in bit 0: 2 × angle + 1/64."""
    a = _nodes(data)
    if len(a):
        a[:, 2] = 2 * a[:, 2] + 1 / 64
    return a


def _nodes_quality_unshifted(data: bytes) -> Any:
    """quality taken as byte 0 whole: 4 q + (not S) · 2 + S."""
    a = _nodes(data)
    if len(a):
        a[:, 1] = 4 * a[:, 1] + 2 - a[:, 0]
    return a


def _turn(rng: np.random.Generator, n: int, noise: int) -> bytes:
    angles = np.sort(rng.uniform(0, 360, n))
    stream = bytearray()
    for k, a in enumerate(angles):
        stream += rplidar.encode_node(k == 0, int(rng.integers(0, 64)), float(a),
                                      float(rng.choice([0.0, rng.uniform(150, 12000)])))
    for _ in range(noise):
        stream.insert(int(rng.integers(0, len(stream))), int(rng.integers(0, 256)))
    return bytes(stream)


def _turns(rng: np.random.Generator) -> list[Case]:
    """Stretches of a turn, the last with stray bytes on the line (relay noise)."""
    cases = [Case(f"random {i}", (_turn(rng, int(rng.integers(5, 60)), int(rng.integers(0, 5))),))
             for i in range(3)]
    cases.append(Case("random 3", (_turn(rng, int(rng.integers(20, 60)),
                                         int(rng.integers(1, 5))),)))
    return cases


_NODE_MISTAKES = (
    Diagnostic("whole 5-byte steps (no resynchronising)", _nodes_no_resync,
               "after a byte that does not fit, move on by ONE byte, not five: check "
               "S != !S and the check bit at every offset"),
    Diagnostic("raw q6 angle and q2 distance", _nodes_raw_units,
               "angle_q6 / 64 gives degrees, distance_q2 / 4 millimetres"),
    Diagnostic("the check bit kept in the angle", _nodes_check_bit_kept,
               "bit 0 of bytes 1–2 is the check bit: angle_q6 = (b1 | b2 << 8) >> 1"),
    Diagnostic("the quality not shifted", _nodes_quality_unshifted,
               "byte 0's two low bits are S and not-S: the quality is byte 0 >> 2"),
)

decode_nodes = Exercise(
    id="lab03.decode_nodes", function="decode_nodes", title="Lidar nodes, resynchronised",
    reference=_nodes, points=3,
    public=(Case("the spec's two nodes", (bytes.fromhex("3D012DA00F" "BE415AE903"),)),
            Case("a stray byte between them", (bytes.fromhex("3D012DA00F" "00" "BE415AE903"),)),
            Case("a turn with line noise", (_turn(np.random.default_rng(3), 40, 3),)),
            Case("nothing", (b"",))),
    hidden=telling(_turns, _nodes, _NODE_MISTAKES),
    diagnostics=_NODE_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- ODrive axis states

def _state(value: int, firmware: str) -> Any:
    try:
        return odrive_driver.axis_state_name(value, firmware)
    except ValueError:
        return None


def _state_paper_table(value: int, firmware: str) -> Any:
    return _state(value, "0.5.1")


def _state_new_table(value: int, firmware: str) -> Any:
    return _state(value, "0.5.6")


FIRMWARES = ("0.4.12", "0.5.1", "0.5.2", "0.5.4", "0.5.6")
"""ODrive releases: the 0.4 line and 0.5.1 number the states as the paper does; 0.5.2 on do
not."""


def _states_hidden(rng: np.random.Generator) -> list[Case]:
    """Any state under any firmware, and the two that tell the tables apart: 5, 11, 12 or 13
    under an older firmware and under a newer one."""
    cases = [Case(f"random {i}", (int(rng.integers(0, 14)), str(rng.choice(FIRMWARES))))
             for i in range(4)]
    for i, firmwares in ((4, FIRMWARES[:2]), (5, FIRMWARES[2:])):
        cases.append(Case(f"random {i}", (int(rng.choice([5, 11, 12, 13])),
                                          str(rng.choice(firmwares)))))
    return cases


_STATE_MISTAKES = (
    Diagnostic("the paper's table for every firmware", _state_paper_table,
               "erratum 9: firmware 0.5.2 renumbered the states — 5 is gone, "
               "11–13 are new"),
    Diagnostic("the new table for every firmware", _state_new_table,
               "firmware before 0.5.2 (0.4.x, 0.5.1) still numbers the states as the paper "
               "does: 5 is SENSORLESS_CONTROL there, and 11–13 do not exist"),
)


axis_state_name = Exercise(
    id="lab03.axis_state_name", function="axis_state_name",
    title="Find the bug: ODrive axis states", reference=_state, points=2,
    public=(Case("closed loop", (8, "0.5.6")), Case("5 on 0.5.1", (5, "0.5.1")),
            Case("5 on 0.5.6", (5, "0.5.6")), Case("11 on 0.5.6", (11, "0.5.6")),
            Case("11 on 0.5.1", (11, "0.5.1")), Case("13 on 0.5.2", (13, "0.5.2"))),
    hidden=telling(_states_hidden, _state, _STATE_MISTAKES),
    diagnostics=_STATE_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- twist → motors

UIABOT = load_robot("uiabot")


def _motors(v: float, w: float, mirror: bool = True, turns: bool = True, gear: bool = True,
            clip_each: bool = False, saturate: bool = True, halve: bool = True) -> Any:
    d = UIABOT
    wheels = kinematics.twist_to_wheel_speeds(v, w, d.wheel_radius,
                                              d.wheel_separation * (1 if halve else 2))
    if clip_each:
        wheels = np.clip(wheels, -d.max_wheel_speed, d.max_wheel_speed)
    elif saturate:
        wheels = kinematics.saturate_wheel_speeds(wheels, d.max_wheel_speed)
    scale = (d.gear_ratio if gear else 1.0) / (2 * math.pi if turns else 1.0)
    signs = np.array([1.0, -1.0 if mirror else 1.0])
    return np.asarray(wheels) * scale * signs


_MOTOR_MISTAKES = (
    Diagnostic("the left motor not mirrored", lambda v, w: _motors(v, w, mirror=False),
               "the left motor is mounted mirrored: its command is negated "
               "(left_motor_sign = -1)"),
    Diagnostic("rad/s instead of turns/s", lambda v, w: _motors(v, w, turns=False),
               "ODrive 0.5.x velocities are in turns/s: divide by 2π"),
    Diagnostic("wheel speed, not motor speed", lambda v, w: _motors(v, w, gear=False),
               "the motors turn 20 times per wheel turn: multiply by the gear ratio"),
    Diagnostic("each wheel clipped on its own", lambda v, w: _motors(v, w, clip_each=True),
               "clipping one wheel changes the curvature: scale both together"),
    Diagnostic("no wheel limit", lambda v, w: _motors(v, w, saturate=False),
               "the wheels top out at UIABOT.max_wheel_speed (20 rad/s): when either "
               "command exceeds it, scale both down by the same factor"),
    Diagnostic("b = the whole wheel separation", lambda v, w: _motors(v, w, halve=False),
               "the wheels sit b = l/2 = 0.1805 m either side of base_link: φ̇ = (v ± ω b) / r"),
)

motor_speeds = Exercise(
    id="lab03.uiabot_motor_speeds", function="uiabot_motor_speeds",
    title="The twist node: cmd_vel → ODrive axes", reference=_motors, points=3,
    public=(Case("straight on", (0.5, 0.0)), Case("turn in place", (0.0, 1.0)),
            Case("an arc", (0.3, 0.5)), Case("too fast: scaled down together", (1.5, 2.0))),
    hidden=telling(lambda rng: [Case(f"random {i}", (float(rng.uniform(-1.2, 1.2)),
                                                     float(rng.uniform(-3, 3))))
                                for i in range(5)], _motors, _MOTOR_MISTAKES),
    diagnostics=_MOTOR_MISTAKES,
    blocked=_BLOCKED,
)


SPEC = LabSpec(
    name="lab03",
    title="Lab 03 — Drivers and bring-up",
    exercises=(crc16_xmodem, velocity_frame, parse_compass, decode_nodes, axis_state_name,
               motor_speeds),
)
