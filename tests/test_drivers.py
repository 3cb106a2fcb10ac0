"""Drivers against the protocol spec's test vectors, fuzzed parsers, and real ports
(pseudo-terminals) with a device thread on the other end."""

from __future__ import annotations

import math
import os
import pty
import time
import tty

import numpy as np
import pytest
import serial
from hypothesis import given, settings
from hypothesis import strategies as st

from kit.drivers import (
    ChecksumError,
    DeviceError,
    DeviceTimeout,
    PortError,
    ProtocolError,
    dpralte,
    os5000,
)
from kit.drivers import checksums as cs


def test_check_codes_match_the_specs_self_checks():
    assert cs.crc16_xmodem(b"123456789") == 0x31C3
    assert cs.crc16_xmodem(bytes.fromhex("A53F02450202")) == 0x962B
    assert cs.crc16_sick(bytes.fromhex("0200010031")) == 0x1215
    assert cs.nmea_checksum("C320.5P0.2R-18.3T19.0") == "3C"
    assert cs.odrive_checksum("r vbus_voltage ") == 93
    assert cs.xor_checksum(bytes.fromhex("A5F0029402")) == 0xC1


REQUESTS = [  # protocols.md §1.8
    ("A1", dpralte.encode_write(0x3F, 0x45, 0x02, dpralte.int32_words(437)),
     "A5 3F 02 45 02 02 96 2B B5 01 00 00 7A A4"),
    ("A2", dpralte.encode_write(0x3E, 0x45, 0x00, dpralte.int32_words(437)),
     "A5 3E 02 45 00 02 5A 18 B5 01 00 00 7A A4"),
    ("A3", dpralte.encode_write(0x3F, 0x45, 0x02, dpralte.int32_words(-437)),
     "A5 3F 02 45 02 02 96 2B 4B FE FF FF 95 DF"),
    ("A4", dpralte.encode_write(0x3F, 0x45, 0x02, dpralte.int32_words(0)),
     "A5 3F 02 45 02 02 96 2B 00 00 00 00 00 00"),
    ("A5", dpralte.encode_write(0x3F, 0x07, 0x00, bytes([0x0F, 0x00])),
     "A5 3F 02 07 00 01 B3 E7 0F 00 10 3E"),
    ("A6", dpralte.encode_write(0x3F, 0x07, 0x00, bytes([0xFF, 0x00])),
     "A5 3F 02 07 00 01 B3 E7 FF 00 03 FF"),
    ("A7", dpralte.encode_write(0x3F, 0x01, 0x00, bytes(2)), "A5 3F 02 01 00 01 01 47 00 00 00 00"),
    ("A8", dpralte.encode_write(0x3F, 0x01, 0x00, bytes([1, 0])),
     "A5 3F 02 01 00 01 01 47 01 00 33 31"),
    ("A9", dpralte.encode_read(0x3F, 0x12, 0x00, 2), "A5 3F 01 12 00 02 B0 CB"),
    ("A10", dpralte.encode_read(0x3E, 0x12, 0x00, 2), "A5 3E 01 12 00 02 1A 9A"),
    ("A11", dpralte.encode_read(0x3F, 0x11, 0x02, 2), "A5 3F 01 11 02 02 8F F9"),
    ("A12", dpralte.encode_read(0x3F, 0x12, 0x00, 2, sequence=5), "A5 3F 15 12 00 02 61 9D"),
]
REPLIES = {
    "R1": ("A5 FF 01 01 00 00 B9 02", 1, None),
    "R2": ("A5 FF 02 01 00 02 02 9C 10 27 00 00 18 F1", 1, 10000),
    "R3": ("A5 FF 02 01 00 02 02 9C 4B FE FF FF 95 DF", 1, -437),
    "R4": ("A5 FF 01 06 00 00 3C 92", 6, None),
    "R5": ("A5 FF 01 04 00 00 52 F2", 4, None),
    "R6": ("A5 FF 01 08 00 00 27 93", 8, None),
    "R7": ("A5 FF 02 01 00 02 02 9C 01 00 00 00 76 B4", 1, 1),
}


@pytest.mark.parametrize(("name", "frame", "expected"), REQUESTS, ids=[r[0] for r in REQUESTS])
def test_requests_are_the_specs_bytes(name, frame, expected):
    assert frame.hex(" ").upper() == expected
    parsed = dpralte.FrameParser().feed(frame)
    assert len(parsed) == 1 and not parsed[0].is_reply


