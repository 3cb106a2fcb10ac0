"""``kit record``, ``kit probe`` and ``kit stop``: a live robot's devices from the command
line.

    kit probe /dev/ttyUSB0                       which device answers, at which rate
    kit record rplidar=/dev/ttyUSB0 bno055=/dev/ttyUSB1 odrive=/dev/ttyACM0 \\
        --robot uiabot --duration 60 --out run1  an MCAP bag of a live session
    kit stop /dev/ttyACM0                        stop the motors on that port, now

A port given without ``DEVICE=`` is probed first. The bag holds each device's topics
(:mod:`kit.drivers.live`), each message stamped with when its data was measured (wall
clock), and ``/tf_static`` from the robot's URDF; it opens in ``ros2 bag``, Foxglove and
the labs (:func:`kit.bag.read_bag`). A device whose port fails (unplugged) is reopened on
its own, with a back-off, and the outage is reported in the summary and kept in the bag's
``metadata.yaml`` (``custom_data``), as is what a device's driver noticed that the messages
do not show (``kit_record.notes``: the lidar's stream stopped for longer than its stamps can
bridge, its scans just after possibly stamped late). The rates printed are computed from the stamps.
"""

from __future__ import annotations

import argparse
import math
import queue
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["record", "register"]


def _port_spec(text: str) -> tuple[str | None, str, int | None]:
    """``DEVICE=PORT[@BAUD]`` or ``PORT`` → (device or None, port, baud or None)."""
    from kit.drivers.live import DEVICES

    device, sep, rest = text.partition("=")
    if not sep:
        device, rest = None, text  # type: ignore[assignment]
    elif device not in DEVICES:
        raise ValueError(f"unknown device {device!r} in {text!r}; known: {', '.join(DEVICES)}")
    port, at, baud = rest.partition("@")
    if not port:
        raise ValueError(f"no port in {text!r}; expected DEVICE=PORT, e.g. rplidar=/dev/ttyUSB0")
    if at and not baud.isdigit():
        raise ValueError(f"baud rate {baud!r} in {text!r} is not a number")
    return device, port, int(baud) if at else None


def _topics(devices: list[str], topics: list[list[str]]) -> list[dict[str, str]]:
    """Topic renames: a topic two devices publish goes under each device's name."""
    seen: dict[str, int] = {}
    for names in topics:
        for t in set(names):
            seen[t] = seen.get(t, 0) + 1
    return [{t: (f"/{d}{t}" if seen[t] > 1 else t) for t in names}
            for d, names in zip(devices, topics, strict=True)]


_TOPICS = {"rplidar": ["/scan"], "lms2xx": ["/scan"], "bno055": ["/imu"], "os5000": ["/imu"],
           "odrive": ["/joint_states", "/odom", "/tf"],
           "dpralte": ["/joint_states", "/odom", "/tf"]}


def record(specs: list[tuple[str, str, int | None]], out: Path, robot: str = "uiabot",
           duration: float = math.inf, log: Any = print,
           on_message: Callable[[str, int, Any], None] | None = None,
           stop: threading.Event | None = None) -> dict[str, int]:
    """Record ``(device, port, baud)`` sources into a new MCAP bag at ``out`` for
    ``duration`` seconds (or until Ctrl-C, or until ``stop`` is set); returns the messages
    written per topic.

    Every message goes through one place, in the order written: the bag, the counts, and
    ``on_message(topic, time_ns, message)`` if given (a live view). A device whose port
    fails is reopened in its reader (:class:`~kit.drivers.reader.Reader`) and its outage
    noted.

    Raises
    ------
    DriverError
        A device that does not start (nothing is recorded then).
    FileExistsError
        ``out`` exists.
    """
    from kit import msgs
    from kit.bag import BagWriter
    from kit.drivers.live import open_source
    from kit.drivers.reader import Reader
    from kit.robots import load

    if Path(out).exists():
        raise FileExistsError(f"{out} exists; a bag is written to a new folder")
    description = load(robot)
    sources = []
    readers: list[Any] = []
    q: queue.Queue[Any] = queue.Queue()
    try:
        # each device is read from the moment it starts (a lidar streams at once: left
        # unread while the others start, its port would overflow)
        renames = _topics([d for d, _, _ in specs], [_TOPICS[d] for d, _, _ in specs])
        for (device, port, baud), names in zip(specs, renames, strict=True):
            src = open_source(device, port, description, baud)
            sources.append(src)
            log(f"{device} on {port}: {src.description}")
            readers.append(Reader(src.device, _renamed(src.read, names), q, src.period,
                                  on_error=_failed(src.device, log), reopen=src.reopen).start())
        tally = _Tally(on_message)
        with BagWriter(out) as bag:
            tally.bag = bag
            start = time.time()
            stamp = msgs.Time.from_sec(start)
            tally.write("/tf_static", stamp.to_nsec(),
                        msgs.TFMessage(description.static_transforms(stamp)))
            end = time.monotonic() + duration
            try:
                while time.monotonic() < end and any(r.alive for r in readers) and \
                        not (stop is not None and stop.is_set()):
                    tally.drain(q, 0.05)
            except KeyboardInterrupt:
                log("stopped (Ctrl-C)")
            for r in readers:
                r.stop()
            tally.drain(q, 0.0)
            gaps = [g for r in readers for g in r.gaps]
            if gaps:
                bag.custom_data("kit_record.gaps", "; ".join(
                    f"{g.device} {g.start}..{'' if g.end is None else g.end} ns" for g in gaps))
                bag.custom_data("kit_record.gap_reasons",
                                "; ".join(g.describe() for g in gaps))
            notes = [f"{src.device}: {said}" for src in sources
                     if src.health is not None and (said := src.health())]
            if notes:
                bag.custom_data("kit_record.notes", "; ".join(notes))
        _summary(readers, tally, out, max(time.time() - start, 1e-9), log, notes)
        return tally.counts
    finally:
        for r in readers:
            r.stop()
        for s in sources:
            s.close()


