"""``python -m sim demo [--out DIR] [--seed N] [--quiet]``, ``python -m sim bench [--quick]`` and
``python -m sim navigate --world office|aisle --robot uiabot|igv --episodes N --seed S
[--localization truth|amcl|slam] [--controller dwb|rpp] [--route tour|glass]
[--keepout|--no-keepout] --out FILE.csv``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim", description="The kit's simulator.")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="the whole loop: the Uiabot maps the office with SLAM, "
                          "then navigates it with AMCL among people; PNG, HTML, MCAP bag")
    demo.add_argument("--out", default="out", help="folder for the PNG (out)")
    demo.add_argument("--seed", type=int, default=7)
    demo.add_argument("--quiet", action="store_true", help="no progress bars")
    bench = sub.add_parser("bench", help="real-time factors and raycaster throughput")
    bench.add_argument("--quick", action="store_true", help="one short run per figure")
    nav = sub.add_parser("navigate", help="seeded navigation episodes; one CSV row per goal")
    nav.add_argument("--world", choices=("office", "aisle"), default="office")
    nav.add_argument("--robot", choices=("uiabot", "igv", "eddie"), default="uiabot")
    nav.add_argument("--episodes", type=int, default=20)
    nav.add_argument("--seed", type=int, default=0, help="episode i runs with seed S + i")
    nav.add_argument("--localization", choices=("truth", "amcl", "slam"), default="truth")
    nav.add_argument("--controller", choices=("rpp", "dwb"), default="rpp")
    nav.add_argument("--route", choices=("tour", "glass", "waypoints"), default=None,
                     help="default: tour, but the IGV's in the aisle is waypoints (it cannot "
                     "turn round in 1.5 m)")
    nav.add_argument("--people", type=int, default=None,
                     help="how many people walk (default: the route's)")
    nav.add_argument("--keepout", action=argparse.BooleanOptionalAction, default=None,
                     help="the glass as a keep-out mask (default: on, but for the glass route)")
    nav.add_argument("--out", required=True, help="CSV file to write")
    args = parser.parse_args(argv)
    if args.command == "navigate":
        return _navigate(args)
    if args.command == "bench":
        from sim import bench as bench_module

        return bench_module.main(args.quick)
    from sim import navdemo

    return navdemo.main(Path(args.out), args.seed, args.quiet)


def _navigate(args: argparse.Namespace) -> int:
    from sim import scenarios

    if args.episodes < 1:
        print("python -m sim navigate: --episodes must be at least 1", file=sys.stderr)
        return 2
    try:
        rows = scenarios.navigate(args.world, args.robot, args.episodes, args.seed,
                                  args.localization, args.controller, args.route, args.keepout,
                                  people=args.people)
    except ValueError as e:
        print(f"python -m sim navigate: {e}", file=sys.stderr)
        return 2
    out = scenarios.write_table(rows, args.out)
    from kit.robots import load

    figures = scenarios.summary(rows, load(args.robot).cruise_velocity)
    route = args.route or scenarios.default_route(args.world, args.robot)
    print(f"{args.world}/{route}, {args.robot}, {args.localization}, {args.controller}: "
          f"{figures['reached']:.0%} of {figures['goals']} goals reached; "
          f"{figures['episodes_without_person_collision']:.0%} of {figures['episodes']} "
          f"episodes without touching a person; {figures['collisions_static']:.0f} contacts "
          f"with walls or obstacles; median time / (shortest / cruise) "
          f"{figures['median_time_ratio']:.2f}")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
