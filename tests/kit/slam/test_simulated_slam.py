"""``kit slam`` on bags recorded in the simulator, scored against its ground truth: the map's
occupied cells against the world's walls, the trajectory against the true path, and the
glass-walled meeting room, which the lidar sees through, mapped as free space."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from kit import maps, msgs, odometry
from kit.cli import main as kit_main

pytestmark = pytest.mark.slow


def drive(world, route, bag_path, seconds, seed=3, people=0):
    """The Uiabot steered along ``route`` by its wheel odometry (as ``sim.demo`` does),
    recorded to an MCAP bag; returns the simulation and the true poses at 50 Hz."""
    from sim.bag import BagWriter
    from sim.demo import blocked, steer
    from sim.simulation import Simulation

    sim = Simulation(world=world, robot="uiabot", seed=seed, people=people)
    robot = sim.robots[0].description
    node = odometry.WheelOdometry.for_robot(robot)
    node.pose = sim.ground_truth().pose.copy()
    node.update(*sim.encoder_ticks(), 0.0)
    truth, target, cmd, last_scan = [sim.ground_truth().pose], 0, msgs.Twist(), None
    with BagWriter(bag_path) as bag:
        bag.write("/tf_static", sim.static_transforms(), 0)
        for k in range(round(seconds / sim.physics.dt)):
            if k % 10 == 0:
                if target < len(route) and math.dist(node.pose[:2], route[target]) < 0.2:
                    target += 1
                if target >= len(route):
                    break
                v, w = steer(node.pose, route[target], robot.max_linear_velocity,
                             robot.max_angular_velocity)
                cmd = msgs.Twist(msgs.Vector3(0.0 if blocked(last_scan) else v, 0.0, 0.0),
                                 msgs.Vector3(0.0, 0.0, w))
            for topic, message in sim.step(cmd):
                if topic == "/scan":
                    bag.write(topic, message)
                    last_scan = message
                elif topic == "/joint_states":
                    bag.write("/odom", node.update(*sim.encoder_ticks(), sim.time))
                    truth.append(sim.ground_truth().pose)
    return sim, np.array(truth)


def trajectory_error(out, truth):
    rows = np.array([[float(v) for v in r] for r in
                     list(csv.reader((out / "trajectory.csv").open()))[1:]])
    t = 0.02 * np.arange(len(truth))  # the truth's samples: t = 0, then every joint state
    x, y = (np.interp(rows[:, 0], t, truth[:, k]) for k in (0, 1))
    return np.hypot(rows[:, 1] - x, rows[:, 2] - y)


def cell_centres(grid, value):
    info = grid.info
    rows, cols = np.nonzero(grid.data.reshape(info.height, info.width) == value)
    return np.column_stack([info.origin.position.x + (cols + 0.5) * info.resolution,
                            info.origin.position.y + (rows + 0.5) * info.resolution])


def wall_distance(points, segments):
    best = np.full(len(points), np.inf)
    for x1, y1, x2, y2 in segments:
        a, e = np.array([x1, y1]), np.array([x2 - x1, y2 - y1])
        t = np.clip(((points - a) @ e) / (e @ e), 0, 1)
        best = np.minimum(best, np.hypot(*(points - (a + t[:, None] * e)).T))
    return best


def test_office_map_trajectory_and_glass_room(tmp_path):
    from sim.demo import ROUTE

    sim, truth = drive("office", ROUTE, tmp_path / "bag", 240.0, seed=1, people=2)
    assert kit_main(["slam", str(tmp_path / "bag"), "--out", str(tmp_path / "out"),
                     "--quiet"]) == 0
    error = trajectory_error(tmp_path / "out", truth)
    assert error.mean() <= 0.05
    grid = maps.read_map(tmp_path / "out" / "map.yaml")
    occupied = cell_centres(grid, 100)
    assert np.median(wall_distance(occupied, sim.world.lidar_segments)) <= 0.05
    # the meeting room behind glass (x 8..13, y 7..12): seen through, so free
    free = cell_centres(grid, 0)
    inside = (free[:, 0] > 8.2) & (free[:, 0] < 12.8) & (free[:, 1] > 7.2) & (free[:, 1] < 11.8)
    assert inside.sum() * 0.05**2 > 0.5 * 4.6 * 4.6
    glass = occupied[(np.abs(occupied[:, 1] - 7.0) < 0.1) & (occupied[:, 0] > 8.1) &
                     (occupied[:, 0] < 12.9)]
    assert len(glass) < 10  # no wall where the glass is


def test_office_slam_is_not_dragged_by_a_person_walking_with_the_robot(tmp_path):
    """Seed 8: a person walks along the office corridor about 1 m behind the robot, at its
    speed, for several seconds; the corridor gives no hold along its length. The person's
    returns land where the scans have seen free space and are dropped: the estimate stays
    on the truth (it fell 0.6 m behind when they drove the matches; 0.28 m at worst with
    the gates of this version but no dropping)."""
    from sim.demo import ROUTE

    _, truth = drive("office", ROUTE, tmp_path / "bag", 240.0, seed=8, people=2)
    assert kit_main(["slam", str(tmp_path / "bag"), "--out", str(tmp_path / "out"),
                     "--quiet"]) == 0
    error = trajectory_error(tmp_path / "out", truth)
    assert error.mean() <= 0.05
    assert error.max() <= 0.15
    scans = list(csv.DictReader((tmp_path / "out" / "scans.csv").open()))
    assert sum(int(s["moving"]) for s in scans) > 1000


def test_the_returns_dropped_as_moving_are_people_not_walls(tmp_path):
    """Against the simulator's own walls: of the returns SLAM dropped as moving (at its
    nodes, placed by the true poses), at least 95 % lie farther than 0.1 m from every wall
    and glass pane — they were people."""
    from kit import geometry
    from kit.slam import offline
    from sim.demo import ROUTE

    sim, truth = drive("office", ROUTE, tmp_path / "bag", 240.0, seed=3, people=2)
    slam = offline.run_bag(offline.read_bag_recording(tmp_path / "bag"))
    stamps = np.array([r.stamp for r in slam.records])
    t = 0.02 * np.arange(len(truth))
    distances = []
    for node in slam.nodes:
        stamp = stamps[node.scan_index]
        pose = [np.interp(stamp, t, truth[:, 0]), np.interp(stamp, t, truth[:, 1]),
                np.interp(stamp, t, np.unwrap(truth[:, 2]))]
        ends, _, _ = node.beams
        points = geometry.transform_points(pose, ends[node.moving])
        distances.append(wall_distance(points, sim.world.lidar_segments))
    d = np.concatenate(distances)
    assert len(d) > 500
    assert np.mean(d > 0.1) >= 0.95


def test_aisle_map_and_trajectory(tmp_path):
    route = [(10.0, 0.75), (20.0, 0.75), (29.25, 0.9), (29.25, 8.0), (29.25, 16.0)]
    sim, truth = drive("aisle", route, tmp_path / "bag", 120.0)
    assert kit_main(["slam", str(tmp_path / "bag"), "--out", str(tmp_path / "out"),
                     "--quiet"]) == 0
    assert trajectory_error(tmp_path / "out", truth).mean() <= 0.05
    occupied = cell_centres(maps.read_map(tmp_path / "out" / "map.yaml"), 100)
    assert np.median(wall_distance(occupied, sim.world.lidar_segments)) <= 0.05
