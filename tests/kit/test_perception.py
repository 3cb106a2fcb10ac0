"""kit.perception: beams to points, checked against the simulator's analytic geometry."""

import numpy as np
import pytest

from kit import geometry, msgs, perception
from sim import Simulation


def test_points_of_a_simulated_scan_lie_on_the_walls_the_simulator_sees():
    sim = Simulation(world="square", robot="uiabot", seed=3, start=[2.0, 5.0, 0.3])
    scan = next(m for _ in range(200) for t, m in sim.step((0.0, 0.0)) if t.endswith("scan"))
    robot = sim.description()
    laser = robot.joint("laser_joint")
    T_base_laser = [laser.xyz[0], laser.xyz[1], laser.rpy[2]]
    pose = sim.ground_truth().pose  # still standing: no motion distortion
    T_world_laser = geometry.compose(pose, T_base_laser)
    points = perception.scan_to_points(scan, T_world_laser)
    assert len(points) == perception.valid_returns(scan).sum() > 300
    # the square world's walls are the lines x = 0, x = 10, y = 0, y = 10
    x, y = points.T
    to_wall = np.min(np.abs(np.stack([x, 10 - x, y, 10 - y])), axis=0)
    assert np.median(to_wall) < 0.03


def test_rep117_beams_become_no_points():
    scan = msgs.LaserScan(angle_min=-1.0, angle_increment=0.5, range_min=0.15, range_max=8.0,
                          ranges=np.array([np.inf, -np.inf, np.nan, 0.1, 9.0, 2.0]))
    assert perception.valid_returns(scan).tolist() == [False] * 5 + [True]
    assert perception.max_range_beams(scan).tolist() == [True, False, False, False, True,
                                                         False]
    np.testing.assert_allclose(perception.scan_to_points(scan),
                               [[2.0 * np.cos(1.5), 2.0 * np.sin(1.5)]])


def test_a_pose_of_the_wrong_shape_is_refused():
    scan = msgs.LaserScan(angle_increment=0.1, range_max=1.0, ranges=np.ones(3))
    with pytest.raises(ValueError, match="pose"):
        perception.scan_to_points(scan, pose=[1.0, 2.0])
