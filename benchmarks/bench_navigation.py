"""Navigation (issue 15): the loop's speed, and the scenario tables.

    .venv/bin/python benchmarks/bench_navigation.py              # real-time factors
    .venv/bin/python benchmarks/bench_navigation.py --tables 20  # + 20 episodes per scenario

Real-time factor: one office tour (five goals, five people) with the whole loop — the
simulator (physics, lidar, encoders), wheel odometry, costmaps fed by every scan, the planner
at 1 Hz, the controller at 20 Hz, the metrics — on one core, simulated seconds per wall second,
best of ``--repeat``; with the truth as localization and with AMCL (2,000 particles).

Tables: ``python -m sim navigate``'s scenarios, each over seeded episodes, summarised as the
issue asks (goals reached, episodes without touching a person, contacts with walls, median
time over shortest path at cruise speed); the CSVs go to ``out/navigation/``.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from kit.robots import load
from sim import scenarios

TABLES = (("office", "uiabot", "truth", "tour"), ("aisle", "uiabot", "truth", "tour"),
          ("office", "uiabot", "amcl", "tour"), ("aisle", "igv", "truth", "waypoints"))


def real_time_factor(localization: str, repeat: int) -> tuple[float, float, float]:
    """Best and median simulated/wall ratio over ``repeat`` tours (after one to warm the
    caches up), and the best one's simulated seconds."""
    s = scenarios.setup("office", "uiabot", "tour")
    scenarios.episode(s, 0, 0, localization)     # imports, compiled kernels, first maps
    factors: list[tuple[float, float]] = []
    for seed in range(repeat):
        start = time.perf_counter()
        rows = scenarios.episode(s, 0, seed, localization)
        wall = time.perf_counter() - start
        sim_seconds = sum(r.seconds for r in rows)
        factors.append((sim_seconds / wall, sim_seconds))
    best, simulated = max(factors)
    return best, statistics.median(f for f, _ in factors), simulated


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--tables", type=int, default=0, help="episodes per scenario (0: none)")
    args = parser.parse_args()
    for loc in ("truth", "amcl"):
        factor, median, simulated = real_time_factor(loc, args.repeat)
        print(f"office tour, 5 people, localization {loc}: {factor:.1f}x real time "
              f"({simulated:.0f} s simulated; best of {args.repeat}, median {median:.1f}x)")
    if not args.tables:
        return
    out = Path("out/navigation")
    for world, robot, loc, route in TABLES:
        start = time.perf_counter()
        rows = scenarios.navigate(world, robot, args.tables, 0, loc, route=route, bar=False)
        scenarios.write_table(rows, out / f"{world}_{robot}_{loc}.csv")
        f = scenarios.summary(rows, load(robot).cruise_velocity)
        print(f"{world:6s} {robot:6s} {loc:5s}: {f['reached']:.0%} of {f['goals']} goals "
              f"reached, {f['episodes_without_person_collision']:.0%} of {f['episodes']} "
              f"episodes without touching a person, {f['collisions_static']:.0f} contacts "
              f"with walls, median time/shortest {f['median_time_ratio']:.2f} "
              f"({time.perf_counter() - start:.0f} s wall)")


if __name__ == "__main__":
    main()
