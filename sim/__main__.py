"""The simulator's command, as ``python -m sim …`` or ``kit sim …``:

``demo [--out DIR] [--seed N] [--params FILE] [--live [HOST:PORT]] [--speed X] [--quiet]``,
``bench [--quick]`` and ``navigate --world office|aisle --robot uiabot|igv|eddie|FILE
--episodes N --seed S [--localization truth|amcl|slam] [--controller dwb|rpp] [--route
tour|glass] [--keepout|--no-keepout] [--params nav2_params.yaml [--namespace NS]] [--bag]
[--live [HOST:PORT]] [--speed X] [--quiet] --out DIR``. ``--robot`` also takes a robot's own
description: a ``.urdf``, ``.urdf.xacro`` (with ``--xacro-arg NAME:=VALUE`` and
``--package-path PKG=DIR``), a kit ``.toml`` or a bag that recorded ``/robot_description``;
``--robot-params FILE`` gives what its URDF does not hold (see :func:`kit.robots.load`).
``--params`` runs the navigation from a Nav2 parameter file (what became of each of its keys
is printed first). ``--live`` serves the robot's topics to Foxglove (:mod:`kit.liveview`)
while it runs, at ``--speed`` times real time."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from kit.liveview import LiveView
    from kit.robots import RobotDescription

__all__ = ["main", "register"]


def _live_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--live", nargs="?", const="127.0.0.1:8765", default=None,
                   metavar="HOST:PORT",
                   help="serve the robot's topics to Foxglove Studio while it runs "
                        "(Foxglove WebSocket, default ws://127.0.0.1:8765)")
    p.add_argument("--speed", type=float, default=None,
                   help="with --live: simulated seconds per real second (default 1)")


def _add_commands(sub: Any) -> None:
    """``demo``, ``bench`` and ``navigate`` on ``sub`` (an argparse subparsers object)."""
    demo = sub.add_parser("demo", help="the whole loop: the Uiabot maps the office with SLAM, "
                          "then navigates it with AMCL among people; PNG, HTML, MCAP bags",
                          description="Writes into --out: demo_office/ (the mapping drive's "
                          "bag), demo_map.yaml + .pgm (the SLAM map), demo_loop.png, "
                          "demo_loop.html (an animation that plays offline) and demo_loop/ "
                          "(the navigation's MCAP bag).")
    demo.add_argument("--out", default="out", help="output folder (default out)")
    demo.add_argument("--seed", type=int, default=7)
    demo.add_argument("--params", default=None,
                      help="a Nav2 parameter file for the navigation (default: the kit's, "
                      "sim/params/uiabot_nav2_params.yaml)")
    _live_options(demo)
    demo.add_argument("--quiet", action="store_true", help="no progress bars")
    demo.set_defaults(sim_func=_demo)
    bench = sub.add_parser("bench", help="real-time factors and raycaster throughput")
    bench.add_argument("--quick", action="store_true", help="one short run per figure")
    bench.set_defaults(sim_func=_bench)
    nav = sub.add_parser("navigate", help="seeded navigation episodes; one CSV row per goal",
                         description="Writes into --out: navigate.csv (one row per goal) and, "
                         "with --bag, episode_000/, episode_001/, ... (an MCAP ROS 2 bag per "
                         "episode).")
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
    nav.add_argument("--bag", action="store_true",
                     help="also write an MCAP ROS 2 bag per episode into --out")
    _live_options(nav)
    nav.add_argument("--quiet", action="store_true", help="no progress bar")
    nav.add_argument("--out", required=True,
                     help="output folder (navigate.csv, episode_NNN/); a name ending in .csv "
                          "is taken as the table's file, as before")
    nav.set_defaults(sim_func=_navigate)


def register(subparsers: Any) -> None:
    """Add ``sim`` to the ``kit`` command (found through the ``kit.commands`` entry point,
    so that ``kit`` itself never imports the simulator)."""
    p = subparsers.add_parser("sim", help="the simulator: demo, navigate, bench",
                              description=__doc__.split("\n\n")[0].replace("``", ""))
    _add_commands(p.add_subparsers(dest="sim_command", required=True))
    p.set_defaults(func=lambda args: args.sim_func(args))


def main(argv: Sequence[str] | None = None) -> int:
    from kit.clitext import negative_values

    parser = argparse.ArgumentParser(prog="python -m sim", description="The kit's simulator.")
    _add_commands(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(negative_values(sys.argv[1:] if argv is None else argv))
    try:
        return int(args.sim_func(args))
    except ValueError as e:
        print(f"python -m sim {args.command}: {e}", file=sys.stderr)
        return 2
    except OSError as e:                # a file the command could not read or write
        where = f"{e.filename}: " if e.filename else ""
        print(f"python -m sim {args.command}: {where}{e.strerror or e}", file=sys.stderr)
        return 2


def _bench(args: argparse.Namespace) -> int:
    from sim import bench as bench_module

    return bench_module.main(args.quick)


def _live(args: argparse.Namespace) -> tuple[LiveView | None, float | None]:
    """The live view ``--live`` asks for (and the pace), or ``(None, None)``."""
    if args.live is None:
        if args.speed is not None:
            raise ValueError("--speed paces the live view: give --live too")
        return None, None
    from kit.liveview import LiveView, parse_address

    speed = 1.0 if args.speed is None else args.speed
    if not speed > 0:
        raise ValueError(f"--speed is a positive factor of real time; got {speed}")
    host, port = parse_address(args.live)
    view = LiveView(host, port, name="kit simulator")
    print(f"live view: open {view.url} in Foxglove Studio (Open connection -> Foxglove "
          f"WebSocket); the simulation runs at {speed:g}x real time", flush=True)
    return view, speed


def _params(path: Any, robot: Any, controller: str | None = None,
            namespace: str | None = None) -> Any:
    """A Nav2 parameter file as the navigation's configuration; what became of each key is
    printed first (a file that cannot be used: ``ValueError``)."""
    from sim import scenarios

    config = scenarios.load_params(path, robot, controller, namespace)
    assert config.report is not None
    lines = config.report.lines()
    print(lines[0] if len(lines) == 1 else "\n".join(lines))
    return config


def _demo(args: argparse.Namespace) -> int:
    from kit.clitext import output_dir
    from sim import navdemo

    out = output_dir(args.out)
    config = _params(args.params if args.params is not None else navdemo.PARAMS, "uiabot")
    view, speed = _live(args)
    try:
        return navdemo.main(out, args.seed, config, live=view, speed=speed,
                            quiet=args.quiet)
    finally:
        if view is not None:
            view.close()


def _table_and_bags(out: str) -> tuple[Path, Path]:
    """``--out``: a folder (``navigate.csv`` in it) or, as before, the table's own file."""
    from kit.clitext import output_file

    table = output_file(out, "navigate.csv")
    return table, table.parent


