import math

import numpy as np
import pytest

from kit import geometry, msgs, robots, rosconv
from kit.tf import (
    ConnectivityError,
    ExtrapolationError,
    RigidTransform,
    TransformTree,
    UnknownFrameError,
)


def pose_tf(x, y, yaw):
    return RigidTransform.from_pose2d([x, y, yaw])


def test_chain_lookup_equals_se2_composition():
    tree = TransformTree()
    tree.set_static("map", "odom", pose_tf(1.0, -2.0, 0.3))
    tree.set_transform("odom", "base_link", 5.0, pose_tf(2.0, 1.0, 1.2))
    tree.set_static("base_link", "laser_link", pose_tf(0.1, 0.0, math.pi / 2))
    expected = geometry.compose(geometry.compose([1.0, -2.0, 0.3], [2.0, 1.0, 1.2]),
                                [0.1, 0.0, math.pi / 2])
    np.testing.assert_allclose(tree.lookup_pose2d("map", "laser_link", 5.0), expected, atol=1e-12)
    # the other direction is the inverse
    np.testing.assert_allclose(tree.lookup_pose2d("laser_link", "map", 5.0),
                               geometry.inverse(expected), atol=1e-12)


def test_lookup_between_siblings_goes_through_common_parent():
    tree = TransformTree()
    tree.set_static("base_link", "laser_link", pose_tf(0.1, 0.0, 0.0))
    tree.set_static("base_link", "imu_link", pose_tf(-0.095, -0.095, 0.0))
    np.testing.assert_allclose(tree.lookup_pose2d("imu_link", "laser_link"), [0.195, 0.095, 0.0],
                               atol=1e-12)


def test_interpolates_between_samples_and_hits_samples_exactly():
    tree = TransformTree()
    tree.set_transform("odom", "base_link", 0.0, pose_tf(0.0, 0.0, 0.0))
    tree.set_transform("odom", "base_link", 1.0, pose_tf(1.0, 2.0, 1.0))
    np.testing.assert_allclose(tree.lookup_pose2d("odom", "base_link", 0.25), [0.25, 0.5, 0.25],
                               atol=1e-12)
    np.testing.assert_allclose(tree.lookup_pose2d("odom", "base_link", 1.0), [1.0, 2.0, 1.0],
                               atol=1e-12)
    # latest common time when none is given
    np.testing.assert_allclose(tree.lookup_pose2d("odom", "base_link"), [1.0, 2.0, 1.0],
                               atol=1e-12)


def test_time_outside_buffer_raises_extrapolation_error():
    tree = TransformTree()
    tree.set_transform("odom", "base_link", 1.0, pose_tf(0, 0, 0))
    tree.set_transform("odom", "base_link", 2.0, pose_tf(1, 0, 0))
    with pytest.raises(ExtrapolationError, match=r"odom -> base_link at t=2\.5"):
        tree.lookup_transform("odom", "base_link", 2.5)
    with pytest.raises(ExtrapolationError):
        tree.lookup_transform("odom", "base_link", msgs.Time(0, 500_000_000))


def test_cache_time_drops_old_samples():
    tree = TransformTree(cache_time=1.0)
    for t in range(5):
        tree.set_transform("odom", "base_link", float(t), pose_tf(t, 0, 0))
    with pytest.raises(ExtrapolationError):
        tree.lookup_transform("odom", "base_link", 1.0)
    assert tree.lookup_pose2d("odom", "base_link", 3.5)[0] == pytest.approx(3.5)


def test_unknown_frame_and_disconnected_trees_have_clear_errors():
    tree = TransformTree()
    tree.set_static("base_link", "laser_link", pose_tf(0.1, 0, 0))
    tree.set_static("world", "sun", pose_tf(0, 0, 0))
    with pytest.raises(UnknownFrameError, match=r"'lidar'.*known frames"):
        tree.lookup_transform("base_link", "lidar")
    with pytest.raises(ConnectivityError, match="not connected"):
        tree.lookup_transform("laser_link", "sun")


def test_second_parent_and_loops_are_refused():
    tree = TransformTree()
    tree.set_static("base_link", "laser_link", pose_tf(0.1, 0, 0))
    with pytest.raises(ValueError, match="two parents"):
        tree.set_static("odom", "laser_link", pose_tf(0, 0, 0))
    with pytest.raises(ValueError, match="loop"):
        tree.set_static("laser_link", "base_link", pose_tf(0, 0, 0))
    with pytest.raises(ValueError, match="leading '/'"):
        tree.set_static("/map", "odom", pose_tf(0, 0, 0))


def test_non_unit_quaternion_in_message_is_refused():
    bad = msgs.Transform(rotation=msgs.Quaternion(0, 0, 0, 2.0))
    with pytest.raises(ValueError, match="unit quaternion"):
        RigidTransform.from_msg(bad)


def test_rep105_tree_of_the_uiabot():
    robot = robots.load("uiabot")
    tree = robot.transform_tree()
    tree.set_transform("odom", "base_link", 0.0, pose_tf(1.0, 2.0, math.pi / 2))
    laser = tree.lookup_transform("map", "laser_link", 0.0)
    # the lidar sits 0.10 m ahead of base_link and 0.13 m up; the robot faces +y
    np.testing.assert_allclose(laser.translation, [1.0, 2.1, 0.13], atol=1e-12)
    assert tree.parent("base_footprint") == "base_link"
    assert tree.parent("base_link") == "odom"
    assert tree.parent("odom") == "map"
    np.testing.assert_allclose(tree.lookup_transform("base_link", "base_footprint").translation,
                               [0, 0, -0.05])


@pytest.mark.dataset
def test_real_turtlebot4_tf_stream_gives_published_lidar_mounting(shared_data):
    """Feed the real robot's /tf_static and /tf into the tree and check the README's facts."""
    from rosbags.highlevel import AnyReader

    bag = shared_data / "ros2-bags" / "turtlebot4-real-olin-mac-first-floor"
    tree = TransformTree(cache_time=100.0)
    first_tf = None
    with AnyReader([bag], default_typestore=rosconv.typestore()) as reader:
        conns = [c for c in reader.connections if c.topic in ("/tf", "/tf_static")]
        for conn, _t, raw in reader.messages(connections=conns):
            m = rosconv.from_ros(reader.deserialize(raw, conn.msgtype))
            tree.add_message(m, static=conn.topic == "/tf_static")
            if conn.topic == "/tf" and first_tf is None:
                first_tf = m
    mount = tree.lookup_transform("base_link", "rplidar_link")
    np.testing.assert_allclose(mount.translation, [0.0039, 0.0, 0.1395], atol=1e-4)
    assert float(geometry.quaternion_to_yaw(mount.rotation)) == pytest.approx(math.pi / 2, abs=1e-3)
    ts = next(t for t in first_tf.transforms if t.child_frame_id == "base_link")
    first = tree.lookup_transform("odom", "base_link", ts.header.stamp)
    np.testing.assert_allclose(first.translation, [6.5396, -8.8584, 0.0518], atol=1e-4)
