"""What a navigation run's bag holds beside /plan: AMCL's pose and particles, the local plan,
both costmaps, the robot's URDF, /clock — read back with rosbags' Humble type store."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim import navtopics


def test_the_local_plan_is_the_plan_ahead_inside_the_local_costmap():
    path = np.column_stack([np.arange(0.0, 10.0, 0.5), np.zeros(20)])
    ahead = navtopics.local_plan(path, np.array([2.1, 0.1, 0.0]), half_width=1.5)
    assert ahead[0].tolist() == [2.0, 0.0] and ahead[-1].tolist() == [3.5, 0.0]
    assert len(navtopics.local_plan(np.zeros((0, 2)), np.zeros(3), 1.0)) == 0


def test_the_shipped_robots_urdf_is_what_robot_description_carries():
    from kit.robots import load

    xml = navtopics.robot_description_xml(load("uiabot"))
    assert xml is not None and "<robot" in xml and "laser_joint" in xml


@pytest.mark.slow
def test_a_navigation_bag_holds_what_nav2_publishes_in_humbles_types(tmp_path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    from kit.bag import BagWriter
    from sim import demo, scenarios
    from sim.runner import Runner, WheelOdometryNode
    from sim.simulation import Simulation
    from sim.world import load_world

    world = load_world("office")
    grid = world.occupancy_grid(0.05, layer="lidar")
    sim = Simulation(world=world, robot="uiabot", seed=3, people=0, start=(1.0, 6.0, 0.0))
    d = sim.description()
    loc = scenarios.AmclLocalization(grid, 3)
    node = scenarios.NavigationNode(scenarios.Navigator(grid, d), loc,
                                    [(14.0, 6.0, 0.0)], [60.0])
    topics = navtopics.NavigationTopics(node, navtopics.robot_description_xml(d))
    with BagWriter(tmp_path / "nav", clock_period=0.01) as bag:
        recorder = demo.BagRecorder(("/scan", "/tf", "/plan", *navtopics.TOPICS), bag)
        runner = Runner(sim, [WheelOdometryNode(), node, topics, recorder])
        recorder.on_message("/map", grid, 0.0)
        runner.run(12.0)
    store = get_typestore(Stores.ROS2_HUMBLE)
    seen: dict[str, list] = {}
    with AnyReader([tmp_path / "nav"], default_typestore=store) as reader:
        qos = {c.topic: c.ext.offered_qos_profiles[0].durability.name for c in reader.connections}
        for conn, t, raw in reader.messages():
            seen.setdefault(conn.topic, []).append((t, reader.deserialize(raw, conn.msgtype)))
    assert {"/clock", "/map", "/robot_description", "/amcl_pose", "/particlecloud",
            "/local_plan", "/plan", "/global_costmap/costmap",
            "/local_costmap/costmap"} <= seen.keys()
    for latched in ("/map", "/robot_description", "/global_costmap/costmap"):
        assert qos[latched] == "TRANSIENT_LOCAL"
    assert qos["/scan"] == qos["/particlecloud"] == "VOLATILE"
    # costmaps at Nav2's publish rates (1 Hz global, 2 Hz local) over 12 s
    assert len(seen["/global_costmap/costmap"]) in (12, 13)
    assert len(seen["/local_costmap/costmap"]) in (24, 25)
    grid_msg = seen["/global_costmap/costmap"][-1][1]
    values = np.asarray(grid_msg.data)
    assert grid_msg.info.width * grid_msg.info.height == len(values)
    assert set(np.unique(values)) <= set(range(-1, 101)) and (values == 100).any()
    cloud = seen["/particlecloud"][-1][1]
    assert 0 < len(cloud.poses) <= navtopics.MAX_CLOUD and cloud.header.frame_id == "map"
    pose = seen["/amcl_pose"][-1][1].pose.pose.position
    truth = sim.ground_truth().pose
    assert math.hypot(pose.x - truth[0], pose.y - truth[1]) < 0.3
    assert "<robot" in seen["/robot_description"][0][1].data
    clock = [c.clock.sec + c.clock.nanosec * 1e-9 for _, c in seen["/clock"]]
    assert np.all(np.diff(clock) > 0) and clock[-1] > 11.9
