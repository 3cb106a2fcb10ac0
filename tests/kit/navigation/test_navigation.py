"""kit.navigation against geometry, Nav2's definitions and closed loops on a kinematic robot."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from kit import geometry, msgs
from kit.navigation import (
    FAILED,
    RUNNING,
    SUCCEEDED,
    BackUp,
    ControlError,
    DwbController,
    DwbParameters,
    GoalChecker,
    NavigationConfig,
    NavigationCostmap,
    Navigator,
    NavigatorParameters,
    ProgressChecker,
    RegulatedPurePursuit,
    RppParameters,
    Spin,
    Unavailable,
    arc_poses,
    check_path,
    closest_index,
    collides_from,
    dynamic_window,
    footprint_collides,
    lookahead_point,
    outline_points,
    pure_pursuit_curvature,
)
from kit.planning import LETHAL_OBSTACLE, Costmap, ObstacleLayer, pad_footprint
from kit.robots import load

SQUARE = np.array([[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.2, -0.2]])


def free_grid(width: float = 10.0, height: float = 4.0, res: float = 0.05,
              boxes: tuple[tuple[float, float, float, float], ...] = ()) -> msgs.OccupancyGrid:
    """A walled rectangle (walls one cell thick) with filled boxes (x0, y0, x1, y1)."""
    w, h = round(width / res), round(height / res)
    cells = np.zeros((h, w), dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = 100
    for x0, y0, x1, y1 in boxes:
        cells[int(y0 / res):math.ceil(y1 / res), int(x0 / res):math.ceil(x1 / res)] = 100
    info = msgs.MapMetaData(resolution=res, width=w, height=h, origin=msgs.Pose())
    return msgs.OccupancyGrid(msgs.Header(frame_id="map"), info, cells.ravel())


# ---------------------------------------------------------------- pure pursuit geometry

@pytest.mark.parametrize("carrot", [(1.0, 0.5), (0.3, -0.8), (-0.5, 1.0), (2.0, 0.01)])
def test_the_pure_pursuit_arc_passes_through_the_robot_and_the_carrot(carrot):
    pose = np.array([1.0, -2.0, 0.7])
    c, s = math.cos(pose[2]), math.sin(pose[2])
    world = pose[:2] + np.array([c * carrot[0] - s * carrot[1], s * carrot[0] + c * carrot[1]])
    k = pure_pursuit_curvature(pose, world)
    # the circle's centre is 1/k to the robot's left; the carrot lies on it
    centre = np.array([0.0, 1.0 / k])
    assert math.isclose(float(np.hypot(*(np.array(carrot) - centre))), abs(1.0 / k),
                        rel_tol=1e-9)
    # driven at 1 m/s, the arc reaches the carrot after turning twice its bearing
    end = arc_poses(pose, 1.0, k, np.array([2 * math.atan2(carrot[1], carrot[0]) / k]))[0]
    assert np.allclose(end[:2], world, atol=1e-9)


def test_the_carrot_is_a_lookahead_away_on_the_path():
    path = check_path([(0.0, 0.0), (1.0, 0.0), (1.0, 2.0), (3.0, 2.0)])
    xy = np.array([0.9, 0.1])
    carrot = lookahead_point(path, xy, 0.8, closest_index(path, xy))
    assert math.isclose(float(np.hypot(*(carrot - xy))), 0.8, rel_tol=1e-9)
    assert math.isclose(carrot[0], 1.0)          # on the second segment, x = 1
    near_end = np.array([2.9, 2.0])
    assert np.allclose(lookahead_point(path, near_end, 1.0, closest_index(path, near_end)),
                       path[-1])


def test_paths_with_nan_or_the_wrong_shape_are_refused():
    with pytest.raises(ValueError, match="finite"):
        check_path([(0.0, 0.0), (np.nan, 1.0)])
    with pytest.raises(ValueError, match=r"\(N, 2\)"):
        check_path([1.0, 2.0, 3.0])


# ---------------------------------------------------------------- regulated pure pursuit

def test_rpp_drives_straight_at_the_desired_speed_and_slows_on_tight_curves():
    c = RegulatedPurePursuit(RppParameters(use_rotate_to_heading=False,
                                           max_linear_accel=100.0))
    c.set_plan([(x, 0.0) for x in np.linspace(0, 5, 51)])
    v, w = c.compute_velocity_commands((0.0, 0.0, 0.0), (0.5, 0.0))
    assert (v, w) == (0.5, 0.0)
    # a circle of radius 0.45 m (half Nav2's min radius 0.9): half speed, ω = v / R
    R = 0.45
    t = np.linspace(0, math.pi, 200)
    c.set_plan(np.column_stack([R * np.sin(t), R - R * np.cos(t)]))
    v, w = c.compute_velocity_commands((0.0, 0.0, 0.0), (0.5, 0.0))
    carrot = c.last_carrot
    k = pure_pursuit_curvature((0.0, 0.0, 0.0), carrot)
    expected = max(0.5 * (1 / k) / 0.9, 0.25)
    assert v == pytest.approx(expected, rel=1e-9)
    assert w == pytest.approx(v * k, rel=1e-9)


def test_rpp_slows_approaching_the_goal_and_rotates_to_a_path_behind_it():
    p = RppParameters(max_linear_accel=100.0)
    c = RegulatedPurePursuit(p)
    c.set_plan([(0.0, 0.0), (0.3, 0.0)])
    v, _ = c.compute_velocity_commands((0.0, 0.0, 0.0), (0.5, 0.0))
    assert v == pytest.approx(0.5 * 0.3 / p.approach_velocity_scaling_dist)
    c.set_plan([(0.0, 0.0), (-2.0, 0.0)])
    v, w = c.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0))
    assert v == 0.0 and 0 < abs(w) <= p.max_angular_accel / p.controller_frequency + 1e-12


def test_rpp_turns_to_the_goal_heading_only_within_the_goal_checkers_tolerance():
    """Nav2's shouldRotateToGoalHeading: the lookahead point (the goal, near the end) closer
    than the goal checker's xy tolerance. 0.20 m short of the goal with a 0.10 m tolerance the
    robot still drives (approach speed 0.5 · 0.2 / 0.6); with Nav2's default 0.25 m it turns
    on the spot (here: already facing the heading, so it stands)."""
    c = RegulatedPurePursuit()
    c.set_plan([(0.0, 0.0), (2.0, 0.0)], goal_yaw=0.0)
    c.goal_dist_tol = 0.10
    v, w = c.compute_velocity_commands((1.8, 0.0, 0.0), (0.2, 0.0))
    assert (v, w) == (pytest.approx(0.5 * 0.2 / 0.6), 0.0)
    c.goal_dist_tol = 0.25
    assert c.compute_velocity_commands((1.8, 0.0, 0.0), (0.2, 0.0)) == (0.0, 0.0)
    # stateful (Nav2's default): once within, it keeps turning even if it drifts out
    c.goal_dist_tol = 0.10
    assert c.compute_velocity_commands((1.8, 0.0, 0.0), (0.0, 0.0)) == (0.0, 0.0)
    c.set_plan([(0.0, 0.0), (2.0, 0.0)], goal_yaw=0.0)             # a new path forgets it
    assert c.compute_velocity_commands((1.8, 0.0, 0.0), (0.2, 0.0))[0] > 0.1


@pytest.mark.parametrize("tolerance", [0.25, 0.10, 0.05])
def test_rpp_reaches_goals_with_tolerances_below_a_quarter_metre(tolerance):
    """The navigator gives the controller its goal checker's tolerance: with 0.10 m (a common
    Nav2 setting) the kit's RPP used to stop turning 0.25 m short and never finish."""
    nav = Navigator(free_grid(), load("uiabot"), controller="rpp",
                    params=NavigatorParameters(xy_goal_tolerance=tolerance))
    nav.navigate_to_pose((8.0, 1.0, 0.0))
    end = drive(nav, (1.0, 1.0, 0.0), 60.0)[-1]
    assert nav.status == SUCCEEDED, nav.reason
    assert math.hypot(end[0] - 8.0, end[1] - 1.0) < tolerance


