"""``kit record`` and ``kit probe``: a live robot's devices from the command line.

    kit probe /dev/ttyUSB0                       which device answers, at which rate
    kit record rplidar=/dev/ttyUSB0 bno055=/dev/ttyUSB1 odrive=/dev/ttyACM0 \\
        --robot uiabot --duration 60 --out run1  an MCAP bag of a live session

A port given without ``DEVICE=`` is probed first. The bag holds each device's topics
(:mod:`kit.drivers.live`) stamped with the wall clock, and ``/tf_static`` from the robot's
URDF; it opens in ``ros2 bag``, Foxglove and the labs (:func:`kit.bag.read_bag`).
"""

from __future__ import annotations

import argparse
import math
import queue
import sys
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
           on_message: Callable[[str, int, Any], None] | None = None) -> dict[str, int]:
    """Record ``(device, port, baud)`` sources into a new MCAP bag at ``out`` for
    ``duration`` seconds (or until Ctrl-C), each message also to ``on_message(topic,
    time_ns, message)`` if given (a live view); returns the messages written per topic.

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
    try:
        for device, port, baud in specs:
            sources.append(open_source(device, port, description, baud))
            log(f"{device} on {port}: {sources[-1].description}")
        renames = _topics([s.device for s in sources], [_TOPICS[s.device] for s in sources])
        q: queue.Queue[Any] = queue.Queue()
        counts: dict[str, int] = {}
        first: dict[str, int] = {}
        last: dict[str, int] = {}
        with BagWriter(out) as bag:
            start = time.time()
            stamp = msgs.Time.from_sec(start)
            # the first message drain() writes (and hands to on_message)
            q.put(("/tf_static", stamp.to_nsec(),
                   msgs.TFMessage(description.static_transforms(stamp))))
            readers = [Reader(src.device, _renamed(src.read, names), q, src.period).start()
                       for src, names in zip(sources, renames, strict=True)]
            end = time.monotonic() + duration

            def drain(wait: float) -> None:
                try:
                    while True:
                        topic, time_ns, message = q.get(timeout=wait)
                        bag.write(topic, message, time_ns)
                        if on_message is not None:
                            on_message(topic, time_ns, message)
                        counts[topic] = counts.get(topic, 0) + 1
                        first.setdefault(topic, time_ns)
                        last[topic] = time_ns
                        wait = 0.0
                except queue.Empty:
                    pass

            try:
                while time.monotonic() < end and any(r.alive for r in readers):
                    drain(0.05)
            except KeyboardInterrupt:
                log("stopped (Ctrl-C)")
            for r in readers:
                r.stop()
            drain(0.0)
        elapsed = max(time.time() - start, 1e-9)
        for r in readers:
            if r.error is not None:
                log(f"{r.name}: stopped early: {r.error}")
            elif r.timeouts or r.errors:
                log(f"{r.name}: {r.timeouts} reads timed out, {r.errors} bad frames skipped")
        for topic, n in sorted(counts.items()):
            span = (last.get(topic, 0) - first.get(topic, 0)) * 1e-9
            rate = f"{(n - 1) / span:8.1f} Hz" if n > 1 and span > 0 else ""
            log(f"  {topic:24s}{n:8d} messages  {rate}")
        log(f"wrote {out} ({sum(counts.values())} messages, {elapsed:.1f} s)")
        return counts
    finally:
        for s in sources:
            s.close()


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


def register(subparsers: Any) -> None:
    """Add ``kit probe`` and ``kit record``."""
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
