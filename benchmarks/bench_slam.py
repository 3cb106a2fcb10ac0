"""Mapping and SLAM figures: occupancy updates, scan-to-scan ICP on the CSAIL relations, pose
graphs against gtsam, and whole-log SLAM on CSAIL.

    .venv/bin/python benchmarks/bench_slam.py [--repeat 3] [--skip-csail]

Prints each figure as best and spread of ``--repeat`` runs, with the machine's load average.
The dataset parts need ``../shared/data`` beside the checkout (skipped otherwise); the gtsam
comparison needs ``gtsam`` (the ``dev`` extra).
"""

from __future__ import annotations

import argparse
import gzip
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from kit import geometry, mapping, msgs, perception
from kit.slam import carmen, evaluate, offline, pose_graph
from kit.slam import scan_matching as sm

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def spread(values: list[float]) -> str:
    return f"best {min(values):.4g}, worst {max(values):.4g} over {len(values)}"


def occupancy(repeat: int) -> None:
    rng = np.random.default_rng(0)
    scans = [msgs.LaserScan(angle_min=-np.pi, angle_increment=2 * np.pi / 360, range_min=0.15,
                            range_max=12.0, ranges=rng.uniform(0.5, 6.0, 360)) for _ in range(50)]
    poses = np.column_stack([rng.uniform(-1, 1, (50, 2)), rng.uniform(-3, 3, 50)])
    for compiled, n in ((True, 2000), (False, 20)):
        rates = []
        for _ in range(repeat):
            grid = mapping.OccupancyGridMap(0.05)
            grid.insert_scan(scans[0], poses[0], compiled)
            t = time.perf_counter()
            for k in range(n):
                grid.insert_scan(scans[k % 50], poses[k % 50], compiled)
            rates.append(n / (time.perf_counter() - t))
        name = "numba" if compiled else "plain Python"
        print(f"occupancy update, 360 beams (0.5-6 m) at 5 cm, {name}: "
              f"{max(rates):.0f} scans/s (worst {min(rates):.0f})")


def scan_to_scan(repeat: int) -> None:
    bench = DATA / "kummerle2009-slam-benchmark"
    log = carmen.read_carmen(bench / "mit-csail.clf.gz")
    rel = carmen.read_relations(bench / "mit-csail.relations")
    index = {round(t, 3): k for k, t in enumerate(log.laser_timestamps)}
    points = [perception.scan_to_points(carmen.laser_to_scan(r)) for r in log.lasers]
    odo = np.array([r.robot_pose for r in log.lasers])
    local = np.flatnonzero(np.abs(rel.t2 - rel.t1) <= 1.0)
    per_match = []
    for _ in range(repeat):
        trans, rot, times = [], [], []
        for k in local:
            i, j = index[round(rel.t1[k], 3)], index[round(rel.t2[k], 3)]
            guess = geometry.relative(odo[i], odo[j])
            t = time.perf_counter()
            result = sm.icp(points[j], points[i], guess, sm.ODOMETRY_PRIOR)
            times.append(time.perf_counter() - t)
            eps = geometry.compose(geometry.inverse(result.pose), rel.delta[k])
            trans.append(np.hypot(eps[0], eps[1]))
            rot.append(abs(float(geometry.wrap_angle(eps[2]))))
        per_match.append(1e3 * float(np.mean(times)))
    print(f"scan-to-scan ICP, CSAIL {len(local)} relations <= 1 s: "
          f"{np.mean(trans):.4f} ± {np.std(trans):.4f} m, "
          f"{np.degrees(np.mean(rot)):.3f} ± {np.degrees(np.std(rot)):.3f} deg; "
          f"mean ms/match {spread(per_match)} (median of the last run "
          f"{1e3 * np.median(times):.2f} ms)")


def _plain(path: Path, tmp: Path) -> Path:
    if path.suffix != ".gz":
        return path
    out = tmp / path.stem
    with gzip.open(path, "rb") as src, out.open("wb") as dst:
        shutil.copyfileobj(src, dst)
    return out


def pose_graphs(repeat: int) -> None:
    try:
        import gtsam
    except ImportError:
        gtsam = None
        print("gtsam not installed: pose graphs timed alone")
    with tempfile.TemporaryDirectory() as tmp:
        for name in ("intel.g2o", "manhattan.g2o", "city10000.g2o.gz"):
            path = _plain(DATA / "posegraphs-2d-sesync" / name, Path(tmp))
            ours, theirs = [], []
            for _ in range(repeat):
                g = pose_graph.read_g2o(path)
                t = time.perf_counter()
                result = g.optimize("gn", tolerance=1e-9)
                ours.append(time.perf_counter() - t)
                if gtsam is not None:
                    graph, initial = gtsam.readG2o(str(path), False)
                    graph.add(gtsam.PriorFactorPose2(0, initial.atPose2(0),
                                                     gtsam.noiseModel.Isotropic.Sigma(3, 1e-9)))
                    params = gtsam.GaussNewtonParams()
                    params.setRelativeErrorTol(1e-9)
                    t = time.perf_counter()
                    gtsam.GaussNewtonOptimizer(graph, initial, params).optimize()
                    theirs.append(time.perf_counter() - t)
            line = (f"pose graph {name}: {result.iterations} GN iterations, chi2 "
                    f"{result.cost:.6g}; ours {spread(ours)} s")
            if theirs:
                line += f"; gtsam GN {spread(theirs)} s; ratio of bests " \
                        f"{min(ours) / min(theirs):.2f}"
            print(line)


def csail(repeat: int) -> None:
    bench = DATA / "kummerle2009-slam-benchmark"
    log = carmen.read_carmen(bench / "mit-csail.clf.gz")
    rel = carmen.read_relations(bench / "mit-csail.relations")
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        slam = offline.run_carmen(log)
        times.append(time.perf_counter() - t)
    stamps, poses = slam.trajectory()
    errors = evaluate.relation_errors(stamps, poses, rel)
    span = log.laser_timestamps[-1] - log.laser_timestamps[0]
    print(f"CSAIL whole-log SLAM ({span:.0f} s of log, {len(log.lasers)} scans): "
          f"{spread(times)} s, {len(slam.nodes)} nodes, {len(slam.loop_closures)} closures")
    print("  " + evaluate.summarize(errors).line("all"))
    print("  " + evaluate.summarize(errors, 1.0).line("<= 1 s"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--skip-csail", action="store_true")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    occupancy(args.repeat)
    if not DATA.is_dir():
        print(f"{DATA} not found: dataset figures skipped")
        return
    scan_to_scan(args.repeat)
    pose_graphs(args.repeat)
    if not args.skip_csail:
        csail(1)
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