def test_rpp_rotation_brakes_to_stop_on_the_heading_after_the_acceleration_limit():
    """Nav2's rotateToHeading: the turn rate within what max_angular_accel reaches in a period,
    then capped at √(2 · a · angle), which stops on the heading. 0.1 rad left, turning at
    1.8 rad/s: √(2 · 3.2 · 0.1) = 0.8 rad/s (the kit's earlier order gave 1.64)."""
    c = RegulatedPurePursuit(RppParameters())
    c.set_plan([(0.0, 0.0), (2.0, 0.0)], goal_yaw=0.0)
    c.goal_dist_tol = 0.25
    v, w = c.compute_velocity_commands((1.9, 0.0, -0.1), (0.0, 1.8))
    assert v == 0.0 and w == pytest.approx(math.sqrt(2 * 3.2 * 0.1))


def test_rpp_cost_regulation_reads_a_cost_as_nav2_jazzy_does():
    """Jazzy's costConstraint: distance = (k · r_ins − ln cost + ln 253) / k with the footprint's
    inscribed radius (nearest vertex or edge: 0.2 m for a 0.4 m square), speed scaled by
    gain · distance / cost_scaling_dist. Cost 100 everywhere, k = 3, 0.6 m: 0.5 · 0.50941 / 0.6."""
    p = RppParameters(use_cost_regulated_linear_velocity_scaling=True, cost_scaling_dist=0.6,
                      max_linear_accel=100.0)
    square = [[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.2, -0.2]]
    c = RegulatedPurePursuit(p, square)
    c.set_plan([(x, 2.0) for x in np.linspace(0.0, 6.0, 121)])
    costmap = Costmap(np.full((80, 120), 100, np.uint8), 0.05)
    v, _ = c.compute_velocity_commands((1.0, 2.0, 0.0), (0.5, 0.0), costmap)
    distance = (3.0 * 0.2 - math.log(100.0) + math.log(253.0)) / 3.0
    assert v == pytest.approx(0.5 * distance / 0.6) and v == pytest.approx(0.42451, abs=1e-5)
    lethal = Costmap(np.full((80, 120), 254, np.uint8), 0.05)        # Nav2 regulates 254 too
    c.set_plan([(x, 2.0) for x in np.linspace(0.0, 6.0, 121)])
    p2 = RppParameters(use_cost_regulated_linear_velocity_scaling=True, cost_scaling_dist=0.6,
                       max_linear_accel=100.0, use_collision_detection=False)
    c2 = RegulatedPurePursuit(p2, square)
    c2.set_plan([(x, 2.0) for x in np.linspace(0.0, 6.0, 121)])
    v254, _ = c2.compute_velocity_commands((1.0, 2.0, 0.0), (0.5, 0.0), lethal)
    assert v254 == pytest.approx(max(0.5 * (0.6 - math.log(254.0) + math.log(253.0)) / 3.0
                                     / 0.6, p2.regulated_linear_scaling_min_speed))


