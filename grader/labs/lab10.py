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

from grader.labs._hidden import until_each_shows
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


def _carrot_local(pose: Any, carrot: Any, turn: float = -1.0) -> tuple[float, float]:
    """The carrot's offset rotated by ``turn · θ`` (−1: into the robot's frame)."""
    dx, dy = carrot[0] - pose[0], carrot[1] - pose[1]
    c, s = math.cos(turn * pose[2]), math.sin(turn * pose[2])
    return c * dx - s * dy, s * dx + c * dy


def _curvature_world_frame(pose: Any, carrot: Any) -> float:
    dx, dy = carrot[0] - pose[0], carrot[1] - pose[1]
    return 2.0 * dy / (dx * dx + dy * dy)


def _curvature_no_two(pose: Any, carrot: Any) -> float:
    return 0.5 * _curvature(pose, carrot)


def _curvature_x(pose: Any, carrot: Any) -> float:
    x, y = _carrot_local(pose, carrot)
    return 2.0 * x / (x * x + y * y)


def _curvature_plus_theta(pose: Any, carrot: Any) -> float:
    x, y = _carrot_local(pose, carrot, turn=1.0)
    return 2.0 * y / (x * x + y * y)


def _curvature_flipped(pose: Any, carrot: Any) -> float:
    return -_curvature(pose, carrot)


