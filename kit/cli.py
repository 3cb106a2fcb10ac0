"""The ``kit`` command: look at the robots and try the kinematics from a shell.

    kit robots                      the robots and their key numbers
    kit robot uiabot                one robot's parameters and static transforms
    kit wheels igv 1.0 0.0          wheel speeds (and the IGV's RPM and drive units) for v, ω

Subcommands of a topic (``kit slam``, ``kit plan``, ...) live beside their algorithms, in a
module with ``register(subparsers)`` listed in :data:`COMMAND_MODULES`; each is imported only
when the parser is built, so ``import kit`` stays light.
"""

from __future__ import annotations

import argparse
import importlib
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
    r = robots.load(args.name)
    print(f"{r.name}: {r.description}")
    print(f"  {'source':22s}{r.source}")
    for key in ("wheel_radius", "wheel_separation", "gear_ratio",
                "encoder_resolution", "counter_bits", "metres_per_tick", "max_wheel_speed",
                "max_linear_velocity", "cruise_velocity", "max_angular_velocity", "mass"):
        print(f"  {key:22s}{getattr(r, key):g}")
    print("  static transforms (parent -> child: x y z [m], yaw [deg])")
    for j in r.joints:
        print(f"    {j.parent} -> {j.child}: {j.xyz[0]:+.4f} {j.xyz[1]:+.4f} {j.xyz[2]:+.4f}, "
              f"{np.degrees(j.rpy[2]):+.1f}")
    for sensor, params in r.sensors.items():
        print(f"  sensor {sensor}: " + ", ".join(f"{k}={v}" for k, v in params.items()))
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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="kit", description="The robotics course kit.")
    parser.add_argument("--version", action="version", version=f"kit {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("robots", help="list the robots").set_defaults(func=_robots)
    p = sub.add_parser("robot", help="one robot's parameters and frames")
    p.add_argument("name", help="uiabot, igv, eddie or a parameter file (.toml)")
    p.set_defaults(func=_robot)
    p = sub.add_parser("wheels", help="wheel speeds for a twist (v [m/s], ω [rad/s])")
    p.add_argument("name")
    p.add_argument("linear", type=float)
    p.add_argument("angular", type=float)
    p.set_defaults(func=_wheels)
    for module in COMMAND_MODULES:
        importlib.import_module(module).register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except (ValueError, KeyError) as exc:
        print(f"kit: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
