"""kit.urdf: URDF parsed, checked, and its frames composed from the root.

The composition is checked against two independent implementations of the same tree: the
kit's own transform tree (``kit.tf``, quaternions) and ROS's ``robot_state_publisher``, whose
``/tf_static`` the real TurtleBot 4 bag and the Gazebo TurtleBot 3 bag recorded.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from kit import description_files, robots, urdf
from kit.tf import RigidTransform, TransformTree
from kit.urdf import RobotDescriptionError

TB4_BAG = Path("ros2-bags/turtlebot4-real-olin-mac-first-floor")
TB3_BAG = Path("ros2-bags/turtlebot3-burger-gazebo-walker")

SUSPENDED = """<robot name="suspended">
  <link name="base_link"><collision><geometry><box size="0.3 0.2 0.1"/></geometry></collision>
  </link>
  <link name="drop_left"/><link name="left_wheel">
    <collision><geometry><cylinder radius="0.035" length="0.015"/></geometry></collision>
  </link>
  <joint name="drop_left_joint" type="prismatic"><parent link="base_link"/>
    <child link="drop_left"/><origin xyz="0 0.1165 0.04" rpy="-1.5707963267948966 0 0"/>
    <axis xyz="0 1 0"/><limit lower="0" upper="0.03" effort="0" velocity="0"/></joint>
  <joint name="left_wheel_joint" type="continuous"><parent link="drop_left"/>
    <child link="left_wheel"/><origin xyz="0 0 0"/><axis xyz="0 0 1"/></joint>
