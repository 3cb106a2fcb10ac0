"""The simulator beside ir-sim, alternately in one process: real-time factors and their ratio.

The kit: the heavy Uiabot configuration — a 360-beam lidar at 10 Hz, the IMU at 100 Hz,
encoders and joint states at 50 Hz, physics at 100 Hz with two sub-steps — in the office
among five walking people, driving a slow circle. ir-sim (``pip install ir-sim``, a dev
extra): one differential robot with a 360-beam lidar, stepped at 10 Hz (its lidar's rate)
among the same office walls, no people (people would only slow it). Each round runs the kit,
then ir-sim (the order swapped every other round), for the same simulated time; the ratio of
each round's real-time factors is reported, with their median, in wall time and in CPU time
(``time.process_time``: what the process itself spent, less sensitive to other load).

Then 20 Uiabots with 360-beam lidars at 10 Hz among 20 people in the square world (the
simulator issue's crowd), the kit alone.

``--against DIR`` (ir-sim not needed): this checkout's simulator against another checkout's
(``DIR`` holds its ``kit/`` and ``sim/``, e.g. ``git worktree add DIR main``), the crowd and
the heavy configuration, each round one fresh process per checkout in turn (the order swapped
every other round), CPU time; the real-time factors per round and the ratios' medians.

``python benchmarks/bench_sim_vs_irsim.py [--seconds 10] [--rounds 7] [--no-crowd]``
``python benchmarks/bench_sim_vs_irsim.py --against DIR [--rounds 7]``
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from kit import msgs
from sim.simulation import Simulation
from sim.world import load_world

CRUISE = msgs.Twist(msgs.Vector3(0.3, 0.0, 0.0), msgs.Vector3(0.0, 0.0, 0.2))


def heavy() -> Simulation:
    return Simulation("office", "uiabot", seed=1, people=5, lidar_rate=10.0, lidar_beams=360)


def crowd() -> Simulation:
    grid = [[1.0 + 2.0 * (i % 5), 1.0 + 2.5 * (i // 5), 0.0] for i in range(20)]
    return Simulation("square", ["uiabot"] * 20, seed=1, people=20, start=grid,
                      lidar_rate=10.0, lidar_beams=360)


def run_kit(make: Callable[[], Simulation], seconds: float) -> tuple[float, float]:
    """(wall, CPU) seconds to simulate ``seconds`` after a first step with the command."""
    sim = make()
    sim.step({i: CRUISE for i in range(len(sim.robots))})
    steps = round(seconds / sim.physics.dt)
    step = sim.step
    wall, cpu = time.perf_counter(), time.process_time()
    for _ in range(steps):
        step()
    return time.perf_counter() - wall, time.process_time() - cpu


def irsim_world(directory: Path) -> Path:
    """The office's lidar-visible walls as an ir-sim world file (one robot, 360 beams)."""
    lines = ["world:", "  height: 12", "  width: 20", "  step_time: 0.1", "  sample_time: 0.1",
             "  offset: [0, 0]", "  collision_mode: 'unobstructed'", "robot:",
             "  - kinematics: {name: 'diff'}", "    shape: {name: 'circle', radius: 0.2}",
             "    state: [1, 6, 0]", "    goal: [18, 6, 0]", "    behavior: {name: 'dash'}",
             "    sensors:", "      - type: 'lidar2d'", "        range_min: 0",
             "        range_max: 12", "        angle_range: 6.283185",
             "        number: 360", "obstacle:"]
    for x1, y1, x2, y2 in load_world("office").lidar_segments.tolist():
        lines += [f"  - shape: {{name: 'linestring', vertices: [[{x1}, {y1}], [{x2}, {y2}]]}}",
                  "    kinematics: {name: 'static'}", "    state: [0, 0, 0]"]
    path = directory / "office.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


def run_irsim(world: Path, seconds: float) -> tuple[float, float]:
    import irsim

    with contextlib.redirect_stdout(io.StringIO()):
        env = irsim.make(str(world), headless=True)
    env.step()
    steps = round(seconds / 0.1)
    wall, cpu = time.perf_counter(), time.process_time()
    for _ in range(steps):
        env.step()
    return time.perf_counter() - wall, time.process_time() - cpu


def run_in(root: Path | None, which: str, seconds: float) -> float:
    """The real-time factor in CPU time of ``which`` (``"crowd"`` or ``"heavy"``) over
    ``seconds`` simulated, in a fresh process on the checkout at ``root`` (None: this one),
    after a warm-up run (numba's caches loaded)."""
    code = (f"import runpy; m = runpy.run_path({str(Path(__file__).resolve())!r}); "
            f"m['run_kit'](m[{which!r}], 0.3); "
            f"print({seconds!r} / m['run_kit'](m[{which!r}], {seconds!r})[1])")
    env = dict(os.environ)
    if root is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(root), env.get("PYTHONPATH", "")])
    with tempfile.TemporaryDirectory() as cwd:   # not this checkout's folder first on the path
        done = subprocess.run([sys.executable, "-c", code], env=env, cwd=cwd,
                              capture_output=True, text=True)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise RuntimeError(f"the {which} run on {root or 'this checkout'} failed: {last}")
    return float(done.stdout.split()[-1])


