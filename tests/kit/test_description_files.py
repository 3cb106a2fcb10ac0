"""kit.description_files: xacro expanded with its arguments, ROS packages found without ROS,
a bag's /robot_description, meshes.

The xacro facts checked here are the data README's (``../shared/data/urdf/README.md``): the
namespaced TurtleBot 3 expands with ``namespace:=tb3_0/`` to 13 prefixed link and joint names
and 12 prefixed parent/child references, and with the default to the same kinematics as the
plain ROS 2 file; the ROS 1 noetic files need ``$(find turtlebot3_description)`` and, given
it, expand to that same kinematics.
"""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from kit import description_files, urdf
from kit.urdf import RobotDescriptionError

URDF = Path("urdf")
PLAIN = URDF / "turtlebot3-ros2-plain"
NAMESPACED = URDF / "turtlebot3-ros2-namespaced-xacro"
NOETIC = URDF / "turtlebot3-ros1-noetic-xacro"
TB4_BAG = Path("ros2-bags/turtlebot4-real-olin-mac-first-floor")


def kinematics(text: str) -> dict[str, tuple[str, str, str, list[float], list[float]]]:
    model = urdf.parse(text, "x")
    return {j.name: (j.type, j.parent, j.child, j.xyz.round(9).tolist(), j.rpy.round(9).tolist())
            for j in model.joints}


def ros_package(tmp_path: Path, shared_data: Path) -> Path:
    """The noetic files laid out as the ROS package they come from."""
    package = tmp_path / "turtlebot3_description"
    (package / "urdf").mkdir(parents=True)
    for f in (shared_data / NOETIC).iterdir():
        shutil.copy(f, package / "urdf")
    return package


def test_xacro_is_told_by_what_a_file_uses_not_by_its_name_or_namespace_declaration():
    assert not description_files.is_xacro(
        "<robot name='x' xmlns:xacro='http://ros.org/wiki/xacro'>"
        "<!-- <xacro:include filename='$(find p)/x.xacro'/> --><link name='a'/></robot>")
    assert description_files.is_xacro(
        "<robot name='x' xmlns:xacro='http://ros.org/wiki/xacro'><xacro:property name='w' "
        "value='1'/></robot>")
    assert description_files.is_xacro("<robot name='x'><link name='${prefix}a'/></robot>")
    assert description_files.is_xacro("<robot name='x'><link name='$(arg prefix)a'/></robot>")


@pytest.mark.dataset
def test_the_plain_ros2_turtlebot3_reads_as_it_is(shared_data):
    path = shared_data / PLAIN / "turtlebot3_burger.urdf"
    text, notes = description_files.read_urdf(path)
    assert text == path.read_text() and notes == ()


@pytest.mark.dataset
def test_the_namespaced_turtlebot3_expands_with_its_namespace_argument(shared_data):
    path = shared_data / NAMESPACED / "turtlebot3_burger.urdf"
    text, notes = description_files.read_urdf(path, {"namespace": "tb3_0/"})
    assert notes[0] == "expanded with xacro (namespace:=tb3_0/)"
    root = ET.fromstring(text)
    names = [e.get("name", "") for e in root.findall("link") + root.findall("joint")]
    refs = [e.get("link", "") for j in root.findall("joint") for e in j if e.tag in
            ("parent", "child")]
    assert len(names) == 13 and all(n.startswith("tb3_0/") for n in names)
    assert len(refs) == 12 and all(r.startswith("tb3_0/") for r in refs)
    default, _ = description_files.read_urdf(path)
    plain, _ = description_files.read_urdf(shared_data / PLAIN / "turtlebot3_burger.urdf")
    assert kinematics(default) == kinematics(plain)


@pytest.mark.dataset
def test_nav2s_sam_bot_is_xacro_named_urdf_and_expands_with_its_properties(shared_data):
    text, notes = description_files.read_urdf(
        shared_data / URDF / "sam-bot-nav2-tutorial" / "sam_bot_description.urdf")
    assert notes == ("expanded with xacro",)
    model = urdf.parse(text, "sam_bot")
    assert (len(model.links), len(model.joints)) == (9, 8)         # the README's counts
    # ${-(wheel_radius+wheel_zoff)} with wheel_radius 0.10, wheel_zoff 0.05
    np.testing.assert_allclose(model.joint("base_joint").xyz, [0.0, 0.0, -0.15], atol=1e-15)


