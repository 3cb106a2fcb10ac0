"""Do the drivers keep up with the devices? Decoding rates in pure Python against what each
device sends, and the emulated Uiabot's logical-clock speed. Run:
python benchmarks/bench_drivers.py

The bar (drivers issue): RPLidar A1 samples and LMS291 telegrams decoded at least 20× faster
than the devices send them.
"""

from __future__ import annotations

import time

import numpy as np
from bench_core import best_rate  # the same median-of-repeats rate (scripts run from here)

from hardware.emulators import Clock, LogicalPort
from hardware.emulators.lms2xx import LMS2xxEmulator
from hardware.emulators.rplidar import RPLidarEmulator
from kit import msgs
from kit.drivers import lms2xx, odrive, rplidar

A1_SAMPLES_PER_S = 2000.0
LMS291_SCANS_PER_S = 75.0  # the mirror's rate, reached at 500 kbaud with 181 values


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


def main() -> None:
    stream = rplidar_stream(200)
    nodes_total = len(rplidar.NodeParser().feed(stream))

    def decode_nodes() -> int:
        parser = rplidar.NodeParser()
        n = 0
        for k in range(0, len(stream), 512):  # as a serial port hands it over
            n += len(parser.feed(stream[k:k + 512]))
        return n

    rate = best_rate(decode_nodes)
    print(f"RPLidar nodes decoded (NodeParser):        {rate / 1e3:8.1f} k nodes/s "
          f"= {rate / A1_SAMPLES_PER_S:5.0f}× the A1's 2000 samples/s ({nodes_total} nodes)")
    nodes = rplidar.NodeParser().feed(stream)
    turns = rplidar.split_revolutions(nodes)[1:-1]
    stamp = msgs.Time(0, 0)
    rate = best_rate(lambda: sum(len(t) for t in turns if
                                 rplidar.revolution_to_scan(t, stamp) is not None))
    print(f"RPLidar nodes → LaserScan (per turn):      {rate / 1e3:8.1f} k nodes/s "
          f"= {rate / A1_SAMPLES_PER_S:5.0f}× the A1")

    clock = Clock()
    driver = rplidar.RPLidar(LogicalPort(RPLidarEmulator(), clock), clock=clock,
                             sleep=clock.sleep)
    driver.start()
    start = time.perf_counter()
    scans = sum(1 for _ in range(100) if driver.read_scan() is not None)
    wall = time.perf_counter() - start
    print(f"RPLidar driver + emulator, whole turns:    {scans / wall:8.1f} scans/s "
          f"= {scans / wall / 5.5:5.0f}× the A1's 5.5 Hz (logical clock)")

    telegrams = lms_stream(300)

    def decode_scans() -> int:
        parser = lms2xx.TelegramParser()
        n = 0
        for k in range(0, len(telegrams), 1024):
            for t in parser.feed(telegrams[k:k + 1024]):
                lms2xx.decode_scan(t.payload)
                n += 1
        return n

    rate = best_rate(decode_scans)
    print(f"LMS291 B0 telegrams (181 values) decoded:  {rate / 1e3:8.2f} k scans/s "
          f"= {rate / LMS291_SCANS_PER_S:5.0f}× the mirror's 75 scans/s")

    clock = Clock()
    device = LMS2xxEmulator()
    scanner = lms2xx.LMS2xx(LogicalPort(device, clock), clock=clock, sleep=clock.sleep)
    scanner.connect(500000, 180, 1.0)
    scanner.start()
    start = time.perf_counter()
    n = sum(1 for _ in range(300) if scanner.read_scan() is not None)
    wall = time.perf_counter() - start
    print(f"LMS2xx driver + emulator at 500 kbaud:      {n / wall:8.1f} scans/s "
          f"= {n / wall / LMS291_SCANS_PER_S:5.0f}× the device (logical clock)")

    rate = best_rate(lambda: sum(1 for _ in range(2000)
                                 if odrive.parse_reply("1.250000 0.500000*35", True)))
    print(f"ODrive reply lines checked and parsed:     {rate / 1e3:8.1f} k lines/s")

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
    print(f"Uiabot bring-up (≈12 s of calibration):    {bring_up * 1e3:8.0f} ms wall")
    print(f"Uiabot driven through its emulated ODrive: {(rig.clock.now - t0) / wall:8.1f}× real "
          f"time (20 Hz control loop, sim with lidar and IMU)")


if __name__ == "__main__":
    main()
