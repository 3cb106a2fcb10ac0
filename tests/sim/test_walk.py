"""The people's compiled rules (sim._walk) against the readable Python ones, bit for bit, and
the simulator's direct Chipmunk reads against pymunk's properties."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kit import geometry, msgs
from sim import Simulation
from sim._walk import hypot
from sim.world import _build


def twist(v: float, w: float = 0.0) -> msgs.Twist:
    return msgs.Twist(msgs.Vector3(v, 0.0, 0.0), msgs.Vector3(0.0, 0.0, w))


def test_the_compiled_hypot_is_pythons_math_hypot_to_the_last_bit():
    """CPython's hypot is its own algorithm, not the C library's: numba's math.hypot differs
    from it in the last bit about once in two hundred calls, enough to change a person's path
    after a few minutes."""
    rng = np.random.default_rng(3)
    pairs = [(0.0, 0.0), (-0.0, 0.0), (0.0, -2.5), (3.0, 4.0), (1e-310, 3e-311),
             (5e-324, 0.0), (math.inf, 1.0), (math.nan, math.inf), (1.0, math.nan),
             (1e308, 1e308)]
    for scale in (1e-6, 1e-2, 1.0, 30.0, 1e6):
        pairs += zip(rng.normal(0, scale, 20_000).tolist(),
                     (rng.normal(0, scale, 20_000) * rng.uniform(0, 2, 20_000)).tolist(),
                     strict=True)
    for x, y in pairs:
        expected, got = math.hypot(x, y), hypot(x, y)
        assert got == expected or (math.isnan(got) and math.isnan(expected)), (x, y)
        assert math.copysign(1.0, got) == math.copysign(1.0, expected)


def door_world():
    """A 1.5 m corridor with one door (an alcove), as the IGV meets people in the aisle."""
    recess = [[-2.0, 0.0], [8.0, 0.0], [8.0, -0.7], [9.0, -0.7], [9.0, 0.0], [20.0, 0.0]]
    return _build("door", "", [([[-2.0, 1.5], [20.0, 1.5]], "wall"), (recess, "wall")], [],
                  [], [], [0.0, 0.75, 0.0], [[[14.0, 0.75], [-1.0, 0.75]]], "test",
                  [[8.5, 0.75, 8.5, -0.4]])


SCENES = {
    # a person steps into the door to let the IGV by (stages 1 to 4 of stepping aside)
    "door": (lambda: Simulation(door_world(), "igv", seed=2, people=1, start=[0.0, 0.75, 0.0]),
             lambda t: twist(0.8), 25.0),
    # the aisle's doors and boxes, four people, the IGV driving down and back
    "aisle": (lambda: Simulation("aisle", "igv", seed=5, people=4),
              lambda t: twist(0.8 if t < 20.0 else -0.5), 40.0),
    # the office: five people passing each other and a Uiabot weaving among them, held up
    "office": (lambda: Simulation("office", "uiabot", seed=4, people=5),
               lambda t: twist(0.4, 0.8 * math.sin(0.4 * t)), 40.0),
    # Lab 11's bystander: standing in the corridor, passed by the walker (the robot waits)
    "bystander": (lambda: with_bystander(door_world(), (9.5, 0.75)),
                  lambda t: twist(0.0), 15.0),
    # three Uiabots and the IGV among six people: the outlines of robots of one footprint
    # turned together (one stacked product), the IGV's alone
    "robots": (lambda: Simulation("office", ["uiabot", "igv", "uiabot", "uiabot"], seed=3,
                                  people=6),
               lambda t: {i: twist(0.3 + 0.1 * i, 0.6 * math.sin(0.3 * t + i))
                          for i in range(4)}, 30.0),
}


def with_bystander(world, where):
    sim = Simulation(world, "igv", seed=2, people=1, start=[0.0, 0.75, 0.0])
    sim.add_bystander(where)
    return sim


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_compiled_people_walk_exactly_as_the_python_rules(scene, monkeypatch):
    """Two simulations of one scene, one walking its people by the compiled rules and one by
    the Python reference: after every walk their velocities, positions and walking states
    (route point, direction, pace, time held up, alcove and stage) are the same numbers."""
    make, command, seconds = SCENES[scene]
    compiled = make()
    monkeypatch.setattr(Simulation, "compiled_walk", False)
    reference = make()
    assert reference.compiled_walk is False
    compiled.compiled_walk = True
    seen_stages, held = set(), False
    for k in range(round(seconds / 0.01)):
        cmd = command(k * 0.01) if k % 10 == 0 else None
        compiled.step(cmd)
        reference.step(cmd)
        if k % 10 == 0:
            for a, b in zip(compiled.people, reference.people, strict=True):
                assert tuple(a.ground.velocity) == tuple(b.ground.velocity), (k, a.index)
                assert tuple(a.body.position) == tuple(b.body.position), (k, a.index)
            np.testing.assert_array_equal(compiled.people_positions(),
                                          reference.people_positions())
            for name in ("target", "direction", "speed", "blocked", "alcove", "stage"):
                np.testing.assert_array_equal(getattr(compiled._crowd, name),
                                              getattr(reference._crowd, name), err_msg=name)
            seen_stages.update(compiled._crowd.stage.tolist())
            held = held or bool(np.any(compiled._crowd.blocked > 0.0))
    assert compiled.collisions == reference.collisions
    if scene == "door":
        assert seen_stages >= {1, 2, 3, 4}       # into the door, waiting, back out
    elif scene != "bystander":
        assert held                              # someone was held up by the robot


def test_a_walker_steps_round_a_bystander_as_round_anyone():
    """A bystander (Lab 11's person in a doorway) moves only when the scenario says, but the
    walking people treat them as one of their own: a walker coming down the corridor at its
    pace of 1.16 m/s is already aside and slower when it comes within 0.7 m of them (it
    passes on its right, then walks on), rather than walking on into them."""
    for compiled in (True, False):
        sim = with_bystander(door_world(), (9.5, 0.75))
        sim.compiled_walk = compiled
        sim.step(twist(0.0))
        before = sim.people_positions()[0].copy()
        closest, passed = np.inf, False
        for _ in range(1500):
            sim.step()
            walker, bystander = sim.people_positions()
            gap = float(np.hypot(*(walker - bystander)))
            if gap < 0.7 and closest >= 0.7:          # the first step within 0.7 m
                toward = float(np.dot(walker - before, bystander - walker)) / gap / 0.01
                assert abs(walker[1] - 0.75) > 0.1 and toward < 0.6, (walker, toward)
            closest, before = min(closest, gap), walker.copy()
            passed = passed or walker[0] < bystander[0] - 1.0
        assert closest < 0.7 and passed
        assert np.allclose(bystander, (9.5, 0.75), atol=0.05)   # nudged at most


def test_direct_chipmunk_reads_agree_with_pymunks_properties():
    """The simulator reads and writes bodies through Chipmunk's functions (pymunk's own
    property wrappers cost more than the physics): the same values as the properties give."""
    sim = Simulation("office", "uiabot", seed=1, people=2)
    sim.run(1.0, twist(0.4, 0.5))
    r = sim.robots[0]
    body = r.body
    assert r.pose.tolist() == [body.position.x, body.position.y,
                               float(geometry.wrap_angle(body.angle))]
    assert r.world_velocity == (body.velocity.x, body.velocity.y)
    assert r.yaw_rate == body.angular_velocity
    np.testing.assert_array_equal(sim.people_positions(),
                                  [tuple(p.body.position) for p in sim.people])
    sim._drive(r, sim.physics.dt)                 # the grounds' velocities, written directly
    c, s = math.cos(body.angle), math.sin(body.angle)
    for k, ground in enumerate(r.grounds):
        rim = r.speeds[k] * r.description.wheel_radius
        assert tuple(ground.velocity) == (rim * c, rim * s)