@pytest.mark.parametrize("controller", ["rpp", "dwb"])
def test_every_new_path_rearms_the_stateful_goal_checker(controller):
    """Nav2's controller server resets its goal checker whenever it is given a path
    (setPlannerPath: every replan, once a second), and the controllers start afresh (DWB's
    critics, RPP's latch): a robot that came within the tolerance, then drifted out while
    turning, is not at its goal after the next replan."""
    nav = Navigator(free_grid(), load("uiabot"), controller=controller)
    nav.navigate_to_pose((8.0, 1.0, 0.0))
    gc = nav.goal_checker
    goal = np.array([8.0, 1.0, 0.0])
    assert not gc.is_goal_reached((7.9, 1.0, 1.5), goal, (0.0, 0.0))    # within xy: latched
    assert gc.is_goal_reached((7.6, 1.0, 0.0), goal, (0.0, 0.0))        # 0.4 m out, stateful
    nav.tick(0.0, np.array([1.0, 1.0, 1.0]), np.zeros(2))               # plans: a new path
    assert not gc.is_goal_reached((7.6, 1.0, 0.0), goal, (0.0, 0.0))


def test_rpp_refuses_an_arc_into_a_wall():
    costs = np.zeros((40, 40), np.uint8)
    costs[:, 12] = LETHAL_OBSTACLE               # a wall at x = 0.6 m
    c = RegulatedPurePursuit(RppParameters(max_linear_accel=100.0), SQUARE)
    c.set_plan([(x, 1.0) for x in np.linspace(0.2, 1.9, 20)])
    with pytest.raises(ControlError, match="collision ahead"):
        c.compute_velocity_commands((0.2, 1.0, 0.0), (0.5, 0.0), Costmap(costs, 0.05))


# ---------------------------------------------------------------- DWB

def test_the_dynamic_window_is_what_the_accelerations_reach_in_sim_time():
    p = DwbParameters(vx_samples=5, vtheta_samples=3, acc_lim_x=0.1, decel_lim_x=-0.2,
                      acc_lim_theta=0.5, decel_lim_theta=-0.5, sim_time=1.0)
    vx, vth = dynamic_window((0.3, 0.2), p)
    assert vx.min() == pytest.approx(0.1) and vx.max() == pytest.approx(0.4)
    assert vth.min() == pytest.approx(-0.3) and vth.max() == pytest.approx(0.7)
    assert len(vx) == 15


def test_dwb_trajectories_at_constant_velocity_follow_the_exact_arc():
    ctrl = DwbController(DwbParameters(linear_granularity=0.001, angular_granularity=0.001))
    pose = np.array([1.0, 2.0, 0.3])
    poses = ctrl.simulate(pose, np.array([0.4]), np.array([0.6]), (0.4, 0.6))[0]
    times = np.linspace(0, ctrl.params.sim_time, len(poses) + 1)[1:]
    exact = arc_poses(pose, 0.4, 0.6, times)
    assert np.max(np.abs(poses - exact)) < 2e-3     # Euler steps of 1.7 ms


def test_dwb_never_drives_into_an_obstacle_across_its_path():
    """A path straight through a box the planner did not know: DWB follows it up to the box
    and stops short; no pose it drives touches the box (replanning is the navigator's job)."""
    grid = free_grid(boxes=((3.0, 1.6, 3.4, 2.4),))
    cm = NavigationCostmap(grid, SQUARE)
    costmap = cm.costmap()
    ctrl = DwbController(DwbParameters(max_vel_x=0.5, acc_lim_x=1.0, decel_lim_x=-1.0),
                         SQUARE, cm.circumscribed_cost)
    ctrl.set_plan([(x, 2.0) for x in np.linspace(0.5, 6.0, 111)], 0.0)
    pose, vel = np.array([0.5, 2.0, 0.0]), np.zeros(2)
    outline = outline_points(SQUARE, 0.05)
    for _ in range(300):
        try:
            v, w = ctrl.compute_velocity_commands(pose, vel, costmap)
        except ControlError:
            v, w = 0.0, 0.0
        pose = arc_poses(pose, v, w, np.array([0.05]))[0]
        vel = np.array([v, w])
        assert not footprint_collides(costmap, pose[None], outline)[0]
    assert 2.0 < pose[0] < 3.0 - 0.2                # came close, stopped before the box


