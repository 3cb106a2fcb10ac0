"""Speed of kit.planning, side by side with a plain heapq A* in the same run.
Run: python benchmarks/bench_planning.py

Prints, for each measurement, the best, the median and the worst of its repeats (wall
clock) and the machine's load average, since the 2-core machine is shared. The Moving AI and
map_server figures need ../shared/data beside the checkout; without it they are skipped.

Targets (issue 14): brc202d median query <= 0.05 s; 1000 x 1000 grid with 20 % random
obstacles, corner to corner <= 0.2 s; building the planner's grid from the largest map
<= 1 s; inflating a 4000 x 4000 costmap <= 1 s.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np

from kit import maps
from kit.planning import (
    GridSearch,
    astar_reference,
    costmap_from_map,
    footprint_radii,
    inflate,
    inflate_reference,
    pad_footprint,
    read_grid_map,
    read_scenarios,
    robot_footprint,
    static_layer,
)
from kit.planning._layered import DEFAULT_PADDING

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def spread(times: list[float], cpu: list[float] | None = None) -> str:
    text = (f"best {min(times):7.4f} s  median {statistics.median(times):7.4f} s  "
            f"worst {max(times):7.4f} s  ({len(times)} runs)")
    return text + (f"; CPU best {min(cpu):.4f} s" if cpu else "")


class Timed:
    """Wall-clock and CPU times of ``repeats`` calls of ``fn``."""

    def __init__(self, fn: Callable[[], object], repeats: int) -> None:
        self.wall: list[float] = []
        self.cpu: list[float] = []
        for _ in range(repeats):
            start, cpu = time.perf_counter(), time.process_time()
            fn()
            self.wall.append(time.perf_counter() - start)
            self.cpu.append(time.process_time() - cpu)

    def __str__(self) -> str:
        return spread(self.wall, self.cpu)


def timed(fn: Callable[[], object], repeats: int) -> list[float]:
    return Timed(fn, repeats).wall


def load() -> str:
    one, five, _ = os.getloadavg()
    return f"load average {one:.2f} (1 min), {five:.2f} (5 min) on {os.cpu_count()} cores"


def first_call() -> None:
    code = ("import time; t = time.perf_counter(); import numpy as np; import kit.planning as p; "
            "t1 = time.perf_counter(); p.astar(np.zeros((8, 8), np.uint8), (0, 0), (7, 7)); "
            "t2 = time.perf_counter(); p.theta_star(np.zeros((8, 8), np.uint8), (0, 0), (7, 7)); "
            "t3 = time.perf_counter(); p.inflate(np.zeros((8, 8), np.uint8), 0.05, "
            "inscribed_radius=0.1); t4 = time.perf_counter(); "
            "print(f'{t1 - t:.2f} {t2 - t1:.2f} {t3 - t2:.2f} {t4 - t3:.2f}')")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    print(f"fresh process: import kit.planning {out[0]} s, first A* {out[1]} s, first Theta* "
          f"{out[2]} s, first inflation {out[3]} s (numba's cache loaded)")


def random_grid() -> None:
    rng = np.random.default_rng(0)
    costs = np.where(rng.random((1000, 1000)) < 0.2, 254, 0).astype(np.uint8)
    costs[0, 0] = costs[-1, -1] = 0
    search = GridSearch(costs, cost_travel_multiplier=0.0)
    result = search.astar((0, 0), (999, 999))
    print(f"1000 x 1000, 20 % obstacles, corner to corner: length {result.length:.3f}, "
          f"{result.expanded} cells expanded")
    print(f"  A* compiled          {Timed(lambda: search.astar((0, 0), (999, 999)), 7)}")
    print(f"  Theta* compiled      {Timed(lambda: search.theta_star((0, 0), (999, 999)), 3)}")
    reference = Timed(lambda: astar_reference(costs, (0, 0), (999, 999),
                                              cost_travel_multiplier=0.0), 1)
    print(f"  A* heapq reference   {reference}")


def brc202d() -> None:
    folder = DATA / "movingai-grid"
    grid = read_grid_map(folder / "maps/dao/brc202d.map")
    scenarios = read_scenarios(folder / "scenarios/dao/brc202d.map.scen")
    search = GridSearch(grid.costs(), cost_travel_multiplier=0.0)
    medians, cpu = [], []
    for _ in range(3):
        times, cpu_times = [], []
        for s in scenarios:
            start, start_cpu = time.perf_counter(), time.process_time()
            search.astar(s.start, s.goal)
            times.append(time.perf_counter() - start)
            cpu_times.append(time.process_time() - start_cpu)
        medians.append(statistics.median(times))
        cpu.append(statistics.median(cpu_times))
    print(f"brc202d (530 x 481), all {len(scenarios)} scenarios, median query per pass:")
    print(f"  A* compiled          {spread(medians, cpu)}; slowest query {max(times):.4f} s")
    sample = scenarios[::25]
    costs = grid.costs()
    ref = [Timed(partial(astar_reference, costs, s.start, s.goal, cost_travel_multiplier=0.0), 1)
           for s in sample]
    fast = [Timed(partial(search.astar, s.start, s.goal), 1) for s in sample]
    ref_wall = statistics.median(t.wall[0] for t in ref)
    ref_cpu = statistics.median(t.cpu[0] for t in ref)
    fast_wall = statistics.median(t.wall[0] for t in fast)
    fast_cpu = statistics.median(t.cpu[0] for t in fast)
    print(f"  every 25th scenario ({len(sample)}), medians: A* heapq reference {ref_wall:.4f} s "
          f"(CPU {ref_cpu:.4f} s), compiled {fast_wall:.5f} s (CPU {fast_cpu:.5f} s): "
          f"{ref_cpu / fast_cpu:.0f}x in CPU time")


def build_grids() -> None:
    olin = DATA / "maps/olin-mac-first-floor-real/mac_1st_floor_final.yaml"
    footprint = robot_footprint("uiabot")

    def from_map() -> None:
        costmap = costmap_from_map(maps.read_map(olin), footprint=footprint)
        GridSearch(costmap.costs)

    info = maps.read_map(olin).info
    print(f"planner's grid from the largest map_server map (Olin, {info.width} x {info.height}"
          f"): read, static layer, inflation, search grid")
    print(f"  {Timed(from_map, 5)}")
    maze = DATA / "movingai-grid/maps/mazes/maze512-1-0.map"
    print("planner's grid from the largest Moving AI map (512 x 512): read, search grid")
    print(f"  {Timed(lambda: GridSearch(read_grid_map(maze).costs()), 5)}")


def inflation() -> None:
    olin = maps.read_map(DATA / "maps/olin-mac-first-floor-real/mac_1st_floor_final.yaml")
    tile = static_layer(olin)
    costs = np.tile(tile, (4000 // tile.shape[0] + 1, 4000 // tile.shape[1] + 1))[:4000, :4000]
    inscribed, _ = footprint_radii(pad_footprint(robot_footprint("uiabot"), DEFAULT_PADDING))
    res = 0.05

    def run(c: np.ndarray, fn: Callable[..., np.ndarray] = inflate) -> None:
        fn(c, res, inscribed_radius=inscribed, inflation_radius=0.55, cost_scaling_factor=10.0)

    print(f"inflation of a 4000 x 4000 costmap (the Olin map tiled, {int((costs == 254).sum())} "
          f"lethal cells; Uiabot footprint, radius 0.55 m at 0.05 m = 11 cells)")
    print(f"  compiled             {Timed(lambda: run(costs), 5)}")
    crop = np.ascontiguousarray(costs[:1000, :1000])
    fast = timed(lambda: run(crop), 5)
    ref = timed(lambda: run(crop, inflate_reference), 3)
    print(f"  1000 x 1000 crop: compiled {min(fast):.4f} s, plain reference {min(ref):.4f} s "
          f"(best of 5 and 3)")


def main() -> None:
    print(load())
    first_call()
    random_grid()
    if DATA.is_dir():
        brc202d()
        build_grids()
        inflation()
    else:
        print(f"{DATA} is absent: Moving AI, map-building and inflation figures skipped")
    print(load())


if __name__ == "__main__":
    main()
