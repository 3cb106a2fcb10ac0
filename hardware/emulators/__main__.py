"""``python -m hardware.emulators DEVICE``: serve an emulated device on a pseudo-terminal.

The first line printed is the port's path (open it with any serial program or the kit's
drivers); the emulator serves in real time until stopped (Ctrl-C). ``uiabot`` and ``igv``
serve a whole simulated robot's devices, one line ``NAME PATH`` each.

Examples::

    python -m hardware.emulators odrive
    python -m hardware.emulators rplidar --sim office --faults seed=1,flip=0.001
    python -m hardware.emulators uiabot --world office --people 3
    python -m hardware.emulators rplidar --replay capture.bin
    python -m hardware.emulators uiabot --stats sent.json

``--stats FILE`` writes, when the emulator stops, what each device sent and did (bytes, and
the time of each turn, IMU reading, encoder reply … on the wall clock, seconds since the
epoch): what a recording of it can be checked against.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
from pathlib import Path
from typing import Any

from hardware.emulators.core import Device, Faults, PtyServer

DEVICES = ("odrive", "bno055", "rplidar", "lms2xx", "dpralte", "os5000")
WARM_UP_S = 0.25
ROBOTS = ("uiabot", "igv")


def make_device(name: str, backend: Any = None, faults: Faults | None = None) -> Device:
    """One emulator by name, optionally backed by a ``SimBackend``."""
    from hardware.emulators import bno055, dpralte, lms2xx, odrive, os5000, rplidar

    if name == "odrive":
        if backend is not None and hasattr(backend, "description"):
            return odrive.ODriveEmulator.for_robot(backend, faults=faults)
        return odrive.ODriveEmulator(backend, faults=faults)
    factories = {"bno055": bno055.BNO055Emulator, "rplidar": rplidar.RPLidarEmulator,
                 "lms2xx": lms2xx.LMS2xxEmulator, "dpralte": dpralte.DpralteBusEmulator,
                 "os5000": os5000.Os5000Emulator}
    if name not in factories:
        raise ValueError(f"unknown device {name!r}; known: {', '.join(DEVICES)}")
    return factories[name](backend, faults=faults)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hardware.emulators",
                                     description="Serve an emulated device on a "
                                                 "pseudo-terminal (path on the first line).")
    parser.add_argument("device", choices=DEVICES + ROBOTS)
    parser.add_argument("--sim", metavar="WORLD", default=None,
                        help="back the device with a simulated robot in WORLD "
                             "(office, aisle, pillars, square or a map .yaml)")
    parser.add_argument("--world", default=None, help="the world of 'uiabot'/'igv'")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--people", type=int, default=0)
    parser.add_argument("--faults", default="", help="e.g. seed=1,flip=0.001,drop=0.01,"
                                                     "silence=0.001,error=0.01")
    parser.add_argument("--stats", metavar="FILE", default=None,
                        help="write what each device sent and did to FILE (JSON) on exit")
    parser.add_argument("--replay", metavar="CAPTURE", default=None,
                        help="rplidar only: send this recorded stream (binary, 0xNN lines or "
                             "a hex dump) when asked to scan")
    args = parser.parse_args(argv)
    try:
        faults = Faults.parse(args.faults) if args.faults else None
    except ValueError as exc:
        parser.error(str(exc))
    names: list[str]
    devices: list[Device]
    backend: Any = None
    if args.replay and args.device != "rplidar":
        parser.error("--replay replays RPLidar captures: use it with 'rplidar'")
    if args.replay:
        from hardware.emulators.replay import CaptureReplay, read_capture

        try:
            capture = read_capture(args.replay)
        except (OSError, ValueError) as exc:
            parser.error(str(exc))
        names, devices = ["rplidar"], [CaptureReplay(capture, faults=faults)]
    elif args.device in ROBOTS:
        from hardware.emulators.rigs import igv_rig, uiabot_rig

        rig = (uiabot_rig if args.device == "uiabot" else igv_rig)(
            world=args.world or ("square" if args.device == "uiabot" else "aisle"),
            seed=args.seed, people=args.people, faults=faults)
        names, devices = list(rig.devices), list(rig.devices.values())
        backend = rig.backend
    else:
        if args.sim:
            from hardware.emulators.backends import SimBackend

            robot = "igv" if args.device in ("lms2xx", "dpralte", "os5000") else "uiabot"
            backend = SimBackend.create(robot=robot, world=args.sim, seed=args.seed,
                                        people=args.people)
        names, devices = [args.device], [make_device(args.device, backend, faults)]
    if backend is not None:
        # the first simulated scan loads the compiled ray caster (a second or more): do it
        # now, not while a driver waits for its first reply
        backend.advance(WARM_UP_S)
    server = PtyServer(devices, start=WARM_UP_S if backend is not None else 0.0)
    if len(devices) == 1:
        print(server.path, flush=True)
    else:
        for name, path in zip(names, server.paths, strict=True):
            print(name, path, flush=True)
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    server.start()
    try:
        done.wait()
    except KeyboardInterrupt:
        pass
    server.stop()
    if args.stats:
        Path(args.stats).write_text(json.dumps({
            "epoch": server.epoch,
            "devices": {name: device.stats() for name, device in zip(names, devices,
                                                                     strict=True)}}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
