"""Real robots' own descriptions load through kit.robots.load, and their wheels match the
figures their makers publish.

Every URDF and xacro file in ``../shared/data/urdf`` and the TurtleBot 4's URDF (the
``/robot_description`` of the real bag in ``../shared/data/ros2-bags``) are loaded as they are;
nothing is renamed. The published figures and where they come from:

* TurtleBot 3 burger: wheel radius 0.033 m, separation 0.160 m — ROBOTIS,
  ``turtlebot3_node/param/burger.yaml`` (``wheels: separation: 0.160, radius: 0.033``) and the
  OpenCR firmware's ``turtlebot3_burger.h`` (``WHEEL_RADIUS 0.033``, ``WHEEL_SEPARATION
  0.160``); size 138 x 178 mm (L x W), ROBOTIS e-Manual, TurtleBot3 Specifications.
* TurtleBot 3 waffle and waffle pi: radius 0.033 m, separation 0.287 m — ROBOTIS OpenCR
  firmware ``turtlebot3_waffle.h`` (``WHEEL_SEPARATION 0.287 // meter (BURGER : 0.160, WAFFLE :
  0.287)``) and ``turtlebot3_node/param/waffle.yaml``; size 281 x 306 mm, e-Manual. The URDF
  puts the wheels at y = ±0.144 (0.288 m apart): 1 mm wider than the firmware's figure.
* TurtleBot 4 (iRobot Create 3 base): separation 0.233 m, radius 0.03575 m — iRobot,
  ``create3_sim/irobot_create_common/irobot_create_control/config/control.yaml``
  (``wheel_separation: 0.233``, ``wheel_radius: 0.03575``); wheel diameter 72 mm — TurtleBot 4
  User Manual, Features, Hardware Specifications (radius 0.036 m, to the millimetre).
* Neato: wheel diameter 70 mm, base width 248 mm — the XV-11 driver the comprobo course runs
  (``neato_node2/neato_driver``: ``WHEEL_DIAMETER = 70``, ``BASE_WIDTH = 248``, millimetres).
  The course's URDF (and its own Gazebo drive plugin, ``wheel_separation 0.235``) puts the
  wheels 0.235 m apart, 13 mm narrower than the driver's figure: the kit reports the URDF.
* Nav2's sam_bot: wheel_radius 0.10, base_width 0.31, wheel_ygap 0.025 — Nav2 documentation,
  "Setting Up The URDF" (the wheels at y = ±(base_width/2 + wheel_ygap) = ±0.18 m: 0.36 m).
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from kit import robots
from kit.robots import RobotDescription, RobotDescriptionError

pytestmark = pytest.mark.dataset

Loader = Callable[[Path, Path], RobotDescription]


def _noetic(model: str) -> Loader:
    def load(shared: Path, tmp: Path) -> RobotDescription:
        package = tmp / "turtlebot3_description"
        (package / "urdf").mkdir(parents=True, exist_ok=True)
        for f in (shared / "urdf" / "turtlebot3-ros1-noetic-xacro").iterdir():
            shutil.copy(f, package / "urdf")
        return robots.load(shared / "urdf" / "turtlebot3-ros1-noetic-xacro" /
                           f"turtlebot3_{model}.urdf.xacro",
                           package_paths={"turtlebot3_description": package})
    return load


def _file(relative: str, **kw: object) -> Loader:
    return lambda shared, tmp: robots.load(shared / relative, **kw)  # type: ignore[arg-type]


# id: (loader, published radius, its tolerance, published separation, its tolerance)
ROBOTS: dict[str, tuple[Loader, float, float, float, float]] = {
    "burger ROS 2": (_file("urdf/turtlebot3-ros2-plain/turtlebot3_burger.urdf"),
                     0.033, 1e-9, 0.160, 1e-9),
    "waffle ROS 2": (_file("urdf/turtlebot3-ros2-plain/turtlebot3_waffle.urdf"),
                     0.033, 1e-9, 0.287, 0.0015),
    "waffle pi ROS 2": (_file("urdf/turtlebot3-ros2-plain/turtlebot3_waffle_pi.urdf"),
                        0.033, 1e-9, 0.287, 0.0015),
    "burger ROS 2 xacro": (_file("urdf/turtlebot3-ros2-namespaced-xacro/turtlebot3_burger.urdf"),
                           0.033, 1e-9, 0.160, 1e-9),
    "burger ROS 2 xacro tb3_0/": (_file(
        "urdf/turtlebot3-ros2-namespaced-xacro/turtlebot3_burger.urdf",
        xacro_args={"namespace": "tb3_0/"}), 0.033, 1e-9, 0.160, 1e-9),
    "waffle ROS 2 xacro": (_file("urdf/turtlebot3-ros2-namespaced-xacro/turtlebot3_waffle.urdf"),
                           0.033, 1e-9, 0.287, 0.0015),
    "burger ROS 1 xacro": (_noetic("burger"), 0.033, 1e-9, 0.160, 1e-9),
    "waffle ROS 1 xacro": (_noetic("waffle"), 0.033, 1e-9, 0.287, 0.0015),
    "burger from its Gazebo bag": (_file("ros2-bags/turtlebot3-burger-gazebo-walker"),
                                   0.033, 1e-9, 0.160, 1e-9),
    "turtlebot4 from its bag": (_file("ros2-bags/turtlebot4-real-olin-mac-first-floor"),
                                0.03575, 1e-9, 0.233, 1e-9),
    "neato": (_file("urdf/neato-comprobo/neato.urdf"), 0.035, 1e-9, 0.248, 0.015),
    "sam_bot": (_file("urdf/sam-bot-nav2-tutorial/sam_bot_description.urdf"),
                0.10, 1e-9, 2 * (0.31 / 2 + 0.025), 1e-9),
}


@pytest.mark.parametrize("robot", list(ROBOTS))
def test_wheel_radius_and_separation_match_the_published_figures(robot, shared_data,
                                                                 tmp_path):
    loader, radius, radius_tol, separation, separation_tol = ROBOTS[robot]
    r = loader(shared_data, tmp_path)
    assert r.wheel_radius == pytest.approx(radius, abs=radius_tol)
    assert r.wheel_separation == pytest.approx(separation, abs=separation_tol)
    assert r.assumed, "a bare URDF says nothing of limits: they are stated as assumed"
    assert any("drive wheels" in line for line in r.found)


def test_the_turtlebot4_wheel_is_the_72_mm_of_its_manual(shared_data, tmp_path):
    r = ROBOTS["turtlebot4 from its bag"][0](shared_data, tmp_path)
    assert abs(2 * r.wheel_radius - 0.072) <= 0.0005 + 1e-9     # 72 mm to the millimetre


def test_the_neato_urdf_and_its_own_drive_plugin_agree_on_235_mm(shared_data, tmp_path):
    r = ROBOTS["neato"][0](shared_data, tmp_path)
    assert r.wheel_separation == pytest.approx(0.235, abs=1e-9)
    assert not any("drive plugin says wheel_separation" in line for line in r.found)


def test_sam_bots_gazebo_plugin_disagreeing_with_its_geometry_is_reported(shared_data,
                                                                          tmp_path):
    r = ROBOTS["sam_bot"][0](shared_data, tmp_path)
    assert "note: the Gazebo drive plugin says wheel_separation 0.4 m; the joints and wheel " \
           "shapes say 0.36 m (the kit takes the geometry)" in r.found
    np.testing.assert_allclose(r.axle, [-0.12, 0.0])        # wheel_xoff: base_link ahead


@pytest.mark.parametrize("robot, length, width, length_tol", [
    ("burger ROS 2", 0.138, 0.178, 0.003),
    # the waffle's collision boxes leave out 11 mm of its length (bumper and camera mount)
    ("waffle ROS 2", 0.281, 0.306, 0.012),
])
def test_the_footprint_from_the_collision_shapes_is_the_published_size(robot, length, width,
                                                                        length_tol, shared_data,
                                                                        tmp_path):
    r = ROBOTS[robot][0](shared_data, tmp_path)
    assert np.ptp(r.footprint[:, 1]) == pytest.approx(width, abs=0.001)
    assert np.ptp(r.footprint[:, 0]) == pytest.approx(length, abs=length_tol)


@pytest.mark.parametrize("robot, frame, pose", [
    # /tf_static of the bags (their READMEs): base_link→rplidar_link (0.0039, 0, 0.1395), +90°
    ("turtlebot4 from its bag", "rplidar_link", (0.00393584, 0.0, math.pi / 2)),
    ("burger from its Gazebo bag", "base_scan", (-0.032, 0.0, 0.0)),
    ("neato", "base_laser_link", (-0.084, 0.0, math.pi)),
])
def test_the_lidar_is_mounted_where_the_description_puts_it(robot, frame, pose, shared_data,
                                                            tmp_path):
    r = ROBOTS[robot][0](shared_data, tmp_path)
    assert r.sensors["lidar"]["frame_id"] == frame
    x, y, yaw = r.sensor_mount("lidar")
    assert (x, y) == pytest.approx(pose[:2], abs=1e-9)
    assert math.cos(yaw - pose[2]) == pytest.approx(1.0)


def test_the_turtlebot4s_lidar_model_comes_from_its_bags_scans(shared_data, tmp_path):
    lidar = ROBOTS["turtlebot4 from its bag"][0](shared_data, tmp_path).sensors["lidar"]
    assert lidar["range_max"] == 12.0 and lidar["scan_rate"] == pytest.approx(7.43, abs=0.01)


def test_a_parameter_file_gives_what_the_urdf_does_not_hold(shared_data, tmp_path):
    """The e-Manual's burger limits (0.22 m/s, 2.84 rad/s) and the LDS-01's 5 Hz from a
    parameter file: used, and no longer listed as assumed."""
    params = tmp_path / "burger.toml"
    params.write_text('name = "burger"\n[drive]\nmax_linear_velocity = 0.22\n'
                      'max_angular_velocity = 2.84\n[sensors.lidar]\nscan_rate = 5.0\n'
                      '[footprint]\nradius = 0.105\n')
    r = robots.load(shared_data / "urdf/turtlebot3-ros2-plain/turtlebot3_burger.urdf",
                    parameters=params)
    assert (r.name, r.max_linear_velocity, r.max_angular_velocity) == ("burger", 0.22, 2.84)
    assert r.sensors["lidar"]["scan_rate"] == 5.0
    assert np.hypot(*r.footprint.T) == pytest.approx(0.105)
    assert not any(line.startswith(("max_linear_velocity", "max_angular_velocity"))
                   for line in r.assumed)
    params.write_text("[drive]\nmax_linear_velocity = -1\n")
    with pytest.raises(RobotDescriptionError, match=r"burger\.toml: \[drive\] "
                       r"max_linear_velocity must be a positive number; got -1"):
        robots.load(shared_data / "urdf/turtlebot3-ros2-plain/turtlebot3_burger.urdf",
                    parameters=params)


@pytest.mark.parametrize("relative", [
    "urdf/turtlebot3-ros2-plain/common_properties.urdf",
    "urdf/turtlebot3-ros1-noetic-xacro/common_properties.xacro",
    "urdf/turtlebot3-ros1-noetic-xacro/turtlebot3_burger.gazebo.xacro",
])
def test_files_that_other_files_include_are_refused_as_robots_with_a_reason(relative,
                                                                            shared_data):
    with pytest.raises(RobotDescriptionError, match="no <link> elements: this file describes "
                       "no robot"):
        robots.load(shared_data / relative)


def test_the_noetic_xacro_without_its_package_says_how_to_give_it(shared_data):
    with pytest.raises(RobotDescriptionError, match=r"--package-path turtlebot3_description="
                       r"DIR"):
        robots.load(shared_data / "urdf/turtlebot3-ros1-noetic-xacro/turtlebot3_burger.urdf"
                                  ".xacro")


def test_the_kits_toml_robots_can_point_at_a_xacro_file_with_its_arguments(shared_data,
                                                                           tmp_path):
    """A kit parameter file naming the namespaced TurtleBot 3 with [xacro] args and the
    wheels' own names in [wheels]."""
    source = shared_data / "urdf/turtlebot3-ros2-namespaced-xacro/turtlebot3_burger.urdf"
    uiabot = robots.load("uiabot").source.read_text()
    text = uiabot.replace('urdf = "uiabot.urdf"', f'urdf = "{source}"') + \
        '\n[xacro]\nargs = { namespace = "tb3_0/" }\n[wheels]\n' \
        'right_joint = "tb3_0/wheel_right_joint"\nleft_joint = "tb3_0/wheel_left_joint"\n'
    (tmp_path / "tb3.toml").write_text(text.replace('name = "uiabot"\n',
                                                    'name = "tb3"\nbase_frame = "tb3_0/base_'
                                                    'link"\n'))
    r = robots.load(tmp_path / "tb3.toml")
    assert (r.wheel_radius, r.wheel_separation, r.base_frame) == (0.033, 0.16, "tb3_0/base_link")
