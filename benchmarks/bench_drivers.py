"""Do the drivers keep up with the devices? Decoding rates in pure Python against what each
device sends (and against the most its serial link can carry), the drivers with their
emulators on the logical clock, and the Uiabot through its emulated ODrive. Run:
python benchmarks/bench_drivers.py

The bar (drivers issues): every device's stream decoded at least 20× faster than the device
sends it. Each figure is the median of 5 repeats.
"""

from __future__ import annotations

import random
import time

import numpy as np
from bench_core import best_rate  # the same median-of-repeats rate (scripts run from here)

from hardware.emulators import Clock, LogicalPort
from hardware.emulators.lms2xx import LMS2xxEmulator
from hardware.emulators.rplidar import RPLidarEmulator
from kit import msgs
from kit.drivers import bno055, dpralte, lms2xx, odrive, os5000, rplidar
from kit.drivers.checksums import nmea_checksum, odrive_checksum

A1_SAMPLES_PER_S = 2000.0
LMS291_SCANS_PER_S = 75.0  # the mirror's rate, reached at 500 kbaud with 181 values
BNO055_HZ = 100.0  # fusion output rate
OS5000_HZ = 40.0  # its fastest output rate
IGV_FRAMES_PER_S = 200.0  # 2 drives × (command + reply + position read + reply) at 25 Hz
UIABOT_ODRIVE_LINES_PER_S = 100.0  # two `f` replies at 50 Hz


def report(what: str, rate: float, unit: str, device: float, device_what: str,
           link: float | None = None) -> None:
    line = f"{what:46s}{rate / 1e3:9.1f} k {unit:9s}= {rate / device:7.0f}× {device_what}"
    if link is not None:
        line += f", {rate / link:5.1f}× what 115200 baud carries"
    print(line)


def rplidar_stream(turns: int) -> bytes:
    device = RPLidarEmulator()
    device.feed(bytes.fromhex("A520"), 0.0)
    out = bytearray()
    for k in range(1, round(turns / 5.5 / 0.05) + 1):  # read as a port would, every 50 ms
        out += device.read(k * 0.05)
    return bytes(out[7:])


def lms_stream(scans: int, values: int = 181) -> bytes:
    rng = np.random.default_rng(0)
    out = bytearray()
    for _ in range(scans):
        ranges = rng.integers(20, 8000, values).astype("<u2")
        payload = b"\xb0" + values.to_bytes(2, "little") + ranges.tobytes() + b"\x10"
        out += b"\x06" + lms2xx.encode_telegram(payload, 0x80)
    return bytes(out)


def chunked(data: bytes, size: int) -> list[bytes]:
    return [data[k:k + size] for k in range(0, len(data), size)]


def decoding_the_scanners() -> None:
    stream = chunked(rplidar_stream(200), 512)  # as a serial port hands it over

    def nodes_and_turns() -> int:
        parser, turns = rplidar.NodeParser(strict=True), rplidar.TurnAssembler()
        n = 0
        for chunk in stream:
            nodes = parser.feed(chunk)
            turns.push(nodes, 0.0)
            n += len(nodes)
        return n

    def nodes_only() -> int:
        parser = rplidar.NodeParser()
        return sum(len(parser.feed(chunk)) for chunk in stream)

    report("RPLidar nodes, check bits only (Lab 03's)", best_rate(nodes_only), "nodes/s",
           A1_SAMPLES_PER_S, "the A1's 2000 samples/s", 11520 / 5)
    report("RPLidar nodes → checked turns (the driver's)", best_rate(nodes_and_turns),
           "nodes/s", A1_SAMPLES_PER_S, "the A1's 2000 samples/s", 11520 / 5)
    nodes = rplidar.NodeParser().feed(b"".join(stream))
    turns = rplidar.split_revolutions(nodes)[1:-1]
    stamp = msgs.Time(0, 0)
    rate = best_rate(lambda: sum(len(t) for t in turns if
                                 rplidar.revolution_to_scan(t, stamp) is not None))
    report("RPLidar turn → LaserScan", rate, "nodes/s", A1_SAMPLES_PER_S, "the A1")

    telegrams = chunked(lms_stream(300), 1024)

    def decode_scans() -> int:
        parser = lms2xx.TelegramParser()
        n = 0
        for chunk in telegrams:
            for t in parser.feed(chunk):
                lms2xx.decode_scan(t.payload)
                n += 1
        return n

    report("LMS291 B0 telegrams (181 values) decoded", best_rate(decode_scans), "scans/s",
           LMS291_SCANS_PER_S, "the mirror's 75 scans/s")


