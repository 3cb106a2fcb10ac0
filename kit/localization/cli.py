"""``kit localize BAG --map MAP.yaml [--params amcl.yaml] [--initial x,y,yaw] --out DIR``.

Runs the kit's AMCL (:class:`kit.localization.Amcl`, Nav2's parameters) over a ROS 2 bag's
``/scan``, ``/tf`` and ``/tf_static`` — the lidar's mounting comes from the bag's transforms —
and writes into ``DIR``:

* ``poses.csv``: ``stamp,x,y,yaw,std_x,std_y,std_yaw`` — one row per scan, ``T_map_base`` at
  the scan's stamp in the map frame and the standard deviations of the estimate (empty fields
  while the filter has no estimate: before the odometry covers a scan);
* ``localization.png``: the map, the estimated path and the last scan placed at its pose.

Without ``--initial`` the filter starts from a uniform spread of particles over the map's free
cells (global localization); with it, from Nav2's initial-pose spread around that pose.

Parameters: Nav2's ``amcl`` defaults, or the file given with ``--params``. Nav2's 2,000
particles and 60 beams cannot find a robot on a whole building floor, so a global start with
no ``--params`` uses 30,000 particles (KLD-sampling brings the count down as the cloud
gathers), 120 beams and an update every 0.1 m or 0.1 rad.

Scan timing (``--scan-timing``): ``ros`` takes beam ``i`` as measured at
``stamp + i * time_increment``, as the ``LaserScan`` message says; ``rplidar_ros`` is how the
RPLidar's ROS driver really publishes — the beams in the reverse order of measurement, the
stamp when the revolution was finished — so each scan is first put back in measurement order
and stamped at its first beam (:func:`kit.perception.reverse_beam_order`), and the rows of
``poses.csv`` carry that stamp. ``auto`` (the default) picks ``rplidar_ros`` when the scan's
frame is named like the driver's (``rplidar…``), ``ros`` otherwise, and says which.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from kit import geometry, maps, msgs
from kit.localization.amcl import (
    SCAN_TIMINGS,
    Amcl,
    AmclParameters,
    LocalizationStep,
    load_parameters,
    localize,
)

__all__ = ["main", "register"]


def register(subparsers: Any) -> None:
    """Add ``localize`` to the ``kit`` command."""
    p = subparsers.add_parser("localize", help="localize a ROS 2 bag in a map (AMCL)",
                              description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("bag", type=Path, help="a ROS 2 bag (folder, .mcap or .db3)")
    p.add_argument("--map", required=True, type=Path, help="a map_server map (YAML)")
    p.add_argument("--params", type=Path, help="a Nav2 parameter file with an amcl section")
    p.add_argument("--initial", help="x,y,yaw [m, m, rad]: start around this pose")
    p.add_argument("--seed", type=int, help="seed of the filter's random numbers")
    p.add_argument("--scan-topic", default="/scan")
    p.add_argument("--scan-timing", choices=("auto", *SCAN_TIMINGS), default="auto",
                   help="when each beam was measured (see above; default: auto)")
    p.add_argument("--out", required=True, type=Path, help="output folder")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_run)


GLOBAL_START: dict[str, Any] = {
    "max_particles": 30000, "min_particles": 2000, "max_beams": 120,
    "update_min_d": 0.1, "update_min_a": 0.1}
"""The parameters a global start uses when no ``--params`` file is given."""


def _scan_frame(bag_path: Path, topic: str) -> str | None:
    from kit import bag

    for _, _, message in bag.read_bag(bag_path, [topic]):
        if isinstance(message, msgs.LaserScan):
            return message.header.frame_id
    return None


def _initial(text: str | None) -> np.ndarray | None:
    if text is None:
        return None
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise ValueError(f"--initial takes x,y,yaw (three numbers: m, m, rad); got {text!r}")
    return np.array(values)


def _write_png(grid: Any, steps: list[LocalizationStep], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from kit import viz

    fig, ax = plt.subplots(figsize=(8, 6))
    viz.plot_grid(grid, ax=ax, title="kit localize")
    known = np.array([s.pose for s in steps if np.all(np.isfinite(s.pose))])
    if len(known):
        ax.plot(known[:, 0], known[:, 1], "-", color="tab:red", label="estimated path")
        ax.plot(*known[-1, :2], "o", color="tab:red")
        last = next(s for s in reversed(steps) if np.all(np.isfinite(s.pose)))
        if last.T_base_laser is not None:
            mount = [last.T_base_laser.translation[0], last.T_base_laser.translation[1],
                     float(geometry.quaternion_to_yaw(last.T_base_laser.rotation))]
            viz.plot_scan(last.scan, geometry.compose(last.pose, mount), ax=ax,
                          color="tab:blue", label="last scan")
        ax.legend(loc="best")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def _csv_row(step: LocalizationStep) -> str:
    stamp = step.scan.header.stamp.to_sec()
    if not np.all(np.isfinite(step.pose)):
        return f"{stamp:.6f},,,,,,\n"
    x, y, yaw = step.pose
    sx, sy, syaw = step.std
    return f"{stamp:.6f},{x:.6f},{y:.6f},{yaw:.6f},{sx:.6f},{sy:.6f},{syaw:.6f}\n"


def _run(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from kit import bag

    if not Path(args.bag).exists():
        raise ValueError(f"{args.bag}: no such bag")
    start = _initial(args.initial)
    if args.params:
        params = load_parameters(args.params)
    elif start is None:
        params = AmclParameters(**GLOBAL_START)
    else:
        params = AmclParameters()
    grid = maps.read_map(args.map)
    timing = args.scan_timing
    if timing == "auto":
        frame = _scan_frame(args.bag, args.scan_topic)
        timing = "rplidar_ros" if frame is not None and "rplidar" in frame.lower() else "ros"
        print(f"scan timing: {timing} (scan frame {frame!r}; --scan-timing to choose)")
    node = Amcl(grid, params, seed=args.seed)
    if start is None:
        node.initialize_global()
    else:
        node.initialize(start)
    messages = ((topic, message) for topic, _, message in bag.read_bag(args.bag))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    steps = []
    with (out / "poses.csv").open("w", encoding="utf-8") as f, \
            tqdm(unit="scan", desc="localize", disable=args.quiet, file=sys.stderr) as bar:
        f.write("stamp,x,y,yaw,std_x,std_y,std_yaw\n")
        for step in localize(messages, node, scan_topic=args.scan_topic,
                             scan_timing=timing):
            f.write(_csv_row(step))
            steps.append(step)
            bar.update(1)
    if not steps:
        raise ValueError(f"{args.bag}: no LaserScan on {args.scan_topic}")
    _write_png(grid, steps, out / "localization.png")
    known = [s for s in steps if np.all(np.isfinite(s.pose))]
    last = f"; last pose ({known[-1].pose[0]:.2f}, {known[-1].pose[1]:.2f}, " \
           f"{known[-1].pose[2]:.2f}) ± ({known[-1].std[0]:.2f}, {known[-1].std[1]:.2f}, " \
           f"{known[-1].std[2]:.2f})" if known else ""
    print(f"{len(steps)} scans, {node.updates} filter updates{last}; wrote {out}/poses.csv, "
          f"localization.png")
    return 0


def main(argv: list[str] | None = None) -> int:
    """``kit localize ...`` on its own (the ``kit`` command is the usual way in)."""
    parser = argparse.ArgumentParser(prog="kit")
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["localize", *(sys.argv[1:] if argv is None else argv)])
    return int(args.func(args))
