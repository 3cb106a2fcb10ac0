"""Robots loaded from their own URDF, xacro file or bag drive in the simulator as their
descriptions say: wheels, lidar mount and outline.

* Kinematics: wheel speeds held for 3 s; the wheel angles the simulated encoders report,
  integrated with the exact-arc odometry of ``kit.odometry`` and the description's radius and
  separation (which ``tests/kit/test_robots_from_urdf.py`` compares with the published ones),
  land where the robot's wheel midpoint truly is.
* Lidar: the ranges of a scan (float64, before noise) are the analytic distances from the
  mount the URDF composes (the TurtleBot 4's turned +90°, the Neato's 180°) to the walls of
  the 10 m square room.
* Outline: driven into a wall, the robot touches it when the footprint taken from its
  collision shapes reaches the wall's face.
"""

from __future__ import annotations

import csv
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from kit import geometry, robots
from kit.odometry import odometry_step
from kit.robots import RobotDescription
from sim.simulation import Simulation

pytestmark = pytest.mark.dataset

FILES = {
    "burger ROS 2": "urdf/turtlebot3-ros2-plain/turtlebot3_burger.urdf",
    "waffle ROS 1 xacro": "urdf/turtlebot3-ros1-noetic-xacro/turtlebot3_waffle.urdf.xacro",
    "turtlebot4 bag": "ros2-bags/turtlebot4-real-olin-mac-first-floor",
    "neato": "urdf/neato-comprobo/neato.urdf",
    "sam_bot": "urdf/sam-bot-nav2-tutorial/sam_bot_description.urdf",
}


def noetic_package(shared_data: Path, tmp_path: Path) -> Path:
    package = tmp_path / "turtlebot3_description"
    (package / "urdf").mkdir(parents=True, exist_ok=True)
    for f in (shared_data / "urdf" / "turtlebot3-ros1-noetic-xacro").iterdir():
        shutil.copy(f, package / "urdf")
    return package


def load(name: str, shared_data: Path, tmp_path: Path) -> RobotDescription:
    packages = {"turtlebot3_description": noetic_package(shared_data, tmp_path)} \
        if "ROS 1" in name else None
    return robots.load(shared_data / FILES[name], package_paths=packages)


def box_range(x: float, y: float, angle: float, size: float = 10.0) -> float:
    """Distance from (x, y) inside [0, size]² along ``angle`` to the boundary."""
    c, s = math.cos(angle), math.sin(angle)
    hits = [t for t in ((size - x) / c if c > 1e-12 else math.inf,
                        -x / c if c < -1e-12 else math.inf,
                        (size - y) / s if s > 1e-12 else math.inf,
                        -y / s if s < -1e-12 else math.inf)]
    return min(hits)


@pytest.mark.parametrize("name", list(FILES))
def test_the_robot_moves_as_its_wheel_radius_and_separation_say(name, shared_data, tmp_path):
    d = load(name, shared_data, tmp_path)
    sim = Simulation("square", robot=d, seed=0, start=(5.0, 5.0, 0.3))
    axle = np.array([d.axle[0], d.axle[1], 0.0])        # the point the wheels move
    start = geometry.compose(sim.ground_truth().pose, axle)
    pose, last = start.copy(), None
    for topic, message in sim.run(3.0, (0.5 * d.max_wheel_speed, 0.2 * d.max_wheel_speed)):
        if topic == "/joint_states":
            position = np.asarray(message.position)
            if last is not None:
                d_right, d_left = (position - last) * d.wheel_radius
                pose = odometry_step(pose, d_right, d_left, d.wheel_separation, "exact")
            last = position
    truth = geometry.compose(sim.ground_truth().pose, axle)
    assert np.hypot(*(truth - start)[:2]) > 0.25            # it went somewhere
    assert abs(geometry.wrap_angle(truth[2] - start[2])) > 1.0   # and turned
    assert np.hypot(*(pose - truth)[:2]) < 0.005
    assert abs(geometry.wrap_angle(pose[2] - truth[2])) < 0.005


