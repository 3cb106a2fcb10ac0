"""A student's functions inside the kit's controllers (Lab 10's last section): Regulated Pure
Pursuit with another curvature and speed rule, DWB with another window and rollout."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kit import msgs
from kit.navigation import (
    SUCCEEDED,
    DwbController,
    DwbParameters,
    Navigator,
    RegulatedPurePursuit,
    RppParameters,
    arc_poses,
    dynamic_window,
)
from kit.planning import LETHAL_OBSTACLE, Costmap
from kit.robots import load

SQUARE = np.array([[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.2, -0.2]])


def curvature(pose, carrot):
    """Lab 10's exercise 1, as a student writes it."""
    dx, dy = carrot[0] - pose[0], carrot[1] - pose[1]
    x = math.cos(pose[2]) * dx + math.sin(pose[2]) * dy
    y = -math.sin(pose[2]) * dx + math.cos(pose[2]) * dy
    return 0.0 if x * x + y * y < 1e-12 else 2.0 * y / (x * x + y * y)


def speed(k, remaining, desired, min_radius, min_speed, approach, min_approach):
    """Lab 10's exercise 2: Nav2's curvature, floor, approach and clamp."""
    v = desired * min(1.0, 1.0 / (abs(k) * min_radius)) if abs(k) > 1e-9 else desired
    v = max(v, min_speed)
    if remaining < approach:
        v = min(v, max(v * remaining / approach, min_approach))
    return min(v, desired)


def window(v, w, T, max_v, max_w, acc_v, acc_w, n_v, n_w):
    """Lab 10's exercise 3."""
    vs = np.linspace(max(0.0, v - acc_v * T), min(max_v, v + acc_v * T), n_v)
    ws = np.linspace(max(-max_w, w - acc_w * T), min(max_w, w + acc_w * T), n_w)
    gv, gw = np.meshgrid(vs, ws, indexing="ij")
    return np.column_stack([gv.ravel(), gw.ravel()])


def rollout(pose, v, w, T, steps):
    """Lab 10's exercise 4: Euler steps, move then turn."""
    x, y, th = pose
    out = []
    for _ in range(steps):
        x, y = x + v * math.cos(th) * T / steps, y + v * math.sin(th) * T / steps
        th += w * T / steps
        out.append((x, y, th))
    return np.array(out)


def winding_path():
    t = np.linspace(0, 2 * math.pi, 300)
    return np.column_stack([t, 0.8 * np.sin(t)])


def commands(controller, steps=120):
    """(v, ω) along a kinematic drive of the winding path."""
    pose, vel, out = np.array([0.0, -0.3, 0.3]), np.zeros(2), []
    controller.set_plan(winding_path(), 0.0)
    for _ in range(steps):
        v, w = controller.compute_velocity_commands(pose, vel)
        out.append((v, w))
        pose, vel = arc_poses(pose, v, w, np.array([0.05]))[0], np.array([v, w])
    return np.array(out)


def test_rpp_with_the_students_curvature_and_speed_drives_as_the_kits():
    params = RppParameters(use_collision_detection=False)
    kit = commands(RegulatedPurePursuit(params))
    mine = commands(RegulatedPurePursuit(params, curvature=curvature, speed=speed))
    assert np.allclose(mine, kit, rtol=1e-9, atol=1e-12)


def test_rpp_with_a_degraded_curvature_drives_otherwise():
    params = RppParameters(use_collision_detection=False)
    kit = commands(RegulatedPurePursuit(params))
    halved = commands(RegulatedPurePursuit(params, curvature=lambda p, c: 0.5 * curvature(p, c),
                                           speed=speed))
    assert np.max(np.abs(halved - kit)) > 0.05


def test_rpp_refuses_a_speed_rule_with_cost_regulation_on():
    with pytest.raises(ValueError, match="use_cost_regulated_linear_velocity_scaling"):
        RegulatedPurePursuit(RppParameters(use_cost_regulated_linear_velocity_scaling=True),
                             speed=speed)


def test_dwb_takes_the_students_window_and_rollouts():
    """The student's window is the kit's (ω = 0 among the samples); the student's rollouts
    hold each sample constant, where the kit's ramp towards it."""
    p = DwbParameters(vx_samples=5, vtheta_samples=7, acc_lim_x=1.0, decel_lim_x=-1.0)
    costs = np.zeros((80, 120), np.uint8)
    costs[30:50, 40:48] = LETHAL_OBSTACLE                  # a box at x = 2.0 … 2.4 m
    costmap = Costmap(costs, 0.05)
    pose, velocity = np.array([1.3, 2.0, 0.0]), (0.4, 0.0)
    kit = DwbController(p, SQUARE)
    mine = DwbController(p, SQUARE, window=window, rollout=rollout)
    for c in (kit, mine):
        c.set_plan([(x, 2.0) for x in np.linspace(0.5, 5.5, 101)], 0.0)
    vx, vth = dynamic_window(velocity, p)
    got_vx, got_vth, poses = mine.samples(pose, velocity)
    assert np.allclose(got_vx, vx) and np.allclose(got_vth, vth)
    steps = kit.steps(vx, vth)
    assert poses.shape == (35, steps, 3)
    for k in (0, 17, 34):
        assert np.allclose(poses[k], rollout(tuple(pose), vx[k], vth[k], p.sim_time, steps))
    assert not np.allclose(poses, kit.simulate(pose, vx, vth, velocity))   # no ramp
    scored = mine.score(pose, velocity, costmap)
    assert 0 < np.count_nonzero(~scored.valid) < len(vx)    # some reach the box, some not
    assert np.all(np.isinf(scored.total[~scored.valid]))


def test_the_navigator_reaches_a_goal_with_the_students_controller_parts():
    res, w, h = 0.05, 160, 60
    cells = np.zeros((h, w), dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = 100
    info = msgs.MapMetaData(resolution=res, width=w, height=h, origin=msgs.Pose())
    grid = msgs.OccupancyGrid(msgs.Header(frame_id="map"), info, cells.ravel())
    robot = load("uiabot")
    rpp = RegulatedPurePursuit(RppParameters.for_robot(robot), SQUARE, curvature=curvature,
                               speed=speed)
    nav = Navigator(grid, robot, controller=rpp)
    nav.navigate_to_pose((6.5, 1.5, 0.0))
    pose, vel = np.array([1.0, 1.2, 0.0]), np.zeros(2)
    for k in range(60 * 20):
        v, w_ = nav.tick(k / 20, pose, vel)
        pose, vel = arc_poses(pose, v, w_, np.array([0.05]))[0], np.array([v, w_])
        if nav.status != "RUNNING":
            break
    assert nav.status == SUCCEEDED, nav.reason
