"""Scan-to-scan matchers side by side on the benchmark's local relations of the three logs.

    .venv/bin/python benchmarks/bench_scan_matchers.py [--logs csail intel fr079]

Every relation of at most 1 s whose two scans are in the log: the later scan is matched
against the earlier from the odometry's guess (CSAIL: its raw wheel odometry; Intel and
FR079, whose poses are already corrected: :func:`kit.slam.evaluate.perturb_odometry`
with seed 0), and the result is scored with the Kümmerle metric. Matchers, in the same run:

* the kit's point-to-line ICP, held by the odometry as a prior (``ODOMETRY_PRIOR``);
* the kit's correlative matcher (2 cm cells, σ 3 cm, ±0.3 m and ±20° at 0.25°, Karto's
  penalty 0.1, sub-cell refinement), the likelihood field built from the earlier scan;
* Karto's correlative matcher (PyPI ``karto-scanmatcher``, the ``dev`` extra; defaults:
  1 cm cells, smear 3 cm, ±0.3 m, ±20°), skipped when not installed.

Printed per matcher: mean ± std, median, matches off by more than 0.1 m and 0.2 m, mean
rotational error, CPU time per match. Needs ``../shared/data``.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from kit import geometry, perception
from kit.slam import carmen, correlative, evaluate
from kit.slam import scan_matching as sm
from kit.slam.frontend import thin

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
LOGS = {
    "csail": ("kummerle2009-slam-benchmark/mit-csail.clf.gz",
              "kummerle2009-slam-benchmark/mit-csail.relations", False),
    "intel": ("flirtlib-carmen-graph-logs/intel-lab.log.gz",
              "kummerle2009-slam-benchmark/intel.relations", True),
    "fr079": ("flirtlib-carmen-graph-logs/fr079.log.gz",
              "kummerle2009-slam-benchmark/fr079.relations", True),
}
Matcher = Callable[[int, int, np.ndarray], np.ndarray]


def kit_icp(points: list[np.ndarray]) -> Matcher:
    def match(i: int, j: int, guess: np.ndarray) -> np.ndarray:
        return sm.icp(points[j], points[i], guess, sm.ODOMETRY_PRIOR).pose
    return match


def kit_correlative(points: list[np.ndarray]) -> Matcher:
    def match(i: int, j: int, guess: np.ndarray) -> np.ndarray:
        field = correlative.likelihood_field(points[i], 0.02, 0.03, margin=0.5)
        return correlative.correlative_match(thin(points[j], 0.02), field, guess, 0.3,
                                             math.radians(20), math.radians(0.25), 4,
                                             penalty=0.1, subcell=True).pose
    return match


def karto(log: carmen.CarmenLog) -> Matcher | None:
    try:
        import karto_scanmatcher as k
    except ImportError:
        return None
    first = log.lasers[0]
    n = len(first.ranges)
    config = k.LaserScanConfig(first.angle_min, first.angle_min + first.angle_increment * (n - 1),
                               first.angle_increment, 0.0, 40.0, 40.0, "laser")
    wrapper = k.Wrapper(k.ScanMatcherConfig())

    def ranges(m: int) -> list[float]:
        r = log.lasers[m].ranges
        return [float(v) for v in np.where(r < 40.0, r, 0.0)]

    def match(i: int, j: int, guess: np.ndarray) -> np.ndarray:
        ref = k.LocalizedRangeScan(config, ranges(i), k.Pose2(0, 0, 0), k.Pose2(0, 0, 0), 0, 0.0)
        g = k.Pose2(*(float(v) for v in guess))
        scan = k.LocalizedRangeScan(config, ranges(j), g, g, 1, 0.0)
        best = wrapper.match_scan(scan, [ref], True, True).best_pose
        return np.array([best.x, best.y, best.yaw])
    return match


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--logs", nargs="+", default=list(LOGS), choices=list(LOGS))
    args = parser.parse_args()
    if not DATA.is_dir():
        print(f"{DATA} not found: nothing to measure")
        return 1
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    for name in args.logs:
        log_file, relations_file, perturbed = LOGS[name]
        log = carmen.read_carmen(DATA / log_file)
        rel = carmen.read_relations(DATA / relations_file)
        odometry = np.array([r.robot_pose for r in log.lasers])
        if perturbed:
            odometry = evaluate.perturb_odometry(odometry, 0)
        index = {round(t, 3): k for k, t in enumerate(log.laser_timestamps)}
        pairs = [(index[round(a, 3)], index[round(b, 3)], k)
                 for k, (a, b) in enumerate(zip(rel.t1, rel.t2, strict=True))
                 if round(a, 3) in index and round(b, 3) in index and abs(b - a) <= 1.0]
        points = [perception.scan_to_points(carmen.laser_to_scan(r)) for r in log.lasers]
        points = [p[np.hypot(p[:, 0], p[:, 1]) < 25.0] for p in points]
        matchers = {"kit ICP": kit_icp(points), "kit correlative": kit_correlative(points),
                    "Karto": karto(log)}
        for label, match in matchers.items():
            if match is None:
                print(f"{name} {label}: not installed (pip install karto-scanmatcher)")
                continue
            start = time.process_time()
            est = np.array([match(i, j, geometry.relative(odometry[i], odometry[j]))
                            for i, j, _ in pairs])
            cpu = time.process_time() - start
            eps = geometry.compose(geometry.inverse(est), rel.delta[[k for _, _, k in pairs]])
            e = np.hypot(eps[:, 0], eps[:, 1])
            r = np.degrees(np.abs(geometry.wrap_angle(eps[:, 2])))
            print(f"{name} {label:16s} {len(e)} relations ≤ 1 s: {e.mean():.4f} ± {e.std():.4f} "
                  f"m, median {np.median(e):.4f}, > 0.1 m: {(e > 0.1).sum()}, > 0.2 m: "
                  f"{(e > 0.2).sum()}, {r.mean():.3f}°; {1e3 * cpu / len(e):.2f} ms CPU per "
                  f"match", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
