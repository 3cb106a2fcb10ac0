"""kit.bag: what read_bag yields, write_bag takes — (topic, time_ns, message) — and the
bag reads back through rosbags with the ROS types."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kit import msgs
from kit.bag import read_bag, write_bag


def test_what_read_bag_yields_write_bag_takes(tmp_path):
    scan = msgs.LaserScan(header=msgs.Header(msgs.Time(3, 5), "laser_link"), angle_min=-1.0,
                          angle_increment=0.5, ranges=np.array([1.0, 2.0, np.inf]))
    imu = msgs.Imu(header=msgs.Header(msgs.Time(3, 7), "imu_link"))
    static = msgs.TFMessage((msgs.TransformStamped(msgs.Header(msgs.Time(3, 0), "base_link"),
                                                   "laser_link"),))
    triples = [("/tf_static", 3_000_000_000, static), ("/scan", 3_000_000_005, scan),
               ("/imu", 3_000_000_007, imu)]
    assert write_bag(tmp_path / "a", triples) == 3
    back = list(read_bag(tmp_path / "a"))
    assert [(t, ns) for t, ns, _ in back] == [(t, ns) for t, ns, _ in triples]
    assert np.array_equal(back[1][2].ranges, scan.ranges)
    assert back[0][2].transforms[0].child_frame_id == "laser_link"
    assert write_bag(tmp_path / "b", back) == 3  # and back in again, unchanged


def test_the_old_order_is_refused_with_a_clear_message(tmp_path):
    imu = msgs.Imu(header=msgs.Header(msgs.Time(1, 0), "imu_link"))
    with pytest.raises(TypeError, match=r"expected \(topic, time_ns, message\)"):
        write_bag(tmp_path / "c", [("/imu", imu, 1_000_000_000)])


DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "ros2-bags"


def _bag(tmp_path):
    scan = msgs.LaserScan(header=msgs.Header(msgs.Time(1, 0), "laser_link"),
                          ranges=np.array([1.0]))
    write_bag(tmp_path / "a", [("/scan", 1_000_000_000, scan),
                               ("/robot_description", 1_000_000_000, msgs.String("<robot/>"))])
    return tmp_path / "a"


def test_asking_for_topics_the_bag_lacks_names_the_bag_and_its_topics(tmp_path):
    """rosbags reads an empty connection list as "all of them": it must never get one."""
    bag = _bag(tmp_path)
    with pytest.raises(ValueError, match=r"a: no topic /nope in this bag; it has "
                       r"/robot_description \(std_msgs/msg/String, 1\), /scan "
                       r"\(sensor_msgs/msg/LaserScan, 1\)"):
        list(read_bag(bag, ["/nope"]))


def test_bag_topics_lists_each_topic_with_its_type_and_count(tmp_path):
    from kit.bag import bag_topics

    assert bag_topics(_bag(tmp_path)) == {"/scan": ("sensor_msgs/msg/LaserScan", 1),
                                          "/robot_description": ("std_msgs/msg/String", 1)}


@pytest.mark.dataset
def test_a_topic_of_a_type_the_kit_does_not_read_is_named():
    if not DATA.exists():
        _skip()
    with pytest.raises(ValueError, match="topic /rosout carries rcl_interfaces/msg/Log, which "
                       "the kit does not read"):
        list(read_bag(DATA / "mcap-talker-rosbag2-fixture", ["/rosout"]))


def _skip():
    pytest.skip("../shared/data is not beside the checkout")


def test_a_missing_path_and_a_file_that_is_no_bag_say_so(tmp_path):
    with pytest.raises(ValueError, match=r"nowhere: no such bag \(a rosbag2 folder"):
        list(read_bag(tmp_path / "nowhere"))
    (tmp_path / "notes.mcap").write_text("not a bag", encoding="utf-8")
    with pytest.raises(ValueError, match=r"notes.mcap: not a bag that can be read"):
        list(read_bag(tmp_path / "notes.mcap"))


@pytest.mark.dataset
def test_the_mcap_fixture_folder_yields_its_strings():
    """The rosbag2 fixture's metadata.yaml and MCAP channels spell the QoS differently, which
    makes rosbags' folder reader yield nothing; the kit reads the .mcap file itself."""
    if not DATA.exists():
        _skip()
    got = [(t, m.data) for t, _, m in read_bag(DATA / "mcap-talker-rosbag2-fixture")]
    assert got == [("/topic", f"Hello, world! {i}") for i in range(10)]
