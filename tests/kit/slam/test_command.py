"""``kit slam``'s command line: topics a bag lacks, the TUM trajectory evo reads, the map
figure with axes in metres."""

from __future__ import annotations

import numpy as np
import pytest

from kit import msgs
from kit.bag import write_bag
from kit.cli import main as kit_main


def _bag(path):
    scan = msgs.LaserScan(header=msgs.Header(msgs.Time(1, 0), "laser_link"),
                          angle_increment=0.1, range_max=5.0, ranges=np.ones(10))
    odom = msgs.Odometry(header=msgs.Header(msgs.Time(1, 0), "odom"), child_frame_id="base_link")
    write_bag(path, [("/front/scan", 1_000_000_000, scan), ("/odom", 1_000_000_000, odom)])
    return path


def test_a_scan_topic_the_bag_lacks_names_the_ones_it_has(tmp_path, capsys):
    bag = _bag(tmp_path / "bag")
    assert kit_main(["slam", str(bag), "--scan-topic", "/nope", "--out", str(tmp_path / "o"),
                     "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"kit: {bag}: no topic /nope; its LaserScan topics: /front/scan (choose one with " \
           f"--scan-topic)" in err
    assert kit_main(["slam", str(bag), "--scan-topic", "/front/scan", "--odom-topic", "/tf",
                     "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert "no topic /tf; its Odometry topics: /odom (choose one with --odom-topic)" in \
        capsys.readouterr().err
    assert not (tmp_path / "o").exists()


@pytest.mark.dataset
def test_a_bag_with_no_scan_at_all_lists_what_it_has(shared_data, tmp_path, capsys):
    """The rosbag2 MCAP fixture (talker strings, /rosout): no traceback, no empty success."""
    bag = shared_data / "ros2-bags/mcap-talker-rosbag2-fixture"
    assert kit_main(["slam", str(bag), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "no topic /scan, and no sensor_msgs/msg/LaserScan on any topic; it has " \
           "/parameter_events (rcl_interfaces/msg/ParameterEvent, 0), /rosout " \
           "(rcl_interfaces/msg/Log, 10), /topic (std_msgs/msg/String, 10)" in err
    assert "Traceback" not in err


@pytest.mark.dataset
@pytest.mark.slow
def test_the_trajectory_in_tum_format_reads_in_evo_and_the_map_figure_has_metres(
        shared_data, tmp_path):
    from evo.tools import file_interface
    from PIL import Image

    bag = shared_data / "ros2-bags/turtlebot3-burger-gazebo-walker"
    assert kit_main(["slam", str(bag), "--format", "tum", "--out", str(tmp_path),
                     "--quiet"]) == 0
    traj = file_interface.read_tum_trajectory_file(str(tmp_path / "trajectory.tum"))
    assert traj.num_poses > 100
    assert np.all(np.diff(traj.timestamps) > 0)
    assert np.hypot(*np.ptp(traj.positions_xyz[:, :2], axis=0)) > 3.0   # it drove ~4.6 m
    assert not (tmp_path / "trajectory.csv").exists()
    # a figure, not the bare grid image: larger than the map's own cells
    with Image.open(tmp_path / "map.png") as png:
        assert png.size[0] > 500


def test_the_map_figure_is_cropped_to_the_walls_and_the_path_not_to_far_free_space(tmp_path):
    """A log's no-return beams clear free space out to the scanner's range (82 m on MIT
    CSAIL); the figure shows the building: its walls (0.5 m around) and the whole path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from kit.mapping import OccupancyGridMap
    from kit.slam.command import write_figure

    grid = OccupancyGridMap(0.1)
    scan = msgs.LaserScan(angle_min=-0.2, angle_increment=0.1, range_min=0.1, range_max=60.0,
                          ranges=np.array([2.0, 2.0, np.inf, 2.0, 2.0]))  # a beam with no return
    for _ in range(5):
        grid.insert_scan(scan, [0.0, 0.0, 0.0])
    poses = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    captured = {}
    close = plt.close
    with pytest.MonkeyPatch.context() as m:
        m.setattr(plt, "close", lambda fig: captured.setdefault("fig", fig))
        write_figure(grid, poses, tmp_path / "map.png", "walls")
    ax = captured["fig"].axes[0]
    close(captured["fig"])
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert x1 < 3.0 and x0 <= -1.5 + 1e-9      # the walls at 2 m, the path back to -1 m
    assert -1.0 < y0 < 0.0 < y1 < 1.0
    assert grid.to_msg().info.width * 0.1 > 55.0  # the map itself reaches the free beam's end