def test_dwb_refuses_every_command_when_walled_in():
    costs = np.zeros((40, 40), np.uint8)
    costs[16, :] = costs[24, :] = costs[:, 16] = costs[:, 24] = LETHAL_OBSTACLE  # touching
    ctrl = DwbController(footprint=SQUARE)
    ctrl.set_plan([(1.0, 1.0), (1.5, 1.0)], 0.0)
    with pytest.raises(ControlError, match="no valid trajectory"):
        ctrl.compute_velocity_commands((1.0, 1.0, 0.0), (0.0, 0.0),
                                       Costmap(costs, 0.05))


def test_a_robot_touching_a_wall_may_leave_it_but_not_creep_further_in():
    """The IGV's footprint (base_link at the front axle, 0.75 m of body behind) stopped with
    its padded rear-left corner on a wall at y = 1.5, heading a little to the right: moves
    that take the corner off the wall are allowed; a slow arc turning right (RPP's first
    step from standstill), which swings the rear further into the wall, is refused, and so
    are backing up and turning right on the spot."""
    igv = pad_footprint(load("igv").footprint, 0.05)
    outline = outline_points(igv, 0.05)
    costs = np.zeros((40, 240), np.uint8)
    costs[30:, :] = LETHAL_OBSTACLE                       # the wall: y >= 1.5
    costmap = Costmap(costs, 0.05)
    start = np.array([8.7, 0.97, -0.12])                  # as the aisle trace found it
    assert footprint_collides(costmap, start[None], outline)[0]     # it does touch
    times = np.linspace(0.05, 1.0, 20)
    creep = arc_poses(start, 0.04, -0.03, times)          # RPP's first step from standstill
    assert collides_from(costmap, start, creep, outline).any()
    for v, w in ((0.2, 0.0), (0.2, 0.3), (0.0, 0.3)):    # ahead; ahead or on the spot to
        leave = arc_poses(start, v, w, times[:4])          # the left, swinging the rear off
        assert not collides_from(costmap, start, leave, outline).any(), (v, w)
    for v, w in ((-0.2, 0.0), (0.0, -0.3)):               # back; on the spot to the right
        assert collides_from(costmap, start, arc_poses(start, v, w, times[:4]), outline).all()
    # the outer half of the padding (2.5 cm) is soft: with the padded side 1 cm into the wall,
    # 1 cm further is allowed, 3 cm further (the inner half reached) is not
    side = np.array([8.7, 1.04, 0.0])                     # left edge padded to y = 1.51
    assert footprint_collides(costmap, side[None], outline)[0]
    deeper = side + np.array([[0.0, 0.01, 0.0], [0.0, 0.03, 0.0]])
    assert list(collides_from(costmap, side, deeper, outline)) == [False, True]


def test_rpp_checks_the_first_creeping_step_from_standstill():
    """From standstill RPP's first command is one acceleration step (0.04 m/s for the IGV),
    whose projection step (a cell's length at that speed, 1.25 s) is longer than the
    horizon: the arc is still checked at the horizon, so the rear swinging into the wall
    beside it is refused instead of creeping in."""
    igv = load("igv")
    footprint = pad_footprint(igv.footprint, 0.05)
    costs = np.zeros((40, 240), np.uint8)
    costs[30:, :] = LETHAL_OBSTACLE                       # the wall: y >= 1.5
    nav2 = RppParameters.for_robot(igv, gentler_arcs_when_colliding=False)
    ctrl = RegulatedPurePursuit(nav2, footprint)
    ctrl.set_plan([(8.7, 0.97), (9.3, 0.75), (10.5, 0.6)])   # veering right, off the wall
    with pytest.raises(ControlError, match="collision ahead"):
        ctrl.compute_velocity_commands((8.7, 0.97, -0.12), (0.0, 0.0), Costmap(costs, 0.05))


def test_rpp_takes_a_gentler_arc_when_its_own_would_collide_and_fails_when_none_is_free():
    """The kit's RPP for a robot whose rear is far behind its base_link, where Nav2's fails
    (above), tries the arc at a half, a quarter, … of its curvature and straight on: the IGV
    beside the wall creeps off on an arc that swings its rear less, which is free; with a
    wall across its way too, no arc is, and it fails."""
    igv = load("igv")
    assert RppParameters.for_robot(igv).gentler_arcs_when_colliding       # rear 0.75 m back
    assert not RppParameters.for_robot(load("uiabot")).gentler_arcs_when_colliding
    assert not RppParameters().gentler_arcs_when_colliding                 # Nav2's default
    footprint = pad_footprint(igv.footprint, 0.05)
    outline = outline_points(footprint, 0.05)
    costs = np.zeros((40, 240), np.uint8)
    costs[30:, :] = LETHAL_OBSTACLE                       # the wall: y >= 1.5
    start = np.array([8.7, 0.97, -0.12])
    ctrl = RegulatedPurePursuit(RppParameters.for_robot(igv), footprint)
    ctrl.set_plan([(8.7, 0.97), (9.3, 0.75), (10.5, 0.6)])
    v, w = ctrl.compute_velocity_commands(start, (0.0, 0.0), Costmap(costs, 0.05))
    local = geometry.transform_points(geometry.inverse(start), ctrl.last_carrot[None])[0]
    wanted = v * 2.0 * local[1] / float(local @ local)     # pure pursuit's own arc
    assert v > 0.0 and wanted < 0.0 and wanted < w <= 0.0  # the same way, gentler
    times = np.linspace(0.05, 1.0, 20)
    assert not collides_from(Costmap(costs, 0.05), start, arc_poses(start, v, w, times),
                             outline).any()
    costs[:, 181:] = LETHAL_OBSTACLE                      # and a wall just ahead
    with pytest.raises(ControlError, match="collision ahead"):
        ctrl.compute_velocity_commands(start, (0.0, 0.0), Costmap(costs, 0.05))


