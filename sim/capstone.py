"""Closed-loop grading (Lab 11): a student's controller drives seeded office episodes.

:func:`office_episode` is the harness the grader runs inside the sandbox
(``Exercise.harness = "sim.capstone:office_episode"``): the student's ``make_controller(robot)``
returns a controller — ``set_plan(path, goal_yaw)`` and ``compute_velocity_commands(pose,
velocity, costmap) -> (v, ω)``, as :class:`kit.navigation.Controller` — and the kit's navigator
(costmaps, the planner at 1 Hz, recoveries) runs it at 20 Hz for the Uiabot from the
north-west office to the north-east one among walking people, the glass kept out. The verdict
of one episode is ``{"reached": …, "no collision": …, "in time": …}``: the goal reached, no
contact with a wall, the glass or a box, and the time within twice the shortest path at
cruise speed plus 10 s. As in a field trial, an episode ends at the first contact with a wall
(the run fails there) or when its time is up (it is not reached). (Contacts with people are
not graded here; ``python -m sim navigate`` counts them.) A controller that raises, loops or
never moves fails its episode with that reason; every episode is the same for the same seed.
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

__all__ = ["PEOPLE", "office_episode", "time_allowed", "verdict"]

PEOPLE = 2
"""People walking the office in a graded episode."""


def verdict(row: scenarios.GoalResult, cruise: float) -> dict[str, bool]:
    """What an episode is graded on."""
    return {"reached": bool(row.reached),
            "no collision": row.collisions_static == 0,
            "in time": bool(row.reached) and
            row.seconds <= time_allowed(row.shortest_length, cruise)}


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
    cruise = robot.cruise_velocity
    limits = [time_allowed(x, cruise) for x in s.shortest]
    node = scenarios.NavigationNode(nav, scenarios.TruthLocalization(), s.route.goals, limits,
                                    0, s.shortest)

    def touched_a_wall() -> bool:
        return any(c.other == "wall" for c in sim.collisions)

    Runner(sim, [WheelOdometryNode(), node], record_rate=1.0).run(
        sum(limits) + 1.0, until=lambda r: node.done or touched_a_wall())
    if not node.results:  # ended at the contact
        return {"reached": False, "no collision": False, "in time": False}
    return verdict(node.results[0], cruise)


def time_allowed(shortest: float, cruise: float) -> float:
    """An episode's time [s]: twice the shortest path at cruise speed, plus 10 s."""
    return 2.0 * shortest / cruise + 10.0 if math.isfinite(shortest) else 120.0