def _navigate(args: argparse.Namespace) -> int:
    from sim import live, navtopics, scenarios

    if args.episodes < 1:
        raise ValueError("--episodes must be at least 1")
    robot = _robot(args)
    if args.namespace is not None and args.params is None:
        raise ValueError("--namespace needs --params")
    config = _params(args.params, robot, args.controller, args.namespace) \
        if args.params is not None else None
    controller = config.controller if config is not None else (args.controller or "rpp")
    table, folder = _table_and_bags(args.out)
    if args.bag:
        taken = sorted(p.name for p in folder.glob("episode_*")) if folder.is_dir() else []
        if taken:
            raise ValueError(f"{folder} already holds {', '.join(taken[:3])}: a bag is written "
                             f"to a new folder; choose another --out")
    view, speed = _live(args)
    outputs = None
    if args.bag or view is not None:
        from kit import description_files

        urdf = navtopics.robot_description_xml(
            robot, description_files.parse_xacro_args(args.xacro_arg),
            description_files.parse_package_paths(args.package_path))
        outputs = live.EpisodeOutputs(folder if args.bag else None, view, speed, urdf)
    try:
        rows = scenarios.navigate(args.world, robot, args.episodes, args.seed,
                                  args.localization, controller, args.route, args.keepout,
                                  bar=not args.quiet, people=args.people, config=config,
                                  observers=outputs)
    finally:
        if outputs is not None:
            outputs.close()
        if view is not None:
            view.close()
    out = scenarios.write_table(rows, table)
    figures = scenarios.summary(rows, robot.cruise_velocity)
    route = args.route or scenarios.default_route(args.world, robot)
    print(f"{args.world}/{route}, {robot.name}, {args.localization}, {controller}: "
          f"{figures['reached']:.0%} of {figures['goals']} goals reached; "
          f"{figures['episodes_without_person_collision']:.0%} of {figures['episodes']} "
          f"episodes without touching a person; {figures['collisions_static']:.0f} contacts "
          f"with walls or obstacles; median time / (shortest / cruise) "
          f"{figures['median_time_ratio']:.2f}")
    bags = f" and {len(outputs.bags)} bags ({folder}/episode_000/ ...)" \
        if outputs is not None and outputs.bags else ""
    print(f"wrote {out}{bags}")
    return 0


def _robot(args: argparse.Namespace) -> RobotDescription:
    """The ``--robot`` description, loaded once with its xacro arguments, package paths and
    parameter file."""
    from kit import robots

    return robots.load_from_options(args.robot, args.robot_params, args.xacro_arg,
                                    args.package_path,
                                    names=("--robot-params", "--xacro-arg", "--package-path"))


if __name__ == "__main__":
    sys.exit(main())