def test_dwb_parameters_are_checked():
    with pytest.raises(ValueError, match="decel_lim_x"):
        DwbParameters(decel_lim_x=1.0)
    with pytest.raises(ValueError, match="unknown critics"):
        DwbParameters(scales={"Twirling": 1.0})


# ---------------------------------------------------------------- costmaps

def test_the_vectorised_obstacle_layer_marks_what_nav2s_marks():
    """The same returns into the kit's ObstacleLayer beam by beam (Nav2's Bresenham as
    written) and into the navigation costmap (all beams in one compiled loop): the same cells
    cleared and marked."""
    rng = np.random.default_rng(3)
    angles = rng.uniform(-math.pi, math.pi, 90)
    ranges = rng.uniform(0.5, 2.4, 90)
    sensor = (2.5, 2.5)
    points = np.column_stack([sensor[0] + ranges * np.cos(angles),
                              sensor[1] + ranges * np.sin(angles)])
    ref = ObstacleLayer((100, 100), 0.05, (0.0, 0.0))
    ref.costs[:] = LETHAL_OBSTACLE
    from kit.planning import ObservationSource
    ref.clear(points, sensor, ObservationSource(clearing=True))
    ref.mark(points, sensor, ObservationSource())
    ours = NavigationCostmap(None, SQUARE, rolling_window=True, width=5.0, height=5.0)
    ours._roll(*sensor)
    layer = ours.obstacles["obstacle_layer"]
    layer.costs[:] = LETHAL_OBSTACLE
    ours.add_points(points, sensor)
    assert ours.origin == (0.0, 0.0)
    assert np.array_equal(layer.costs, ref.costs)
    assert 1000 < np.count_nonzero(layer.costs == 0) < 9000     # cleared a good part


def test_a_rolling_window_keeps_what_it_saw_where_it_was():
    cm = NavigationCostmap(None, SQUARE, rolling_window=True, width=3.0, height=3.0)
    cm.update_points([[1.0, 0.5]], (0.0, 0.0), (0.0, 0.0))
    cm.update_points(np.zeros((0, 2)), (0.7, 0.3), (0.7, 0.3))       # the robot moves on
    costmap = cm.costmap()
    row, col = costmap.world_to_cell(1.0, 0.5)
    assert costmap.costs[row, col] == LETHAL_OBSTACLE
    cm.update_points(np.zeros((0, 2)), (5.0, 0.3), (5.0, 0.3))       # far away: forgotten
    assert not np.any(cm.obstacles["obstacle_layer"].costs == LETHAL_OBSTACLE)


def test_a_new_map_replaces_the_static_layer_and_keeps_what_was_seen():
    """SLAM's /map every few seconds: the static layer follows it (keep-out applied again),
    the marks of the obstacle layer stay when the canvas does; a new resolution gives the
    costmap the map's geometry, as Nav2's static layer resizes its costmap."""
    blank = free_grid()
    keepout = free_grid(boxes=((7.0, 1.0, 7.5, 1.5),))
    cm = NavigationCostmap(blank, SQUARE, keepout=keepout)
    cm.add_points([[2.0, 2.0]], (1.0, 2.0))
    walled = free_grid(boxes=((5.0, 0.0, 5.3, 4.0),))
    cm.set_static(walled)
    costs = cm.costmap()
    assert costs.costs[costs.world_to_cell(5.1, 2.0)] == LETHAL_OBSTACLE        # the new wall
    assert costs.costs[costs.world_to_cell(2.0, 2.0)] == LETHAL_OBSTACLE        # still seen
    assert costs.costs[costs.world_to_cell(7.2, 1.2)] == LETHAL_OBSTACLE        # kept out
    same = free_grid()
    info = msgs.MapMetaData(resolution=same.info.resolution, width=same.info.width,
                            height=same.info.height, origin=msgs.Pose(msgs.Point(1.0, 0.0, 0.0)))
    cm.set_static(msgs.OccupancyGrid(same.header, info, same.data))  # another canvas: marks go
    assert cm.origin == (1.0, 0.0)
    assert not np.any(cm.obstacles["obstacle_layer"].costs == LETHAL_OBSTACLE)
    cm.set_static(free_grid(res=0.1))
    assert (cm.resolution, cm.shape) == (pytest.approx(0.1), (40, 100))


