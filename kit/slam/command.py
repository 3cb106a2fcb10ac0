"""``kit slam LOG_OR_BAG [--relations FILE] [--odometry-noise SEED] [--format csv|tum] --out
DIR``: SLAM over a CARMEN log or a ROS bag.

Writes into ``DIR``:

* ``map.yaml`` + ``map.pgm``: a map_server map (Nav2's map_server and RViz open it);
* ``map.png``: the map with axes in metres and the path the robot took;
* ``trajectory.csv`` (``stamp,x,y,yaw``) or, with ``--format tum``, ``trajectory.tum``
  (``timestamp tx ty tz qx qy qz qw``, as evo and the TUM tools read it): every scan's
  optimised ``T_map_base``; a CARMEN log's stamps are its IPC timestamps;
* ``graph.g2o``: the optimised pose graph;
* ``closures.csv``: every loop-closure attempt, accepted or not, with its figures and
  the reason it was rejected;
* ``scans.csv``: how each scan's pose was found and how many of its returns were dropped
  as moving things;
* with ``--relations``, ``errors.csv`` (the benchmark's metric per relation) and its summary
  on the terminal.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from kit import clitext
from kit.slam import carmen, evaluate, offline
from kit.slam.frontend import Slam
from kit.slam.pose_graph import write_g2o

__all__ = ["main", "register"]

BAG_SUFFIXES = (".mcap", ".db3", ".bag")


def register(subparsers: Any) -> None:
    """Add ``slam`` to the ``kit`` command."""
    p = subparsers.add_parser("slam", help="map a CARMEN log or a ROS bag (graph SLAM)",
                              description=clitext.plain(__doc__),
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("recording", help="a CARMEN log (.clf, .log, .gz) or a bag (folder, .mcap, "
                                     ".db3, .bag)")
    p.add_argument("--out", required=True, type=Path,
                   help="output folder: map.yaml, map.pgm, map.png, trajectory.csv (or .tum), "
                        "graph.g2o, closures.csv, scans.csv[, errors.csv]")
    p.add_argument("--format", choices=clitext.TRAJECTORY_FORMATS, default="csv",
                   help="the trajectory's format (default csv; tum for evo)")
    p.add_argument("--relations", type=Path, help="Kümmerle et al. relations to score against")
    p.add_argument("--resolution", type=float, default=0.05, help="map cell size [m]")
    p.add_argument("--odometry-noise", type=int, metavar="SEED",
                   help="CARMEN logs: replace the log's odometry by its poses with a seeded "
                        "wheel-like error (+2 %% distance, +1 %% turning, 0.01 rad/m drift, "
                        "Gaussian noise per step; kit.slam.evaluate.perturb_odometry), for "
                        "logs whose poses are already corrected")
    p.add_argument("--scan-topic", default="/scan", help="a bag's LaserScan topic (/scan)")
    p.add_argument("--odom-topic", default="/odom", help="a bag's Odometry topic (/odom)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=_run)


def _is_bag(path: Path) -> bool:
    return path.is_dir() or path.suffix in BAG_SUFFIXES


def _progress(total: int, quiet: bool, what: str) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, unit="scan", desc=what, disable=quiet, file=sys.stderr)


def _slam(args: argparse.Namespace) -> Slam:
    path = Path(args.recording)
    if not path.exists():
        raise ValueError(f"{path}: no such log or bag")
    if _is_bag(path):
        if args.odometry_noise is not None:
            raise ValueError("--odometry-noise applies to CARMEN logs, not to bags")
        from kit.bag import check_topic

        check_topic(path, args.scan_topic, "sensor_msgs/msg/LaserScan", "--scan-topic")
        check_topic(path, args.odom_topic, "nav_msgs/msg/Odometry", "--odom-topic")
        recording = offline.read_bag_recording(path, args.scan_topic, args.odom_topic)
        with _progress(len(recording.scans), args.quiet, "slam") as bar:
            return offline.run_bag(recording, progress=bar.update)
    log = carmen.read_carmen(path)
    odometry = None
    if args.odometry_noise is not None:
        odometry = evaluate.perturb_odometry(np.array([r.robot_pose for r in log.lasers]),
                                             args.odometry_noise)
    with _progress(len(log.lasers), args.quiet, "slam") as bar:
        return offline.run_carmen(log, progress=bar.update, odometry=odometry)


def write_png(grid: np.ndarray, path: Path) -> None:
    """The trinary grid as map_saver's grey levels (free 254, occupied 0, unknown 205),
    top row first: the image alone, one pixel a cell."""
    from PIL import Image

    image = np.full(grid.shape, 205, dtype=np.uint8)
    image[grid == 0] = 254
    image[grid == 100] = 0
    Image.fromarray(np.flipud(image)).save(path)


def write_figure(grid: Any, poses: np.ndarray, path: Path, title: str) -> None:
    """The map with axes in metres and the robot's path, cropped to the walls (a log's
    no-return beams clear free space out to the scanner's range, 82 m on MIT CSAIL: the
    known cells reach far past the building)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from kit import viz

    fig, ax = plt.subplots(figsize=(9, 7))
    msg = grid.to_msg()
    viz.plot_grid(msg, ax=ax, title=title)
    if len(poses):
        ax.plot(poses[:, 0], poses[:, 1], color="tab:red", lw=1.0, label="optimised path")
        ax.plot(*poses[0, :2], "o", color="tab:red", label="start")
        ax.legend(loc="best", fontsize=8)
    walls = np.any(msg.data == 100)
    x0, x1, y0, y1 = viz.known_extent(msg, occupied=bool(walls))
    if len(poses):  # the whole path shows, even where it ran past the walls
        x0, x1 = min(x0, poses[:, 0].min() - 0.5), max(x1, poses[:, 0].max() + 0.5)
        y0, y1 = min(y0, poses[:, 1].min() - 0.5), max(y1, poses[:, 1].max() + 0.5)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.grid(True, alpha=0.3)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def write_closures(slam: Slam, path: Path) -> None:
    """Every loop-closure attempt: the nodes (and their scans' stamps), accepted or not and
    why, the correlative response, the supports, the correction asked of the node and the
    edge's χ² after optimisation (empty where a figure was not reached)."""
    def num(v: float, digits: int = 4) -> str:
        return "" if not np.isfinite(v) else f"{v:.{digits}f}"

    stamp = [slam.records[n.scan_index].stamp if n.scan_index < len(slam.records) else np.nan
             for n in slam.nodes]
    with path.open("w", encoding="utf-8") as f:
        f.write("node,node_stamp,candidate,candidate_stamp,reference,accepted,reason,response,"
                "support,recent_support,shift_x,shift_y,shift_yaw,chi2\n")
        for c in slam.closures:
            reason = c.reason.replace(",", ";")
            f.write(f"{c.node},{num(stamp[c.node], 6)},{c.candidate},"
                    f"{num(stamp[c.candidate], 6)},{c.reference if c.reference >= 0 else ''},"
                    f"{int(c.accepted)},{reason},{num(c.response)},{num(c.support)},"
                    f"{num(c.recent_support)},{num(c.shift[0])},{num(c.shift[1])},"
                    f"{num(c.shift[2])},{num(c.chi2, 2)}\n")


