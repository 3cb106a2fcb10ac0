"""The headless see–think–act demo.

The Uiabot follows a scripted route through the office — along the corridor, across the oil
patch, into an office and back — steering by its own wheel odometry (*see*: encoders → the
kit's odometry; *think*: turn towards the next waypoint; *act*: ``cmd_vel`` → inverse
kinematics → wheel servos). The demo writes a PNG (true path, odometry path, lidar returns)
and an MCAP ROS 2 bag with ``/scan``, ``/odom``, ``/imu``, ``/joint_states``, ``/cmd_vel``,
``/tf`` and ``/tf_static``, and prints what it wrote.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np

from kit import msgs, odometry
from sim.bag import BagWriter
from sim.simulation import Simulation

ROUTE = [(7.0, 6.0), (9.0, 6.0), (16.45, 6.0), (16.45, 8.5), (16.45, 6.2), (4.45, 6.2),
         (4.45, 9.0), (4.45, 6.0), (1.5, 6.0)]
"""Waypoints [m]: east along the corridor, stopping on the oil (where braking and starting
again slip), into the north-east office, back west, into the north-west office, and home."""

SAFETY_DISTANCE = 0.45
"""The robot will not drive on while its lidar sees anything this close ahead [m]."""


def blocked(scan: msgs.LaserScan | None) -> bool:
    """Something within SAFETY_DISTANCE in the ±35° in front of the lidar."""
    if scan is None:
        return False
    ahead = np.abs(scan.angles()) < math.radians(35)
    r = scan.ranges[ahead]
    return bool(np.any(np.isfinite(r) & (r > 0) & (r < SAFETY_DISTANCE)))


def steer(pose: np.ndarray, goal: tuple[float, float], max_v: float, max_w: float
          ) -> tuple[float, float]:
    """Turn towards ``goal`` and drive when roughly facing it (a proportional controller)."""
    dx, dy = goal[0] - pose[0], goal[1] - pose[1]
    error = math.remainder(math.atan2(dy, dx) - pose[2], 2 * math.pi)
    w = max(-max_w, min(max_w, 2.0 * error))
    v = max_v * max(0.0, math.cos(error)) ** 4 * min(1.0, math.hypot(dx, dy) / 0.5)
    return v, w


def run(seconds: float = 240.0, seed: int = 7, people: int = 4,
        bag_path: Path | None = None) -> dict[str, object]:
    """Drive the route; returns paths, scans and counts (and writes the bag if asked)."""
    sim = Simulation(world="office", robot="uiabot", seed=seed, people=people)
    robot = sim.robots[0].description
    node = odometry.WheelOdometry.for_robot(robot)
    start = sim.ground_truth().pose
    # odometry starts at the robot's true start: odom coincides with the world there
    node.pose = start.copy()
    node.update(*sim.encoder_ticks(), 0.0)
    bag = BagWriter(bag_path) if bag_path is not None else None
    truth, estimate, scans = [start.copy()], [node.pose.copy()], []
    target, cmd = 0, msgs.Twist()
    last_scan: msgs.LaserScan | None = None
    counts: dict[str, int] = {}

    def record(topic: str, message: msgs.Message, time_ns: int | None = None) -> None:
        counts[topic] = counts.get(topic, 0) + 1
        if bag is not None:
            bag.write(topic, message, time_ns)

    if bag is not None:
        bag.__enter__()
    try:
        record("/tf_static", sim.static_transforms(), 0)
        steps = round(seconds / sim.physics.dt)
        for k in range(steps):
            if k % 10 == 0 and target < len(ROUTE):  # the controller runs at 10 Hz
                if math.dist(node.pose[:2], ROUTE[target]) < 0.2:
                    target += 1
                if target < len(ROUTE):
                    v, w = steer(node.pose, ROUTE[target], robot.max_linear_velocity,
                                 robot.max_angular_velocity)
                else:
                    v, w = 0.0, 0.0
                if blocked(last_scan):  # someone in the way: wait for them to step aside
                    v = 0.0
                cmd = msgs.Twist(msgs.Vector3(v, 0.0, 0.0), msgs.Vector3(0.0, 0.0, w))
                record("/cmd_vel", cmd, round(sim.time * 1e9))
            for topic, message in sim.step(cmd):
                record(topic, message)
                if topic == "/scan":
                    scans.append((sim.ground_truth().pose, message))
                    last_scan = message
                if topic == "/joint_states":  # the odometry node runs with the encoders
                    odom = node.update(*sim.encoder_ticks(), sim.time)
                    record("/odom", odom)
                    record("/tf", msgs.TFMessage((node.transform(sim.time),)),
                           round(sim.time * 1e9))
                    truth.append(sim.ground_truth().pose)
                    estimate.append(node.pose.copy())
            if target >= len(ROUTE) and k % 10 == 0:
                break
    finally:
        if bag is not None:
            bag.__exit__(None, None, None)
    return {"sim": sim, "truth": np.array(truth), "odometry": np.array(estimate),
            "scans": scans, "counts": counts, "reached": target}


def main(out_dir: Path, seed: int = 7) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sim import render

    out_dir.mkdir(parents=True, exist_ok=True)
    bag_path = out_dir / "demo_office"
    if bag_path.exists():
        shutil.rmtree(bag_path)
    result = run(seed=seed, bag_path=bag_path)
    sim = result["sim"]
    assert isinstance(sim, Simulation)
    truth = np.asarray(result["truth"])
    est = np.asarray(result["odometry"])
    fig, ax = plt.subplots(figsize=(11, 7))
    render.plot_world(sim.world, ax)
    mount = sim.robots[0].lidar.mount if sim.robots[0].lidar else (0.0, 0.0, 0.0)
    scans = list(result["scans"])  # type: ignore[call-overload]
    cloud = np.vstack([render.scan_points(scan, pose, mount) for pose, scan in scans[::5]])
    ax.scatter(cloud[:, 0], cloud[:, 1], s=1, color="tab:red", alpha=0.4,
               label="lidar returns (from true poses)")
    ax.plot(truth[:, 0], truth[:, 1], color="tab:blue", label="true path")
    ax.plot(est[:, 0], est[:, 1], color="tab:green", linestyle="--", label="wheel odometry")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title("Uiabot in the office: route steered by odometry, over the oil patch")
    png = out_dir / "demo_office.png"
    fig.savefig(png, dpi=100)
    plt.close(fig)
    error = float(np.linalg.norm(truth[-1, :2] - est[-1, :2]))
    heading = math.degrees(abs(math.remainder(truth[-1, 2] - est[-1, 2], 2 * math.pi)))
    print(f"Uiabot drove {sim.time:.1f} s through the office, {result['reached']} of "
          f"{len(ROUTE)} waypoints reached by odometry")
    print(f"final odometry error: {error:.3f} m, {heading:.1f} deg; collisions: "
          f"{len(sim.collisions)}")
    counts = result["counts"]
    assert isinstance(counts, dict)
    print("bag topics: " + ", ".join(f"{t} ({n})" for t, n in sorted(counts.items())))
    print(f"wrote {png}")
    print(f"wrote {bag_path}/ (MCAP ROS 2 bag)")
    return 0