def test_the_navigator_plans_on_the_newest_map():
    nav = Navigator(free_grid(), load("uiabot"))
    nav.navigate_to_pose((8.0, 1.0, 0.0))
    nav.tick(0.0, (1.0, 1.0, 0.0))
    assert np.max(nav.path[:, 1]) < 1.5                           # straight across
    nav.update_map(free_grid(boxes=((4.0, 0.0, 4.3, 2.8),)))
    nav.tick(1.0, (1.0, 1.0, 0.0))
    assert np.max(nav.path[:, 1]) > 2.8                           # round the new wall


# ---------------------------------------------------------------- behaviours and checkers

def test_spin_turns_its_angle_and_backup_will_not_back_into_a_wall():
    spin = Spin(spin_dist=1.57, footprint=SQUARE)
    pose, t = np.array([1.0, 1.0, 0.0]), 0.0
    spin.start(t, pose)
    status = RUNNING
    while status == RUNNING and t < 10:
        status, (_v, w) = spin.tick(t, pose, None)
        pose = pose + np.array([0.0, 0.0, w * 0.05])
        t += 0.05
    assert status == SUCCEEDED and abs(pose[2] - 1.57) < 0.06
    costs = np.zeros((40, 40), np.uint8)
    costs[:, 10] = LETHAL_OBSTACLE                 # a wall 0.3 m behind the robot's back
    back = BackUp(footprint=SQUARE)
    back.start(0.0, (0.8, 1.0, 0.0))
    status, cmd = back.tick(0.0, (0.8, 1.0, 0.0), Costmap(costs, 0.05))
    assert status == FAILED and cmd == (0.0, 0.0) and "behind" in back.reason


def test_the_progress_checker_and_the_stateful_goal_checker():
    pc = ProgressChecker(0.5, 10.0)
    assert pc.check(0.0, (0, 0)) and pc.check(9.9, (0.4, 0.0))
    assert not pc.check(10.1, (0.4, 0.0))
    gc = GoalChecker(0.25, 0.25, stateful=True)
    goal = (1.0, 0.0, math.pi / 2)
    assert not gc.is_goal_reached((0.9, 0.0, 0.0), goal)           # there, but facing east
    assert gc.is_goal_reached((1.3, 0.0, 1.5), goal)                # drifted, yet turned


# ---------------------------------------------------------------- the navigator in a loop

def drive(nav: Navigator, pose, seconds: float, obstacles=None):
    """A kinematic robot under the navigator at 20 Hz; ``obstacles(t)`` gives the points a
    scan sees at time t. Returns the poses."""
    pose = np.asarray(pose, dtype=float)
    vel = np.zeros(2)
    trail = [pose]
    for k in range(int(seconds * 20)):
        t = k / 20
        if k % 4 == 0 and obstacles is not None:
            nav.on_points(obstacles(t), pose[:2], pose)
        v, w = nav.tick(t, pose, vel)
        pose = arc_poses(pose, v, w, np.array([0.05]))[0]
        vel = np.array([v, w])
        trail.append(pose)
        if nav.status != RUNNING:
            break
    return np.array(trail)


@pytest.mark.parametrize("controller", ["rpp", "dwb"])
def test_the_navigator_reaches_a_goal_round_a_wall(controller):
    grid = free_grid(boxes=((4.0, 0.0, 4.3, 2.8),))
    nav = Navigator(grid, load("uiabot"), controller=controller)
    nav.navigate_to_pose((8.0, 1.0, 0.0))
    trail = drive(nav, (1.0, 1.0, 0.0), 90.0)
    assert nav.status == SUCCEEDED, nav.reason
    assert np.hypot(*(trail[-1, :2] - (8.0, 1.0))) <= 0.25
    assert np.max(trail[:, 1]) > 2.8                 # went round the wall's end


def test_an_obstacle_only_the_lidar_sees_is_planned_round():
    grid = free_grid()
    box = np.array([[3.0 + 0.05 * i, y] for i in range(8) for y in np.linspace(0.05, 2.9, 58)])
    nav = Navigator(grid, load("uiabot"))
    nav.navigate_to_pose((8.0, 1.0, 0.0))
    trail = drive(nav, (1.0, 1.0, 0.0), 90.0, lambda t: box)
    assert nav.status == SUCCEEDED, nav.reason
    assert np.max(trail[:, 1]) > 2.9


def test_an_unreachable_goal_ends_with_the_planners_reason_and_no_collision():
    grid = free_grid(boxes=((6.0, 0.0, 6.3, 4.0),))   # a wall across the whole room
    nav = Navigator(grid, load("uiabot"))
    nav.navigate_to_pose((8.0, 2.0, 0.0))
    trail = drive(nav, (1.0, 2.0, 0.0), 300.0)
    assert nav.status == FAILED
    assert "planning failed" in nav.reason and "no valid path" in nav.reason
    costmap = nav.global_costmap.costmap()
    assert not np.any(footprint_collides(costmap, trail, outline_points(SQUARE, 0.05)))
    assert [e.detail for e in nav.events if e.kind == "recovery"][:4] == \
        ["clear costmaps", "spin", "wait", "backup"]