class _Tally:
    """Every message of a recording through one place, in the order written: the bag, the
    counts and stamps per topic, and the live view's callback."""

    def __init__(self, on_message: Callable[[str, int, Any], None] | None) -> None:
        self.on_message = on_message
        self.bag: Any = None
        self.counts: dict[str, int] = {}
        self.first: dict[str, int] = {}
        self.last: dict[str, int] = {}
        self.disorder: dict[str, int] = {}

    def write(self, topic: str, time_ns: int, message: Any) -> None:
        self.bag.write(topic, message, time_ns)
        self.counts[topic] = self.counts.get(topic, 0) + 1
        self.first.setdefault(topic, time_ns)
        if topic in self.last and time_ns <= self.last[topic]:
            self.disorder[topic] = self.disorder.get(topic, 0) + 1
        self.last[topic] = max(time_ns, self.last.get(topic, time_ns))
        if self.on_message is not None:
            self.on_message(topic, time_ns, message)

    def drain(self, q: queue.Queue[Any], wait: float) -> None:
        try:
            while True:
                self.write(*q.get(timeout=wait))
                wait = 0.0
        except queue.Empty:
            pass


def _summary(readers: list[Any], tally: _Tally, out: Path, elapsed: float, log: Any,
             notes: list[str]) -> None:
    for note in notes:
        log(note)
    for r in readers:
        for g in r.gaps:
            log(f"gap: {g.describe()}")
        if r.error is not None:
            log(f"{r.name}: stopped early: {r.error}")
        elif r.timeouts or r.errors:
            log(f"{r.name}: {r.timeouts} reads timed out, {r.errors} bad frames skipped")
    for topic, n in sorted(tally.counts.items()):
        span = (tally.last.get(topic, 0) - tally.first.get(topic, 0)) * 1e-9
        rate = f"{(n - 1) / span:8.2f} Hz" if n > 1 and span > 0 else ""
        out_of_order = f"  ({tally.disorder[topic]} stamps out of order)" \
            if topic in tally.disorder else ""
        log(f"  {topic:24s}{n:8d} messages  {rate}{out_of_order}")
    log(f"wrote {out} ({sum(tally.counts.values())} messages, {elapsed:.1f} s; rates from the "
        f"messages' stamps)")


def _failed(name: str, log: Any) -> Callable[[BaseException], None]:
    return lambda exc: log(f"{name}: {exc}; reopening it when it is back")


def _renamed(read: Any, names: dict[str, str]) -> Any:
    def renamed() -> list[tuple[str, Any]]:
        return [(names.get(topic, topic), message) for topic, message in read()]
    return renamed


def _probe(args: argparse.Namespace) -> int:
    from kit.drivers.errors import PortError
    from kit.drivers.probe import probe

    try:
        answer = probe(args.port, timeout=args.timeout,
                       log=(lambda m: print(f"  trying {m}", file=sys.stderr))
                       if args.verbose else None)
    except PortError as exc:
        print(f"kit probe: {exc}", file=sys.stderr)
        return 2
    if answer is None:
        print(f"{args.port}: no known device answered (tried the ODrive, RPLidar, BNO055, "
              f"DPRALTE, OS5000 and LMS2xx at their rates)")
        return 1
    print(f"{args.port}: {answer.device} at {answer.baudrate} baud ({answer.detail})")
    return 0