def test_the_igv_papers_frame_is_ten_rpm():
    assert dpralte.rpm_to_units(10.0) == 437
    units = dpralte.rpm_to_units(10.0)
    frame = dpralte.encode_write(0x3F, 0x45, 0x02, dpralte.int32_words(units))
    assert frame == bytes.fromhex("A53F02450202962BB50100007AA4")
    assert dpralte.units_to_rpm(437) == pytest.approx(10.0, rel=1e-3)


@pytest.mark.parametrize("name", list(REPLIES))
def test_replies_decode_byte_by_byte(name):
    text, status, value = REPLIES[name]
    parser = dpralte.FrameParser()
    frames = []
    for b in bytes.fromhex(text):
        frames += parser.feed(bytes([b]))
    assert len(frames) == 1 and frames[0].is_reply and frames[0].status == status
    if value is not None:
        assert (frames[0].uint16() if name == "R7" else frames[0].int32()) == value


ALL_FRAMES = [bytes.fromhex(e) for _, _, e in REQUESTS] + \
    [bytes.fromhex(t) for t, _, _ in REPLIES.values()]


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=400))
def test_random_bytes_give_only_checked_frames_and_never_hang(data):
    frames = dpralte.FrameParser().feed(data)
    for f in frames:  # anything returned passed both CRCs
        assert isinstance(f, dpralte.Frame)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.sampled_from(range(len(ALL_FRAMES))), min_size=2, max_size=8),
       st.data())
def test_corruption_loses_no_other_frame(corrupt, indices, data):
    frames = [ALL_FRAMES[i] for i in indices]
    victim = data.draw(st.integers(0, len(frames) - 1))
    stream = bytearray()
    corrupted = corrupt(frames[victim], data)
    for i, f in enumerate(frames):
        stream += corrupted if i == victim else f
    chunks = data.draw(st.integers(1, 7))
    parser = dpralte.FrameParser()
    got = []
    for k in range(0, len(stream), chunks):
        got += parser.feed(bytes(stream[k:k + chunks]))
    got_bytes = [_reencode(f) for f in got]
    expected = [f for i, f in enumerate(frames) if i != victim]
    it = iter(got_bytes)
    assert all(any(g == e for g in it) for e in expected)  # a subsequence, in order
    assert all(g in frames for g in got_bytes)  # and nothing that was not sent


def _reencode(frame: dpralte.Frame) -> bytes:
    head = bytes([0xA5, frame.address, frame.command | frame.sequence << 2, frame.a, frame.b,
                  frame.words])
    out = head + cs.crc16_xmodem(head).to_bytes(2, "big")
    if frame.data:
        out += frame.data + cs.crc16_xmodem(frame.data).to_bytes(2, "big")
    return out


# ------------------------------------------------------------------ over a real port

@pytest.fixture
def pty_pair():
    master, slave = pty.openpty()
    tty.setraw(slave)
    name = os.ttyname(slave)
    yield master, name
    os.close(master)
    os.close(slave)


def test_driver_talks_to_a_drive_over_a_port():
    from hardware.emulators import PtyServer
    from hardware.emulators.dpralte import DpralteBusEmulator

    with PtyServer(DpralteBusEmulator()) as server:
        # a hang guard: the emulator's thread may be kept off a loaded machine's CPU for a while
        drive = dpralte.DpralteDrive(server.path, 0x3F, velocity_offset=0x02, timeout=10.0)
        with pytest.raises(DeviceError, match="no write access") as info:
            drive.enable()
        assert info.value.code == 6
        drive.get_write_access()
        drive.enable()
        assert drive.set_velocity_rpm(10.0) == 437
        time.sleep(0.1)
        assert drive.read_velocity_rpm() == pytest.approx(10.0, abs=0.01)
        assert drive.read_position() > 0
        with pytest.raises(DeviceError, match="invalid command"):
            drive.read((0x99, 0x00), 1, "read an unknown index")


def test_a_silent_drive_times_out_naming_device_and_command():
    from hardware.emulators import Faults, PtyServer
    from hardware.emulators.dpralte import DpralteBusEmulator

    with PtyServer(DpralteBusEmulator(faults=Faults(silence=1.0, silence_s=1e9))) as server:
        drive = dpralte.DpralteDrive(server.path, 0x3E, timeout=0.2)
        with pytest.raises(DeviceTimeout, match=r"DPRALTE: read position: no reply from 0x3E "
                                                r"within 0\.2 s"):
            drive.read_position()


