"""``kit plan``: solve the problems of a Moving AI scenario file, one CSV row each.

    kit plan maps/dao/arena.map --scen scenarios/dao/arena.map.scen --out results

writes ``results/plan.csv`` (an ``--out`` ending in ``.csv`` is taken as the file itself).
The CSV has the header ``index,length,optimal,expanded,seconds``: the scenario's position in
the file, the length found (octile moves, in cells; ``inf`` when unreachable), the published
optimum, the cells expanded and the query's wall time. The summary line counts the problems
solved at the optimum within the file's printed precision; with ``--corner-cutting`` many come
out shorter, because the benchmark's optimum forbids diagonal moves past blocked corners.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
import time
from typing import Any

from kit.planning._gridsearch import GridSearch
from kit.planning._movingai import read_grid_map, read_scenarios

__all__ = ["register"]


def _plan(args: argparse.Namespace) -> int:
    grid = read_grid_map(args.map)
    scenarios = read_scenarios(args.scen)
    for s in scenarios:
        if (s.map_width, s.map_height) != (grid.width, grid.height):
            raise ValueError(f"{args.scen}: scenario {s.index} is for a {s.map_width} x "
                             f"{s.map_height} map; {args.map} is {grid.width} x {grid.height}")
    search = GridSearch(grid.costs(), connectivity=8, corner_cutting=args.corner_cutting,
                        cost_travel_multiplier=0.0)
    run = {"astar": search.astar, "dijkstra": search.dijkstra,
           "theta_star": search.theta_star}[args.algorithm]
    from tqdm import tqdm

    from kit.clitext import output_file

    out = output_file(args.out, "plan.csv")
    rows: list[tuple[int, float, float, int, float]] = []
    for s in tqdm(scenarios, desc="plan", unit="problem", disable=args.quiet,
                  file=sys.stderr):
        begin = time.perf_counter()
        result = run(s.start, s.goal)
        rows.append((s.index, result.length, s.optimal_length, result.expanded,
                     time.perf_counter() - begin))
    try:
        with open(out, "w", newline="", encoding="utf-8") as fh:
            writer = csv.writer(fh)
            writer.writerow(["index", "length", "optimal", "expanded", "seconds"])
            for index, length, optimal, expanded, seconds in rows:
                writer.writerow([index, f"{length:.10g}", f"{optimal:.10g}", expanded,
                                 f"{seconds:.6f}"])
    except OSError as exc:
        raise ValueError(f"cannot write {out}: {exc.strerror}") from None
    optimal = sum(abs(r[1] - s.optimal_length) <= s.tolerance
                  for r, s in zip(rows, scenarios, strict=True))
    shorter = sum(r[1] < s.optimal_length - s.tolerance for r, s in zip(rows, scenarios,
                                                                       strict=True))
    unreached = sum(r[1] == float("inf") for r in rows)
    median = statistics.median(r[4] for r in rows) if rows else 0.0
    print(f"{grid.name}: {len(rows)} scenarios with {args.algorithm}"
          f"{' (corner cutting)' if args.corner_cutting else ''}: {optimal} at the published "
          f"optimum, {shorter} shorter, {len(rows) - optimal - shorter - unreached} longer, "
          f"{unreached} unreachable; median query {median * 1e3:.2f} ms -> {out}")
    return 0


def register(subparsers: Any) -> None:
    """Add ``kit plan`` to the ``kit`` command's subparsers."""
    p = subparsers.add_parser(
        "plan", help="solve a Moving AI scenario file (one CSV row per problem)",
        description="Plan every problem of a Moving AI .scen file on its .map and write "
                    "index,length,optimal,expanded,seconds per problem.")
    p.add_argument("map", help="the Moving AI .map file")
    p.add_argument("--scen", required=True, help="its .map.scen scenario file")
    p.add_argument("--out", required=True,
                   help="output folder: plan.csv (a name ending in .csv: that file)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--corner-cutting", action="store_true",
                   help="allow diagonal moves past blocked corners (the benchmark forbids them; "
                        "A* and Dijkstra only)")
    p.add_argument("--algorithm", choices=("astar", "dijkstra", "theta_star"), default="astar",
                   help="the search (default: astar)")
    p.set_defaults(func=_plan)