def decoding_the_others() -> None:
    stamp = msgs.Time(0, 0)
    rng = random.Random(1)
    frames = b"".join(
        dpralte.encode_write(0x3F, 0x45, 0x02, dpralte.int32_words(rng.randrange(-4000, 4000)),
                             k % 16) + bytes.fromhex("A5FF02010002029C") +
        (k).to_bytes(4, "little") + dpralte.crc16_xmodem(k.to_bytes(4, "little")).to_bytes(
            2, "big") for k in range(3000))
    dpr = chunked(frames, 64)

    def decode_frames() -> int:
        parser = dpralte.FrameParser()
        return sum(len(parser.feed(c)) for c in dpr)

    report("DPRALTE frames (14 bytes) checked", best_rate(decode_frames), "frames/s",
           IGV_FRAMES_PER_S, "the IGV's bus at 25 Hz", 11520 / 14)

    bodies = [f"C{rng.uniform(0, 360):.1f}P{rng.uniform(-20, 20):.1f}"
              f"R{rng.uniform(-20, 20):.1f}T24.5" for _ in range(3000)]
    sentences = chunked(b"".join(f"${b}*{nmea_checksum(b)}\r\n".encode() for b in bodies), 64)

    def decode_sentences() -> int:
        splitter, n = os5000.LineSplitter(), 0
        for chunk in sentences:
            for line in splitter.feed(chunk):
                os5000.reading_to_imu(os5000.parse_sentence(line), stamp)
                n += 1
        return n

    report("OS5000 sentences → Imu", best_rate(decode_sentences), "lines/s", OS5000_HZ,
           "its 40 Hz", 1920 / 28)

    texts = [f"{rng.uniform(-500, 500):f} {rng.uniform(-50, 50):f}" for _ in range(3000)]
    replies = chunked(b"".join(f"{t}*{odrive_checksum(t)}\r\n".encode() for t in texts), 64)

    def decode_replies() -> int:
        lines = odrive.ReplyLines(checksum=True)
        return sum(len(lines.feed(c)) for c in replies)

    report("ODrive `f` replies split and checked", best_rate(decode_replies), "lines/s",
           UIABOT_ODRIVE_LINES_PER_S, "2 axes at 50 Hz", 11520 / 28)

    block = bytes([0xBB, 44]) + bytes(rng.randrange(256) for _ in range(44))

    class _Block:  # the reply to every request, without a port in the way
        timeout = 0.01
        in_waiting = len(block)

        def reset_input_buffer(self) -> None: ...

        def write(self, data: bytes) -> int:
            return len(data)

        def read(self, size: int = 1) -> bytes:
            return block

    imu = bno055.BNO055(_Block())
    report("BNO055 44-byte block → Imu (driver)",
           best_rate(lambda: sum(1 for _ in range(2000) if imu.read_imu(stamp))), "Imu/s",
           BNO055_HZ, "its 100 Hz", 11520 / 50)


def drivers_on_the_logical_clock() -> None:
    clock = Clock()
    driver = rplidar.RPLidar(LogicalPort(RPLidarEmulator(), clock), clock=clock,
                             sleep=clock.sleep)
    driver.start()
    start = time.perf_counter()
    scans = sum(1 for _ in range(100) if driver.read_scan() is not None)
    wall = time.perf_counter() - start
    print(f"{'RPLidar driver + emulator, whole turns':46s}{scans / wall:9.1f}   scans/s   = "
          f"{scans / wall / 5.5:7.0f}× the A1's 5.5 Hz (logical clock)")

    clock = Clock()
    scanner = lms2xx.LMS2xx(LogicalPort(LMS2xxEmulator(), clock), clock=clock,
                            sleep=clock.sleep)
    scanner.connect(500000, 180, 1.0)
    scanner.start()
    start = time.perf_counter()
    n = sum(1 for _ in range(300) if scanner.read_scan() is not None)
    wall = time.perf_counter() - start
    print(f"{'LMS2xx driver + emulator at 500 kbaud':46s}{n / wall:9.1f}   scans/s   = "
          f"{n / wall / LMS291_SCANS_PER_S:7.0f}× the device (logical clock)")

    from hardware.emulators.rigs import uiabot_rig
    from kit.drivers.bases import UiabotBase

    rig = uiabot_rig(start=(5.0, 4.0, 0.0))
    base = UiabotBase(rig.ports["odrive"], **rig.driver_options())
    start = time.perf_counter()
    base.bring_up()
    bring_up = time.perf_counter() - start
    t0 = rig.clock.now
    start = time.perf_counter()
    for _ in range(400):
        base.drive((0.4, 0.2))
        rig.clock.sleep(0.05)
        base.update()
    wall = time.perf_counter() - start
    print(f"{'Uiabot bring-up (≈12 s of calibration)':46s}{bring_up * 1e3:9.0f}   ms wall")
    print(f"{'Uiabot driven through its emulated ODrive':46s}{(rig.clock.now - t0) / wall:9.1f}"
          f"   × real time (20 Hz control loop, sim with lidar and IMU)")


if __name__ == "__main__":
    decoding_the_scanners()
    decoding_the_others()
    drivers_on_the_logical_clock()
