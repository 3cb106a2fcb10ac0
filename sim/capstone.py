"""Closed-loop grading (Lab 11): a student's controller drives seeded office episodes.

:func:`office_episode` is the harness the grader runs inside the sandbox
(``Exercise.harness = "sim.capstone:office_episode"``): the student's ``make_controller(robot)``
returns a controller — ``set_plan(path, goal_yaw)`` and ``compute_velocity_commands(pose,
velocity, costmap) -> (v, ω)``, as :class:`kit.navigation.Controller` — and the kit's navigator
(costmaps, the planner at 1 Hz, recoveries) runs it at 20 Hz for the Uiabot from the
north-west office to the north-east one among walking people, the glass kept out. The verdict
of one episode is ``{"reached": …, "no collision": …, "in time": …}``: the goal reached within
its time limit, no contact with a wall, the glass or a box, and the time within twice the
shortest path at cruise speed plus 10 s. (Contacts with people are not graded: the simulated
people also walk into a robot standing still; ``python -m sim navigate`` counts them.) A
controller that raises, loops or never moves fails its episode with that reason; every
episode is the same for the same seed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from kit.navigation import Navigator
from kit.robots import RobotDescription
from sim import scenarios
from sim.runner import Runner, WheelOdometryNode
from sim.simulation import Simulation

__all__ = ["PEOPLE", "office_episode", "verdict"]

PEOPLE = 2
"""People walking the office in a graded episode."""


def verdict(row: scenarios.GoalResult, cruise: float) -> dict[str, bool]:
    """What an episode is graded on."""
    return {"reached": bool(row.reached),
            "no collision": row.collisions_static == 0,
            "in time": bool(row.reached) and
            row.seconds <= 2.0 * row.shortest_length / cruise + 10.0}


def office_episode(make_controller: Callable[[RobotDescription], Any], seed: int
                   ) -> dict[str, bool]:
    """One seeded episode with the student's controller; its verdict."""
    s = scenarios.setup("office", "uiabot", "glass", keepout=True)
    sim = Simulation(world=s.world, robot="uiabot", seed=int(seed), people=PEOPLE,
                     start=s.route.start)
    robot = sim.description()
    controller = make_controller(robot)
    for method in ("set_plan", "compute_velocity_commands"):
        if not callable(getattr(controller, method, None)):
            raise TypeError(f"make_controller must return a controller with a {method}() "
                            f"method; got {type(controller).__name__}")
    nav = Navigator(s.nav_grid, robot, controller=controller, keepout=s.keepout)
    cruise = robot.max_linear_velocity
    limits = [30.0 + 4.0 * x / cruise if math.isfinite(x) else 120.0 for x in s.shortest]
    node = scenarios.NavigationNode(nav, scenarios.TruthLocalization(), s.route.goals, limits,
                                    0, s.shortest)
    Runner(sim, [WheelOdometryNode(), node], record_rate=1.0).run(sum(limits) + 1.0,
                                                                  until=lambda r: node.done)
    return verdict(node.results[0], cruise)
