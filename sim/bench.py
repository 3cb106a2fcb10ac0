"""``python -m sim bench``: real-time factors of the simulator and the raycaster's rate.

Real-time factor = simulated seconds per wall-clock second, on one core. Each figure is the
median of three runs of 10 simulated seconds (``--quick``: one run of 3 s).
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from kit import msgs
from sim.raycast import cast_rays, cast_scan
from sim.simulation import Simulation
from sim.world import load_world

CRUISE = msgs.Twist(msgs.Vector3(0.3, 0.0, 0.0), msgs.Vector3(0.0, 0.0, 0.2))


def real_time_factor(make: object, seconds: float, repeats: int) -> float:
    factors = []
    for _ in range(repeats):
        sim = make()  # type: ignore[operator]
        commands = {i: CRUISE for i in range(len(sim.robots))}
        sim.step(commands)
        steps = round(seconds / sim.physics.dt)
        start = time.perf_counter()
        for _ in range(steps):
            sim.step()
        factors.append(seconds / (time.perf_counter() - start))
    return statistics.median(factors)


def raycaster_rate(repeats: int, compiled: bool) -> float:
    """Beams per second for 360-beam scans in the office (walls, and 5 people when compiled)."""
    world = load_world("office")
    rng = np.random.default_rng(0)
    origins = np.column_stack([rng.uniform(1, 19, 360), rng.uniform(5.2, 6.8, 360)])
    angles = rng.uniform(-np.pi, np.pi, 360)
    people = rng.uniform(1, 19, (1, 5, 3))
    people[..., 2] = 0.25
    step = np.zeros(360, dtype=np.int64)
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        n = 0
        while time.perf_counter() - start < 0.5:
            if compiled:
                cast_scan(origins, angles, world.lidar_segments, world.circles, people, step,
                          12.0)
            else:
                cast_rays(origins, angles, world.lidar_segments, world.circles, 12.0)
            n += 360
        rates.append(n / (time.perf_counter() - start))
    return statistics.median(rates)


def irsim_factor(seconds: float) -> str:
    """ir-sim on the same office walls, one robot with a 360-beam lidar at 10 Hz, if a Python
    with ir-sim is named by $IRSIM_PYTHON (or ir-sim imports here)."""
    python = os.environ.get("IRSIM_PYTHON", "")
    if not python:
        try:
            import irsim  # noqa: F401

            python = sys.executable
        except ImportError:
            return "not measured (set IRSIM_PYTHON to a Python with ir-sim installed)"
    world = load_world("office")
    script = Path(__file__).resolve().parents[1] / "benchmarks" / "irsim_office.py"
    payload = json.dumps({"segments": world.lidar_segments.tolist(), "seconds": seconds})
    try:
        out = subprocess.run([python, str(script)], input=payload, capture_output=True,
                             text=True, timeout=600, check=True)
    except (OSError, subprocess.SubprocessError) as exc:
        return f"failed ({exc})"
    return out.stdout.strip().splitlines()[-1]


def main(quick: bool = False) -> int:
    seconds, repeats = (3.0, 1) if quick else (10.0, 3)
    print(f"real-time factors (median of {repeats} x {seconds:g} s simulated, one core)")
    print(f"{'robot':8s} {'world':8s} {'sensors':>8s} {'lidar off':>10s}")
    for robot in ("uiabot", "igv", "eddie"):
        for world in ("office", "aisle", "pillars", "square"):
            on = real_time_factor(lambda r=robot, w=world: Simulation(w, r, seed=1), seconds,
                                  repeats)
            off = real_time_factor(lambda r=robot, w=world: Simulation(w, r, seed=1,
                                                                       sensors=False),
                                   seconds, repeats)
            print(f"{robot:8s} {world:8s} {on:7.0f}x {off:9.0f}x")
    headline = real_time_factor(
        lambda: Simulation("office", "uiabot", seed=1, people=5, lidar_rate=10.0,
                           lidar_beams=360), seconds, repeats)
    print(f"Uiabot, 360-beam lidar at 10 Hz, IMU, encoders, office, 5 people: {headline:.0f}x")
    grid = [[1.0 + 2.0 * (i % 5), 1.0 + 2.5 * (i // 5), 0.0] for i in range(20)]
    crowd = real_time_factor(
        lambda: Simulation("square", ["uiabot"] * 20, seed=1, people=20, start=grid,
                           lidar_rate=10.0, lidar_beams=360), min(seconds, 3.0), 1)
    print(f"20 Uiabots with 360-beam lidars at 10 Hz among 20 people: {crowd:.1f}x")
    print(f"raycaster, numpy reference (office walls): "
          f"{raycaster_rate(repeats, False) / 1e3:.0f} k beams/s")
    print(f"raycaster, compiled scan caster (office walls + 5 people): "
          f"{raycaster_rate(repeats, True) / 1e3:.0f} k beams/s")
    print(f"ir-sim, same office walls, 360-beam lidar at 10 Hz: {irsim_factor(seconds)}")
    return 0


if __name__ == "__main__":
    sys.exit(main("--quick" in sys.argv))
