"""The closed-loop runner (sim/runner.py): the same numbers as wiring the loop by hand, nodes
at their own rates, signals recorded by name, episodes, and clear errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kit import msgs, odometry
from kit.estimation import FusionFilter, SensorConfig
from sim import Simulation
from sim.runner import (
    FusionNode,
    Node,
    ProgressNode,
    Runner,
    ScriptedCommands,
    WheelOdometryNode,
    pose_of,
    truth_pose,
)

T, F = True, False
ODOM0 = SensorConfig((T, T, F, F, F, T, F, F, F, F, F, T, F, F, F))
IMU0 = SensorConfig((F, F, F, F, F, T, F, F, F, F, F, T, F, F, F))
START = [3.6, 2.0, 0.0]


def twist(v: float, w: float) -> msgs.Twist:
    return msgs.Twist(msgs.Vector3(v, 0, 0), msgs.Vector3(0, 0, w))


PLAN = [(0.5, twist(0.4, 0.0)), (0.5, twist(0.0, 1.5)), (0.3, twist(0.3, -0.5))]


def by_hand(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The loop the demo, the tests and Lab 05 used to wire themselves."""
    sim = Simulation(world="square", robot="uiabot", seed=seed, start=START)
    node = odometry.WheelOdometry.for_robot(sim.description())
    node.pose = sim.ground_truth().pose.copy()
    node.update(*sim.encoder_ticks(), 0.0)
    fusion = FusionFilter({"odom0": ODOM0, "imu0": IMU0})
    fusion.x[:3] = node.pose
    fused = []
    for seconds, cmd in PLAN:
        for k in range(round(seconds / 0.01)):
            for topic, message in sim.step(cmd if k == 0 else None):
                if topic == "/joint_states":
                    fusion.add_odometry("odom0", node.update(*sim.encoder_ticks(), sim.time))
                    fused.append(fusion.x[:3].copy())
                elif topic == "/imu":
                    fusion.add_imu("imu0", message)
    return sim.ground_truth().pose, node.pose, np.array(fused)


def with_runner(seed: int) -> tuple[Runner, WheelOdometryNode, FusionNode]:
    sim = Simulation(world="square", robot="uiabot", seed=seed, start=START)
    wheels = WheelOdometryNode()
    fusion = FusionNode(FusionFilter({"odom0": ODOM0, "imu0": IMU0}, initial_pose=START),
                        {"/odom": "odom0", "/imu": "imu0"})
    run = Runner(sim, [wheels, fusion], controller=ScriptedCommands(PLAN),
                 signals={"truth": truth_pose(), "fused": lambda r: fusion.pose,
                          "published": pose_of("/odometry/filtered"),
                          "wheels": lambda r: wheels.pose})
    return run, wheels, fusion


def test_runner_gives_the_same_numbers_as_the_hand_wired_loop():
    truth, wheel_pose, fused = by_hand(seed=2)
    run, wheels, fusion = with_runner(seed=2)
    recording = run.run(sum(s for s, _ in PLAN))
    np.testing.assert_array_equal(run.sim.ground_truth().pose, truth)
    np.testing.assert_array_equal(wheels.pose, wheel_pose)
    np.testing.assert_array_equal(fusion.pose, fused[-1])
    # the fused pose recorded at 50 Hz is the one after each joint state (20 ms apart)
    np.testing.assert_array_equal(recording["fused"][1:], fused)
    np.testing.assert_allclose(recording.time, np.arange(len(fused) + 1) * 0.02, atol=1e-9)
    np.testing.assert_array_equal(recording["truth"][-1], truth)
    # /odometry/filtered is published at the filter's 30 Hz: never newer than the estimate
    published = recording["published"]
    assert np.isnan(published[0]).all() and np.isfinite(published[2:]).all()


class Counter(Node):
    def __init__(self, rate: float) -> None:
        self.rate = rate
        self.times: list[float] = []

    def on_tick(self, time: float):
        self.times.append(time)
        return ()


def test_nodes_tick_at_their_own_rates_from_the_start():
    sim = Simulation(world="square", robot="uiabot", seed=0, sensors=False)
    planner, controller = Counter(1.0), Counter(20.0)
    Runner(sim, [planner], controller=controller).run(3.0)
    np.testing.assert_allclose(planner.times, [0.0, 1.0, 2.0, 3.0], atol=1e-9)
    assert len(controller.times) == 61
    np.testing.assert_allclose(np.diff(controller.times), 0.05, atol=1e-9)


class Echo(Node):
    """Publishes on /echo what it receives on /ping: messages reach subscribers in order."""

    subscriptions = ("/ping",)

    def on_message(self, topic, message, time):
        return [("/echo", message)]