def write_scans(slam: Slam, path: Path) -> None:
    """Per scan: its stamp, the node it hangs from, how its pose was found (``icp``,
    ``search``, ``odometry`` when every match was rejected, ``first``), the returns dropped
    as moving, and for a node's own scan whether its edge to the previous node is the
    match's, the odometry's, or the odometry's after the match edge was found inconsistent
    (``replaced``)."""
    replaced = set(slam.replaced_matches)
    node_of_scan = {n.scan_index: k for k, n in enumerate(slam.nodes)}
    with path.open("w", encoding="utf-8") as f:
        f.write("stamp,node,matched,moving,edge\n")
        for s, r in enumerate(slam.records):
            k = node_of_scan.get(s)
            edge = "" if k is None or k == 0 else "replaced" if k in replaced else \
                "odometry" if r.matched == "odometry" else "match"
            f.write(f"{r.stamp:.6f},{r.anchor},{r.matched},{r.moving},{edge}\n")


def _run(args: argparse.Namespace) -> int:
    out = clitext.output_dir(args.out, make=False)
    relations = carmen.read_relations(args.relations) if args.relations else None
    slam = _slam(args)
    clitext.output_dir(out)
    with _progress(len(slam.nodes), args.quiet, "map") as bar:
        grid = slam.occupancy_map(args.resolution, progress=bar.update)
    grid.save(out / "map.yaml")
    stamps, poses = slam.trajectory()
    summary = (f"{len(stamps)} scans, {slam.graph.num_nodes} nodes, "
               f"{len(slam.loop_closures)} loop closures")
    write_figure(grid, np.asarray(poses), out / "map.png",
                 f"kit slam {Path(args.recording).name}: {summary}")
    trajectory = clitext.write_trajectory(out / f"trajectory.{args.format}", stamps, poses,
                                          args.format)
    write_g2o(slam.graph, out / "graph.g2o")
    write_closures(slam, out / "closures.csv")
    write_scans(slam, out / "scans.csv")
    print(f"{summary} of {len(slam.closures)} candidates; wrote {out}/map.yaml, map.pgm, "
          f"map.png, {trajectory.name}, graph.g2o, closures.csv, scans.csv")
    if relations is not None:
        errors = evaluate.relation_errors(stamps, poses, relations)
        with (out / "errors.csv").open("w", encoding="utf-8") as f:
            f.write("t1,t2,translational_m,rotational_rad\n")
            for a, b, e, r in zip(relations.t1[errors.evaluated], relations.t2[errors.evaluated],
                                  errors.translational, errors.rotational, strict=True):
                f.write(f"{a:.6f},{b:.6f},{e:.6f},{r:.6f}\n")
        print(f"relations: {int(errors.evaluated.sum())} of {len(relations)} evaluated "
              f"(errors.csv); mean ± std:")
        print(evaluate.summarize(errors).line("all"))
        if np.any(np.abs(errors.span) <= 1.0):
            print(evaluate.summarize(errors, 1.0).line("≤ 1 s"))
    return 0


def main(argv: list[str] | None = None) -> int:
    """``kit slam ...`` on its own (the ``kit`` command is the usual way in)."""
    parser = argparse.ArgumentParser(prog="kit")
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["slam", *clitext.negative_values(sys.argv[1:] if argv is None
                                                               else argv)])
    return int(args.func(args))
