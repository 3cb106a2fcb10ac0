"""A step with several robots makes their scans and joint states together, and turns their
outlines for the people's rules together: the same messages and numbers, to the bit, as
making each robot's alone."""

from __future__ import annotations

import math
import pickle

import numpy as np

from kit import geometry, msgs
from sim import Simulation, sensors
from sim import _walk as walk_rules
from sim import simulation as simulation_module


def twist(v: float, w: float = 0.0) -> msgs.Twist:
    return msgs.Twist(msgs.Vector3(v, 0.0, 0.0), msgs.Vector3(0.0, 0.0, w))


def one_by_one(lidars, segments, circles):
    """Every due scan made by its own lidar, as a simulation of one robot makes it."""
    return [lidar._finish(segments, circles) for lidar in lidars]


def joint_states_one_by_one(robots, header):
    return [Simulation._joint_state(r, header) for r in robots]


def drive(sim, k):
    """Every robot a command of its own every half second (forward, turning, reversing)."""
    if k % 50:
        return None
    return {i: twist(0.5 - 0.3 * ((k // 50 + i) % 3), 0.7 * math.sin(k / 70 + i))
            for i in range(len(sim.robots))}


def scenes():
    grid = [[1.0 + 2.0 * (i % 4), 1.5 + 3.0 * (i // 4), 0.3 * i] for i in range(8)]
    return {
        # eight Uiabots' scans due together, cast in one call: the square's oil patch too
        "square": lambda: Simulation("square", ["uiabot"] * 8, seed=4, people=8, start=grid,
                                     lidar_rate=10.0, lidar_beams=360),
        # different lidars due together (beams, timing, noise, dropouts of their own), the
        # office's many walls culled per scan
        "office": lambda: Simulation("office", ["igv", "uiabot", "eddie", "uiabot"], seed=9,
                                     people=5, lidar_rate=10.0),
    }


def test_scans_and_joint_states_made_together_are_the_ones_made_alone(monkeypatch):
    for name, make in scenes().items():
        together, alone = make(), make()
        a: list = []
        b: list = []
        for k in range(400):
            cmd = drive(together, k)
            a += together.step(cmd)
            with monkeypatch.context() as m:
                m.setattr(simulation_module, "finish_scans", one_by_one)
                m.setattr(Simulation, "_joint_states", staticmethod(joint_states_one_by_one))
                b += alone.step(cmd)
        assert [topic for topic, _ in a] == [topic for topic, _ in b], name
        scans = [topic for topic, _ in a if topic.endswith("/scan")]
        assert len(scans) >= 4 * len(together.robots), name          # some 10 Hz scans each
        for (topic, x), (_, y) in zip(a, b, strict=True):
            # every field to the bit (pickle keeps floats' and arrays' exact bytes)
            assert pickle.dumps(x) == pickle.dumps(y), (name, topic)
        for r, s in zip(together.robots, alone.robots, strict=True):
            assert r.lidar is not None and s.lidar is not None
            assert r.lidar.last_ranges.tobytes() == s.lidar.last_ranges.tobytes()
        assert together.collisions == alone.collisions


def test_the_scans_are_cast_in_one_call_when_the_lidars_share_their_steps(monkeypatch):
    """The test above compares something: the eight Uiabots' scans are cast together."""
    calls = []
    original = sensors._cast_many

    def counting(*args):
        calls.append(args[4].shape[0])     # one row of parameters per lidar
        return original(*args)

    monkeypatch.setattr(sensors, "_cast_many", counting)
    sim = scenes()["square"]()
    sim.run(0.5, twist(0.3))
    assert calls == [8] * 5


def test_the_people_see_each_robots_outline_as_transform_points_gives_it(monkeypatch):
    """The outlines handed to the compiled rules (robots of one footprint turned by one
    stacked product) are kit.geometry.transform_points of each robot's footprint, to the
    bit."""
    sim = Simulation("office", ["uiabot", "igv", "uiabot", "eddie", "uiabot"], seed=2,
                     people=3)
    original = walk_rules.walk
    compared = []

    def spy(*args):
        outlines, corners = args[13], args[14]
        for i, r in enumerate(sim.robots):   # where the robots are as the people decide
            expected = geometry.transform_points(r.pose, r.description.footprint)
            assert outlines[i, :corners[i]].tobytes() == expected.tobytes(), (sim.time, i)
        compared.append(r.pose)
        return original(*args)

    monkeypatch.setattr(walk_rules, "walk", spy)
    for k in range(300):
        sim.step(drive(sim, k))
    assert len(compared) == 30
    assert np.ptp([pose[2] for pose in compared]) > 0.5        # turned, not only moved