def _live_view(address: str | None) -> Any:
    """``--live``: a Foxglove live view of what is recorded (None without it)."""
    if address is None:
        return None
    from kit.liveview import LiveView, parse_address

    view = LiveView(*parse_address(address), name="kit record")
    print(f"live view: open {view.url} in Foxglove Studio (Open connection -> Foxglove "
          f"WebSocket)", flush=True)
    return view


def _record(args: argparse.Namespace) -> int:
    from kit.drivers.errors import DriverError
    from kit.drivers.probe import probe

    specs: list[tuple[str, str, int | None]] = []
    try:
        for text in args.ports:
            device, port, baud = _port_spec(text)
            if device is None:
                answer = probe(port)
                if answer is None:
                    print(f"kit record: no known device answered on {port}; name it "
                          f"(DEVICE={port})", file=sys.stderr)
                    return 2
                print(f"{port}: found {answer.device} at {answer.baudrate} baud")
                device, baud = answer.device, baud or answer.baudrate
            specs.append((device, port, baud))
        view = _live_view(args.live)
        try:
            record(specs, Path(args.out), args.robot,
                   math.inf if args.duration is None else args.duration,
                   on_message=None if view is None else
                   (lambda topic, time_ns, message: view.publish(topic, message, time_ns)))
        finally:
            if view is not None:
                view.close()
    except DriverError as exc:
        print(f"kit record: {exc}", file=sys.stderr)
        return 1
    except FileExistsError as exc:
        print(f"kit record: {exc}", file=sys.stderr)
        return 2
    return 0


def _stop(args: argparse.Namespace) -> int:
    from kit.drivers.errors import DriverError
    from kit.drivers.stop import stop_motors

    worst = 0
    for text in args.ports:
        try:
            device, port, baud = _port_spec(text)
            report = stop_motors(port, device, baud, timeout=args.timeout)
        except (DriverError, ValueError) as exc:
            print(f"kit stop: {exc}", file=sys.stderr)
            worst = max(worst, 2 if isinstance(exc, ValueError) else 1)
            continue
        print(report)
        if not report.confirmed:
            worst = max(worst, 1)
    return worst


def register(subparsers: Any) -> None:
    """Add ``kit probe``, ``kit record`` and ``kit stop``."""
    p = subparsers.add_parser("probe", help="which device answers on a serial port")
    p.add_argument("port", help="/dev/ttyUSB0, /dev/ttyACM0, a pseudo-terminal, a pyserial URL")
    p.add_argument("--timeout", type=float, default=0.2, help="seconds per try (0.2)")
    p.add_argument("--verbose", action="store_true", help="say what is tried")
    p.set_defaults(func=_probe)
    p = subparsers.add_parser(
        "record", help="record a live robot's devices into an MCAP ROS 2 bag",
        description="Record devices into a new MCAP bag (wall-clock stamps, /tf_static from "
                    "the robot's URDF). PORT is DEVICE=PATH[@BAUD] (DEVICE: rplidar, "
                    "bno055, odrive, os5000, lms2xx, dpralte) or a PATH to probe.")
    p.add_argument("ports", nargs="+", metavar="PORT")
    p.add_argument("--out", required=True, help="the bag folder to create")
    p.add_argument("--robot", default="uiabot", help="uiabot, igv, eddie or a .toml (uiabot)")
    p.add_argument("--duration", type=float, default=None,
                   help="seconds to record (default: until Ctrl-C)")
    p.add_argument("--live", nargs="?", const="127.0.0.1:8765", default=None,
                   metavar="HOST:PORT", help="also serve what is recorded to Foxglove Studio "
                   "(Foxglove WebSocket, default ws://127.0.0.1:8765)")
    p.set_defaults(func=_record)
    p = subparsers.add_parser(
        "stop", help="stop a robot's motors now (from another terminal)",
        description="Zero speed and motors off on each port: the ODrive's axes to IDLE, the "
                    "DPRALTE drives' bridges inhibited, read back. PORT is DEVICE=PATH[@BAUD] "
                    "(DEVICE: odrive, dpralte) or a PATH to probe. A port another program "
                    "holds is shared for the stop. Exit 0 when every port's motors were read "
                    "back stopped.")
    p.add_argument("ports", nargs="+", metavar="PORT")
    p.add_argument("--timeout", type=float, default=0.3, help="seconds per reply (0.3)")
    p.set_defaults(func=_stop)
