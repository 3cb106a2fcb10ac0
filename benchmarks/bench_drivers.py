"""Do the drivers keep up with the devices, decode what they can and refuse what they cannot
check, stop the motors, stamp honestly? Run: python benchmarks/bench_drivers.py [SECTION...]

Sections (all by default):

* ``speed``: decoding rates in pure Python against what each device sends (and against the
  most its serial link can carry), the drivers with their emulators on the logical clock,
  and the Uiabot through its emulated ODrive. The bar: every device's stream decoded at
  least 20× faster than the device sends it. Each figure is the median of 5 repeats.
* ``fuzz``: the tests' fuzz, longer (fixed seeds): DPRALTE frames on a clean line (frames
  lost, phantoms) and on a noisy one; ODrive replies with noise before their lines (wrong
  numbers taken, lines lost).
* ``safety``: the emulated Uiabot and IGV driven by a child process, then SIGKILLed or
  SIGTERMed: when the wheels stopped, on the emulator's clock.
* ``failures``: how long each driver takes to give its own error when its device freezes or
  is unplugged (wall clock: the tests only check the error, never the time).
* ``record``: ``kit record`` of the emulated Uiabot for 20 s: the rates it prints (from the
  stamps) against the devices' own (the emulator's log), and how far each stamp is from the
  device's own time of the measurement.
"""

from __future__ import annotations

import itertools
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_core import best_rate  # the same median-of-repeats rate (scripts run from here)

from hardware.emulators import Clock, LogicalPort
from hardware.emulators.lms2xx import LMS2xxEmulator
from hardware.emulators.rplidar import RPLidarEmulator
from kit import msgs
from kit.drivers import bno055, dpralte, lms2xx, odrive, os5000, rplidar
from kit.drivers.checksums import nmea_checksum, odrive_checksum
from kit.drivers.timing import SampleClock

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
        clock = SampleClock(500e-6)
        n = 0
        for k, chunk in enumerate(stream):
            nodes = parser.feed(chunk)
            clock.observe(n + len(nodes), k * 0.05)
            turns.push(nodes, [clock.time_of(n + i) for i in range(len(nodes))])
            n += len(nodes)
        return n

    def nodes_only() -> int:
        parser = rplidar.NodeParser()
        return sum(len(parser.feed(chunk)) for chunk in stream)

    report("RPLidar nodes, check bits only (Lab 03's)", best_rate(nodes_only), "nodes/s",
           A1_SAMPLES_PER_S, "the A1's 2000 samples/s", 11520 / 5)
    report("RPLidar nodes → timed, checked turns (driver)", best_rate(nodes_and_turns),
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


def fuzz() -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "kit" / "drivers"))
    import test_mutated_streams as m

    t0 = time.process_time()
    rng = random.Random(2027)
    n = 500_000
    planted = [rng.random() < 0.01 for _ in range(n)]
    frames = [m.adversarial_reply(rng, i % 16) if p else m.dpralte_frame(rng, i % 60_000)
              for i, p in enumerate(planted)]
    parser = dpralte.FrameParser()
    got = [f for chunk in m.pieces(b"".join(frames), rng) for f in parser.feed(chunk)]
    got += parser.flush()
    sent = frames
    decoded = [m.reencode(f) for f in got]
    lost = len(m.in_order(sent, decoded))
    phantom = len(m.in_order(decoded, sent))
    print(f"DPRALTE, clean line: {n} frames ({sum(planted)} 3-word replies whose data is a "
          f"header): {lost} lost, {phantom} phantoms, {parser.ambiguous} given with their "
          f"other reading ({time.process_time() - t0:.0f} s CPU)")

    t0 = time.process_time()
    rng = random.Random(2028)
    frames = [m.dpralte_frame(rng, i % 60_000) for i in range(200_000)]
    stream, intact, hit = m.mutated(frames, rng)
    parser = dpralte.FrameParser()
    got = [f for chunk in m.pieces(stream, rng) for f in parser.feed(chunk)] + parser.flush()
    lost = len(m.in_order(intact, m.readings(got)))
    certain = [m.reencode(f) for f in got if not f.alternatives]
    wrong = len(m.in_order(certain, frames))
    print(f"DPRALTE, 1 frame in 10 damaged: {len(frames)} frames, {hit} damaged: {lost} intact "
          f"lost, {wrong} damaged taken as certain, {parser.ambiguous} with two readings "
          f"({time.process_time() - t0:.0f} s CPU)")

    for form, seed in (("feedback", 11), ("number", 12)):
        t0 = time.process_time()
        rng = random.Random(seed)
        frames = [m.odrive_reply(rng, i, form) for i in range(200_000)]
        stream = b"".join(bytes(rng.randrange(256) for _ in range(rng.randint(0, 6))) + f
                          for f in frames)
        lines = odrive.ReplyLines(checksum=True, form=form)
        got = [t for chunk in m.pieces(stream, rng) for t in lines.feed(chunk)]
        texts = [m._text(f) for f in frames]  # each one different
        place = {t: k for k, t in enumerate(texts)}
        order = [place.get(t, -1) for t in got]
        wrong = sum(k < 0 for k in order) + sum(b <= a for a, b in itertools.pairwise(order))
        taken = set(got)
        lost = [t for t in texts if t not in taken]
        prefix = sum(m._zero_xor_prefix(t, form) for t in lost)
        print(f"ODrive {form} replies, 0-6 random bytes before each: {len(frames)} lines: "
              f"{wrong} corrupted numbers taken, {len(lost)} lost "
              f"({len(lost) / len(frames):.1%}; {prefix} of them ambiguous even when clean: "
              f"a zero-XOR prefix, told apart by the driver) ({time.process_time() - t0:.0f} s "
              f"CPU)")


