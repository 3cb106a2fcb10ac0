"""Captures read in each format they come in, and played back as the device."""

from __future__ import annotations

import subprocess
import sys

import pytest

from hardware.emulators.replay import CaptureReplay, read_capture
from kit.drivers import rplidar


def turns(n: int = 3, per_turn: int = 300) -> bytes:
    return b"".join(rplidar.encode_node(k % per_turn == 0, 15,
                                        (351.0 + 360.0 * k / per_turn) % 360.0, 1500.0)
                    for k in range(n * per_turn))


def test_captures_are_read_from_binary_pyserial_logs_and_annotated_hex(tmp_path):
    data = bytes.fromhex("A55A0300000006000000") + rplidar.SCAN_DESCRIPTOR + turns(1)[:20]
    (tmp_path / "a.bin").write_bytes(data)
    (tmp_path / "b.txt").write_text("\n".join(f"0x{b:02x}" for b in data))
    (tmp_path / "c.txt").write_text("A5 5A 03 00 00 00 06 00 00 00 -> HEALTH OK ? [A5 52]\n"
                                    + rplidar.SCAN_DESCRIPTOR.hex(" ") + " -> SCAN\n"
                                    + turns(1)[:20].hex(" ") + "\n")
    assert read_capture(tmp_path / "a.bin") == read_capture(tmp_path / "b.txt") == \
        read_capture(tmp_path / "c.txt") == data
    (tmp_path / "d.txt").write_text("A5 5A\nA5 XY\n")
    with pytest.raises(ValueError, match=r"d.txt, line 2: 'XY' is not a hex byte"):
        read_capture(tmp_path / "d.txt")
    with pytest.raises(ValueError, match="an empty capture has nothing to replay"):
        CaptureReplay(b"")


def test_the_command_line_replays_a_capture_to_the_driver(tmp_path):
    capture = tmp_path / "run.bin"
    capture.write_bytes(b"\xff\xff" + bytes.fromhex("A55A0300000006000000") +
                        rplidar.SCAN_DESCRIPTOR + turns(3))
    proc = subprocess.Popen([sys.executable, "-m", "hardware.emulators", "rplidar",
                             "--replay", str(capture)], stdout=subprocess.PIPE, text=True)
    try:
        lidar = rplidar.RPLidar(proc.stdout.readline().strip(), timeout=10.0)  # a hang guard
        lidar.start()
        assert [len(lidar.read_revolution()) for _ in range(2)] == [300, 300]
        lidar.close()
    finally:
        proc.terminate()
        assert proc.wait(10) == 0