@pytest.mark.dataset
def test_a_ros1_find_without_ros_is_a_clear_error_naming_the_package_and_the_way_to_give_it(
        shared_data):
    path = shared_data / NOETIC / "turtlebot3_burger.urdf.xacro"
    with pytest.raises(RobotDescriptionError) as info:
        description_files.read_urdf(path)
    assert str(info.value) == (
        f"{path}: $(find turtlebot3_description): the ROS package 'turtlebot3_description' is "
        f"not found without ROS; say where its folder is with --package-path "
        f"turtlebot3_description=DIR (in Python: package_paths={{'turtlebot3_description': DIR}};"
        f" or set KIT_PACKAGE_PATH=turtlebot3_description=DIR)")


@pytest.mark.dataset
@pytest.mark.parametrize("how", ["argument", "environment", "folder above"])
@pytest.mark.parametrize("model", ["burger", "waffle"])
def test_the_ros1_noetic_xacro_expands_given_its_package_to_the_plain_files_kinematics(
        shared_data, tmp_path, monkeypatch, how, model):
    package = ros_package(tmp_path, shared_data)
    monkeypatch.delenv(description_files.PACKAGE_PATH_VARIABLE, raising=False)
    if how == "argument":
        path, paths = shared_data / NOETIC / f"turtlebot3_{model}.urdf.xacro", \
            {"turtlebot3_description": package}
    elif how == "environment":
        path, paths = shared_data / NOETIC / f"turtlebot3_{model}.urdf.xacro", None
        monkeypatch.setenv(description_files.PACKAGE_PATH_VARIABLE,
                           f"other=/nowhere:turtlebot3_description={package}")
    else:
        path, paths = package / "urdf" / f"turtlebot3_{model}.urdf.xacro", None
    text, notes = description_files.read_urdf(path, package_paths=paths)
    assert f"xacro included common_properties.xacro, turtlebot3_{model}.gazebo.xacro" in notes
    plain, _ = description_files.read_urdf(shared_data / PLAIN / f"turtlebot3_{model}.urdf")
    assert kinematics(text) == kinematics(plain)
    sensors = {s.name: s for s in urdf.parse(text, "noetic").sensors}
    assert sensors["lds_lfcd_sensor"].values["samples"] == 360     # the Gazebo LDS-01


@pytest.mark.dataset
def test_an_xacro_argument_the_file_does_not_take_is_refused_with_the_ones_it_does(
        shared_data):
    with pytest.raises(RobotDescriptionError, match=r"turtlebot3_burger\.urdf: no xacro "
                       r"argument named 'nmspace'; it takes namespace$"):
        description_files.read_urdf(shared_data / NAMESPACED / "turtlebot3_burger.urdf",
                                    {"nmspace": "tb3_0/"})
    with pytest.raises(RobotDescriptionError, match=r"is plain URDF .* takes no xacro arguments"):
        description_files.read_urdf(shared_data / PLAIN / "turtlebot3_burger.urdf",
                                    {"namespace": "x"})


@pytest.mark.parametrize("body, message", [
    ("<link name='a${width}'/>", r"x\.xacro: xacro could not expand it: name 'width' is not "
                                 r"defined"),
    ("<xacro:include filename='nothere.xacro'/>", "No such file or directory"),
    ("<xacro:arg name='prefix'/><link name='$(arg prefix)a'/>", "xacro could not expand it"),
    ("<link name='$(arg prefix)a'/>", r"the xacro argument 'prefix' has no default; give it "
                                      r"with --xacro-arg prefix:=VALUE"),
])
def test_xacro_failures_name_the_file(tmp_path, body, message):
    path = tmp_path / "x.xacro"
    path.write_text(f"<robot name='x' xmlns:xacro='http://ros.org/wiki/xacro'>{body}</robot>")
    with pytest.raises(RobotDescriptionError, match=message) as info:
        description_files.read_urdf(path)
    assert str(info.value).startswith(f"{path}: ")


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(RobotDescriptionError, match=r"nothere\.urdf: no such file"):
        description_files.read_urdf(tmp_path / "nothere.urdf")


def test_command_line_forms_parse_and_bad_ones_say_the_form(tmp_path):
    assert description_files.parse_xacro_args(["namespace:=tb3_0/", "a:="]) == \
        {"namespace": "tb3_0/", "a": ""}
    assert description_files.parse_package_paths([f"p={tmp_path}"]) == {"p": tmp_path}
    with pytest.raises(ValueError, match="a xacro argument is NAME:=VALUE"):
        description_files.parse_xacro_args(["namespace=tb3_0/"])
    with pytest.raises(ValueError, match="a package path is PACKAGE=DIR"):
        description_files.parse_package_paths(["just_a_dir"])


