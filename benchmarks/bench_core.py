"""Throughput of the kit's core pieces on this machine. Run: python benchmarks/bench_core.py

Prints one line per measurement: the median of several repeats.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

import numpy as np

from kit import kinematics, msgs, odometry, robots, rosconv
from kit.tf import RigidTransform
from sim import DiffDriveModel, drive_square


def best_rate(fn: Callable[[], int], repeats: int = 5) -> float:
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        n = fn()
        rates.append(n / (time.perf_counter() - start))
    return statistics.median(rates)


def main() -> None:
    rng = np.random.default_rng(0)
    phi = rng.uniform(-20, 20, (1_000_000, 2))
    rate = best_rate(lambda: len(kinematics.forward_kinematics(phi, 0.05, 0.1805)))
    print(f"forward kinematics, vectorised:         {rate / 1e6:8.1f} M wheel pairs/s")
    rate = best_rate(lambda: sum(1 for p in phi[:20_000]
                                 if kinematics.forward_kinematics(p, 0.05, 0.1805) is not None))
    print(f"forward kinematics, one call per pair:  {rate / 1e3:8.1f} k calls/s")

    dr, dl = rng.uniform(0, 0.01, (2, 1_000_000))
    rate = best_rate(lambda: len(odometry.integrate_odometry(dr, dl, 0.39)))
    print(f"odometry integration, vectorised:       {rate / 1e6:8.1f} M steps/s")

    eddie = robots.load("eddie")

    def node_updates() -> int:
        node = odometry.WheelOdometry.for_robot(eddie)
        for i in range(5000):
            node.update(3 * i, 2 * i, 0.01 * i)
        return 5000

    rate = best_rate(node_updates)
    print(f"WheelOdometry node (ticks -> Odometry): {rate / 1e3:8.1f} k updates/s "
          f"(Eddie publishes at 20-50 Hz)")

    tree = robots.load("uiabot").transform_tree(cache_time=1e9)
    for i in range(1000):
        tree.set_transform("odom", "base_link", 0.01 * i, RigidTransform.from_pose2d([i, 0, 0]))
    times = rng.uniform(0, 9.99, 20_000)
    rate = best_rate(lambda: sum(1 for t in times
                                 if tree.lookup_transform("map", "laser_link", t) is not None))
    print(f"tf lookup map -> laser_link, interpolated: {rate / 1e3:5.1f} k lookups/s")

    scan = msgs.LaserScan(msgs.Header(msgs.Time(1, 0), "laser_link"), -np.pi, np.pi,
                          2 * np.pi / 360, 1 / 2000, 1 / 5.5, 0.15, 12.0,
                          rng.uniform(0.2, 12, 360).astype(np.float32),
                          np.zeros(360, np.float32))
    rate = best_rate(lambda: sum(1 for _ in range(2000)
                                 if rosconv.deserialize_cdr(rosconv.serialize_cdr(scan),
                                                            scan.ROS_TYPE) is not None))
    print(f"LaserScan (360 beams) CDR round trip:   {rate / 1e3:8.1f} k scans/s")

    def sim_run() -> int:
        model = DiffDriveModel(robots.load("uiabot"), seed=1)
        run = drive_square(model, side=2.0)
        return int(run["time"][-1] / 0.01)

    rate = best_rate(sim_run, repeats=3)
    print(f"kinematic model at 100 Hz:              {rate / 1e3:8.1f} k steps/s "
          f"= {rate / 100:,.0f}x real time")


if __name__ == "__main__":
    main()
