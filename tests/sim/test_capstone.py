"""Lab 11's closed-loop episode says why each failing controller failed — touched a wall or a
person (when, where), gave up (after how many recoveries), out of time (how far left), stuck,
oscillating, raised, looped forever, returned nothing — and the bystander in the doorway
stops a controller that looks where it goes and is touched by one that does not."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kit import geometry
from kit import navigation as nav
from kit.planning import pad_footprint
from sim import capstone

pytestmark = pytest.mark.slow


class Follower:
    """The Lab 11 solution's controller, with its collision check optional."""

    def __init__(self, robot, look=True, speed=None):
        self.rpp = nav.RppParameters.for_robot(robot)
        self.speed_cap = speed
        self.look = look
        self.footprint = pad_footprint(robot.footprint, 0.05)
        self.path, self.goal_yaw, self.index = np.zeros((0, 2)), None, 0

    def set_plan(self, path, goal_yaw=None):
        self.path, self.goal_yaw, self.index = np.asarray(path, float), goal_yaw, 0

    def compute_velocity_commands(self, pose, velocity, costmap):
        pose = np.asarray(pose, dtype=float)
        if len(self.path) == 0:
            raise nav.ControlError("no path")
        self.index = nav.closest_index(self.path, pose, self.index, 2.0)
        remaining = nav.remaining_length(self.path, pose, self.index)
        carrot = nav.lookahead_point(self.path, pose, 0.6, self.index)
        bearing = float(geometry.wrap_angle(math.atan2(carrot[1] - pose[1],
                                                       carrot[0] - pose[0]) - pose[2]))
        if remaining < 0.25 and self.goal_yaw is not None:
            v, w = 0.0, float(np.clip(2.0 * geometry.wrap_angle(self.goal_yaw - pose[2]), -1, 1))
        elif abs(bearing) > 0.785:
            v, w = 0.0, math.copysign(min(1.0, 2.0 * abs(bearing)), bearing)
        else:
            k = nav.pure_pursuit_curvature(pose, carrot)
            v = self.speed_cap or self.rpp.desired_linear_vel
            w = v * k
        if self.look:
            ahead = nav.arc_poses(pose, v, w, np.linspace(0.05, 1.0, 20))
            outline = nav.outline_points(self.footprint, costmap.resolution)
            if np.any(nav.collides_from(costmap, pose, ahead, outline)):
                raise nav.ControlError("collision ahead")
        return v, w


class Commands:
    """A controller that answers with ``answer(step)`` whatever it is asked."""

    def __init__(self, answer):
        self.answer, self.step = answer, 0

    def set_plan(self, path, goal_yaw=None):
        pass

    def compute_velocity_commands(self, pose, velocity, costmap):
        self.step += 1
        return self.answer(self.step)


def episode(make, seed=0):
    return capstone.office_episode(make, seed)


def test_a_controller_that_looks_where_it_goes_waits_for_the_bystander():
    result = episode(lambda robot: Follower(robot))
    assert result.passed and result.category == "reached", result.message
    assert any("control failed collision ahead" in e for e in result.events)  # it waited


def test_a_controller_blind_to_obstacles_touches_the_bystander_every_time():
    for seed in range(6):
        result = episode(lambda robot: Follower(robot, look=False), seed)
        door = capstone.bystander_for(seed).door
        assert result.category == "touched a person", (seed, result.message)
        x, y = (float(v) for v in result.message.split("at (")[1].split(")")[0].split(", "))
        assert math.hypot(x - door[0], y - door[1]) < 1.2, result.message


def test_driving_straight_on_touches_a_wall_and_says_when_and_where():
    result = episode(lambda robot: Commands(lambda step: (0.5, 0.0)))
    assert result.category == "touched a wall", result.message
    assert " at " in result.message and "m" in result.message
    assert not result.verdict["no collision"]


def test_a_controller_that_always_refuses_makes_the_navigator_give_up_after_its_recoveries():
    def refuse(step):
        raise nav.ControlError("no way through")

    result = episode(lambda robot: Commands(refuse))
    assert result.category == "gave up", result.message
    assert "after 6 recoveries" in result.message and "no way through" in result.message
    assert any(e.endswith("(after 6 recoveries)") for e in result.events[-3:])


def test_a_controller_that_never_moves_is_called_stuck():
    result = episode(lambda robot: Commands(lambda step: (0.0, 0.0)))
    assert result.category == "stuck", result.message
    assert "asked for no motion" in result.message


def test_a_controller_that_turns_back_and_forth_is_called_oscillating():
    result = episode(lambda robot: Commands(lambda step: (0.0, 1.0 if step // 10 % 2 else -1.0)))
    assert result.category == "oscillating", result.message
    assert "changed direction" in result.message


def test_a_controller_too_slow_runs_out_of_time_and_says_how_far_is_left():
    result = episode(lambda robot: Follower(robot, speed=0.05))
    assert result.category == "out of time", result.message
    assert "still to go" in result.message and not result.verdict["reached"]


def test_an_endless_controller_stops_within_its_cpu_limit_naming_its_line():
    namespace: dict = {}
    exec(compile("def endless(step):\n    while True:\n        pass\n", "<cell 5>", "exec"),
         namespace)
    result = episode(lambda robot: Commands(namespace["endless"]))
    assert result.category == "timed out", result.message
    assert "an endless loop" in result.message and "line 2" in result.message


def test_a_missing_return_and_a_wrong_object_are_named():
    result = episode(lambda robot: Commands(lambda step: None))
    assert result.category == "raised" and "missing return" in result.message
    result = episode(lambda robot: object())
    assert result.category == "not a controller" and "set_plan()" in result.message
    result = episode(lambda robot: 1 / 0)
    assert result.category == "raised" and "ZeroDivisionError" in result.message


def test_an_unfinished_exercise_is_not_implemented_not_a_failed_episode():
    def make_controller(robot):
        raise NotImplementedError

    with pytest.raises(NotImplementedError):
        episode(make_controller)
