"""Lab 10's specification where it was ambiguous or fragile: Regulated Pure Pursuit's order of
operations, and Nav2's inclusive goal tolerances at their boundary."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grader.labs import lab10
from grader.spec import course_seed

STUDENTS = [f"student{i:02d}" for i in range(10)]


def nav2_speed(k, remaining, desired, min_radius, min_speed, approach, min_approach):
    """Nav2's RegulatedPurePursuitController::applyConstraints with its heuristics
    (curvatureConstraint, approachVelocityConstraint), cost regulation off, the remaining
    length taken as the distance to the goal."""
    linear = desired
    radius = abs(1.0 / k) if k != 0 else math.inf
    curvature_vel = linear * (1.0 - abs(radius - min_radius) / min_radius) \
        if radius < min_radius else linear
    linear = max(min(linear, curvature_vel), min_speed)
    scaling = remaining / approach if remaining < approach else 1.0
    approach_vel = max(linear * scaling, min_approach)
    linear = min(linear, approach_vel)
    return min(max(abs(linear), 0.0), desired)


def test_the_reference_speed_is_nav2s_on_every_case():
    cases = list(lab10.regulated_speed.public)
    for student in STUDENTS:
        cases += lab10.regulated_speed.hidden_cases(course_seed("lab10.regulated_speed",
                                                                student, "s"))
    for case in cases:
        assert lab10._regulated(*case.args) == pytest.approx(nav2_speed(*case.args),
                                                             rel=1e-12), case


def test_the_goal_approach_reading_that_scales_desired_loses_points_for_everyone():
    """The two readings the old text allowed disagree on a tight curve near the goal; every
    student's hidden cases hold one, and so do the public cases."""
    def other_reading(k, remaining, desired, min_radius, min_speed, approach, min_approach):
        v = max(desired * min(1.0, 1.0 / (abs(k) * min_radius)) if k else desired, min_speed)
        if remaining < approach:
            v = min(v, max(desired * remaining / approach, min_approach))
        return v

    public = lab10.regulated_speed.public
    assert any(other_reading(*c.args) != pytest.approx(lab10._regulated(*c.args))
               for c in public)
    for student in STUDENTS:
        cases = lab10.regulated_speed.hidden_cases(course_seed("lab10.regulated_speed",
                                                               student, "s"))
        combined = [c for c in cases if c.name == "a tight curve near the goal"]
        assert combined
        assert other_reading(*combined[0].args) != pytest.approx(lab10._regulated(
            *combined[0].args))


def test_min_approach_is_below_min_speed_which_is_below_desired_in_every_hidden_case():
    for student in STUDENTS:
        for case in lab10.regulated_speed.hidden_cases(course_seed("lab10.regulated_speed",
                                                                   student, "s")):
            _, remaining, desired, _, min_speed, _, min_approach = case.args
            assert 0 < min_approach < min_speed < desired and remaining >= 0


def _wraps(e):
    return [math.atan2(math.sin(e), math.cos(e)), (e + math.pi) % (2 * math.pi) - math.pi,
            math.remainder(e, 2 * math.pi), float(np.angle(np.exp(1j * e)))]


def test_the_boundary_cases_sit_exactly_on_the_tolerances_however_they_are_computed():
    for student in STUDENTS:
        cases = {c.name: c for c in lab10.goal_reached.hidden_cases(
            course_seed("lab10.goal_reached", student, "s"))}
        pose, goal, xy, yaw = cases["exactly at the xy tolerance"].args
        dx, dy = goal[0] - pose[0], goal[1] - pose[1]
        for d in (math.hypot(dx, dy), math.sqrt(dx * dx + dy * dy),
                  float(np.linalg.norm([-dx, -dy]))):
            assert d == xy
        assert dx * dx + dy * dy == xy * xy
        pose, goal, xy, yaw = cases["exactly at the yaw tolerance"].args
        for e in (goal[2] - pose[2], pose[2] - goal[2]):
            assert [abs(w) for w in _wraps(e)] == [yaw] * 4
        assert lab10._reached(*cases["exactly at the xy tolerance"].args)
        assert lab10._reached(*cases["exactly at the yaw tolerance"].args)


def test_a_rollout_case_never_carries_its_heading_across_pi():
    for student in STUDENTS:
        for case in lab10.rollout.hidden_cases(course_seed("lab10.rollout", student, "s")):
            headings = lab10._rollout(*case.args)[:, 2]
            assert np.all(np.abs(headings) < math.pi) and abs(case.args[0][2]) < math.pi