class Ping(Node):
    rate = 10.0

    def __init__(self) -> None:
        self.count = 0

    def on_tick(self, time):
        self.count += 1
        return [("/ping", self.count)]


def test_published_messages_reach_their_subscribers_in_the_same_step():
    sim = Simulation(world="square", robot="uiabot", seed=0, sensors=False)
    run = Runner(sim, [Ping(), Echo()], signals={"echo": lambda r: r.latest.get("/echo", 0)},
                 record_rate=10.0)
    recording = run.run(1.0)
    np.testing.assert_array_equal(recording["echo"], np.arange(1, 12))


def test_episodes_repeat_after_reset_with_the_same_seed_and_differ_with_another():
    run, _, _ = with_runner(seed=4)
    first = run.run(1.0)["fused"][-1]
    run.reset(seed=4)
    again = run.run(1.0)["fused"][-1]
    run.reset(seed=5)
    other = run.run(1.0)["fused"][-1]
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first, other)


def test_until_stops_the_run_early():
    sim = Simulation(world="square", robot="uiabot", seed=0, sensors=False)
    run = Runner(sim, controller=ScriptedCommands([(5.0, twist(0.3, 0.0))]),
                 signals={"x": lambda r: r.sim.ground_truth().pose[0]})
    start_x = sim.ground_truth().pose[0]
    run.run(5.0, until=lambda r: r.sim.ground_truth().pose[0] > start_x + 0.2)
    assert 0.2 < sim.ground_truth().pose[0] - start_x < 0.21
    assert sim.time < 1.5


def test_a_scripted_plan_ends_with_a_stop():
    sim = Simulation(world="square", robot="uiabot", seed=0, sensors=False)
    plan = ScriptedCommands([(0.5, (10.0, 10.0))])
    Runner(sim, controller=plan).run(2.0)
    assert plan.duration == 0.5
    assert abs(sim.ground_truth().velocity[0]) < 1e-3


def test_bad_runs_are_refused_with_a_clear_error():
    sim = Simulation(world="square", robot="uiabot", seed=0, sensors=False)
    with pytest.raises(TypeError, match=r"sim\.runner\.Node"):
        Runner(sim, [object()])  # type: ignore[list-item]
    with pytest.raises(ValueError, match="record_rate"):
        Runner(sim, record_rate=0.0)
    with pytest.raises(ValueError, match="seconds"):
        Runner(sim).run(math.nan)
    with pytest.raises(ValueError, match="positive number of seconds"):
        ScriptedCommands([(0.0, twist(0, 0))])
    with pytest.raises(ValueError, match="at least one"):
        ScriptedCommands([])
    with pytest.raises(KeyError, match="recorded"):
        Runner(sim).run(0.1)["nothing"]
    with pytest.raises(RuntimeError, match="not started"):
        _ = WheelOdometryNode().pose


def test_fusion_node_refuses_other_messages():
    node = FusionNode(FusionFilter({"odom0": ODOM0}), {"/scan": "odom0"})
    with pytest.raises(TypeError, match="Odometry and Imu"):
        node.on_message("/scan", msgs.Twist(), 0.0)


def test_description_accessor_and_initial_poses():
    sim = Simulation(world="square", robot=["uiabot", "eddie"], seed=0, sensors=False)
    assert sim.description(1).name == "eddie"
    with pytest.raises(ValueError, match="out of range"):
        sim.description(2)
    node = odometry.WheelOdometry.for_robot(sim.description(), initial_pose=[1.0, 2.0, 0.5])
    np.testing.assert_array_equal(node.pose, [1.0, 2.0, 0.5])
    assert FusionFilter({"odom0": ODOM0}, initial_pose=[1.0, 2.0, 0.5]).x.tolist() == \
        [1.0, 2.0, 0.5, 0.0, 0.0, 0.0]
    with pytest.raises(ValueError, match="one pose"):
        FusionFilter({"odom0": ODOM0}, initial_pose=np.zeros((2, 3)))
    with pytest.raises(ValueError, match="one pose"):
        odometry.WheelOdometry(0.001, 0.3, initial_pose=np.zeros((2, 3)))


class CountingBar:
    def __init__(self) -> None:
        self.n = 0.0

    def update(self, n: float) -> None:
        self.n += n


def test_a_progress_node_moves_its_bar_by_the_simulated_seconds_of_each_run():
    bar = CountingBar()
    sim = Simulation(world="square", robot="uiabot", seed=1, sensors=False)
    runner = Runner(sim, [ProgressNode(bar)])
    runner.run(3.0)
    assert bar.n == pytest.approx(3.0)        # twice a simulated second, up to the end
    runner.run(1.0)                            # the bar goes on with the next run
    assert bar.n == pytest.approx(4.0)
