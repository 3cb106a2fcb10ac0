"""What the closed-loop runner costs: the Lab 05 fusion run (odometry node, fusion node,
scripted commands, three signals at 50 Hz) through sim.runner.Runner against the same loop
wired by hand. Run: python benchmarks/bench_runner.py [repeats]
"""

from __future__ import annotations

import statistics
import sys
import time

from kit import msgs, odometry
from kit.estimation import FusionFilter, SensorConfig
from sim import Simulation
from sim.runner import FusionNode, Runner, ScriptedCommands, WheelOdometryNode, truth_pose

T, F = True, False
ODOM0 = SensorConfig((T, T, T, F, F, F, F, F, F, F, F, T, F, F, F))
IMU0 = SensorConfig((F, F, F, T, T, T, F, F, F, F, F, F, F, F, F))
START = [3.6, 2.0, 0.0]
PLAN = [(1.5, msgs.Twist(msgs.Vector3(0.4, 0, 0))),
        (1.5, msgs.Twist(angular=msgs.Vector3(0, 0, 2.0))),
        (3.0, msgs.Twist(msgs.Vector3(0.4, 0, 0)))]
SECONDS = sum(s for s, _ in PLAN)


def by_hand() -> float:
    sim = Simulation(world="square", robot="uiabot", seed=3, start=START)
    node = odometry.WheelOdometry.for_robot(sim.description(), initial_pose=START)
    node.update(*sim.encoder_ticks(), 0.0)
    fusion = FusionFilter({"odom0": ODOM0, "imu0": IMU0}, initial_pose=START)
    rows = []
    start = time.perf_counter()
    for seconds, cmd in PLAN:
        for k in range(round(seconds / 0.01)):
            for topic, message in sim.step(cmd if k == 0 else None):
                if topic == "/joint_states":
                    fusion.add_odometry("odom0", node.update(*sim.encoder_ticks(), sim.time))
                    rows.append((sim.ground_truth().pose, node.pose.copy(), fusion.x[:3].copy()))
                elif topic == "/imu":
                    fusion.add_imu("imu0", message)
    return time.perf_counter() - start


def with_runner() -> float:
    sim = Simulation(world="square", robot="uiabot", seed=3, start=START)
    wheels = WheelOdometryNode()
    fusion = FusionNode(FusionFilter({"odom0": ODOM0, "imu0": IMU0}, initial_pose=START),
                        {"/odom": "odom0", "/imu": "imu0"})
    run = Runner(sim, [wheels, fusion], controller=ScriptedCommands(PLAN),
                 signals={"truth": truth_pose(), "wheels": lambda r: wheels.pose,
                          "fused": lambda r: fusion.pose})
    start = time.perf_counter()
    run.run(SECONDS)
    return time.perf_counter() - start


def main(repeats: int = 7) -> None:
    for name, fn in (("by hand", by_hand), ("Runner", with_runner)):
        times = [fn() for _ in range(repeats)]
        best = min(times)
        print(f"{name:8s}: {SECONDS:.0f} s simulated in best {best * 1e3:6.1f} ms "
              f"({SECONDS / best:5.1f}x real time), median {statistics.median(times) * 1e3:6.1f}"
              f" ms, spread {(max(times) - best) * 1e3:5.1f} ms over {repeats} runs")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
