"""``kit localize`` on real bags: what it says when it cannot localize, a negative start pose,
the TUM file evo reads, the bag of its estimates, the figure's start."""

from __future__ import annotations

import numpy as np
import pytest

from kit.cli import main as kit_main

NEATO = "ros2-bags/ros1-neato-real-olin-ac109/left_side.bag"
TB3 = "ros2-bags/turtlebot3-burger-gazebo-walker"


def _map(shared_data):
    return str(shared_data / "maps/turtlebot3-world-nav2/map.yaml")


@pytest.mark.dataset
def test_a_bag_without_the_base_frame_names_the_frame_and_writes_nothing(
        shared_data, tmp_path, capsys):
    """The real ROS 1 Neato bag has odom -> base_link, not Nav2's base_footprint: every scan is
    set aside; the command says so, names the bag's frame to use, and exits non-zero."""
    code = kit_main(["localize", str(shared_data / NEATO), "--map", _map(shared_data),
                     "--initial", "1.49,0.56,-2.48", "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert "left_side.bag: 174 scans, no filter update: the frame 'base_footprint' is not in " \
           "the bag's transforms (its frames: base_laser_link, base_link, odom), so none of " \
           "the 174 scans could be placed; name the bag's with --base-frame (the bag's child " \
           "of odom: base_link)" in err
    assert "Traceback" not in err
    assert not (tmp_path / "out").exists()


@pytest.mark.dataset
@pytest.mark.slow
def test_scans_that_de_skew_rejects_are_counted_and_the_way_round_named(
        shared_data, tmp_path, capsys):
    """With its base frame named, the Neato's scans still never reach the filter: their beams
    span 0.2 s, and the odometry's transforms do not cover them when each scan is taken up."""
    args = ["localize", str(shared_data / NEATO), "--map", _map(shared_data), "--initial",
            "1.49,0.56,-2.48", "--base-frame", "base_link", "--out", str(tmp_path / "out"),
            "--quiet"]
    assert kit_main(args) == 2
    assert "174 scans, no filter update: de-skew rejected 174 of 174 scans" in \
        capsys.readouterr().err
    assert kit_main([*args, "--no-deskew"]) == 0
    assert "174 scans," in capsys.readouterr().out


@pytest.mark.dataset
@pytest.mark.slow
def test_a_negative_start_a_tum_file_for_evo_and_a_bag_of_estimates(shared_data, tmp_path,
                                                                     capsys):
    """The Gazebo TurtleBot3 bag starts at odometry (-2.54, -0.36, -1.44): that start parses;
    evo reads poses.tum (one pose per scan with an estimate); localization/ holds /map
    (latched), /amcl_pose, /particlecloud and /tf, read with rosbags' Humble type store."""
    from evo.tools import file_interface
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    out = tmp_path / "out"
    assert kit_main(["localize", str(shared_data / TB3), "--map", _map(shared_data),
                     "--initial", "-2.5,-0.36,-1.44", "--seed", "0", "--format", "tum", "--bag",
                     "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "138 scans" in printed and "poses.tum, localization.png, localization/" in printed
    traj = file_interface.read_tum_trajectory_file(str(out / "poses.tum"))
    assert traj.num_poses == 138                     # the odometry covers every scan
    assert np.hypot(*(traj.positions_xyz[0, :2] - [-2.5, -0.36])) < 0.2
    store = get_typestore(Stores.ROS2_HUMBLE)
    counts: dict[str, int] = {}
    with AnyReader([out / "localization"], default_typestore=store) as reader:
        for conn, _, raw in reader.messages():
            message = reader.deserialize(raw, conn.msgtype)
            counts[conn.topic] = counts.get(conn.topic, 0) + 1
            if conn.topic == "/particlecloud":
                assert conn.msgtype == "geometry_msgs/msg/PoseArray"
                assert 0 < len(message.poses) <= 2000 and message.header.frame_id == "map"
            if conn.topic == "/map":
                assert conn.ext.offered_qos_profiles[0].durability.name == "TRANSIENT_LOCAL"
    updates = int(printed.split(" filter updates")[0].rsplit(" ", 1)[-1])
    assert counts == {"/map": 1, "/amcl_pose": updates, "/particlecloud": updates,
                      "/tf": updates}
    assert (out / "localization.png").stat().st_size > 10_000


def test_converged_from_is_the_first_step_under_the_spread():
    from kit.localization.cli import converged_from

    class Step:
        def __init__(self, std):
            self.pose, self.std = np.zeros(3), np.array(std)

    steps = [Step([3.0, 5.0, 1.0]), Step([0.2, 0.4, 0.1]), Step([0.2, 0.1, 0.1]),
             Step([0.1, 0.1, 0.1])]
    assert converged_from(steps) == 2
    assert converged_from(steps[:2]) is None