def against(old: Path, rounds: int) -> int:
    """This checkout against the one at ``old``, alternately: the crowd (3 s simulated) and
    the heavy configuration (10 s simulated)."""
    if not (old / "sim" / "simulation.py").is_file():
        print(f"{old} holds no checkout of the kit (no sim/simulation.py)", file=sys.stderr)
        return 2
    print(f"load average at start: {os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} cores")
    print(f"{rounds} rounds, CPU time, one fresh process per run; old: {old}")
    print(f"{'round':>5s} {'crowd old':>10s} {'new':>7s} {'ratio':>6s}   "
          f"{'heavy old':>10s} {'new':>7s} {'ratio':>6s}")
    ratios: dict[str, list[float]] = {"crowd": [], "heavy": []}
    factors: dict[str, list[float]] = {"crowd": [], "heavy": []}
    for i in range(rounds):
        row = []
        for which, seconds in (("crowd", 3.0), ("heavy", 10.0)):
            order: list[Path | None] = [old, None] if i % 2 == 0 else [None, old]
            got = {str(root): run_in(root, which, seconds) for root in order}
            new_factor, old_factor = got["None"], got[str(old)]
            ratios[which].append(new_factor / old_factor)
            factors[which].append(new_factor)
            row.append(f"{old_factor:9.1f}x {new_factor:6.1f}x {new_factor / old_factor:5.2f}x")
        print(f"{i + 1:5d} " + "   ".join(row))
    for which in ("crowd", "heavy"):
        print(f"{which}: new {statistics.median(factors[which]):.1f}x real time in CPU time "
              f"(median; {min(factors[which]):.1f}-{max(factors[which]):.1f}), new / old "
              f"{statistics.median(ratios[which]):.2f}x (median; "
              f"{min(ratios[which]):.2f}-{max(ratios[which]):.2f})")
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated per run")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--no-crowd", action="store_true")
    parser.add_argument("--against", type=Path, metavar="DIR",
                        help="another checkout's simulator to run alternately with this one")
    args = parser.parse_args(argv)
    if args.rounds < 1:
        print(f"--rounds must be at least 1; got {args.rounds}", file=sys.stderr)
        return 2
    if args.against is not None:
        try:
            return against(args.against, args.rounds)
        except RuntimeError as e:
            print(e, file=sys.stderr)
            return 1
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            import irsim
    except ImportError:
        print("ir-sim is not installed: pip install ir-sim (the kit's dev extra has it)",
              file=sys.stderr)
        return 2
    print(f"load average at start: {os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory() as tmp:
        world = irsim_world(Path(tmp))
        run_kit(heavy, 1.0)                        # compile / load caches, warm both
        run_irsim(world, 1.0)
        s = args.seconds
        print(f"{args.rounds} rounds of {s:g} s simulated each, alternately "
              f"(kit: heavy Uiabot, office, 5 people; ir-sim {irsim.__version__}: one robot, "
              f"360 beams at 10 Hz, office walls)")
        print(f"{'round':>5s} {'kit wall':>9s} {'ir-sim':>8s} {'ratio':>6s}   "
              f"{'kit CPU':>8s} {'ir-sim':>8s} {'ratio':>6s}")
        ratios, cpu_ratios, kits, irsims = [], [], [], []
        for i in range(args.rounds):
            if i % 2 == 0:
                kit_t = run_kit(heavy, s)
                ir_t = run_irsim(world, s)
            else:
                ir_t = run_irsim(world, s)
                kit_t = run_kit(heavy, s)
            kits.append(s / kit_t[0])
            irsims.append(s / ir_t[0])
            ratios.append(ir_t[0] / kit_t[0])
            cpu_ratios.append(ir_t[1] / kit_t[1])
            print(f"{i + 1:5d} {s / kit_t[0]:8.0f}x {s / ir_t[0]:7.1f}x {ratios[-1]:5.2f}x   "
                  f"{s / kit_t[1]:7.0f}x {s / ir_t[1]:7.1f}x {cpu_ratios[-1]:5.2f}x")
    print(f"median: kit {statistics.median(kits):.0f}x real time, ir-sim "
          f"{statistics.median(irsims):.1f}x; kit / ir-sim {statistics.median(ratios):.2f}x "
          f"(wall), {statistics.median(cpu_ratios):.2f}x (CPU); "
          f"range {min(ratios):.2f}-{max(ratios):.2f}x")
    if not args.no_crowd:
        seconds = min(s, 3.0)
        runs = [run_kit(crowd, seconds) for _ in range(3)]
        walls = [seconds / wall for wall, _ in runs]
        cpus = [seconds / cpu for _, cpu in runs]
        print(f"20 Uiabots with 360-beam lidars at 10 Hz among 20 people (square world): "
              f"median {statistics.median(walls):.1f}x real time in wall time "
              f"({', '.join(f'{f:.1f}' for f in walls)}), "
              f"{statistics.median(cpus):.1f}x in CPU time")
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
