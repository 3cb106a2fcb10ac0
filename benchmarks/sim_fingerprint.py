"""The simulator's outputs, bit for bit, as one SHA-256 per scene: the check that a speed-up
changed nothing.

Eight scenes run for a few simulated seconds under a fixed schedule of commands (forward,
turning, reversing, wheel-speed commands; the robots meet walls, people and each other):

- ``office-heavy``: the heavy Uiabot configuration (360-beam lidar at 10 Hz, the IMU at
  100 Hz, encoders and joint states at 50 Hz) in the office among five walking people;
- ``office-default``: the Uiabot with its own devices (RPLidar at 5.5 Hz) among eight people;
- ``aisle-igv``: the IGV (LMS291, OS5000) in the aisle among three people (the alcoves);
- ``aisle-slip``: the Uiabot in the aisle with wheel-slip noise and worn tyres, two people;
- ``pillars-eddie``: Eddie (the Kinect row) among the pillars, three people;
- ``crowd``: 20 Uiabots with 360-beam lidars at 10 Hz among 20 people in the square world
  (``benchmarks/bench_sim_vs_irsim.py``'s crowd);
- ``mixed``: two Uiabots, the IGV and Eddie in the office among six people, every lidar at
  10 Hz (their scans due together, each with its own beams, timing, noise and dropouts);
- ``mixed-default``: the IGV, a Uiabot and Eddie with their own lidar rates among four people
  (scans due together now and then, from different steps).

Each digest covers, every physics step: every message (topic, type, every field: floats by
their exact bits, arrays by dtype, shape and bytes, strings, the Python type of each
scalar), every robot's pose, velocity, wheel speeds and angles, encoder counts and ground
truth, every person's position, and the collisions recorded; with each scan, the float64
ranges it was made from.

Run it on two versions of the code and compare (``--save FILE`` writes the lines,
``--check FILE`` compares with saved ones and exits 1 on any difference). The old code need
not have this script: put its checkout (its ``sim/``, and ``kit/``) first on the path and run
this file from another folder::

    git worktree add /tmp/old main
    cd /tmp && PYTHONPATH=/tmp/old python CHECKOUT/benchmarks/sim_fingerprint.py --save before.txt
    cd CHECKOUT && python benchmarks/sim_fingerprint.py --check /tmp/before.txt

``--seconds`` scales every scene's length (default 1: 20-30 s simulated per scene, 10 s for
the crowd; about 5 s of CPU in all once numba's caches are warm, a minute the first time).
"""

from __future__ import annotations

import argparse
import hashlib
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from fingerprint import feed

from kit import msgs
from sim.simulation import Physics, Simulation


def _twist(v: float, w: float) -> msgs.Twist:
    return msgs.Twist(msgs.Vector3(v, 0.0, 0.0), msgs.Vector3(0.0, 0.0, w))


def _schedule(n_robots: int, step: int) -> dict[int, Any] | None:
    """The commands at physics step ``step`` (a new one every 0.5 s; None keeps them)."""
    if step % 50:
        return None
    phase = step // 50
    commands: dict[int, Any] = {}
    for i in range(n_robots):
        k = (phase + i) % 6
        if k == 0:
            commands[i] = _twist(0.4, 0.0)
        elif k == 1:
            commands[i] = _twist(0.3, 0.6 if i % 2 else -0.6)
        elif k == 2:
            commands[i] = _twist(0.8, 0.1)       # beyond some robots' limits: saturated
        elif k == 3:
            commands[i] = (6.0, -2.0)            # wheel speeds (right, left) [rad/s]
        elif k == 4:
            commands[i] = _twist(-0.2, 0.3)
        else:
            commands[i] = np.array([3.0, 3.5])
    return commands