</robot>"""


def _tree(joints: tuple[urdf.Joint, ...]) -> TransformTree:
    tree = TransformTree()
    for j in joints:
        tree.set_static(j.parent, j.child, j.transform())
    return tree


def test_a_joint_under_a_suspension_joint_is_placed_by_the_composed_chain():
    model = urdf.parse(SUSPENDED, "suspended.urdf")
    wheel = model.joint("left_wheel_joint")
    assert wheel.xyz.tolist() == [0.0, 0.0, 0.0]          # its own origin says nothing
    T = model.transform("left_wheel", "base_link")
    np.testing.assert_allclose(T[:3, 3], [0.0, 0.1165, 0.04], atol=1e-12)
    np.testing.assert_allclose(T[:3, :3] @ wheel.axis, [0.0, 1.0, 0.0], atol=1e-12)
    assert [j.name for j in model.chain("left_wheel")] == ["drop_left_joint",
                                                            "left_wheel_joint"]
    assert model.roots() == ["base_link"]


def test_parsed_joints_carry_limits_mimic_and_unit_axes():
    text = SUSPENDED.replace('<axis xyz="0 0 1"/>', '<axis xyz="0 0 2"/><mimic joint="drop_left'
                             '_joint"/>')
    model = urdf.parse(text, "x.urdf")
    drop, wheel = model.joint("drop_left_joint"), model.joint("left_wheel_joint")
    assert (drop.lower, drop.upper) == (0.0, 0.03) and drop.velocity == math.inf
    assert wheel.axis.tolist() == [0.0, 0.0, 1.0] and wheel.mimic == "drop_left_joint"
    assert not wheel.xyz.flags.writeable


@pytest.mark.parametrize("text, message", [
    ("<robot name='x'><link name='a'></robot>", r"bad\.urdf: not well-formed XML"),
    ("<sdf version='1.6'><model name='m'/></sdf>", r"<sdf>, not <robot> \(an SDF model"),
    ("<robot name='x'><material name='m'/></robot>", "no <link> elements"),
    ("<robot name='x'><link name='a'/><link name='a'/></robot>", r"links defined twice: \['a'\]"),
    ("<robot name='x'><link name='a'><collision><geometry><box size='1 2'/></geometry>"
     "</collision></link></robot>", r"link 'a' <collision> 0 box size: expected 3"),
    ("<robot name='x'><link name='a'><collision><geometry><cylinder radius='-1' length='1'/>"
     "</geometry></collision></link></robot>", "cylinder: radius must be a positive number"),
    ("<robot name='x'><link name='a'><visual><geometry/></visual></link></robot>",
     "link 'a' <visual> 0: needs a <geometry>"),
    ("<robot name='x'><link name='${w}'/></robot>", r"still holds xacro \('\$\{w\}'"),
    ("<robot name='x' xmlns:xacro='http://ros.org/wiki/xacro'><xacro:property name='w' "
     "value='1'/><link name='a'/></robot>", r"still holds xacro \(<xacro:property>"),
    ("<robot name='x'><link name='a'/><link name='b'/><joint name='j' type='hinge'>"
     "<parent link='a'/><child link='b'/></joint></robot>", "joint 'j' has type 'hinge'"),
    ("<robot name='x'><link name='a'/><link name='b'/><joint name='j' type='continuous'>"
     "<parent link='a'/><child link='b'/><axis xyz='0 0 0'/></joint></robot>",
     r"joint 'j' has axis \[0.0, 0.0, 0.0\], which is no direction"),
    ("<robot name='x'><link name='a'/><link name='b'/><joint name='j' type='fixed'>"
     "<parent link='a'/><child link='b'/><origin xyz='0 0 nan'/></joint></robot>",
     "joint 'j' origin xyz: expected 3 finite numbers"),
    ("<robot name='x'><link name='a'/><link name='b'/><joint name='j' type='fixed'>"
     "<parent link='a'/><child link='c'/></joint></robot>", "'c', which is not defined"),
    ("<robot name='x'><link name='a'/><link name='b'/><link name='c'/>"
     "<joint name='j' type='fixed'><parent link='a'/><child link='c'/></joint>"
     "<joint name='k' type='fixed'><parent link='b'/><child link='c'/></joint></robot>",
     r"links with two parents: \['c'\]"),
    ("<robot name='x'><link name='a'/><link name='b'/>"
     "<joint name='j' type='fixed'><parent link='a'/><child link='b'/></joint>"
     "<joint name='k' type='fixed'><parent link='b'/><child link='a'/></joint></robot>",
     "the joints form a loop"),
    ("<robot name='x'><link name='a'/><link name='b'/><joint name='j' type='revolute'>"
     "<parent link='a'/><child link='b'/><mimic joint='nope'/></joint></robot>",
     "joint 'j' mimics 'nope', which is not defined"),
    ("<robot name='x'><link name='a'/><link name='b'/><joint name='j' type='revolute'>"
     "<parent link='a'/><child link='b'/><limit lower='x' upper='1' velocity='1'/></joint>"
     "</robot>", "joint 'j' <limit>: lower must be a number"),
])
def test_malformed_urdf_gets_a_message_naming_the_file_and_the_element(text, message):
    with pytest.raises(RobotDescriptionError, match=message) as info:
        urdf.parse(text, "bad.urdf")
    assert str(info.value).startswith("bad.urdf: ")


def test_floating_joints_are_left_out_with_a_note():
    text = ("<robot name='x'><link name='world'/><link name='base_link'/>"
            "<joint name='w' type='floating'><parent link='world'/><child link='base_link'/>"
            "</joint></robot>")
    model = urdf.parse(text, "x.urdf")
    assert model.joints == () and "'w' is floating" in model.notes[0]


def test_gazebo_sensors_and_the_drive_plugin_are_read():
    text = """<robot name="x"><link name="base_link"/><link name="laser"/>
      <joint name="j" type="fixed"><parent link="base_link"/><child link="laser"/></joint>
      <gazebo reference="laser"><sensor type="ray" name="lds"><update_rate>5</update_rate>
        <pose>0.01 0 0 0 0 0</pose>
        <ray><scan><horizontal><samples>360</samples><min_angle>0</min_angle>
        <max_angle>6.28</max_angle></horizontal></scan><range><min>0.12</min><max>3.5</max>
        </range><noise><stddev>0.01</stddev></noise></ray></sensor></gazebo>
      <gazebo><plugin name="d" filename="libgazebo_ros_diff_drive.so">
        <leftJoint>l</leftJoint><wheelSeparation>0.160</wheelSeparation></plugin></gazebo>
      </robot>"""
    model = urdf.parse(text, "x.urdf")
    (tag,) = model.sensors
    assert (tag.name, tag.type, tag.link, tag.rate) == ("lds", "ray", "laser", 5.0)
    assert dict(tag.values) == {"samples": 360.0, "min_angle": 0.0, "max_angle": 6.28,
                                "range_min": 0.12, "range_max": 3.5, "noise_std": 0.01}
    assert tag.pose[0, 3] == 0.01
    assert dict(model.drive_plugin) == {"left_joint": "l", "wheel_separation": "0.160"}


@pytest.mark.dataset
def test_composition_agrees_with_the_kits_own_transform_tree_for_every_link(shared_data,
                                                                           tmp_path):
    """pytransform3d's composed tree and kit.tf's, built from the same joints, agree on every
    link of every URDF in ../shared/data/urdf and of the TurtleBot 4's."""
    texts = []
    for path in sorted((shared_data / "urdf").rglob("*.urdf")):
        if path.name != "common_properties.urdf":
            texts.append((description_files.read_urdf(path)[0], str(path)))
    texts.append((description_files.read_bag_description(shared_data / TB4_BAG)[0], "tb4"))
    for text, source in texts:
        model = urdf.parse(text, source)
        tree = _tree(model.joints)
        root = model.roots()[0]
        for link in model.links:
            if link.name == root:
                continue
            T = model.transform(link.name, root)
            kit_T = tree.lookup_transform(root, link.name)
            np.testing.assert_allclose(T[:3, 3], kit_T.translation, atol=1e-12,
                                       err_msg=f"{source}: {link.name}")
            rotated = T[:3, :3] @ np.array([0.3, -0.2, 0.9])
            np.testing.assert_allclose(rotated, kit_T.apply([0.3, -0.2, 0.9]) -
                                       kit_T.translation, atol=1e-12)