def test_a_closed_port_is_a_clear_error():
    port = serial.serial_for_url("loop://", timeout=0.01)
    drive = dpralte.DpralteDrive(port, 0x3F)
    port.close()
    with pytest.raises(PortError, match=r"DPRALTE: read position: the port failed"):
        drive.read_position()


# ------------------------------------------------------------------ OS5000

COMPASS = [  # protocols.md §2.6
    ("$C320.5P0.2R-18.3T19.0*3C", 320.5, 0.2, -18.3, 19.0),
    ("$C288.6P-0.2R-0.1T26.6*20", 288.6, -0.2, -0.1, 26.6),
    ("$C335.7P-0.4R-88.4T26.9*1A", 335.7, -0.4, -88.4, 26.9),
    ("$C212.4P2.5R-14.0T28.4Mx107977.90My-79422.00Mz173.27Ax0.045Ay-0.245Az0.977*3A",
     212.4, 2.5, -14.0, 28.4),
    ("$C328.3P28.4R-12.4T21.1D21.01*61", 328.3, 28.4, -12.4, 21.1),
    ("$C90.0P0.0R0.0T25.0*1B", 90.0, 0.0, 0.0, 25.0),
    ("$C0.0P-45.0R179.9T-5.2*25", 0.0, -45.0, 179.9, -5.2),
]


@pytest.mark.parametrize(("line", "heading", "pitch", "roll", "temp"), COMPASS)
def test_compass_sentences_decode(line, heading, pitch, roll, temp):
    r = os5000.parse_sentence(line)
    assert (r.heading_deg, r.pitch_deg, r.roll_deg, r.temperature_c) == (heading, pitch, roll,
                                                                         temp)
    assert r.yaw == pytest.approx(math.remainder(math.pi / 2 - math.radians(heading),
                                                 2 * math.pi), abs=1e-12)


def test_compass_heading_becomes_rep103_yaw_once():
    assert os5000.heading_to_yaw(0.0) == pytest.approx(math.pi / 2)  # north is +y
    assert os5000.heading_to_yaw(90.0) == pytest.approx(0.0)  # east is +x
    assert os5000.heading_to_yaw(180.0) == pytest.approx(-math.pi / 2)
    r = os5000.parse_sentence("$C212.4P2.5R-14.0T28.4Mx107977.90My-79422.00Mz173.27Ax0.045"
                              "Ay-0.245Az0.977*3A")
    assert r.extra["Az"] == 0.977 and r.extra["Mx"] == 107977.90


def test_bad_sentences_raise_the_documented_errors():
    with pytest.raises(ChecksumError, match="OS5000: checksum 3D"):
        os5000.parse_sentence("$C320.5P0.2R-18.3T19.0*3D")
    with pytest.raises(ProtocolError, match="not a compass sentence"):
        os5000.parse_sentence("$GPGGA,1,2*55")
    with pytest.raises(ProtocolError, match="malformed sentence"):
        os5000.parse_sentence("$HCHDT,212.4*54")
    with pytest.raises(ProtocolError, match="not a sentence"):
        os5000.parse_sentence("CMD:C")
    # a NUL byte leaves the XOR as it was: the characters themselves give it away
    body = "C10.0P0.0R0.0T20.0"
    with pytest.raises(ProtocolError, match="not a sentence"):
        os5000.parse_sentence(f"$C1\x000.0P0.0R0.0T20.0*{cs.nmea_checksum(body)}")


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=300))
def test_compass_stream_of_random_bytes_never_hangs(data):
    splitter = os5000.LineSplitter()
    for line in splitter.feed(data):
        try:
            os5000.parse_sentence(line)
        except (ChecksumError, ProtocolError):
            pass


def test_compass_over_a_port_skips_text_and_corruption(pty_pair):
    master, name = pty_pair
    compass = os5000.Os5000(name, timeout=0.5)  # opening the port flushes its input
    os.write(master, b"CMD:R\r\nFlash Write\r\n$C90.0P0.0R0.0T25.0*1C\r\n"
                     b"$C90.0P0.0R0.0T25.0*1B\r\n")
    reading = compass.read()
    assert reading.heading_deg == 90.0 and reading.yaw == pytest.approx(0.0)
    assert compass.rejected == 1
    with pytest.raises(DeviceTimeout, match=r"OS5000: no valid sentence within 0\.5 s"):
        compass.read()


# ------------------------------------------------------------------ RPLidar

