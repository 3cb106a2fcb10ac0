"""``kit localize BAG --map MAP.yaml [--params amcl.yaml] [--initial x,y,yaw] [--format
csv|tum] [--bag] --out DIR``.

Runs the kit's AMCL (:class:`kit.localization.Amcl`, Nav2's parameters) over a ROS 2 bag's
``/scan``, ``/tf`` and ``/tf_static`` — the lidar's mounting comes from the bag's transforms —
and writes into ``DIR``:

* ``poses.csv``: ``stamp,x,y,yaw,std_x,std_y,std_yaw`` — one row per scan, ``T_map_base`` at
  the scan's stamp in the map frame and the standard deviations of the estimate (empty fields
  while the filter has no estimate: before the odometry covers a scan); with ``--format tum``
  ``poses.tum`` instead (``timestamp tx ty tz qx qy qz qw``, the rows with an estimate, as
  evo and the TUM tools read it);
* ``localization.png``: the known part of the map, the estimated path — after a global
  start from the first converged estimate (both position standard deviations under 0.25 m)
  — and the last scan placed at its pose;
* with ``--bag``, ``localization/``: an MCAP ROS 2 bag of the estimates, stamped as the
  scans — ``/map`` (latched), ``/amcl_pose`` and ``/particlecloud`` (``PoseArray``, at most
  2,000 of the particles) at every filter update, ``map → odom`` on ``/tf``.

Without ``--initial`` the filter starts from a uniform spread of particles over the map's free
cells (global localization); with it, from Nav2's initial-pose spread around that pose.

Parameters: Nav2's ``amcl`` defaults, or the file given with ``--params``. Nav2's 2,000
particles and 60 beams cannot find a robot on a whole building floor, so a global start with
no ``--params`` uses 30,000 particles (KLD-sampling brings the count down as the cloud
gathers), 120 beams and an update every 0.1 m or 0.1 rad. ``--base-frame`` and
``--odom-frame`` name the robot's frames when the bag's differ from the parameters'
(Nav2's ``base_footprint`` and ``odom``).

Scan timing (``--scan-timing``): ``ros`` takes beam ``i`` as measured at
``stamp + i * time_increment``, as the ``LaserScan`` message says; ``rplidar_ros`` is how the
RPLidar's ROS driver really publishes — the beams in the reverse order of measurement, the
stamp when the revolution was finished — so each scan is first put back in measurement order
and stamped at its first beam (:func:`kit.perception.reverse_beam_order`), and the rows of
``poses.csv`` carry that stamp. ``auto`` (the default) picks ``rplidar_ros`` when the scan's
frame is named like the driver's (``rplidar…``), ``ros`` otherwise, and says which.

A run in which the filter never updates writes nothing and exits non-zero, saying why: a
frame the bag's transforms lack, scans its odometry never covers.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from kit import clitext, geometry, maps, msgs
from kit.localization.amcl import (
    SCAN_TIMINGS,
    Amcl,
    AmclParameters,
    LocalizationStep,
    load_parameters,
    localize,
)

__all__ = ["CONVERGED_STD", "main", "register"]

CONVERGED_STD = 0.25
"""Both position standard deviations under this [m]: the estimate has converged (the figure
starts there)."""

MAX_CLOUD = 2000
"""At most this many particles in a bag's ``/particlecloud`` message (evenly strided)."""