def _tf_messages(bag: Path, topic: str) -> list[dict[tuple[str, str], RigidTransform]]:
    """Each message of ``topic`` as {(parent, child): transform}."""
    from kit import bag as kit_bag
    from kit import msgs

    out = []
    for _, _, message in kit_bag.read_bag(bag, topics=[topic]):
        assert isinstance(message, msgs.TFMessage)
        out.append({(t.header.frame_id, t.child_frame_id): RigidTransform.from_msg(t.transform)
                    for t in message.transforms})
    return out


@pytest.mark.dataset
def test_the_turtlebot4_urdf_composes_to_what_its_robot_state_publisher_published(shared_data):
    """The real TurtleBot 4 bag's first /tf_static message is robot_state_publisher's (KDL):
    each of its 33 transforms equals the composed transform of the bag's URDF. The second is
    the Create 3's own, and puts the wheels where the spring-loaded wheel-drop joints hold
    them: the composed wheel moved along the drop joint's axis, within its limits."""
    model = urdf.parse(description_files.read_bag_description(shared_data / TB4_BAG)[0], "tb4")
    publisher, create3 = _tf_messages(shared_data / TB4_BAG, "/tf_static")
    assert len(publisher) == 33
    for (parent, child), published in publisher.items():
        T = model.transform(child, parent)
        np.testing.assert_allclose(T[:3, 3], published.translation, atol=1e-9,
                                   err_msg=f"{parent} -> {child}")
        np.testing.assert_allclose(T[:3, :3] @ [1.0, 2.0, 3.0],
                                   published.apply([1.0, 2.0, 3.0]) - published.translation,
                                   atol=1e-9)
    np.testing.assert_allclose(publisher[("base_link", "rplidar_link")].translation,
                               [0.0039, 0.0, 0.1395], atol=1e-4)   # the bag's README
    for side in ("left", "right"):
        drop = model.joint(f"wheel_drop_{side}_joint")
        axis = model.transform(drop.child, "base_link")[:3, :3] @ drop.axis
        moved = create3[("base_link", f"{side}_wheel")].translation - \
            model.transform(f"{side}_wheel", "base_link")[:3, 3]
        extension = float(moved @ axis)
        np.testing.assert_allclose(moved, extension * axis, atol=1e-7)
        assert drop.lower <= extension <= drop.upper


@pytest.mark.dataset
def test_the_turtlebot3_urdf_composes_to_what_gazebo_published(shared_data):
    """The ROS 2 TurtleBot 3 burger file: base_footprint→base_link, base_link→base_scan on
    /tf_static and the wheels on /tf of the Gazebo bag (README: (0, ±0.08, 0.023))."""
    path = shared_data / "urdf" / "turtlebot3-ros2-plain" / "turtlebot3_burger.urdf"
    model = urdf.parse(path.read_text(), str(path))
    recorded = {pair: t for message in _tf_messages(shared_data / TB3_BAG, "/tf_static") +
                _tf_messages(shared_data / TB3_BAG, "/tf")[:50] for pair, t in message.items()}
    for pair in [("base_footprint", "base_link"), ("base_link", "base_scan"),
                 ("base_link", "wheel_left_link"), ("base_link", "wheel_right_link")]:
        np.testing.assert_allclose(model.transform(pair[1], pair[0])[:3, 3],
                                   recorded[pair].translation, atol=1e-6, err_msg=str(pair))
    np.testing.assert_allclose(recorded[("base_link", "wheel_left_link")].translation,
                               [0.0, 0.08, 0.023], atol=1e-6)


def test_a_robot_descriptions_frame_pose_composes_its_joints():
    uiabot = robots.load("uiabot")
    np.testing.assert_allclose(uiabot.frame_pose("laser_link"), [0.10, 0.0, 0.0])
    assert uiabot.sensor_mount("lidar") == (0.10, 0.0, 0.0)
    with pytest.raises(KeyError, match="no frame 'nope'"):
        uiabot.frame_pose("nope")
