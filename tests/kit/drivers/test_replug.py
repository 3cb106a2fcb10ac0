"""Drivers that come back: each emulated device, behind a stable path (as udev's
``/dev/serial/by-id`` links are), is unplugged — its pseudo-terminal closed, the path gone —
and plugged back in as a device that lost power. The same driver object reports the failure
once, refuses to pretend, and resumes with ``reopen()``; ``kit record`` keeps recording,
reopening on its own, and reports the gap in its summary and in the bag."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml

from hardware.emulators import PtyServer
from hardware.emulators.bno055 import BNO055Emulator
from hardware.emulators.dpralte import DpralteBusEmulator
from hardware.emulators.lms2xx import LMS2xxEmulator
from hardware.emulators.odrive import ODriveEmulator
from hardware.emulators.os5000 import Os5000Emulator
from hardware.emulators.rplidar import RPLidarEmulator
from kit.drivers import PortError, bno055, lms2xx, odrive, os5000, rplidar
from kit.drivers.bases import IgvBase, UiabotBase

# A happy path's replies are awaited for up to REPLY s, not the devices' own 0.1-1 s: the
# emulator's thread can be kept off a loaded machine's CPU for longer than a device takes
# (tests of the time-outs pass their own).
REPLY = 10.0


def _rplidar(path: str) -> tuple[Any, Callable[[], Any]]:
    lidar = rplidar.RPLidar(path, timeout=REPLY)
    lidar.start()
    return lidar, lidar.read_scan


def _bno055(path: str) -> tuple[Any, Callable[[], Any]]:
    imu = bno055.BNO055(path, timeout=REPLY)
    imu.begin()
    return imu, imu.read_imu


def _odrive(path: str) -> tuple[Any, Callable[[], Any]]:
    base = UiabotBase(odrive.ODrive(path, timeout=REPLY))
    return base, base.read_wheels


def _dpralte(path: str) -> tuple[Any, Callable[[], Any]]:
    base = IgvBase(path, timeout=REPLY)
    return base, base.read_wheels


def _os5000(path: str) -> tuple[Any, Callable[[], Any]]:
    compass = os5000.Os5000(path, timeout=REPLY)
    return compass, compass.read_imu


def _lms2xx(path: str) -> tuple[Any, Callable[[], Any]]:
    scanner = lms2xx.LMS2xx(path, timeout=REPLY)
    scanner.connect(38400, 180, 1.0)
    scanner.start()
    return scanner, scanner.read_scan


DEVICES: dict[str, tuple[Callable[[], Any], Callable[[str], tuple[Any, Callable[[], Any]]]]] = {
    "rplidar": (RPLidarEmulator, _rplidar), "bno055": (BNO055Emulator, _bno055),
    "odrive": (ODriveEmulator, _odrive), "dpralte": (DpralteBusEmulator, _dpralte),
    "os5000": (Os5000Emulator, _os5000), "lms2xx": (LMS2xxEmulator, _lms2xx)}


def failing(read: Callable[[], Any], tries: int = 200) -> PortError:
    for _ in range(tries):
        try:
            read()
        except PortError as exc:
            return exc
    raise AssertionError("the port never failed")


@pytest.mark.parametrize("name", list(DEVICES))
def test_the_same_driver_resumes_after_an_unplug_and_replug(name, tmp_path):
    make, start = DEVICES[name]
    link = str(tmp_path / f"tty{name}")
    server = PtyServer(make(), links=[link]).start()
    try:
        driver, read = start(link)
        read()
        server.unplug()
        error = failing(read)
        assert any(why in str(error) for why in ("input/output error", "disconnected", "closed")), \
            str(error)
        # reported once: later calls raise the same failure and touch nothing
        with pytest.raises(PortError, match=r"the port failed earlier .*reopen\(\) once the "
                                            r"device is back"):
            read()
        with pytest.raises(PortError, match="no such port"):
            driver.reopen()  # not back yet
        server.replug(device=make())  # back, having lost power: it starts afresh
        driver.reopen()
        assert read() is not None and driver.link.reopened == 1
    finally:
        server.stop()


def test_a_uiabot_driving_when_unplugged_is_stopped_by_its_watchdog_and_says_so(tmp_path):
    """Unplugged while driving: the ODrive's watchdog stops the axes; after ``reopen()``
    the base knows it no longer controls them (``drive`` says to bring it up again)."""
    from kit.drivers import DriverError

    link = str(tmp_path / "ttyACM0")
    device = ODriveEmulator(calibration_time=0.2)
    server = PtyServer(device, links=[link]).start()
    try:
        base = UiabotBase(odrive.ODrive(link, timeout=REPLY), watchdog_timeout=0.3)
        base.bring_up()
        base.drive((0.2, 0.0))
        server.unplug()
        deadline = time.monotonic() + 60  # gives up on a broken run only
        while not all(a.current_state == 1 for a in device.axes):
            assert time.monotonic() < deadline
            time.sleep(0.01)
        assert all(a.error == 0x800 for a in device.axes)  # the watchdog, not the host
        server.replug()  # the same ODrive, its USB back (it kept its supply)
        base.reopen()
        assert not base.ready
        with pytest.raises(DriverError, match=r"bring_up\(\) first"):
            base.drive((0.2, 0.0))
        base.bring_up()
        base.drive((0.1, 0.0))
        base.close()
    finally:
        server.stop()


def test_kit_record_keeps_recording_across_a_replug_and_reports_the_gap(tmp_path):
    from kit.bag import read_bag
    from kit.drivers._cli import record

    names = ["odrive", "rplidar", "bno055"]
    links = [str(tmp_path / f"tty{n}") for n in names]
    server = PtyServer([ODriveEmulator(), RPLidarEmulator(), BNO055Emulator()],
                       links=links).start()
    scans: list[int] = []
    printed: list[str] = []
    out = tmp_path / "bag"

    def on_message(topic: str, time_ns: int, message: Any) -> None:
        if topic == "/scan":
            scans.append(time_ns)

    done = threading.Event()

    def run() -> None:
        record([(n, p, None) for n, p in zip(names, links, strict=True)], out,
               log=printed.append, on_message=on_message, stop=done)

    recorder = threading.Thread(target=run)
    try:
        recorder.start()
        wait_for(lambda: len(scans) >= 3, "scans before the unplug")
        server.unplug(1)
        time.sleep(0.5)  # the lidar away for a while (no figure depends on how long)
        replugged = time.time_ns()
        server.replug(1, RPLidarEmulator())
        # scans measured after the replug (their stamps are the wall clock's): a recorder
        # that lags may still deliver scans from before the unplug after it
        wait_for(lambda: sum(t > replugged for t in scans) >= 3, "scans after the replug")
    finally:
        done.set()
        recorder.join(60)
        server.stop()
    text = "\n".join(printed)
    assert "rplidar: " in text and "reopening it when it is back" in text
    gap_lines = [line for line in printed if line.startswith("gap: rplidar:")]
    assert len(gap_lines) == 1 and "s without data" in gap_lines[0]
    metadata = yaml.safe_load(Path(out, "metadata.yaml").read_text())
    custom = metadata["rosbag2_bagfile_information"]["custom_data"]
    assert custom["kit_record.gap_reasons"].startswith("rplidar: ")
    device, span, _ = custom["kit_record.gaps"].split(" ")
    start, end = (int(t) for t in span.split(".."))
    stamps = [t for topic, t, _ in read_bag(out) if topic == "/scan"]
    # the gap lies between two recorded scans, with no scan in it, and the IMU went on
    assert device == "rplidar" and start in stamps and end in stamps
    assert not any(start < t < end for t in stamps)
    imu = [t for topic, t, _ in read_bag(out) if topic == "/imu"]
    assert any(start < t < end for t in imu)


def wait_for(condition: Callable[[], bool], what: str, limit: float = 60.0) -> None:
    end = time.monotonic() + limit  # gives up on a broken run only; no figure
    while not condition():
        if time.monotonic() > end:
            raise AssertionError(f"{what} never came")
        time.sleep(0.01)



def test_a_bag_note_must_be_text(tmp_path):
    from kit.bag import BagWriter

    with BagWriter(tmp_path / "b") as bag:
        with pytest.raises(TypeError, match="custom data is str: str; got str: int"):
            bag.custom_data("kit_record.gaps", 3)
        bag.custom_data("kit_record.gaps", "none")
    metadata = yaml.safe_load(Path(tmp_path, "b", "metadata.yaml").read_text())
    assert metadata["rosbag2_bagfile_information"]["custom_data"] == {"kit_record.gaps": "none"}