def test_uris_resolve_to_files(tmp_path):
    package = tmp_path / "p"
    package.mkdir()
    near = tmp_path / "robot.urdf"
    assert description_files.resolve_uri("package://p/meshes/a.stl", near, {"p": package}) == \
        package / "meshes" / "a.stl"
    assert description_files.resolve_uri("file:///abs/a.stl", near) == Path("/abs/a.stl")
    assert description_files.resolve_uri("meshes/a.stl", near) == tmp_path / "meshes" / "a.stl"
    with pytest.raises(RobotDescriptionError, match=r"the package path given for 'p', .* is not "
                       "a folder"):
        description_files.package_directory("p", near, {"p": tmp_path / "missing"})


def test_mesh_vertices_are_read_and_scaled(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    trimesh.creation.box(extents=(2.0, 4.0, 6.0)).export(tmp_path / "box.stl")
    vertices = description_files.mesh_vertices(tmp_path / "box.stl", (0.5, 0.5, 0.5))
    np.testing.assert_allclose(vertices.max(axis=0), [0.5, 1.0, 1.5])
    with pytest.raises(RobotDescriptionError, match=r"nothere\.stl: no such mesh file"):
        description_files.mesh_vertices(tmp_path / "nothere.stl", (1, 1, 1))


@pytest.mark.dataset
def test_the_turtlebot4_bag_gives_its_urdf_and_its_lidars_model(shared_data):
    """The bag's README: robot 'turtlebot4'; /scan from rplidar_link, 720 beams from
    -3.1241393 to +3.1415927 rad, 0.15-12 m, scan_time 0.1345 s."""
    text, lidar = description_files.read_bag_description(shared_data / TB4_BAG)
    assert ET.fromstring(text).get("name") == "turtlebot4"
    assert lidar["frame_id"] == "rplidar_link" and lidar["topic"] == "/scan"
    beams = round((lidar["angle_max"] - lidar["angle_min"]) / lidar["angle_increment"]) + 1
    assert beams == 720
    assert (lidar["range_min"], lidar["range_max"]) == pytest.approx((0.15, 12.0))
    assert lidar["scan_rate"] == pytest.approx(1 / 0.1345, rel=1e-3)


@pytest.mark.dataset
def test_a_bag_without_the_topic_or_with_another_type_on_it_is_named(shared_data, tmp_path):
    with pytest.raises(RobotDescriptionError, match=r"no /nope topic \(the bag has /cmd_vel, "
                       r"/odom, /robot_description, /scan, /tf, /tf_static\)"):
        description_files.read_bag_description(shared_data / TB4_BAG, "/nope")
    with pytest.raises(RobotDescriptionError, match="/scan is sensor_msgs/msg/LaserScan, not "
                       "std_msgs/msg/String"):
        description_files.read_bag_description(shared_data / TB4_BAG, "/scan")
    (tmp_path / "x.mcap").write_bytes(b"not an mcap")
    with pytest.raises(RobotDescriptionError, match=r"x\.mcap: not a bag rosbags can read"):
        description_files.read_bag_description(tmp_path / "x.mcap")
    with pytest.raises(RobotDescriptionError, match=r"gone\.bag: no such bag"):
        description_files.read_bag_description(tmp_path / "gone.bag")


def test_a_package_in_the_same_source_tree_is_found_by_its_package_xml(tmp_path):
    """A cloned repository with two packages: the robot's file includes the other one's
    macro through $(find); the kit finds it by its package.xml and says so."""
    repo = tmp_path / "clone"
    for folder, name in (("robot_a", "robot_a_bringup"), ("common", "shared_parts")):
        (repo / folder / "urdf").mkdir(parents=True)
        (repo / folder / "package.xml").write_text(f"<package><name>{name}</name></package>")
    (repo / "common" / "urdf" / "parts.xacro").write_text(
        "<robot xmlns:xacro='http://ros.org/wiki/xacro'><xacro:macro name='box_link' "
        "params='name'><link name='${name}'/></xacro:macro></robot>")
    top = repo / "robot_a" / "urdf" / "robot.urdf.xacro"
    top.write_text("<robot name='a' xmlns:xacro='http://ros.org/wiki/xacro'><xacro:include "
                   "filename='$(find shared_parts)/urdf/parts.xacro'/><xacro:box_link "
                   "name='base_link'/></robot>")
    text, notes = description_files.read_urdf(top)
    assert urdf.parse(text, "a").links[0].name == "base_link"
    assert f"$(find shared_parts) taken as {repo / 'common'}, found in the source tree" in notes
    (repo / "common" / "urdf" / "parts.xacro").unlink()
    with pytest.raises(RobotDescriptionError, match=r"No such file or directory.*\$\(find "
                       r"shared_parts\) was taken as .*common, found in the source tree: where "
                       r"the package installs its files elsewhere, give --package-path "
                       r"shared_parts=DIR"):
        description_files.read_urdf(top)
