"""kit.bag: what read_bag yields, write_bag takes — (topic, time_ns, message) — and the
bag reads back through rosbags with the ROS types."""

from __future__ import annotations

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