DRIVER = """
import sys, time
from kit.drivers.bases import IgvBase, UiabotBase
robot, path, timeout = sys.argv[1], sys.argv[2], float(sys.argv[3])
base = UiabotBase(path, watchdog_timeout=timeout) if robot == "uiabot" else \
    IgvBase(path, watchdog_timeout=timeout)
base.bring_up() if robot == "uiabot" else base.start()
base.drive((0.2, 0.0))
print("driving", flush=True)
time.sleep(600)
"""


def safety(runs: int = 5, timeout: float = 0.5) -> None:
    from hardware.emulators import PtyServer
    from hardware.emulators.backends import IdealWheels
    from hardware.emulators.dpralte import DpralteBusEmulator
    from hardware.emulators.odrive import ODriveEmulator

    for robot in ("uiabot", "igv"):
        for how in ("SIGKILL", "SIGTERM"):
            delays = []
            for _ in range(runs):
                wheels = IdealWheels()
                device = ODriveEmulator(wheels, calibration_time=0.2) if robot == "uiabot" \
                    else DpralteBusEmulator(wheels)
                server = PtyServer(device).start()
                proc = subprocess.Popen([sys.executable, "-c", DRIVER, robot, server.path,
                                         str(timeout)], stdout=subprocess.PIPE, text=True)
                assert proc.stdout.readline().strip() == "driving"
                while not all(wheels.speeds):
                    time.sleep(0.005)
                sent = server.now()
                os.kill(proc.pid, getattr(signal, how))
                proc.wait(30)
                while any(wheels.speeds):
                    time.sleep(0.001)
                stopped = server.now()  # (IdealWheels: the speed goes to 0 at the stop)
                if how == "SIGKILL":
                    parts = device.axes if robot == "uiabot" else device.drives.values()
                    stopped = max(p.watchdog_expired_at for p in parts)
                delays.append(stopped - sent)
                server.stop()
            print(f"{robot} {how}: wheels stopped {1e3 * np.median(delays):6.0f} ms after the "
                  f"signal (median of {runs}; max {1e3 * max(delays):.0f} ms; watchdog "
                  f"{timeout:g} s; emulator's clock)")


def failures() -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "hardware"))
    from test_device_failures import emulators, start

    from hardware.emulators import PtyServer

    for fault in ("freeze", "unplug"):
        devices = emulators()
        server = PtyServer(list(devices.values())).start()
        readings = {}
        for name, path in zip(devices, server.paths, strict=True):
            read, deadline = start(name, path)
            read()
            readings[name] = (read, deadline)
        server.freeze() if fault == "freeze" else server.stop()
        for name, (read, deadline) in readings.items():
            for _ in range(100):
                t0 = time.monotonic()
                try:
                    read()
                except Exception as exc:
                    took = time.monotonic() - t0
                    print(f"{fault:7s} {name:8s} {type(exc).__name__:14s} after "
                          f"{took * 1e3:6.0f} ms (its deadline {deadline:g} s)")
                    break
        server.stop()


def record(seconds: float = 20.0) -> None:
    from kit import cli
    from kit.bag import read_bag

    folder = Path(tempfile.mkdtemp())
    stats = folder / "sent.json"
    proc = subprocess.Popen([sys.executable, "-m", "hardware.emulators", "uiabot", "--stats",
                             str(stats)], stdout=subprocess.PIPE, text=True)
    ports = [f"{n}={p}" for n, p in (proc.stdout.readline().split() for _ in range(3))]
    cli.main(["record", *ports, "--duration", str(seconds), "--out", str(folder / "bag")])
    proc.terminate()
    proc.wait(60)
    sent = json.loads(stats.read_text())
    bag = list(read_bag(folder / "bag"))
    for topic, device, kind in (("/scan", "rplidar", "turn"), ("/imu", "bno055", "imu"),
                                ("/joint_states", "odrive", "feedback1")):
        stamps = np.array([t * 1e-9 for name, t, _ in bag if name == topic])
        events = sent["epoch"] + np.array(sent["devices"][device]["events"][kind])
        within = events[(events >= stamps[0] - 0.05) & (events <= stamps[-1] + 0.05)]
        rate = (len(stamps) - 1) / (stamps[-1] - stamps[0])
        device_rate = (len(within) - 1) / (within[-1] - within[0])
        error = np.abs(events[np.abs(events[:, None] - stamps).argmin(axis=0)] - stamps)
        print(f"{topic:14s} {len(stamps):5d} messages, {rate:7.2f} Hz from the stamps, the "
              f"device {device_rate:7.2f} Hz ({rate / device_rate - 1:+.2%}); stamp − device's "
              f"time: median {np.median(error) * 1e3:.2f} ms, max {error.max() * 1e3:.2f} ms, "
              f"{sent['devices'][device]['lost']} bytes the host did not take")


SECTIONS = {"speed": lambda: (decoding_the_scanners(), decoding_the_others(),
                              drivers_on_the_logical_clock()),
            "fuzz": fuzz, "safety": safety, "failures": failures, "record": record}

if __name__ == "__main__":
    for section in sys.argv[1:] or list(SECTIONS):
        print(f"== {section}")
        SECTIONS[section]()
