"""``kit slam LOG_OR_BAG [--relations FILE] [--format csv|tum] --out DIR``: SLAM over a
CARMEN log or a ROS bag.

Writes into ``DIR``:

* ``map.yaml`` + ``map.pgm``: a map_server map (Nav2's map_server and RViz open it);
* ``map.png``: the map with axes in metres and the path the robot took;
* ``trajectory.csv`` (``stamp,x,y,yaw``) or, with ``--format tum``, ``trajectory.tum``
  (``timestamp tx ty tz qx qy qz qw``, as evo and the TUM tools read it): every scan's
  optimised ``T_map_base``; a CARMEN log's stamps are its IPC timestamps;
* ``graph.g2o``: the optimised pose graph;
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
                        "graph.g2o[, errors.csv]")
    p.add_argument("--format", choices=clitext.TRAJECTORY_FORMATS, default="csv",
                   help="the trajectory's format (default csv; tum for evo)")
    p.add_argument("--relations", type=Path, help="Kümmerle et al. relations to score against")
    p.add_argument("--resolution", type=float, default=0.05, help="map cell size [m]")
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
        from kit.bag import check_topic

        check_topic(path, args.scan_topic, "sensor_msgs/msg/LaserScan", "--scan-topic")
        check_topic(path, args.odom_topic, "nav_msgs/msg/Odometry", "--odom-topic")
        recording = offline.read_bag_recording(path, args.scan_topic, args.odom_topic)
        with _progress(len(recording.scans), args.quiet, "slam") as bar:
            return offline.run_bag(recording, progress=bar.update)
    log = carmen.read_carmen(path)
    with _progress(len(log.lasers), args.quiet, "slam") as bar:
        return offline.run_carmen(log, progress=bar.update)


def write_png(grid: np.ndarray, path: Path) -> None:
    """The trinary grid as map_saver's grey levels (free 254, occupied 0, unknown 205),
    top row first: the image alone, one pixel a cell."""
    from PIL import Image

    image = np.full(grid.shape, 205, dtype=np.uint8)
    image[grid == 0] = 254
    image[grid == 100] = 0
    Image.fromarray(np.flipud(image)).save(path)


def write_figure(grid: Any, poses: np.ndarray, path: Path, title: str) -> None:
    """The map (cropped to its known cells) with axes in metres and the robot's path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from kit import viz

    fig, ax = plt.subplots(figsize=(9, 7))
    viz.plot_grid(grid.to_msg(), ax=ax, title=title, crop=True)
    if len(poses):
        ax.plot(poses[:, 0], poses[:, 1], color="tab:red", lw=1.0, label="optimised path")
        ax.plot(*poses[0, :2], "o", color="tab:red", label="start")
        ax.legend(loc="best", fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


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
    print(f"{summary}; wrote {out}/map.yaml, map.pgm, map.png, {trajectory.name}, graph.g2o")
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
