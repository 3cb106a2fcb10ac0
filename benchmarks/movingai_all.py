"""Every scenario of the eight Moving AI maps in ``../shared/data/movingai-grid`` (Sturtevant
2012): the kit's A* without corner cutting against each scenario's published optimal length,
with the time it took.

The tests (``tests/kit/planning/test_movingai_benchmark.py``) solve every scenario of seven
maps and a sample of the maze's 11,960 (every 40th: each of its length buckets); this solves
them all, the maze's included, and exits 1 if any length is off.

``python benchmarks/movingai_all.py [--data ../shared/data] [--maps mazes/maze512-1-0 ...]``
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from kit.planning import GridSearch, read_grid_map, read_scenarios

MAPS = ["cities/Berlin_0_256", "dao/arena", "dao/brc202d", "dao/den312d", "dao/lak303d",
        "mazes/maze512-1-0", "random/random512-10-0", "rooms/8room_000"]


def solve_all(folder: Path, name: str) -> tuple[int, list[tuple[int, float, float]], float]:
    """(scenarios, the ones off their optimum as (index, length, optimum), CPU seconds)."""
    grid = read_grid_map(folder / "maps" / f"{name}.map")
    scenarios = read_scenarios(folder / "scenarios" / f"{name}.map.scen")
    search = GridSearch(grid.costs(), cost_travel_multiplier=0.0)
    search.astar(scenarios[0].start, scenarios[0].goal)        # compiled before timing
    off = []
    start = time.process_time()
    for s in scenarios:
        length = search.astar(s.start, s.goal).length
        if not abs(length - s.optimal_length) <= s.tolerance:
            off.append((s.index, length, s.optimal_length))
    return len(scenarios), off, time.process_time() - start


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = Path(__file__).resolve().parents[2] / "shared" / "data"
    parser.add_argument("--data", type=Path, default=default, help="the shared data folder")
    parser.add_argument("--maps", nargs="*", default=MAPS, choices=MAPS, metavar="MAP")
    args = parser.parse_args(argv)
    folder = args.data / "movingai-grid"
    if not folder.is_dir():
        print(f"movingai_all: no {folder}", file=sys.stderr)
        return 2
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; one core")
    print(f"{'map':24s} {'scenarios':>9s} {'at optimum':>10s} {'CPU s':>7s} {'per s':>7s}")
    failed = 0
    for name in args.maps:
        count, off, cpu = solve_all(folder, name)
        failed += len(off)
        print(f"{name:24s} {count:9d} {count - len(off):10d} {cpu:7.1f} {count / cpu:7.0f}")
        for index, length, optimum in off[:5]:
            print(f"    scenario {index}: {length:.6f} against the published {optimum:.6f}")
    print("every scenario at its published optimum" if not failed else
          f"{failed} scenarios off their published optimum")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