def register(subparsers: Any) -> None:
    """Add ``localize`` to the ``kit`` command."""
    p = subparsers.add_parser("localize", help="localize a ROS 2 bag in a map (AMCL)",
                              description=clitext.plain(__doc__),
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("bag", type=Path, help="a ROS 2 bag (folder, .mcap or .db3) or ROS 1 .bag")
    p.add_argument("--map", required=True, type=Path, help="a map_server map (YAML)")
    p.add_argument("--params", type=Path, help="a Nav2 parameter file with an amcl section")
    p.add_argument("--initial", metavar="X,Y,YAW",
                   help="start around this pose [m, m, rad], e.g. -2.5,-0.36,-1.44")
    p.add_argument("--seed", type=int, help="seed of the filter's random numbers")
    p.add_argument("--scan-topic", default="/scan", help="the bag's LaserScan topic (/scan)")
    p.add_argument("--base-frame", help="the robot's base frame in the bag's transforms "
                   "(default: the parameters' base_frame_id, Nav2's base_footprint)")
    p.add_argument("--odom-frame", help="the odometry frame (default: odom_frame_id, odom)")
    p.add_argument("--deskew", action=argparse.BooleanOptionalAction, default=None,
                   help="correct each scan for the motion during it (default: the "
                        "parameters' deskew, on)")
    p.add_argument("--scan-timing", choices=("auto", *SCAN_TIMINGS), default="auto",
                   help="when each beam was measured (see above; default: auto)")
    p.add_argument("--format", choices=clitext.TRAJECTORY_FORMATS, default="csv",
                   help="poses.csv (default) or poses.tum (for evo)")
    p.add_argument("--bag", dest="write_bag", action="store_true",
                   help="also write localization/, an MCAP bag of the estimates")
    p.add_argument("--out", required=True, type=Path,
                   help="output folder: poses.csv (or poses.tum), localization.png"
                        "[, localization/]")
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


def converged_from(steps: list[LocalizationStep], std: float = CONVERGED_STD) -> int | None:
    """Index of the first step whose position standard deviations are both under ``std``
    metres (None if none is)."""
    for i, s in enumerate(steps):
        if np.all(np.isfinite(s.pose)) and s.std[0] < std and s.std[1] < std:
            return i
    return None


def _write_png(grid: Any, steps: list[LocalizationStep], path: Path,
               global_start: bool = True) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from kit import viz

    first = converged_from(steps) if global_start else 0
    shown = steps[first:] if first is not None else steps
    known = np.array([s.pose for s in shown if np.all(np.isfinite(s.pose))])
    fig, ax = plt.subplots(figsize=(8, 6))
    title = ("kit localize from the given start" if not global_start else
             "kit localize, global start: from the first converged estimate" if first is not None
             else f"kit localize: the estimate never converged (position std >= "
                  f"{CONVERGED_STD} m)")
    viz.plot_grid(grid, ax=ax, title=title, crop=True)
    if len(known):
        since = shown[0].scan.header.stamp.to_sec() - steps[0].scan.header.stamp.to_sec()
        label = (f"estimated path from t = {since:.1f} s" if first is not None else
                 "estimated path (not converged)")
        ax.plot(known[:, 0], known[:, 1], "-", color="tab:red", label=label)
        ax.plot(*known[0, :2], "o", color="tab:red", mfc="none",
                label="first converged estimate" if global_start and first is not None
                else "first estimate")
        ax.plot(*known[-1, :2], "o", color="tab:red", label="last estimate")
        last = next(s for s in reversed(steps) if np.all(np.isfinite(s.pose)))
        if last.T_base_laser is not None:
            mount = [last.T_base_laser.translation[0], last.T_base_laser.translation[1],
                     float(geometry.quaternion_to_yaw(last.T_base_laser.rotation))]
            viz.plot_scan(last.scan, geometry.compose(last.pose, mount), ax=ax,
                          color="tab:blue", label="last scan")
        ax.legend(loc="best", fontsize=8)
    viz.crop_to_known(ax, grid)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def _csv_row(step: LocalizationStep) -> str:
    stamp = step.scan.header.stamp.to_sec()
    if not np.all(np.isfinite(step.pose)):
        return f"{stamp:.6f},,,,,,\n"
    x, y, yaw = step.pose
    sx, sy, syaw = step.std
    return f"{stamp:.6f},{x:.6f},{y:.6f},{yaw:.6f},{sx:.6f},{sy:.6f},{syaw:.6f}\n"


def _write_poses(steps: list[LocalizationStep], out: Path, fmt: str) -> Path:
    if fmt == "tum":
        return clitext.write_trajectory(
            out / "poses.tum", [s.scan.header.stamp.to_sec() for s in steps],
            [s.pose for s in steps], "tum")
    path = out / "poses.csv"
    with path.open("w", encoding="utf-8") as f:
        f.write("stamp,x,y,yaw,std_x,std_y,std_yaw\n")
        for step in steps:
            f.write(_csv_row(step))
    return path


def _write_bag(grid: msgs.OccupancyGrid, steps: list[LocalizationStep], params: AmclParameters,
               path: Path) -> int:
    """The estimates as AMCL publishes them, stamped as their scans."""
    from kit.bag import BagWriter
    from kit.tf import RigidTransform

    with BagWriter(path) as bag:
        first = steps[0].scan.header.stamp
        bag.write("/map", dataclasses.replace(grid, header=msgs.Header(
            first, params.global_frame_id)), first.to_nsec())
        for s in steps:
            if not s.updated or not np.all(np.isfinite(s.pose)):
                continue
            stamp = s.scan.header.stamp
            header = msgs.Header(stamp, params.global_frame_id)
            bag.write("/amcl_pose", _pose_message(header, s), stamp.to_nsec())
            if s.particles is not None:
                cloud = s.particles[::max(1, math.ceil(len(s.particles) / MAX_CLOUD))]
                bag.write("/particlecloud", msgs.PoseArray(header, tuple(
                    _pose(p) for p in cloud)), stamp.to_nsec())
            map_to_odom = geometry.compose(s.pose, geometry.inverse(s.odom_pose))
            tf = msgs.TransformStamped(header, params.odom_frame_id,
                                       RigidTransform.from_pose2d(map_to_odom).to_msg())
            bag.write("/tf", msgs.TFMessage((tf,)), stamp.to_nsec())
        return bag.count


def _pose(p: np.ndarray) -> msgs.Pose:
    q = geometry.yaw_to_quaternion(float(p[2]))
    return msgs.Pose(msgs.Point(float(p[0]), float(p[1]), 0.0), msgs.Quaternion(*map(float, q)))


def _pose_message(header: msgs.Header, s: LocalizationStep) -> msgs.PoseWithCovarianceStamped:
    c6 = np.zeros((6, 6))
    c6[0, 0], c6[1, 1], c6[5, 5] = s.std ** 2
    return msgs.PoseWithCovarianceStamped(header, msgs.PoseWithCovariance(_pose(s.pose),
                                                                          c6.ravel()))


class _Frames:
    """The frames a bag's transforms name, seen as its messages go by."""

    def __init__(self, messages: Iterator[tuple[str, int, msgs.Message]]) -> None:
        self.messages = messages
        self.children: dict[str, str] = {}

    def __iter__(self) -> Iterator[tuple[str, msgs.Message]]:
        for topic, _, message in self.messages:
            if isinstance(message, msgs.TFMessage):
                for t in message.transforms:
                    self.children[t.child_frame_id.lstrip("/")] = t.header.frame_id.lstrip("/")
            yield topic, message

    @property
    def names(self) -> set[str]:
        return set(self.children) | set(self.children.values())


def _no_update(bag: Path, steps: list[LocalizationStep], frames: _Frames,
               params: AmclParameters) -> ValueError:
    """Why the filter never updated, and what to do."""
    unplaced = [s for s in steps if not np.all(np.isfinite(s.odom_pose))]
    head = f"{bag}: {len(steps)} scans, no filter update"
    known = ", ".join(sorted(frames.names)) or "none"
    for option, frame in (("--odom-frame", params.odom_frame_id),
                          ("--base-frame", params.base_frame_id)):
        if frame not in frames.names:
            under = sorted(c for c, parent in frames.children.items()
                           if parent == params.odom_frame_id)
            hint = (f" (the bag's child of {params.odom_frame_id}: {', '.join(under)})"
                    if option == "--base-frame" and under else "")
            return ValueError(f"{head}: the frame {frame!r} is not in the bag's transforms "
                              f"(its frames: {known}), so none of the {len(unplaced)} scans "
                              f"could be placed; name the bag's with {option}{hint}")
    scan_frame = steps[0].scan.header.frame_id.lstrip("/")
    if scan_frame not in frames.names:
        return ValueError(f"{head}: the scan's frame {scan_frame!r} is not in the bag's "
                          f"transforms (its frames: {known})")
    deskewed = _rejected_by_deskew(bag, unplaced, params)
    if deskewed:
        return ValueError(
            f"{head}: de-skew rejected {deskewed} of {len(steps)} scans (the transforms "
            f"{params.odom_frame_id} -> {params.base_frame_id} did not cover the times of "
            f"their beams when each scan was processed); run with --no-deskew")
    return ValueError(f"{head}: {len(unplaced)} scans had no {params.odom_frame_id} -> "
                      f"{params.base_frame_id} transform at their stamps, and the robot never "
                      f"moved update_min_d ({params.update_min_d} m) or update_min_a "
                      f"({params.update_min_a} rad) between the others")


def _rejected_by_deskew(bag: Path, unplaced: list[LocalizationStep],
                        params: AmclParameters) -> int:
    """How many of the scans left without a pose had every transform at their own stamp
    (so only de-skew, which needs the odometry over all their beams, set them aside)."""
    from kit import bag as bags
    from kit.tf import TransformTree

    if not params.deskew or not unplaced:
        return 0
    tree = TransformTree(cache_time=1e9)
    for topic, _, message in bags.read_bag(bag, ["/tf", "/tf_static"]):
        if isinstance(message, msgs.TFMessage):
            tree.add_message(message, static=topic == "/tf_static")
    count = 0
    for s in unplaced:
        try:
            tree.lookup_pose2d(params.odom_frame_id, params.base_frame_id, s.scan.header.stamp)
            tree.lookup_transform(params.base_frame_id, s.scan.header.frame_id,
                                  s.scan.header.stamp)
        except LookupError:
            continue
        count += s.scan.time_increment > 0
    return count


def _parameters(args: argparse.Namespace, start: np.ndarray | None) -> AmclParameters:
    if args.params:
        params = load_parameters(args.params)
    elif start is None:
        params = AmclParameters(**GLOBAL_START)
    else:
        params = AmclParameters()
    changes: dict[str, Any] = {k: v for k, v in (("base_frame_id", args.base_frame),
                                                 ("odom_frame_id", args.odom_frame)) if v}
    if args.deskew is not None:
        changes["deskew"] = args.deskew
    return dataclasses.replace(params, **changes) if changes else params


def _run(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from kit import bag

    if not Path(args.bag).exists():
        raise ValueError(f"{args.bag}: no such bag")
    clitext.output_dir(args.out, make=False)
    start = _initial(args.initial)
    bag.check_topic(args.bag, args.scan_topic, "sensor_msgs/msg/LaserScan", "--scan-topic")
    params = _parameters(args, start)
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
    frames = _Frames(bag.read_bag(args.bag))
    with tqdm(unit="scan", desc="localize", disable=args.quiet, file=sys.stderr) as bar:
        steps = []
        for step in localize(frames, node, scan_topic=args.scan_topic, scan_timing=timing):
            steps.append(step)
            bar.update(1)
    if not steps:
        raise ValueError(f"{args.bag}: no LaserScan on {args.scan_topic}")
    if node.updates == 0:
        raise _no_update(args.bag, steps, frames, params)
    return _write(args, grid, steps, params, node.updates)


def _write(args: argparse.Namespace, grid: msgs.OccupancyGrid, steps: list[LocalizationStep],
           params: AmclParameters, updates: int) -> int:
    out = clitext.output_dir(args.out)
    written = [_write_poses(steps, out, args.format).name, "localization.png"]
    _write_png(grid, steps, out / "localization.png", global_start=args.initial is None)
    if args.write_bag:
        bag_path = out / "localization"
        if bag_path.exists():
            raise ValueError(f"{bag_path} exists; remove it or choose another --out")
        _write_bag(grid, steps, params, bag_path)
        written.append("localization/")
    known = [s for s in steps if np.all(np.isfinite(s.pose))]
    last = f"; last pose ({known[-1].pose[0]:.2f}, {known[-1].pose[1]:.2f}, " \
           f"{known[-1].pose[2]:.2f}) ± ({known[-1].std[0]:.2f}, {known[-1].std[1]:.2f}, " \
           f"{known[-1].std[2]:.2f})" if known else ""
    unplaced = len(steps) - len(known)
    skipped = f" ({unplaced} without an estimate: no transform at their stamps)" \
        if unplaced else ""
    print(f"{len(steps)} scans{skipped}, {updates} filter updates{last}; wrote {out}/"
          + ", ".join(written))
    return 0


def main(argv: list[str] | None = None) -> int:
    """``kit localize ...`` on its own (the ``kit`` command is the usual way in)."""
    parser = argparse.ArgumentParser(prog="kit")
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["localize", *clitext.negative_values(
        sys.argv[1:] if argv is None else argv)])
    return int(args.func(args))
