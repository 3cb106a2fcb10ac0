"""The headless see–think–act demo.

The Uiabot follows a scripted route through the office — along the corridor, across the oil
patch, into an office and back — steering by its own wheel odometry (*see*: encoders → the
kit's odometry; *think*: turn towards the next waypoint; *act*: ``cmd_vel`` → inverse
kinematics → wheel servos). The demo writes a PNG (true path, odometry path, lidar returns)
and an MCAP ROS 2 bag with ``/scan``, ``/odom``, ``/imu``, ``/joint_states``, ``/cmd_vel``,
``/tf``, ``/tf_static`` and ``/clock`` (simulation time), and prints what it wrote.
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from kit import msgs
from kit.geometry import wrap_angle
from sim.bag import BagWriter
from sim.runner import (
    Node,
    Published,
    Runner,
    WheelOdometryNode,
    odometry_pose,
    pose_of,
    truth_pose,
)
from sim.simulation import Simulation

ROUTE = [(7.0, 6.0), (9.0, 6.0), (16.45, 6.0), (16.45, 8.5), (16.45, 6.2), (4.45, 6.2),
         (4.45, 9.0), (4.45, 6.0), (1.5, 6.0)]
"""Waypoints [m]: east along the corridor, stopping on the oil (where braking and starting
again slip), into the north-east office, back west, into the north-west office, and home."""

TOPICS = ("/scan", "/odom", "/imu", "/joint_states", "/cmd_vel", "/tf", "/tf_static")
"""What the demo's bag records."""

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
    error = float(wrap_angle(math.atan2(dy, dx) - pose[2]))
    w = max(-max_w, min(max_w, 2.0 * error))
    v = max_v * max(0.0, math.cos(error)) ** 4 * min(1.0, math.hypot(dx, dy) / 0.5)
    return v, w


class RouteFollower(Node):
    """The demo's controller at 10 Hz: steer by the odometry's pose to the next waypoint of
    ``ROUTE``, and wait while the lidar sees someone in the way."""

    subscriptions = ("/odom", "/scan")
    rate = 10.0

    def __init__(self) -> None:
        self.target = 0
        self.pose: np.ndarray | None = None
        self.last_scan: msgs.LaserScan | None = None
        self.limits = (0.0, 0.0)

    @property
    def done(self) -> bool:
        return self.target >= len(ROUTE)

    def start(self, sim: Simulation, robot: int) -> Published:
        d = sim.description(robot)
        self.target, self.pose, self.last_scan = 0, sim.ground_truth(robot).pose, None
        self.limits = (d.max_linear_velocity, d.max_angular_velocity)
        return ()

    def on_message(self, topic: str, message: Any, time: float) -> Published:
        if topic == "/odom":
            self.pose = odometry_pose(message)
        else:
            self.last_scan = message
        return ()

    def on_tick(self, time: float) -> Published:
        assert self.pose is not None, "start() comes first"
        if not self.done and math.dist(self.pose[:2], ROUTE[self.target]) < 0.2:
            self.target += 1
        v, w = (0.0, 0.0) if self.done else steer(self.pose, ROUTE[self.target], *self.limits)
        if blocked(self.last_scan):  # someone in the way: wait for them to step aside
            v = 0.0
        return [("/cmd_vel", msgs.Twist(msgs.Vector3(v, 0.0, 0.0), msgs.Vector3(0.0, 0.0, w)))]


class BagRecorder(Node):
    """Writes every message of its topics to a bag (when given one) and counts them."""

    def __init__(self, topics: tuple[str, ...], bag: BagWriter | None) -> None:
        self.subscriptions = topics
        self.bag = bag
        self.counts: dict[str, int] = {}

    def on_message(self, topic: str, message: Any, time: float) -> Published:
        self.counts[topic] = self.counts.get(topic, 0) + 1
        if self.bag is not None:
            self.bag.write(topic, message, round(time * 1e9))
        return ()


class ScanLog(Node):
    """Keeps each scan with the true pose it was taken from (for the figure)."""

    subscriptions = ("/scan",)

    def __init__(self) -> None:
        self.scans: list[tuple[np.ndarray, msgs.LaserScan]] = []
        self._sim: Simulation | None = None

    def start(self, sim: Simulation, robot: int) -> Published:
        self._sim, self.scans = sim, []
        return ()

    def on_message(self, topic: str, message: Any, time: float) -> Published:
        assert self._sim is not None, "start() comes first"
        self.scans.append((self._sim.ground_truth().pose, message))
        return ()


def run(seconds: float = 240.0, seed: int = 7, people: int = 4,
        bag_path: Path | None = None, nodes: Sequence[Node] = (),
        clock_period: float | None = 0.01) -> dict[str, object]:
    """Drive the route; returns paths, scans and counts (and writes the bag if asked, with
    ``/clock`` every ``clock_period`` simulated seconds). ``nodes`` run beside the drive's
    own (a live view, a :class:`sim.runner.ProgressNode`); they get ``/tf_static`` first."""
    sim = Simulation(world="office", robot="uiabot", seed=seed, people=people)
    bag = BagWriter(bag_path, clock_period=clock_period) if bag_path is not None else None
    recorder = BagRecorder(TOPICS, bag)
    follower = RouteFollower()
    scans = ScanLog()
    # the recorder comes after the odometry node, so it sees each step's /odom and /tf
    runner = Runner(sim, [WheelOdometryNode(), recorder, scans, *nodes], controller=follower,
                    signals={"truth": truth_pose(), "odometry": pose_of("/odom")})
    if bag is not None:
        bag.__enter__()
    try:
        for node in (recorder, *nodes):
            node.on_message("/tf_static", sim.static_transforms(), 0.0)
        recording = runner.run(seconds, until=lambda r: follower.done)
    finally:
        if bag is not None:
            bag.__exit__(None, None, None)
    truth, estimate = recording["truth"], recording["odometry"]
    estimate[0] = truth[0]  # odometry starts at the true pose, before its first message
    return {"sim": sim, "truth": truth, "odometry": estimate, "scans": scans.scans,
            "counts": recorder.counts, "reached": follower.target}


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
    laser = sim.description().joint("laser_joint")
    mount = (float(laser.xyz[0]), float(laser.xyz[1]), float(laser.rpy[2]))
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
    heading = math.degrees(abs(float(wrap_angle(truth[-1, 2] - est[-1, 2]))))
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