@pytest.mark.parametrize("name", list(FILES))
def test_the_lidar_sees_the_walls_from_the_mount_the_urdf_composes(name, shared_data,
                                                                   tmp_path):
    d = load(name, shared_data, tmp_path)
    start = np.array([4.0, 3.0, 0.3])
    sim = Simulation("square", robot=d, seed=0, start=start)
    sim.run(1.0, (0.0, 0.0))
    lidar = sim.robots[0].lidar
    assert lidar is not None and lidar.beams >= 360
    x, y, yaw = geometry.compose(start, np.array(d.sensor_mount("lidar")))
    angles = lidar.angle_min + lidar.increment * np.arange(lidar.beams)
    expected = np.array([box_range(x, y, yaw + a) for a in angles])
    seen = np.isfinite(lidar.last_ranges)
    assert seen.sum() > 50
    np.testing.assert_allclose(lidar.last_ranges[seen], expected[seen], atol=1e-9)
    assert np.all(expected[~seen] > lidar.range_max - 1e-9)   # the rest are out of range


@pytest.mark.parametrize("name", list(FILES))
def test_the_robot_touches_a_wall_when_its_footprint_reaches_it(name, shared_data, tmp_path):
    d = load(name, shared_data, tmp_path)
    front = float(d.footprint[:, 0].max())
    sim = Simulation("square", robot=d, seed=0, start=(9.8 - front, 5.0, 0.0))
    speed = 0.1 / d.wheel_radius                  # 0.1 m/s straight at the east wall
    for _ in range(400):
        sim.step((speed, speed))
        if sim.collisions:
            break
    assert sim.collisions and sim.collisions[0].other == "wall"
    reach = geometry.transform_points(sim.ground_truth().pose, d.footprint)[:, 0].max()
    assert reach == pytest.approx(10.0 - 0.02, abs=0.002)   # the wall's face: 2 cm radius


@pytest.mark.slow
def test_sim_navigate_takes_a_ros1_xacro_robot_with_its_package_and_parameters(shared_data,
                                                                             tmp_path):
    """The command line end to end: ``python -m sim navigate --robot FILE.urdf.xacro
    --package-path ... --robot-params ...`` runs the office tour with the TurtleBot 3."""
    package = noetic_package(shared_data, tmp_path)
    params = tmp_path / "burger.toml"
    params.write_text("[drive]\nmax_linear_velocity = 0.22\nmax_angular_velocity = 2.84\n")
    out = tmp_path / "rows.csv"
    done = subprocess.run(
        [sys.executable, "-m", "sim", "navigate", "--robot",
         str(package / "urdf" / "turtlebot3_burger.urdf.xacro"), "--package-path",
         f"turtlebot3_description={package}", "--robot-params", str(params), "--episodes", "1",
         "--people", "0", "--out", str(out)],
        capture_output=True, text=True, check=False, cwd=Path(__file__).resolve().parents[2])
    assert done.returncode == 0, done.stderr
    assert "office/tour, turtlebot3_burger, truth, rpp:" in done.stdout
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == 5
    assert sum(int(r["reached"]) for r in rows) >= 4
    assert all(int(r["collisions_static"]) == 0 for r in rows)


@pytest.mark.parametrize("args, message", [
    (["--robot", "nothere.urdf"], "nothere.urdf: no such file"),
    (["--robot", "turtlebot"], "'turtlebot' is neither a shipped robot"),
    (["--robot", "igv", "--xacro-arg", "a:=b"], "go with a robot file, not the shipped igv"),
    (["--robot", "x.urdf.xacro", "--package-path", "nodir"], "a package path is PACKAGE=DIR"),
])
def test_sim_navigate_refuses_a_bad_robot_in_one_line(args, message, tmp_path):
    done = subprocess.run([sys.executable, "-m", "sim", "navigate", *args, "--out",
                           str(tmp_path / "x.csv")], capture_output=True, text=True,
                          check=False, cwd=Path(__file__).resolve().parents[2])
    assert done.returncode == 2
    assert message in done.stderr and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
