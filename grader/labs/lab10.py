"""Lab 10 — local planning (think → act): the exercises, their cases and their mistakes.

Students write pure pursuit's curvature, Regulated Pure Pursuit's speed rule, DWB's dynamic
window and forward simulation, and Nav2's goal check; :mod:`kit.navigation` is the reference
for the curvature, the others are written out here as Nav2 defines them (the window without
the kit's extra sample at ω = 0).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grader.spec import Case, Diagnostic, Exercise, LabSpec
from kit import geometry
from kit import navigation as nav

_BLOCKED = (
    "kit.navigation._pursuit:pure_pursuit_curvature", "kit.navigation._pursuit:arc_poses",
    "kit.navigation._pursuit:RegulatedPurePursuit", "kit.navigation._dwb:dynamic_window",
    "kit.navigation._dwb:DwbController", "kit.navigation._behaviors:GoalChecker",
)


# ---------------------------------------------------------------- pure pursuit

def _curvature(pose: Any, carrot: Any) -> float:
    return float(nav.pure_pursuit_curvature(pose, carrot))


def _curvature_world_frame(pose: Any, carrot: Any) -> float:
    dx, dy = carrot[0] - pose[0], carrot[1] - pose[1]
    return 2.0 * dy / (dx * dx + dy * dy)


def _curvature_no_two(pose: Any, carrot: Any) -> float:
    return 0.5 * _curvature(pose, carrot)


def _curvature_x(pose: Any, carrot: Any) -> float:
    local = geometry.transform_points(geometry.inverse(np.asarray(pose, float)),
                                      np.asarray(carrot, float)[None, :2])[0]
    return 2.0 * float(local[0]) / float(local @ local)


def _carrots(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(4):
        pose = (float(rng.uniform(-5, 5)), float(rng.uniform(-5, 5)),
                float(rng.uniform(-math.pi, math.pi)))
        carrot = (pose[0] + float(rng.uniform(-1.5, 1.5)),
                  pose[1] + float(rng.uniform(-1.5, 1.5)))
        cases.append(Case(f"random {i}", (pose, carrot)))
    return cases


pure_pursuit_curvature = Exercise(
    id="lab10.pure_pursuit_curvature", function="pure_pursuit_curvature",
    title="Pure pursuit: the arc through the carrot", reference=_curvature, points=2,
    public=(Case("carrot ahead and to the left", ((0.0, 0.0, 0.0), (1.0, 0.5))),
            Case("robot facing north-west, carrot to its right", ((2.0, 1.0, 2.0),
                                                                 (2.6, 1.8))),
            Case("carrot straight ahead", ((1.0, 1.0, math.pi / 4), (2.0, 2.0)))),
    hidden=_carrots, rtol=1e-9, atol=1e-12,
    diagnostics=(
        Diagnostic("the carrot left in the map frame", _curvature_world_frame,
                   "take the carrot into the robot's frame first (rotate by −θ): y is "
                   "sideways from the robot's heading, not the map's north"),
        Diagnostic("y / L² (the 2 left out)", _curvature_no_two,
                   "the circle through the robot tangent to its heading and through (x, y) "
                   "has curvature 2 y / (x² + y²)"),
        Diagnostic("x instead of y", _curvature_x,
                   "the curvature comes from the carrot's sideways offset y, not x"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- RPP's speed

def _regulated(curvature: float, remaining: float, desired: float, min_radius: float,
               min_speed: float, approach_dist: float, min_approach: float, *,
               floor: bool = True, approach: bool = True, inverted: bool = False) -> float:
    v = desired
    if abs(curvature) > 1e-9:
        radius = 1.0 / abs(curvature)
        if radius < min_radius:
            v *= (min_radius / radius) if inverted else radius / min_radius
    if floor and v < desired:
        v = max(v, min_speed)
    if approach and remaining < approach_dist:
        v = max(min(v, v * remaining / approach_dist), min_approach)
    return float(v)


def _regulated_no_floor(*a: float) -> float:
    return _regulated(*a, floor=False)


def _regulated_no_approach(*a: float) -> float:
    return _regulated(*a, approach=False)


def _regulated_inverted(*a: float) -> float:
    return _regulated(*a, inverted=True)


_NAV2 = (0.5, 0.9, 0.25, 0.6, 0.05)     # desired, min radius, min speed, approach, min approach


def _speeds(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(4):
        k = float(rng.choice([-1, 1]) * rng.uniform(0.0, 5.0))
        cases.append(Case(f"random {i}", (k, float(rng.uniform(0.0, 3.0)),
                                          float(rng.uniform(0.3, 1.0)), 0.9, 0.25, 0.6,
                                          0.05)))
    return cases


regulated_speed = Exercise(
    id="lab10.regulated_speed", function="regulated_speed",
    title="Regulated Pure Pursuit's speed", reference=_regulated, points=2,
    public=(Case("a straight stretch", (0.0, 5.0, *_NAV2)),
            Case("a curve of radius 0.6 m", (1 / 0.6, 5.0, *_NAV2)),
            Case("a tight turn: radius 0.25 m", (-4.0, 5.0, *_NAV2)),
            Case("0.3 m from the goal", (0.0, 0.3, *_NAV2)),
            Case("0.01 m from the goal", (0.0, 0.01, *_NAV2))),
    hidden=_speeds, rtol=1e-9, atol=1e-12,
    diagnostics=(
        Diagnostic("no floor at regulated_linear_scaling_min_speed", _regulated_no_floor,
                   "a regulated speed never drops below regulated_linear_scaling_min_speed"),
        Diagnostic("no slowing near the goal", _regulated_no_approach,
                   "within approach_velocity_scaling_dist of the goal, scale by "
                   "remaining / approach_velocity_scaling_dist (not below "
                   "min_approach_linear_velocity)"),
        Diagnostic("min_radius / radius instead of radius / min_radius", _regulated_inverted,
                   "on a tight curve the speed scales DOWN: by radius / min_radius (< 1)"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- DWB's window

def _window(v: float, w: float, sim_time: float, max_v: float, max_w: float, acc_v: float,
            acc_w: float, n_v: int, n_w: int, *, period: float | None = None) -> Any:
    """DWB's window over ``sim_time`` (or ``period``), evenly sampled, without the kit's move
    of the sample nearest ω = 0 onto it."""
    t = sim_time if period is None else period
    vs = np.linspace(max(0.0, v - acc_v * t), min(max_v, v + acc_v * t), n_v)
    ws = np.linspace(max(-max_w, w - acc_w * t), min(max_w, w + acc_w * t), n_w)
    gv, gw = np.meshgrid(vs, ws, indexing="ij")
    return np.column_stack([gv.ravel(), gw.ravel()])


def _window_one_period(*a: Any) -> Any:
    return _window(*a, period=0.05)


def _window_unclipped(v: float, w: float, sim_time: float, max_v: float, max_w: float,
                      acc_v: float, acc_w: float, n_v: int, n_w: int) -> Any:
    vx = np.linspace(v - acc_v * sim_time, v + acc_v * sim_time, n_v)
    vth = np.linspace(w - acc_w * sim_time, w + acc_w * sim_time, n_w)
    gx, gth = np.meshgrid(vx, vth, indexing="ij")
    return np.column_stack([gx.ravel(), gth.ravel()])


def _windows(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(3):
        cases.append(Case(f"random {i}", (float(rng.uniform(0, 0.5)),
                                          float(rng.uniform(-1, 1)), 1.7, 0.5, 1.0,
                                          float(rng.uniform(0.05, 0.3)),
                                          float(rng.uniform(0.1, 0.8)), 5, 3)))
    return cases


dynamic_window = Exercise(
    id="lab10.dynamic_window", function="dynamic_window", title="DWB's dynamic window",
    reference=_window, points=2,
    public=(Case("standing still, gentle accelerations", (0.0, 0.0, 1.7, 0.5, 1.0, 0.1, 0.2,
                                                           5, 3)),
            Case("cruising, limits reached", (0.45, 0.3, 1.7, 0.5, 1.0, 1.0, 3.2, 4, 5))),
    hidden=_windows, rtol=1e-9, atol=1e-12,
    diagnostics=(
        Diagnostic("the window over one control period", _window_one_period,
                   "DWB's standard generator opens the window over sim_time, not one control "
                   "period: each trajectory then ramps towards its target"),
        Diagnostic("velocities beyond the limits", _window_unclipped,
                   "clip the window to [min_vel_x, max_vel_x] and ±max_vel_theta"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- forward simulation

def _rollout(pose: Any, v: float, w: float, sim_time: float, steps: int, *,
             heading_first: bool = False, whole_dt: bool = False) -> Any:
    x, y, th = (float(c) for c in pose)
    dt = sim_time if whole_dt else sim_time / steps
    out = []
    for _ in range(steps):
        if heading_first:
            th += w * dt
        x += v * math.cos(th) * dt
        y += v * math.sin(th) * dt
        if not heading_first:
            th += w * dt
        out.append((x, y, th))
    return np.array(out)


def _rollout_heading_first(*a: Any) -> Any:
    return _rollout(*a, heading_first=True)


def _rollout_whole_dt(*a: Any) -> Any:
    return _rollout(*a, whole_dt=True)


def _rollouts(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", ((float(rng.uniform(-3, 3)), float(rng.uniform(-3, 3)),
                                  float(rng.uniform(-3, 3))), float(rng.uniform(0, 0.5)),
                                 float(rng.uniform(-1, 1)), 1.7, int(rng.integers(5, 30))))
            for i in range(3)]


rollout = Exercise(
    id="lab10.rollout", function="rollout", title="Forward simulation of a sample",
    reference=_rollout, points=2,
    public=(Case("straight ahead", ((0.0, 0.0, 0.0), 0.5, 0.0, 1.7, 17)),
            Case("a left arc", ((1.0, 2.0, 0.3), 0.4, 0.6, 1.7, 17)),
            Case("turning in place", ((0.0, 0.0, 3.0), 0.0, -1.0, 1.7, 10))),
    hidden=_rollouts, rtol=1e-9, atol=1e-12,
    diagnostics=(
        Diagnostic("heading turned before the step", _rollout_heading_first,
                   "as DWB's generator: move along the heading you had, THEN turn"),
        Diagnostic("dt = sim_time", _rollout_whole_dt,
                   "each of the steps lasts sim_time / steps"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- the goal checker

def _reached(pose: Any, goal: Any, xy_tolerance: float, yaw_tolerance: float, *,
             wrap: bool = True) -> bool:
    d = math.hypot(goal[0] - pose[0], goal[1] - pose[1])
    e = float(geometry.wrap_angle(goal[2] - pose[2])) if wrap else goal[2] - pose[2]
    return bool(d <= xy_tolerance and abs(e) <= yaw_tolerance)


def _reached_unwrapped(*a: Any) -> bool:
    return _reached(*a, wrap=False)


def _goals(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(4):
        g = (float(rng.uniform(-3, 3)), float(rng.uniform(-3, 3)), float(rng.choice([-3.1, 3.1])))
        p = (g[0] + float(rng.uniform(-0.3, 0.3)), g[1] + float(rng.uniform(-0.3, 0.3)),
             -g[2] + float(rng.uniform(-0.1, 0.1)))
        cases.append(Case(f"random {i}", (p, g, 0.25, 0.25)))
    return cases


goal_reached = Exercise(
    id="lab10.goal_reached", function="goal_reached", title="Nav2's goal check",
    reference=_reached, points=1,
    public=(Case("there and facing the right way", ((1.1, 2.0, 0.1), (1.0, 2.1, 0.0), 0.25,
                                                    0.25)),
            Case("there, facing away", ((1.0, 2.0, 1.0), (1.0, 2.0, 0.0), 0.25, 0.25)),
            Case("facing west either side of ±π", ((0.0, 0.0, 3.1), (0.1, 0.0, -3.1), 0.25,
                                                   0.25)),
            Case("0.3 m short", ((0.7, 0.0, 0.0), (1.0, 0.0, 0.0), 0.25, 0.25))),
    hidden=_goals, rtol=0.0, atol=0.0,
    diagnostics=(
        Diagnostic("the heading error not wrapped", _reached_unwrapped,
                   "3.1 rad and −3.1 rad are 0.08 rad apart: wrap the difference into "
                   "[−π, π) (kit.geometry.wrap_angle)"),
    ),
    blocked=_BLOCKED,
)


SPEC = LabSpec(name="lab10", title="Local planning",
               exercises=(pure_pursuit_curvature, regulated_speed, dynamic_window, rollout,
                          goal_reached))
