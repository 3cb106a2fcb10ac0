"""``python -m sim demo [--out DIR] [--seed N] [--params FILE]``, ``python -m sim bench
[--quick]`` and ``python -m sim navigate --world office|aisle --robot uiabot|igv|eddie|FILE
--episodes N --seed S [--localization truth|amcl|slam] [--controller dwb|rpp] [--route
tour|glass] [--keepout|--no-keepout] [--params nav2_params.yaml [--namespace NS]] --out
FILE.csv``. ``--robot`` also takes a robot's own description: a ``.urdf``, ``.urdf.xacro``
(with ``--xacro-arg NAME:=VALUE`` and ``--package-path PKG=DIR``), a kit ``.toml`` or a bag
that recorded ``/robot_description``; ``--robot-params FILE`` gives what its URDF does not
hold (see :func:`kit.robots.load`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from kit.robots import RobotDescription


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim", description="The kit's simulator.")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="the whole loop: the Uiabot maps the office with SLAM, "
                          "then navigates it with AMCL among people; PNG, HTML, MCAP bag")
    demo.add_argument("--out", default="out", help="folder for the PNG (out)")
    demo.add_argument("--seed", type=int, default=7)
    demo.add_argument("--params", default=None,
                      help="a Nav2 parameter file for the navigation (default: the kit's, "
                      "sim/params/uiabot_nav2_params.yaml)")
    bench = sub.add_parser("bench", help="real-time factors and raycaster throughput")
    bench.add_argument("--quick", action="store_true", help="one short run per figure")
    nav = sub.add_parser("navigate", help="seeded navigation episodes; one CSV row per goal")
    nav.add_argument("--world", choices=("office", "aisle"), default="office")
    nav.add_argument("--robot", default="uiabot",
                     help="uiabot, igv, eddie, or a robot file: .urdf, .urdf.xacro, .xacro, "
                     ".toml, or a bag with /robot_description")
    nav.add_argument("--robot-params", default=None, metavar="FILE",
                     help="for a URDF, xacro file or bag: a TOML file of what the URDF does "
                     "not hold ([drive] limits, [sensors.lidar], [footprint] ...)")
    nav.add_argument("--xacro-arg", action="append", default=[], metavar="NAME:=VALUE",
                     help="a xacro argument of the robot file (repeatable)")
    nav.add_argument("--package-path", action="append", default=[], metavar="PKG=DIR",
                     help="where ROS package PKG is, for $(find PKG) and package:// without "
                     "ROS (repeatable)")
    nav.add_argument("--episodes", type=int, default=20)
    nav.add_argument("--seed", type=int, default=0, help="episode i runs with seed S + i")
    nav.add_argument("--localization", choices=("truth", "amcl", "slam"), default="truth")
    nav.add_argument("--controller", choices=("rpp", "dwb"), default=None,
                     help="default: the parameter file's FollowPath, else rpp")
    nav.add_argument("--route", choices=("tour", "glass", "waypoints"), default=None,
                     help="default: tour, but the IGV's in the aisle is waypoints (it cannot "
                     "turn round in 1.5 m)")
    nav.add_argument("--people", type=int, default=None,
                     help="how many people walk (default: the route's)")
    nav.add_argument("--keepout", action=argparse.BooleanOptionalAction, default=None,
                     help="the glass as a keep-out mask (default: on, but for the glass route)")
    nav.add_argument("--params", default=None, metavar="FILE",
                     help="a Nav2 parameter file (nav2_params.yaml, a vendor's): the "
                     "controller, planner, costmaps, checkers, recoveries and AMCL as it "
                     "says; what became of each key is printed first")
    nav.add_argument("--namespace", default=None,
                     help="the robot's namespace, when the parameter file has several")
    nav.add_argument("--out", required=True, help="CSV file to write")
    args = parser.parse_args(argv)
    if args.command == "navigate":
        return _navigate(args)
    if args.command == "bench":
        from sim import bench as bench_module

        return bench_module.main(args.quick)
    from sim import navdemo, scenarios

    path = args.params if args.params is not None else navdemo.PARAMS
    try:
        config = scenarios.load_params(path, "uiabot")
    except ValueError as e:
        print(f"python -m sim demo: {e}", file=sys.stderr)
        return 2
    assert config.report is not None
    lines = config.report.lines()
    print(lines[0] if len(lines) == 1 else "\n".join(lines))
    return navdemo.main(Path(args.out), args.seed, config)


def _navigate(args: argparse.Namespace) -> int:
    from sim import scenarios

    if args.episodes < 1:
        print("python -m sim navigate: --episodes must be at least 1", file=sys.stderr)
        return 2
    try:
        robot = _robot(args)
    except ValueError as e:
        print(f"python -m sim navigate: {e}", file=sys.stderr)
        return 2
    config = None
    if args.namespace is not None and args.params is None:
        print("python -m sim navigate: --namespace needs --params", file=sys.stderr)
        return 2
    if args.params is not None:
        try:
            config = scenarios.load_params(args.params, robot, args.controller,
                                           args.namespace)
        except ValueError as e:
            print(f"python -m sim navigate: {e}", file=sys.stderr)
            return 2
        assert config.report is not None
        print("\n".join(config.report.lines()))
    controller = config.controller if config is not None else (args.controller or "rpp")
    try:
        rows = scenarios.navigate(args.world, robot, args.episodes, args.seed,
                                  args.localization, controller, args.route, args.keepout,
                                  people=args.people, config=config)
    except ValueError as e:
        print(f"python -m sim navigate: {e}", file=sys.stderr)
        return 2
    out = scenarios.write_table(rows, args.out)
    figures = scenarios.summary(rows, robot.cruise_velocity)
    route = args.route or scenarios.default_route(args.world, robot)
    print(f"{args.world}/{route}, {robot.name}, {args.localization}, {controller}: "
          f"{figures['reached']:.0%} of {figures['goals']} goals reached; "
          f"{figures['episodes_without_person_collision']:.0%} of {figures['episodes']} "
          f"episodes without touching a person; {figures['collisions_static']:.0f} contacts "
          f"with walls or obstacles; median time / (shortest / cruise) "
          f"{figures['median_time_ratio']:.2f}")
    print(f"wrote {out}")
    return 0


def _robot(args: argparse.Namespace) -> RobotDescription:
    """The ``--robot`` description, loaded once with its xacro arguments, package paths and
    parameter file."""
    from kit import description_files, robots

    if args.robot in robots.ROBOTS and (args.robot_params or args.xacro_arg or
                                        args.package_path):
        raise ValueError(f"--robot-params, --xacro-arg and --package-path go with a robot "
                         f"file, not the shipped {args.robot}")
    return robots.load(args.robot, parameters=args.robot_params,
                       xacro_args=description_files.parse_xacro_args(args.xacro_arg),
                       package_paths=description_files.parse_package_paths(args.package_path))


if __name__ == "__main__":
    sys.exit(main())