def test_a_robot_pinned_by_a_person_waits_then_goes_on():
    grid = free_grid(width=12.0, height=2.0)
    nav = Navigator(grid, load("uiabot"), params=NavigatorParameters(moving_margin=0.0))
    nav.navigate_to_pose((10.0, 1.0, 0.0))
    person = np.array([[3.0 + 0.25 * math.cos(a), 1.0 + 0.25 * math.sin(a)]
                       for a in np.linspace(0, 2 * math.pi, 24)])
    wall = np.column_stack([np.full(20, 3.0), np.linspace(0.05, 1.95, 20)])

    def seen(t):                                    # a person and a row of people: blocked
        return np.vstack([person, wall]) if t < 25.0 else np.zeros((0, 2))

    trail = drive(nav, (1.0, 1.0, 0.0), 120.0, seen)
    assert nav.status == SUCCEEDED, nav.reason
    kinds = [e.detail for e in nav.events if e.kind == "recovery"]
    assert "wait" in kinds
    blocked = trail[: 25 * 20]
    assert np.max(blocked[:, 0]) < 3.0 - 0.2         # never touched the people while there


def test_the_navigator_refuses_no_goals_and_unknown_controllers():
    nav = Navigator(free_grid(), load("uiabot"))
    with pytest.raises(ValueError, match="at least one goal"):
        nav.navigate_through_poses([])
    with pytest.raises(ValueError, match="'dwb', 'rpp'"):
        Navigator(free_grid(), load("uiabot"), controller="teb")
    with pytest.raises(ValueError):
        nav.navigate_to_pose((1.0, np.nan, 0.0))


# ---------------------------------------------------------------- Nav2's parameters, mirrored

def straight_plan(ctrl, goal_yaw=0.0):
    ctrl.set_plan([(x, 2.0) for x in np.linspace(0.5, 5.5, 101)], goal_yaw)


def open_costmap():
    return Costmap(np.zeros((80, 120), np.uint8), 0.05)


def test_dwb_scores_with_the_critics_listed_and_their_scales():
    """The total is Σ scale · score over the listed critics only; an unlisted critic neither
    scores nor rules a trajectory out (Nav2's DWB loads only the critics it is given)."""
    pose, vel = np.array([1.3, 2.0, 0.0]), (0.3, 0.0)
    full = DwbController(DwbParameters(vx_samples=5, vtheta_samples=5), SQUARE)
    straight_plan(full)
    a = full.score(pose, vel, open_costmap())
    only = DwbController(DwbParameters(vx_samples=5, vtheta_samples=5,
                                       critics=("PathDist", "GoalDist"),
                                       scales={"PathDist": 2.0, "GoalDist": 3.0}), SQUARE)
    straight_plan(only)
    b = only.score(pose, vel, open_costmap())
    np.testing.assert_allclose(b.total, 2.0 * a.scores["PathDist"] + 3.0 * a.scores["GoalDist"])
    with pytest.raises(ValueError, match="unknown critics"):
        DwbParameters(critics=("Twirling",))


def test_dwb_base_obstacle_sums_the_trajectory_or_takes_its_last_pose():
    costs = np.zeros((80, 120), np.uint8)
    costs[:, 60:] = 100                                # a costly half, not lethal
    cm = Costmap(costs, 0.05)
    pose, vel = np.array([2.5, 2.0, 0.0]), (0.4, 0.0)
    scored = {}
    for sum_scores in (True, False):
        ctrl = DwbController(DwbParameters(vx_samples=3, vtheta_samples=3,
                                           sum_scores=sum_scores), SQUARE)
        straight_plan(ctrl)
        scored[sum_scores] = ctrl.score(pose, vel, cm)
    poses = scored[True].poses
    cells = np.floor(poses[..., :2] / 0.05).astype(int)
    under = costs[cells[..., 1], cells[..., 0]].astype(float)
    np.testing.assert_array_equal(scored[True].scores["BaseObstacle"], under.sum(axis=1))
    np.testing.assert_array_equal(scored[False].scores["BaseObstacle"], under[:, -1])


def test_dwb_speed_limits_rule_out_samples_as_nav2s_kinematic_parameters():
    """Nav2's ``isValidSpeed``: faster than max_speed_xy, slower than min_speed_xy while
    turning slower than min_speed_theta, and standing still are invalid."""
    p = DwbParameters(vx_samples=5, vtheta_samples=5, max_speed_xy=0.3, min_speed_xy=0.1,
                      min_speed_theta=0.4, max_vel_x=0.5)
    ctrl = DwbController(p, SQUARE)
    straight_plan(ctrl)
    scored = ctrl.score(np.array([1.3, 2.0, 0.0]), (0.0, 0.0), open_costmap())
    vx, vth = scored.velocities.T
    expected = (vx <= 0.3 + 1e-9) & ~((vx < 0.1) & (np.abs(vth) < 0.4)) & \
        ~((vx == 0) & (vth == 0))
    np.testing.assert_array_equal(scored.valid, expected)
    assert scored.reasons["speed limits"] == int((~expected).sum())