def _record(h: Any, sim: Simulation, out: list[tuple[str, Any]]) -> None:
    feed(h, sim.time)
    for topic, message in out:
        feed(h, topic)
        feed(h, message)
        if topic.endswith("/scan"):   # the float64 ranges the scan was made from
            index = int(topic[6:-5]) if topic.startswith("/robot") else 0
            lidar = sim.robots[index].lidar
            feed(h, None if lidar is None else lidar.last_ranges)
    for i, r in enumerate(sim.robots):
        feed(h, r.xy_yaw)
        feed(h, (r.forward_speed, r.yaw_rate, r.world_velocity, r.accel, r.yaw_accel))
        feed(h, (tuple(r.speeds), tuple(r.angles)))
        feed(h, sim.encoder_ticks(i))
        truth = sim.ground_truth(i)
        feed(h, (truth.time, truth.pose, truth.velocity, truth.wheel_slip, truth.in_oil))
    if sim.people or sim.bystanders:
        feed(h, sim.people_positions())
    feed(h, len(sim.collisions))
    for c in sim.collisions:
        feed(h, (c.time, c.robot, c.other))


def run_scene(make: Callable[[], Simulation], seconds: float) -> tuple[str, int, int]:
    """(digest, messages, collisions) of ``seconds`` simulated under the schedule."""
    sim = make()
    h = hashlib.sha256()
    messages = 0
    for k in range(round(seconds / sim.physics.dt)):
        out = sim.step(_schedule(len(sim.robots), k))
        messages += len(out)
        _record(h, sim, out)
    return h.hexdigest(), messages, len(sim.collisions)


def _crowd() -> Simulation:
    grid = [[1.0 + 2.0 * (i % 5), 1.0 + 2.5 * (i // 5), 0.0] for i in range(20)]
    return Simulation("square", ["uiabot"] * 20, seed=1, people=20, start=grid,
                      lidar_rate=10.0, lidar_beams=360)


SCENES: dict[str, tuple[Callable[[], Simulation], float]] = {
    "office-heavy": (lambda: Simulation("office", "uiabot", seed=1, people=5, lidar_rate=10.0,
                                        lidar_beams=360), 20.0),
    "office-default": (lambda: Simulation("office", "uiabot", seed=2, people=8), 20.0),
    "aisle-igv": (lambda: Simulation("aisle", "igv", seed=3, people=3), 30.0),
    "aisle-slip": (lambda: Simulation(
        "aisle", "uiabot", seed=4, people=2,
        physics=Physics(slip_variance=2e-4, wheel_radius_errors=(0.004, -0.003))), 20.0),
    "pillars-eddie": (lambda: Simulation("pillars", "eddie", seed=5, people=3), 20.0),
    "crowd": (_crowd, 10.0),
    "mixed": (lambda: Simulation("office", ["uiabot", "igv", "eddie", "uiabot"], seed=6,
                                 people=6, lidar_rate=10.0), 10.0),
    "mixed-default": (lambda: Simulation("office", ["igv", "uiabot", "eddie"], seed=7,
                                         people=4), 10.0),
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0,
                        help="scale of every scene's simulated length (default 1)")
    parser.add_argument("--scene", action="append", choices=sorted(SCENES),
                        help="only this scene (repeatable; default all)")
    parser.add_argument("--save", type=Path, help="write the digests to this file")
    parser.add_argument("--check", type=Path, help="compare with the digests in this file")
    args = parser.parse_args(argv)
    if not (math.isfinite(args.seconds) and args.seconds > 0):
        print(f"--seconds must be a positive number; got {args.seconds}", file=sys.stderr)
        return 2
    expected: dict[str, str] = {}
    if args.check is not None:
        try:
            lines = args.check.read_text().split("\n")
        except OSError as e:
            print(f"cannot read {args.check}: {e.strerror}", file=sys.stderr)
            return 2
        expected = {line.split()[0]: line for line in lines if line.strip()}
    rows, failed = [], 0
    for name in args.scene or list(SCENES):
        make, seconds = SCENES[name]
        cpu = time.process_time()
        digest, messages, collisions = run_scene(make, seconds * args.seconds)
        row = f"{name} {seconds * args.seconds:g}s {digest} messages={messages} " \
              f"collisions={collisions}"
        verdict = ""
        if args.check is not None:
            same = expected.get(name) == row
            failed += not same
            verdict = "  identical" if same else "  DIFFERENT (expected " + \
                (expected.get(name, "no such scene").split()[2] if name in expected
                 else "no such scene") + ")"
        print(f"{row}{verdict}   [{time.process_time() - cpu:.1f} s CPU]", flush=True)
        rows.append(row)
    if args.save is not None:
        args.save.write_text("\n".join(rows) + "\n")
    if args.check is not None:
        print("all identical" if not failed else f"{failed} scene(s) differ")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