def _carrot_draw(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(4):
        pose = (float(rng.uniform(-5, 5)), float(rng.uniform(-5, 5)),
                float(rng.uniform(-math.pi, math.pi)))
        carrot = (pose[0] + float(rng.uniform(-1.5, 1.5)),
                  pose[1] + float(rng.uniform(-1.5, 1.5)))
        cases.append(Case(f"random {i}", (pose, carrot)))
    return cases


def _carrots(rng: np.random.Generator) -> list[Case]:
    return until_each_shows(rng, _carrot_draw, _curvature,
                            [d.wrong for d in _PURSUIT_MISTAKES], rtol=1e-9, atol=1e-12)


_PURSUIT_MISTAKES = (
    Diagnostic("the carrot left in the map frame", _curvature_world_frame,
               "take the carrot into the robot's frame first (rotate by −θ): y is "
               "sideways from the robot's heading, not the map's north"),
    Diagnostic("y / L² (the 2 left out)", _curvature_no_two,
               "the circle through the robot tangent to its heading and through (x, y) "
               "has curvature 2 y / (x² + y²)"),
    Diagnostic("x instead of y", _curvature_x,
               "the curvature comes from the carrot's sideways offset y, not x"),
    Diagnostic("the carrot rotated by +θ instead of −θ", _curvature_plus_theta,
               "into the robot's frame is the inverse rotation: x = cos θ Δx + sin θ Δy, "
               "y = −sin θ Δx + cos θ Δy"),
    Diagnostic("the curvature's sign flipped", _curvature_flipped,
               "REP-103: y is to the left and a left turn is positive, κ = +2 y / (x² + y²)"),
)


pure_pursuit_curvature = Exercise(
    id="lab10.pure_pursuit_curvature", function="pure_pursuit_curvature",
    title="Pure pursuit: the arc through the carrot", reference=_curvature, points=2,
    public=(Case("carrot ahead and to the left", ((0.0, 0.0, 0.0), (1.0, 0.5))),
            Case("robot facing north-west, carrot to its right", ((2.0, 1.0, 2.0),
                                                                 (2.6, 1.8))),
            Case("carrot straight ahead", ((1.0, 1.0, 0.7),
                                           (1.0 + 1.2 * math.cos(0.7),
                                            1.0 + 1.2 * math.sin(0.7))))),
    hidden=_carrots, rtol=1e-9, atol=1e-12,
    diagnostics=_PURSUIT_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- RPP's speed

def _regulated(curvature: float, remaining: float, desired: float, min_radius: float,
               min_speed: float, approach_dist: float, min_approach: float, *,
               floor: bool = True, approach: bool = True, inverted: bool = False,
               approach_of_desired: bool = False, approach_floor: bool = True,
               floor_last: bool = False, signed: bool = False, clamp: bool = True) -> float:
    """Nav2's ``RegulatedPurePursuitController`` order of operations (its heuristics'
    ``curvatureConstraint``, the floor, ``approachVelocityConstraint``, the clamp), or one of
    the classic slips."""
    v = desired
    radius = math.inf if curvature == 0 else 1.0 / (curvature if signed else abs(curvature))
    if radius < min_radius:
        v = desired * ((min_radius / radius) if inverted else radius / min_radius)
    if floor and not floor_last:
        v = max(v, min_speed)
    if approach and remaining < approach_dist:
        scale = remaining / approach_dist
        slowed = (desired if approach_of_desired else v) * scale
        if approach_floor:
            slowed = max(slowed, min_approach)
        v = min(v, slowed)
    if floor_last:
        v = max(v, min_speed)
    return float(min(max(v, 0.0), desired) if clamp else v)


def _regulated_no_floor(*a: float) -> float:
    return _regulated(*a, floor=False)


def _regulated_no_approach(*a: float) -> float:
    return _regulated(*a, approach=False)


def _regulated_inverted(*a: float) -> float:
    return _regulated(*a, inverted=True, clamp=False)


def _regulated_inverted_clamped(*a: float) -> float:
    return _regulated(*a, inverted=True)


def _regulated_approach_of_desired(*a: float) -> float:
    return _regulated(*a, approach_of_desired=True)


def _regulated_no_approach_floor(*a: float) -> float:
    return _regulated(*a, approach_floor=False)


def _regulated_floor_last(*a: float) -> float:
    return _regulated(*a, floor_last=True)


def _regulated_signed(*a: float) -> float:
    return _regulated(*a, signed=True)


_NAV2 = (0.5, 0.9, 0.25, 0.6, 0.05)     # desired, min radius, min speed, approach, min approach


def _speed_draw(rng: np.random.Generator) -> list[Case]:
    """One case of each kind, the parameters drawn too (min_approach < min_speed < desired):
    a gentle right turn, a tight curve above the floor, one below it, straight on near the goal
    (above min_approach, below min_speed), right at the goal, and a tight curve near the goal."""
    cases = []
    kinds = ("a gentle right turn", "a tight curve", "a curve below the floor",
             "straight on near the goal", "at the goal", "a tight curve near the goal")
    for kind in kinds:
        desired = float(rng.uniform(0.4, 1.0))
        min_radius = float(rng.uniform(0.6, 1.2))
        min_speed = float(rng.uniform(0.15, 0.3))
        approach = float(rng.uniform(0.4, 1.0))
        min_approach = float(rng.uniform(0.02, 0.08))
        far = float(rng.uniform(1.5, 5.0))
        sign = float(rng.choice([-1.0, 1.0]))
        # radius with the curvature's speed between the floor and desired, and below it
        above = min_radius * float(rng.uniform(min_speed / desired + 0.1, 0.9))
        below = min_radius * float(rng.uniform(0.1, 0.8)) * min_speed / desired
        if kind == "a gentle right turn":
            k, left = -1.0 / (min_radius * float(rng.uniform(1.2, 4.0))), far
        elif kind == "a tight curve":
            k, left = sign / above, far
        elif kind == "a curve below the floor":
            k, left = sign / below, far
        elif kind == "straight on near the goal":
            # desired · remaining / approach between min_approach and min_speed
            share = float(rng.uniform(min_approach, min_speed)) / desired
            k, left = 0.0, share * approach
        elif kind == "at the goal":
            k, left = 0.0, float(rng.uniform(0.0, 0.5)) * min_approach / desired * approach
        else:
            v1 = desired * above / min_radius
            share = float(rng.uniform(min_approach / v1 + 0.05, 0.95))
            k, left = sign / above, share * approach
        cases.append(Case(kind, (k, left, desired, min_radius, min_speed, approach,
                                 min_approach)))
    return cases


def _speeds(rng: np.random.Generator) -> list[Case]:
    return until_each_shows(rng, _speed_draw, _regulated, [d.wrong for d in _RPP_MISTAKES],
                            rtol=1e-9, atol=1e-12)


_RPP_MISTAKES = (
    Diagnostic("no floor at regulated_linear_scaling_min_speed", _regulated_no_floor,
               "a regulated speed never drops below regulated_linear_scaling_min_speed"),
    Diagnostic("no slowing near the goal", _regulated_no_approach,
               "within approach_velocity_scaling_dist of the goal, scale by "
               "remaining / approach_velocity_scaling_dist (not below "
               "min_approach_linear_velocity)"),
    Diagnostic("min_radius / radius instead of radius / min_radius", _regulated_inverted,
               "on a tight curve the speed scales DOWN: by radius / min_radius (< 1)"),
    Diagnostic("min_radius / radius instead of radius / min_radius",
               _regulated_inverted_clamped,
               "on a tight curve the speed scales DOWN: by radius / min_radius (< 1)"),
    Diagnostic("the goal approach scaling desired_linear_vel", _regulated_approach_of_desired,
               "the approach factor scales the speed already regulated by the curvature "
               "(and floored), not desired_linear_vel: v = min(v, max(v · remaining / "
               "approach_dist, min_approach))"),
    Diagnostic("no floor at min_approach_linear_velocity", _regulated_no_approach_floor,
               "near the goal the scaled speed never drops below "
               "min_approach_linear_velocity, or the robot stalls short of the goal"),
    Diagnostic("the floor at min_speed applied after the goal approach", _regulated_floor_last,
               "the floor at regulated_linear_scaling_min_speed comes BEFORE the goal "
               "approach: near the goal the speed may drop to min_approach_linear_velocity"),
    Diagnostic("the curvature's sign kept in the radius", _regulated_signed,
               "a right turn has a negative curvature but a positive radius: "
               "R = 1 / |κ|"),
)

regulated_speed = Exercise(
    id="lab10.regulated_speed", function="regulated_speed",
    title="Regulated Pure Pursuit's speed", reference=_regulated, points=2,
    public=(Case("a straight stretch", (0.0, 5.0, *_NAV2)),
            Case("a curve of radius 0.6 m", (1 / 0.6, 5.0, *_NAV2)),
            Case("a tight turn: radius 0.25 m", (-4.0, 5.0, *_NAV2)),
            Case("a gentle right turn: radius 2 m", (-0.5, 5.0, *_NAV2)),
            Case("0.3 m from the goal", (0.0, 0.3, *_NAV2)),
            Case("0.01 m from the goal", (0.0, 0.01, *_NAV2)),
            Case("a curve of radius 0.6 m, 0.36 m from the goal", (1 / 0.6, 0.36, *_NAV2))),
    hidden=_speeds, rtol=1e-9, atol=1e-12,
    diagnostics=_RPP_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- DWB's window

def _window(v: float, w: float, sim_time: float, max_v: float, max_w: float, acc_v: float,
            acc_w: float, n_v: int, n_w: int, *, period: float | None = None,
            clip: bool = True, dynamic: bool = True, min_v: float = 0.0,
            v_slowest: bool = True) -> Any:
    """DWB's window over ``sim_time`` (or ``period``), evenly sampled, without the kit's move
    of the sample nearest ω = 0 onto it; or one of the classic slips."""
    t = sim_time if period is None else period
    if dynamic:
        lo_v, hi_v, lo_w, hi_w = v - acc_v * t, v + acc_v * t, w - acc_w * t, w + acc_w * t
    else:
        lo_v, hi_v, lo_w, hi_w = min_v, max_v, -max_w, max_w
    if clip:
        lo_v, hi_v = max(min_v, lo_v), min(max_v, hi_v)
        lo_w, hi_w = max(-max_w, lo_w), min(max_w, hi_w)
    vs, ws = np.linspace(lo_v, hi_v, n_v), np.linspace(lo_w, hi_w, n_w)
    if v_slowest:
        gv, gw = np.meshgrid(vs, ws, indexing="ij")
    else:
        gv, gw = np.meshgrid(vs, ws)               # numpy's default: ω varies slowest
    return np.column_stack([gv.ravel(), gw.ravel()])


def _window_one_period(*a: Any) -> Any:
    return _window(*a, period=0.05)


def _window_unclipped(*a: Any) -> Any:
    return _window(*a, clip=False)


def _window_whole_limits(*a: Any) -> Any:
    return _window(*a, dynamic=False)


def _window_down_to_minus_max(v: float, w: float, sim_time: float, max_v: float, *a: Any
                              ) -> Any:
    return _window(v, w, sim_time, max_v, *a, min_v=-max_v)


def _window_omega_slowest(*a: Any) -> Any:
    return _window(*a, v_slowest=False)


def _window_draw(rng: np.random.Generator) -> list[Case]:
    """A robot nearly standing (the window reaches below 0), one turning hard (it reaches past
    ±max_w) and one cruising at the speed limit."""
    cases = []
    for i, (v, w) in enumerate(((float(rng.uniform(0.0, 0.1)), float(rng.uniform(-0.3, 0.3))),
                                (float(rng.uniform(0.1, 0.4)),
                                 float(rng.choice([-1, 1]) * rng.uniform(0.6, 1.0))),
                                (0.5, float(rng.uniform(-0.2, 0.2))))):
        cases.append(Case(f"random {i}", (v, w, 1.7, 0.5, 1.0, float(rng.uniform(0.1, 0.4)),
                                          float(rng.uniform(0.2, 0.8)),
                                          int(rng.integers(3, 7)), int(rng.integers(3, 8)))))
    return cases


def _windows(rng: np.random.Generator) -> list[Case]:
    return until_each_shows(rng, _window_draw, _window, [d.wrong for d in _WINDOW_MISTAKES],
                            rtol=1e-9, atol=1e-12)


_WINDOW_MISTAKES = (
    Diagnostic("the window over one control period", _window_one_period,
               "DWB's standard generator opens the window over sim_time, not one control "
               "period: each trajectory then ramps towards its target"),
    Diagnostic("velocities beyond the limits", _window_unclipped,
               "clip the window to [min_vel_x, max_vel_x] and ±max_vel_theta"),
    Diagnostic("the acceleration limits ignored", _window_whole_limits,
               "the window is what the accelerations reach within sim_time from the current "
               "velocity — [v − acc_v T, v + acc_v T] ∩ [0, max_v] and [ω − acc_w T, "
               "ω + acc_w T] ∩ [−max_w, max_w] — not every velocity the limits allow"),
    Diagnostic("the speed clipped at −max_v instead of 0", _window_down_to_minus_max,
               "DWB's min_vel_x is 0: the window's speeds start at max(0, v − acc_v T), "
               "the robot does not reverse"),
    Diagnostic("ω varying slowest (meshgrid's default indexing)", _window_omega_slowest,
               "the samples are ordered with the speed varying slowest: "
               "np.meshgrid(vs, ws, indexing=\"ij\") before ravel"),
)

dynamic_window = Exercise(
    id="lab10.dynamic_window", function="dynamic_window", title="DWB's dynamic window",
    reference=_window, points=2,
    public=(Case("standing still, gentle accelerations", (0.0, 0.0, 1.7, 0.5, 1.0, 0.1, 0.8,
                                                           5, 3)),
            Case("cruising, limits reached", (0.45, 0.3, 1.7, 0.5, 1.0, 1.0, 3.2, 4, 5))),
    hidden=_windows, rtol=1e-9, atol=1e-12,
    diagnostics=_WINDOW_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- forward simulation

def _rollout(pose: Any, v: float, w: float, sim_time: float, steps: int, *,
             heading_first: bool = False, whole_dt: bool = False,
             with_start: bool = False) -> Any:
    x, y, th = (float(c) for c in pose)
    dt = sim_time if whole_dt else sim_time / steps
    out = [(x, y, th)] if with_start else []
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


def _rollout_with_start(*a: Any) -> Any:
    return _rollout(*a, with_start=True)


def _rollout_exact_arc(pose: Any, v: float, w: float, sim_time: float, steps: int) -> Any:
    times = sim_time / steps * np.arange(1, steps + 1, dtype=np.float64)
    return nav.arc_poses(np.asarray(pose, dtype=float), v, w, times)


def _rollout_draw(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(3):
        w = float(rng.uniform(-1, 1))
        # headings that stay inside (−π, π) all the way: a wrapped heading is as right
        th = float(rng.uniform(-3.0 - min(w, 0.0) * 1.7, 3.0 - max(w, 0.0) * 1.7))
        cases.append(Case(f"random {i}", ((float(rng.uniform(-3, 3)), float(rng.uniform(-3, 3)),
                                           th), float(rng.uniform(0.1, 0.5)), w, 1.7,
                                          int(rng.integers(5, 30)))))
    return cases


def _rollouts(rng: np.random.Generator) -> list[Case]:
    return until_each_shows(rng, _rollout_draw, _rollout, [d.wrong for d in _ROLLOUT_MISTAKES],
                            rtol=1e-9, atol=1e-12)


_ROLLOUT_MISTAKES = (
    Diagnostic("heading turned before the step", _rollout_heading_first,
               "as DWB's generator: move along the heading you had, THEN turn"),
    Diagnostic("dt = sim_time", _rollout_whole_dt,
               "each of the steps lasts sim_time / steps"),
    Diagnostic("the exact arc instead of Euler steps", _rollout_exact_arc,
               "these are the poses on the exact circular arc; DWB's generator (and this "
               "exercise) takes Euler steps — x += v cos θ Δt, y += v sin θ Δt, then "
               "θ += ω Δt — whose poses differ a little from the arc's"),
    Diagnostic("the start pose included", _rollout_with_start,
               "return the poses AFTER each step: `steps` rows, the start pose not among "
               "them"),
)

rollout = Exercise(
    id="lab10.rollout", function="rollout", title="Forward simulation of a sample",
    reference=_rollout, points=2,
    public=(Case("straight ahead", ((0.0, 0.0, 0.0), 0.5, 0.0, 1.7, 17)),
            Case("a left arc", ((1.0, 2.0, 0.3), 0.4, 0.6, 1.7, 17)),
            Case("turning in place", ((0.0, 0.0, 3.0), 0.0, -1.0, 1.7, 10))),
    hidden=_rollouts, rtol=1e-9, atol=1e-12,
    diagnostics=_ROLLOUT_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- the goal checker

def _reached(pose: Any, goal: Any, xy_tolerance: float, yaw_tolerance: float, *,
             wrap: bool = True, strict: bool = False, yaw: bool = True,
             absolute: bool = True, squared: bool = False, box: bool = False) -> bool:
    dx, dy = goal[0] - pose[0], goal[1] - pose[1]
    e = float(geometry.wrap_angle(goal[2] - pose[2])) if wrap else goal[2] - pose[2]
    e = abs(e) if absolute else e
    if box:
        near = max(abs(dx), abs(dy)) <= xy_tolerance
    else:
        d = dx * dx + dy * dy if squared else math.hypot(dx, dy)
        near = d < xy_tolerance if strict else d <= xy_tolerance
    facing = (e < yaw_tolerance if strict else e <= yaw_tolerance) if yaw else True
    return bool(near and facing)


def _reached_unwrapped(*a: Any) -> bool:
    return _reached(*a, wrap=False)


def _reached_strict(*a: Any) -> bool:
    return _reached(*a, strict=True)


def _reached_position_only(*a: Any) -> bool:
    return _reached(*a, yaw=False)


def _reached_signed(*a: Any) -> bool:
    return _reached(*a, absolute=False)


def _reached_squared(*a: Any) -> bool:
    return _reached(*a, squared=True)


def _reached_box(*a: Any) -> bool:
    return _reached(*a, box=True)


_GOAL_SLIPS = (_reached_unwrapped, _reached_strict, _reached_position_only, _reached_signed,
               _reached_squared, _reached_box)
"""every slip the hidden cases must catch (some share a hint)"""


_SIXTEENTH = 1.0 / 16


def _goal_draw(rng: np.random.Generator) -> list[Case]:
    """Goals in sixteenths of a metre and of a radian, so that the boundary cases sit exactly
    on Nav2's inclusive tolerances whichever way a distance or a wrapped angle is computed:
    across ±π, exactly at the xy tolerance (along an axis, or 3-4-5), exactly at the yaw
    tolerance, facing away either way round, and a diagonal offset beyond the tolerance but
    inside its square."""
    def sixteenths(low: float, high: float) -> float:
        return float(rng.integers(round(low * 16), round(high * 16) + 1)) * _SIXTEENTH

    cases = []
    xy = float(rng.choice([0.125, 0.1875, 0.25, 0.3125]))
    yaw = float(rng.choice([0.125, 0.25, 0.375]))
    sign = float(rng.choice([-1.0, 1.0]))

    def goal(heading: float) -> tuple[float, float, float]:
        return (sixteenths(-3, 3), sixteenths(-3, 3), heading)

    # across ±π: 0.1 rad apart through π, 6.2 rad apart unwrapped
    g = goal(sign * float(rng.uniform(3.05, 3.13)))
    cases.append(Case("facing west either side of ±π",
                      ((g[0] + _SIXTEENTH * sign, g[1], -g[2] + sign * 0.02), g, 0.25, 0.25)))
    # exactly at the xy tolerance, along an axis or on a 3-4-5 triangle
    g = goal(sixteenths(-2, 2))
    if rng.random() < 0.5:
        offset = (xy * sign, 0.0) if rng.random() < 0.5 else (0.0, xy * sign)
        tolerance = xy
    else:
        offset, tolerance = (3 * _SIXTEENTH * sign, 4 * _SIXTEENTH), 5 * _SIXTEENTH
    cases.append(Case("exactly at the xy tolerance",
                      ((g[0] - offset[0], g[1] - offset[1], g[2]), g, tolerance, yaw)))
    # exactly at the yaw tolerance
    g = goal(sixteenths(-2, 2))
    cases.append(Case("exactly at the yaw tolerance",
                      ((g[0], g[1] + _SIXTEENTH, g[2] - sign * yaw), g, xy, yaw)))
    # there, facing away: a quarter turn one way, then just beyond the tolerance the other
    for i, turn in enumerate((sign * float(rng.uniform(1.0, 2.0)),
                              -sign * (yaw + float(rng.uniform(0.05, 0.3))))):
        g = goal(sixteenths(-1, 1))
        cases.append(Case(f"there, facing away {i}", ((g[0], g[1], g[2] - turn), g, xy, yaw)))
    # a diagonal offset beyond the tolerance, inside its square and inside √tolerance
    g = goal(sixteenths(-2, 2))
    step = xy * float(rng.uniform(0.75, 0.95))
    cases.append(Case("diagonally just outside", ((g[0] + step, g[1] - sign * step, g[2]), g,
                                                  xy, yaw)))
    return cases


def _goals(rng: np.random.Generator) -> list[Case]:
    return until_each_shows(rng, _goal_draw, _reached, _GOAL_SLIPS, rtol=1e-9, atol=1e-12)


_GOAL_MISTAKES = (
    Diagnostic("the heading error not wrapped", _reached_unwrapped,
               "3.1 rad and −3.1 rad are 0.08 rad apart: wrap the difference into "
               "[−π, π) (kit.geometry.wrap_angle)"),
    Diagnostic("< instead of ≤ (the tolerances exclusive)", _reached_strict,
               "Nav2's SimpleGoalChecker counts a robot exactly at a tolerance as there: "
               "distance ≤ xy_goal_tolerance and |heading error| ≤ yaw_goal_tolerance"),
    # a True/False answer cannot tell some slips apart: a heading error compared with its
    # sign says True exactly where the heading is not checked (on the side it gets wrong),
    # and every offset inside the tolerance's square is inside √tolerance too
    Diagnostic("the heading not checked", _reached_position_only,
               "a goal is a pose: the robot must also face within yaw_goal_tolerance of the "
               "goal's heading — |wrap(θ_goal − θ)|, its size whichever way round — not only "
               "stand within xy_goal_tolerance of it"),
    Diagnostic("the distance measured wrong (squared, or per axis)", _reached_squared,
               "the tolerance is a radius: √(dx² + dy²) ≤ xy_goal_tolerance — not dx² + dy² "
               "against the tolerance itself, nor |dx| and |dy| each"),
)

goal_reached = Exercise(
    id="lab10.goal_reached", function="goal_reached", title="Nav2's goal check",
    reference=_reached, points=1,
    public=(Case("there and facing the right way", ((1.1, 2.0, 0.1), (1.0, 2.1, 0.0), 0.25,
                                                    0.25)),
            Case("there, facing away", ((1.0, 2.0, 1.0), (1.0, 2.0, 0.0), 0.25, 0.25)),
            Case("there, facing away the other way", ((1.0, 2.0, -0.5), (1.0, 2.0, 0.0), 0.25,
                                                       0.25)),
            Case("facing west either side of ±π", ((0.0, 0.0, 3.1), (0.1, 0.0, -3.1), 0.25,
                                                   0.25)),
            Case("0.3 m short", ((0.7, 0.0, 0.0), (1.0, 0.0, 0.0), 0.25, 0.25)),
            Case("exactly 0.25 m short", ((0.75, 0.0, 0.0), (1.0, 0.0, 0.0), 0.25, 0.25)),
            Case("0.2 m off along both axes", ((0.8, 0.2, 0.0), (1.0, 0.0, 0.0), 0.25, 0.25))),
    hidden=_goals, rtol=0.0, atol=0.0,
    diagnostics=_GOAL_MISTAKES,
    blocked=_BLOCKED,
)


SPEC = LabSpec(name="lab10", title="Local planning",
               exercises=(pure_pursuit_curvature, regulated_speed, dynamic_window, rollout,
                          goal_reached))