def test_rotate_to_goal_weighs_speed_by_its_slowing_factor_and_looks_ahead_in_time():
    pose, vel = np.array([5.4, 2.0, 0.3]), (0.4, 0.0)    # arriving: in the goal window, fast
    out = {}
    for factor, lookahead in ((5.0, -1.0), (2.0, -1.0), (5.0, 0.5)):
        ctrl = DwbController(DwbParameters(vx_samples=4, vtheta_samples=5,
                                           slowing_factor=factor,
                                           rotate_lookahead_time=lookahead), SQUARE)
        straight_plan(ctrl, goal_yaw=0.0)
        out[factor, lookahead] = ctrl.score(pose, vel, open_costmap())
    base, slow = out[5.0, -1.0], out[2.0, -1.0]
    vx = base.velocities[:, 0]
    np.testing.assert_allclose(base.scores["RotateToGoal"] - slow.scores["RotateToGoal"],
                               3.0 * vx ** 2)
    ahead = out[5.0, 0.5]
    steps = ahead.poses.shape[1]
    dt = 1.7 / steps
    i = int(0.5 / dt)
    yaw = np.concatenate([np.full((len(vx), 1), 0.3), ahead.poses[:, :, 2]], axis=1)
    expected = yaw[:, i] + (0.5 - i * dt) / dt * (yaw[:, i + 1] - yaw[:, i])
    np.testing.assert_allclose(ahead.scores["RotateToGoal"],
                               5.0 * vx ** 2 + np.abs(geometry.wrap_angle(-expected)))


def test_rpp_looks_for_the_robot_on_the_path_only_so_far_ahead():
    path = [(x, 0.0) for x in np.linspace(0.0, 6.0, 61)]
    for reach, expected in ((2.0, 20), (6.0, 50)):
        ctrl = RegulatedPurePursuit(RppParameters(max_robot_pose_search_dist=reach), SQUARE)
        ctrl.set_plan(path)
        ctrl.compute_velocity_commands((5.0, 0.0, 0.0), (0.0, 0.0))
        assert ctrl._index == expected


def test_the_stopped_goal_checker_and_the_pose_progress_checker():
    gc = GoalChecker(0.25, 0.25, trans_stopped_velocity=0.1, rot_stopped_velocity=0.2)
    goal = (1.0, 0.0, 0.0)
    assert not gc.is_goal_reached((1.0, 0.0, 0.0), goal, (0.3, 0.0))     # still moving
    assert not gc.is_goal_reached((1.0, 0.0, 0.0), goal, (0.0, 0.5))     # still turning
    assert gc.is_goal_reached((1.0, 0.0, 0.0), goal, (0.05, 0.1))
    pc = ProgressChecker(0.5, 10.0, required_movement_angle=0.5)
    assert pc.check(0.0, (0.0, 0.0, 0.0)) and pc.check(9.0, (0.1, 0.0, 0.6))   # turned
    assert pc.check(18.0, (0.1, 0.0, 0.7)) and not pc.check(19.5, (0.1, 0.0, 0.7))


def test_the_controller_servers_failure_tolerance_stops_the_robot_before_failing():
    grid = free_grid()
    config = NavigationConfig.for_robot(load("uiabot"))

    class Flaky:
        def __init__(self):
            self.calls = 0

        def set_plan(self, path, goal_yaw=None):
            pass

        def compute_velocity_commands(self, pose, velocity, costmap):
            self.calls += 1
            if 3 <= self.calls <= 6:
                raise ControlError("collision ahead")
            return 0.2, 0.0

    for tolerance, failed in ((0.0, 1), (0.5, 0), (0.1, 1)):
        cfg = dataclasses.replace(config, navigator=dataclasses.replace(
            config.navigator, failure_tolerance=tolerance))
        nav = Navigator(grid, load("uiabot"), controller=Flaky(), config=cfg)
        nav.navigate_to_pose((8.0, 1.0, 0.0))
        commands = [nav.tick(k / 20, (1.0, 1.0, 0.0)) for k in range(8)]
        failures = sum(e.kind == "control failed" for e in nav.events)
        assert (failures > 0) == bool(failed), (tolerance, commands)
        if not failed:
            assert commands[2:6] == [(0.0, 0.0)] * 4 and commands[6] == (0.2, 0.0)


def test_a_recovery_the_behaviour_server_lacks_fails_at_once_and_the_round_goes_on():
    config = NavigationConfig.for_robot(load("uiabot"))
    cfg = dataclasses.replace(config, behaviors=dataclasses.replace(
        config.behaviors, unavailable=("spin",)))
    nav = Navigator(free_grid(), load("uiabot"), config=cfg)
    assert [b.name if b is not None else None for b in nav.behaviors] == [
        None, "spin", "wait", "backup"]
    assert isinstance(nav.behaviors[1], Unavailable)
    status, cmd = nav.behaviors[1].tick(0.0, (1.0, 1.0, 0.0), None)
    assert status == FAILED and cmd == (0.0, 0.0) and "behavior_plugins" in \
        nav.behaviors[1].reason