def test_rplidar_requests_descriptors_and_nodes_match_the_spec():
    from kit.drivers import rplidar

    assert rplidar.encode_request(0x25) == bytes.fromhex("A525")
    assert rplidar.encode_request(0xF0, bytes(2)) == bytes.fromhex("A5F0020000" "57")
    assert rplidar.encode_request(0x82, bytes(5)) == bytes.fromhex("A58205000000000022")
    assert rplidar.parse_descriptor(bytes.fromhex("A55A0300000006")) == (3, 0, 6)
    node = rplidar.decode_node(bytes.fromhex("BE415AE903"))
    assert node == rplidar.Node(False, 47, 180.5, 250.25)
    with pytest.raises(ProtocolError, match="RPLidar: not a response descriptor"):
        rplidar.parse_descriptor(b"\x00" * 7)


def capture_bytes(shared_data, name: str) -> bytes:
    folder = shared_data / "device-captures" / "rplidar-msp430-relay-115200"
    if name.endswith(".bin"):
        return (folder / name).read_bytes()
    text = (folder / name).read_text()
    if name.startswith("sample"):
        return bytes(int(v, 16) for v in text.split())
    hexes = []
    for line in text.splitlines():
        hexes += line.split("->")[0].split()
    return bytes(int(h, 16) for h in hexes)


@pytest.mark.dataset
@pytest.mark.parametrize(("name", "nodes", "starts", "zeros", "median"), [
    ("capture_1.txt", 573, 3, 164, 735),
    ("sample_data_pyserial_2.txt", 269, 1, 150, 1247),
    ("frame_0002.bin", 1881, 7, 745, 2098),
])
def test_real_rplidar_captures_decode_as_published(shared_data, name, nodes, starts, zeros,
                                                   median):
    """Nodes after the SCAN descriptor: counts and distances of the captures' README."""
    from kit.drivers import rplidar

    data = capture_bytes(shared_data, name)
    after = data[data.index(rplidar.SCAN_DESCRIPTOR) + 7:]
    got = rplidar.NodeParser().feed(after)
    assert len(got) == nodes
    assert sum(n.start for n in got) == starts
    assert sum(n.distance_mm == 0 for n in got) == zeros
    valid = sorted(n.distance_mm for n in got if n.distance_mm > 0)
    assert int(valid[len(valid) // 2]) == pytest.approx(median, abs=1)


@pytest.mark.dataset
def test_rplidar_decoding_agrees_with_the_pypi_rplidar_package(shared_data):
    rp = pytest.importorskip("rplidar")
    from kit.drivers import rplidar

    data = capture_bytes(shared_data, "sample_data_pyserial_1.txt")
    after = data[data.index(rplidar.SCAN_DESCRIPTOR) + 7:]
    ours = rplidar.NodeParser().feed(after)
    theirs = []
    i = 0
    while i + 5 <= len(after):  # their decoder on the same stream, resynchronising likewise
        try:
            theirs.append(rp._process_scan(after[i:i + 5]))
            i += 5
        except rp.RPLidarException:
            i += 1
    assert len(ours) == len(theirs) > 10_000
    assert all((n.start, n.quality, n.angle_deg, n.distance_mm) == t
               for n, t in zip(ours, theirs, strict=True))


@pytest.mark.dataset
def test_a_real_turn_becomes_a_counter_clockwise_laserscan(shared_data):
    from kit.drivers import rplidar

    data = capture_bytes(shared_data, "sample_data_pyserial_1.txt")
    nodes = rplidar.NodeParser().feed(data[data.index(rplidar.SCAN_DESCRIPTOR) + 7:])
    turns = rplidar.split_revolutions(nodes)
    assert 314 <= len(turns[1]) <= 322
    scan = rplidar.revolution_to_scan(turns[1], msgs_time())
    assert len(scan.ranges) == 360 and np.isfinite(scan.ranges).sum() > 100
    # a node 90° clockwise (to the right) lands at −90°: the scan's y is left
    one = rplidar.revolution_to_scan([rplidar.Node(True, 15, 90.0, 1000.0)], msgs_time())
    i = int(np.flatnonzero(np.isfinite(one.ranges))[0])
    assert one.angle_min + i * one.angle_increment == pytest.approx(-math.pi / 2, abs=1e-6)
    assert one.ranges[i] == pytest.approx(1.0)


def msgs_time():
    from kit import msgs

    return msgs.Time(0, 0)
