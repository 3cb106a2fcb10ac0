import math

import numpy as np
import pytest

from kit import robots
from kit.robots import RobotDescriptionError


def test_uiabot_numbers_with_errata_3_and_4_fixed():
    r = robots.load("uiabot")
    assert r.wheel_radius == 0.05
    assert r.wheel_separation == pytest.approx(0.361)
    assert r.wheel_separation / 2 == pytest.approx(0.1805)  # erratum 3: not the paper's 0.032 m
    assert r.joint("right_wheel_joint").xyz[1] == pytest.approx(-0.1805)  # erratum 4: y is left
    assert r.joint("left_wheel_joint").xyz[1] == pytest.approx(0.1805)
    np.testing.assert_allclose(r.joint("laser_joint").xyz, [0.10, 0.0, 0.13])
    np.testing.assert_allclose(r.joint("imu_joint").xyz, [-0.095, -0.095, 0.0475])
    assert r.gear_ratio == 20 and r.encoder_resolution == 20480
    assert r.ticks_per_wheel_turn == 409600
    assert r.sensors["lidar"]["baudrate"] == 115200  # erratum 10
    assert r.sensors["lidar"]["samples_per_second"] == 2000  # erratum 11


def test_igv_and_eddie_numbers_from_the_papers():
    igv, eddie = robots.load("igv"), robots.load("eddie")
    assert igv.wheel_radius == 0.16 and igv.wheel_separation == pytest.approx(0.72)
    assert igv.encoder_resolution == 400
    assert igv.max_wheel_speed * 60 / (2 * math.pi) == pytest.approx(110.0)
    assert igv.parameters["drive"]["right_drive_address"] == 0x3F
    assert igv.parameters["drive"]["left_drive_address"] == 0x3E
    assert eddie.wheel_radius == pytest.approx(0.0762)
    assert eddie.wheel_separation == pytest.approx(0.39)
    assert eddie.ticks_per_wheel_turn == 144
    assert eddie.metres_per_tick == pytest.approx(math.pi * 0.1524 / 144)


@pytest.mark.parametrize("name", robots.ROBOTS)
def test_static_transforms_cover_rep105_children(name):
    r = robots.load(name)
    children = {t.child_frame_id for t in r.static_transforms()}
    assert {"base_footprint", "laser_link", "right_wheel_link", "left_wheel_link"} <= children
    assert all(t.header.frame_id == "base_link" for t in r.static_transforms())
    assert r.footprint.shape[1] == 2 and not r.footprint.flags.writeable


def test_description_is_frozen():
    r = robots.load("eddie")
    with pytest.raises(AttributeError):
        r.wheel_radius = 1.0


def write_robot(tmp_path, urdf_text, toml_extra=""):
    (tmp_path / "bot.urdf").write_text(urdf_text)
    base = (robots.load("uiabot").source.read_text().replace('urdf = "uiabot.urdf"',
                                                             'urdf = "bot.urdf"'))
    (tmp_path / "bot.toml").write_text(base + toml_extra)
    return tmp_path / "bot.toml"


def test_missing_file_names_the_file(tmp_path):
    with pytest.raises(RobotDescriptionError, match=r"nothere\.toml: no such"):
        robots.load(tmp_path / "nothere.toml")
    with pytest.raises(RobotDescriptionError, match="neither a shipped robot"):
        robots.load("turtlebot")


def test_malformed_xml_names_the_file(tmp_path):
    path = write_robot(tmp_path, "<robot name='x'><link name='a'></robot>")
    with pytest.raises(RobotDescriptionError, match=r"bot\.urdf: not well-formed XML"):
        robots.load(path)


def test_joint_to_undefined_link_and_missing_wheel_are_named(tmp_path):
    uiabot_urdf = (robots.load("uiabot").source.parent / "uiabot.urdf").read_text()
    path = write_robot(tmp_path, uiabot_urdf.replace('<child link="laser_link"/>',
                                                     '<child link="lidar"/>'))
    with pytest.raises(RobotDescriptionError, match="'lidar', which is not defined"):
        robots.load(path)
    path = write_robot(tmp_path, uiabot_urdf.replace("left_wheel_joint", "lw"))
    with pytest.raises(RobotDescriptionError, match="no joint named 'left_wheel_joint'"):
        robots.load(path)


def test_right_wheel_on_the_left_is_refused(tmp_path):
    uiabot_urdf = (robots.load("uiabot").source.parent / "uiabot.urdf").read_text()
    swapped = uiabot_urdf.replace('xyz="0 -0.1805 0"', "TMP").replace(
        'xyz="0 0.1805 0"', 'xyz="0 -0.1805 0"').replace("TMP", 'xyz="0 0.1805 0"')
    with pytest.raises(RobotDescriptionError, match="REP-103"):
        robots.load(write_robot(tmp_path, swapped))


def test_bad_toml_and_bad_values_name_the_file(tmp_path):
    (tmp_path / "bad.toml").write_text("name = [unclosed")
    with pytest.raises(RobotDescriptionError, match=r"bad\.toml: not valid TOML"):
        robots.load(tmp_path / "bad.toml")
    uiabot_urdf = (robots.load("uiabot").source.parent / "uiabot.urdf").read_text()
    path = write_robot(tmp_path, uiabot_urdf)
    path.write_text(path.read_text().replace("gear_ratio = 20.0", "gear_ratio = -20.0"))
    with pytest.raises(RobotDescriptionError, match="gear_ratio must be a positive"):
        robots.load(path)


def test_cruise_velocity_is_the_top_speed_unless_a_slower_one_is_given(tmp_path):
    uiabot, igv = robots.load("uiabot"), robots.load("igv")
    assert uiabot.cruise_velocity == uiabot.max_linear_velocity == 0.5
    assert igv.max_linear_velocity == 1.8 and igv.cruise_velocity == 0.8
    uiabot_urdf = (uiabot.source.parent / "uiabot.urdf").read_text()
    for bad in ("0.0", "0.6", "true", '"fast"'):   # the Uiabot's top speed is 0.5 m/s
        path = write_robot(tmp_path, uiabot_urdf, f"\n[navigation]\ncruise_velocity = {bad}\n")
        with pytest.raises(RobotDescriptionError, match=r"bot\.toml: \[navigation\] cruise"):
            robots.load(path)
    path = write_robot(tmp_path, uiabot_urdf, "\n[navigation]\ncruise_velocity = 0.3\n")
    assert robots.load(path).cruise_velocity == 0.3


@pytest.mark.dataset
def test_parses_the_real_turtlebot3_urdf(shared_data, tmp_path):
    """Our URDF reader on ROBOTIS' own file: the README's wheel geometry comes out."""
    src = shared_data / "urdf" / "turtlebot3-ros2-plain" / "turtlebot3_burger.urdf"
    text = src.read_text().replace("wheel_left_joint", "left_wheel_joint").replace(
        "wheel_right_joint", "right_wheel_joint")
    r = robots.load(write_robot(tmp_path, text))
    assert len(r.links) == 7 and len(r.joints) == 6
    assert r.wheel_separation == pytest.approx(0.160)
    assert r.wheel_radius == pytest.approx(0.033)
    np.testing.assert_allclose(r.joint("scan_joint").xyz, [-0.032, 0, 0.172])
