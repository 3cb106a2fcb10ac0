"""The ``kit`` command: look at the robots and try the kinematics from a shell.

    kit robots                      the robots and their key numbers
    kit robot uiabot                one robot's parameters and static transforms
    kit robot FILE                  any robot's URDF, xacro file or bag: what was found in it
                                    and what was assumed (--params, --xacro-arg, --package-path)
    kit wheels igv 1.0 0.0          wheel speeds (and the IGV's RPM and drive units) for v, ω
    kit sim demo|navigate|bench     the simulator (python -m sim ...), when it is installed

Subcommands of a topic (``kit slam``, ``kit plan``, ...) live beside their algorithms, in a
module with ``register(subparsers)`` listed in :data:`COMMAND_MODULES`; each is imported only
when the parser is built, so ``import kit`` stays light.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.metadata
import sys
from collections.abc import Sequence

import numpy as np

from kit import __version__, kinematics, robots


def _robots(args: argparse.Namespace) -> int:
    for name in robots.ROBOTS:
        r = robots.load(name)
        print(f"{name:7s} wheel radius {r.wheel_radius:.4f} m, separation "
              f"{r.wheel_separation:.3f} m, {r.ticks_per_wheel_turn:g} ticks/wheel turn — "
              f"{r.description}")
    return 0


def _robot(args: argparse.Namespace) -> int:
    r = robots.load_from_options(args.name, args.params, args.xacro_arg, args.package_path,
                                 topic=args.topic)
    print(f"{r.name}: {r.description}")
    print(f"  {'source':22s}{r.source}")
    for key in ("wheel_radius", "wheel_separation", "gear_ratio",
                "encoder_resolution", "counter_bits", "metres_per_tick", "max_wheel_speed",
                "max_linear_velocity", "cruise_velocity", "max_angular_velocity", "mass"):
        print(f"  {key:22s}{getattr(r, key):g}")
    print(f"  {'base frame':22s}{r.base_frame}")
    print(f"  {'wheel joints':22s}{r.wheel_joints[0]} (right), {r.wheel_joints[1]} (left), "
          f"midpoint at ({r.axle[0]:+.3f}, {r.axle[1]:+.3f}) m")
    fp = r.footprint
    print(f"  {'footprint':22s}{len(fp)} points, x {np.min(fp[:, 0]):+.3f} to "
          f"{np.max(fp[:, 0]):+.3f} m, y {np.min(fp[:, 1]):+.3f} to {np.max(fp[:, 1]):+.3f} m")
    print("  static transforms (parent -> child: x y z [m], yaw [deg])")
    for j in r.joints:
        print(f"    {j.parent} -> {j.child}: {j.xyz[0]:+.4f} {j.xyz[1]:+.4f} {j.xyz[2]:+.4f}, "
              f"{np.degrees(j.rpy[2]):+.1f}")
    for sensor, params in r.sensors.items():
        print(f"  sensor {sensor}: " + ", ".join(f"{k}={v}" for k, v in params.items()))
    if r.found:
        print("  found in the description:")
        for line in r.found:
            print(f"    {line}")
    if r.assumed:
        print("  assumed (give them in a parameter file with --params):")
        for line in r.assumed:
            print(f"    {line}")
    return 0


def _wheels(args: argparse.Namespace) -> int:
    r = robots.load(args.name)
    phi = kinematics.twist_to_wheel_speeds(args.linear, args.angular, r.wheel_radius,
                                           r.wheel_separation)
    limited = kinematics.saturate_wheel_speeds(phi, r.max_wheel_speed)
    print(f"v = {args.linear:g} m/s, ω = {args.angular:g} rad/s on the {r.name}:")
    print(f"  wheel speeds (right, left): {phi[0]:.4f}, {phi[1]:.4f} rad/s")
    if not np.allclose(phi, limited):
        print(f"  beyond {r.max_wheel_speed:g} rad/s; scaled to keep the arc: "
              f"{limited[0]:.4f}, {limited[1]:.4f} rad/s")
    radius = float(kinematics.turning_radius(args.linear, args.angular))
    print(f"  turning radius {radius:g} m")
    if r.name == "igv":
        u_right, u_left = kinematics.igv_wheel_rpm(args.linear, args.angular)
        units = kinematics.rpm_to_drive_units(np.array([u_right, u_left]),
                                              r.encoder_resolution)
        print(f"  IGV RPM (right, left): {float(u_right):.3f}, {float(u_left):.3f}; drive units "
              f"0x{int(units[0]) & 0xFFFFFFFF:08X}, 0x{int(units[1]) & 0xFFFFFFFF:08X}")
    return 0


COMMAND_MODULES: tuple[str, ...] = ("kit.drivers._cli", "kit.planning._cli", "kit.slam.command",
                                     "kit.localization.cli")
"""Modules with a ``register(subparsers)`` that adds their subcommands."""

PLUGIN_GROUP = "kit.commands"
"""Entry points of installed packages whose ``register(subparsers)`` adds a subcommand: the
simulator's ``kit sim …`` comes this way, so that ``kit`` never imports ``sim``."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="kit", description="The robotics course kit.")
    parser.add_argument("--version", action="version", version=f"kit {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("robots", help="list the robots").set_defaults(func=_robots)
    p = sub.add_parser("robot", help="one robot's parameters and frames: a shipped robot, or "
                       "any robot's URDF, xacro file or bag")
    p.add_argument("name", help="uiabot, igv, eddie, a parameter file (.toml), a .urdf, "
                   ".urdf.xacro or .xacro file, or a bag that recorded /robot_description")
    p.add_argument("--params", default=None, metavar="FILE",
                   help="for a URDF, xacro file or bag: a TOML file of what the URDF does not "
                   "hold ([drive] limits, [sensors.lidar], [footprint] ...)")
    p.add_argument("--xacro-arg", action="append", default=[], metavar="NAME:=VALUE",
                   help="a xacro argument (repeatable), e.g. namespace:=tb3_0/")
    p.add_argument("--package-path", action="append", default=[], metavar="PKG=DIR",
                   help="where ROS package PKG is, for $(find PKG) and package:// without ROS "
                   "(repeatable)")
    p.add_argument("--topic", default="/robot_description",
                   help="a bag's URDF topic (default /robot_description)")
    p.set_defaults(func=_robot)
    p = sub.add_parser("wheels", help="wheel speeds for a twist (v [m/s], ω [rad/s])")
    p.add_argument("name")
    p.add_argument("linear", type=float)
    p.add_argument("angular", type=float)
    p.set_defaults(func=_wheels)
    for module in COMMAND_MODULES:
        importlib.import_module(module).register(sub)
    for entry in importlib.metadata.entry_points(group=PLUGIN_GROUP):
        entry.load()(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    from kit.clitext import negative_values

    args = build_parser().parse_args(negative_values(sys.argv[1:] if argv is None else argv))
    try:
        return int(args.func(args))
    except (ValueError, KeyError) as exc:
        print(f"kit: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:              # a file the command could not read or write
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"kit: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
