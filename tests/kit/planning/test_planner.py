"""The ComputePathToPose-shaped interface: poses in, a nav_msgs/Path out, Nav2's error codes
for starts and goals it cannot use, and no-path as a result."""

import itertools
import math

import numpy as np
import pytest

from kit import geometry, maps, msgs
from kit.planning import (
    GOAL_OCCUPIED,
    GOAL_OUTSIDE_MAP,
    NO_VALID_PATH,
    START_OCCUPIED,
    START_OUTSIDE_MAP,
    Costmap,
    GridPlanner,
    PlanningError,
    ThetaStarPlanner,
    compute_path_to_pose,
    costmap_from_map,
    load_costmap_params,
    path_length,
    path_to_points,
)
from kit.planning._planner import TF_ERROR


def pose(x, y, yaw=0.0, frame="map"):
    q = geometry.yaw_to_quaternion(yaw)
    return msgs.PoseStamped(msgs.Header(frame_id=frame),
                            msgs.Pose(msgs.Point(x, y, 0.0), msgs.Quaternion(*map(float, q))))


def room():
    """10 m x 6 m at 0.1 m, walls all round and a wall with a door at x = 5 m."""
    costs = np.zeros((60, 100), np.uint8)
    costs[0, :] = costs[-1, :] = costs[:, 0] = costs[:, -1] = 254
    costs[:, 50] = 254
    costs[40:46, 50] = 0
    return Costmap(costs, 0.1, origin=(-1.0, -2.0))


def test_theta_star_paths_have_a_point_every_cell_between_their_corners():
    """Nav2's Theta* planner hands its controller a path interpolated at the costmap's
    resolution (linearInterpolation: ``⌊length / resolution⌋ − 1`` points inside each
    segment, so the last step before a corner is shorter than two cells), not the corners
    alone: a controller such as DWB needs a dense path. The kit keeps the goal as the last
    point, where Nav2's path stops short of it."""
    cm = Costmap(np.zeros((10, 12), np.uint8), 0.1)
    result = compute_path_to_pose(pose(0.05, 0.05), pose(0.95, 0.05), cm,
                                  planner=ThetaStarPlanner())
    points = path_to_points(result.path)
    assert len(points) == 9 and (points[:, 1] == 0.05).all()     # 0.9 / 0.1 = 8.999… in floats
    np.testing.assert_allclose(points[:-1, 0], np.arange(8) * 0.1 + 0.05, atol=1e-12)
    assert points[-1].tolist() == [0.95, 0.05]
    turn = compute_path_to_pose(pose(0.0, -1.0), pose(7.0, -1.0), room(),
                                planner=ThetaStarPlanner())
    corners = ThetaStarPlanner().leg((0.0, -1.0, 0.0), (7.0, -1.0, 0.0), room())[1]
    steps = np.hypot(*np.diff(path_to_points(turn.path), axis=0).T)
    assert len(steps) > 10 * len(corners.cells) and steps.max() < 0.2


@pytest.mark.parametrize("planner", [GridPlanner(), GridPlanner(use_astar=False),
                                     ThetaStarPlanner()])
def test_path_goes_from_start_through_the_door_to_the_goal(planner):
    cm = room()
    result = compute_path_to_pose(pose(0.0, -1.0, 0.3), pose(7.0, -1.0, 1.2), cm,
                                  planner=planner)
    assert result.ok and result.error_msg == "" and result.planning_time > 0
    points = path_to_points(result.path)
    assert points[0].tolist() == [0.0, -1.0] and points[-1].tolist() == [7.0, -1.0]
    assert result.path.header.frame_id == "map"
    last = result.path.poses[-1].pose.orientation
    assert float(geometry.quaternion_to_yaw([last.x, last.y, last.z, last.w])) == \
        pytest.approx(1.2)
    dense = np.vstack([np.linspace(a, b, 20) for a, b in itertools.pairwise(points)])
    cells = np.floor((dense - cm.origin) / cm.resolution).astype(int)
    assert (cm.costs[cells[:, 1], cells[:, 0]] < 253).all()      # never through a wall
    assert (np.abs(dense[:, 1] - (-2.0 + 4.3)) < 0.35)[np.abs(dense[:, 0] - 4.05) < 0.05].any()
    assert path_length(points) >= math.dist((0, -1), (4.05, 2.3)) + math.dist((4.05, 2.3),
                                                                              (7, -1)) - 0.3


def test_poses_face_the_next_pose():
    result = compute_path_to_pose((0.05, 0.05, 0.0), (0.05, 0.95, 0.0),
                                  Costmap(np.zeros((10, 3), np.uint8), 0.1))
    yaws = [float(geometry.quaternion_to_yaw([p.pose.orientation.x, p.pose.orientation.y,
                                               p.pose.orientation.z, p.pose.orientation.w]))
            for p in result.path.poses]
    assert yaws[:-1] == pytest.approx([math.pi / 2] * (len(yaws) - 1))
    assert yaws[-1] == 0.0


def test_viapoints_are_visited_in_order():
    cm = room()
    result = compute_path_to_pose(pose(0.0, -1.0), pose(1.0, -1.0), cm,
                                  viapoints=[pose(7.0, 3.0)])
    points = path_to_points(result.path)
    assert result.ok and len(result.searches) == 2
    assert np.any(np.all(np.isclose(points, [7.0, 3.0]), axis=1))
    assert points[:, 0].max() >= 7.0


def test_no_path_is_a_result_with_nav2s_code_and_a_reason():
    cm = room()
    closed = np.array(cm.costs)
    closed[40:46, 50] = 254                              # shut the door
    result = compute_path_to_pose(pose(0.0, -1.0), pose(7.0, -1.0), Costmap(closed, 0.1,
                                                                            (-1.0, -2.0)))
    assert not result.ok and result.error_code == NO_VALID_PATH
    assert result.error_msg.startswith("goal: no path from") and result.path.poses == ()


@pytest.mark.parametrize(("start", "goal", "code", "message"), [
    ((-1.5, 0.0), (7.0, -1.0), START_OUTSIDE_MAP, r"start \(-1.5, 0\) is off the map"),
    ((0.0, -1.0), (7.0, 9.0), GOAL_OUTSIDE_MAP, r"goal \(7, 9\) is off the map"),
    ((4.05, 0.0), (7.0, -1.0), START_OCCUPIED, r"start \(4.05, 0\) is in an obstacle"),
    ((0.0, -1.0), (-0.95, 0.0), GOAL_OCCUPIED, r"goal \(-0.95, 0\) is in an obstacle"),
])
def test_unusable_start_or_goal_raises_with_nav2s_error_code(start, goal, code, message):
    with pytest.raises(PlanningError, match=message) as info:
        compute_path_to_pose((*start, 0.0), (*goal, 0.0), room())
    assert info.value.error_code == code


def test_poses_in_another_frame_and_bad_options_are_errors():
    with pytest.raises(PlanningError, match="in frame 'odom', the costmap in 'map'") as info:
        compute_path_to_pose(pose(0.0, -1.0, frame="odom"), pose(7.0, -1.0), room())
    assert info.value.error_code == TF_ERROR
    with pytest.raises(ValueError, match="w_euc_cost must be a non-negative"):
        ThetaStarPlanner(w_euc_cost=-1)
    with pytest.raises(ValueError, match="must be 4 or 8"):
        GridPlanner(connectivity=5)
    with pytest.raises(PlanningError, match=r"viapoint 1 \(50, 0\) is off the map"):
        compute_path_to_pose(pose(0.0, -1.0), pose(7.0, -1.0), room(),
                             viapoints=[(50.0, 0.0, 0.0)])


@pytest.mark.dataset
def test_turtlebot3_world_path_between_the_pillars(shared_data, tmp_path):
    grid = maps.read_map(shared_data / "maps" / "turtlebot3-world-nav2" / "map.yaml")
    params = load_costmap_params({"robot_radius": 0.1, "resolution": 0.05,
                                  "inflation_layer": {"plugin": "nav2_costmap_2d::InflationLayer",
                                                      "cost_scaling_factor": 3.0}})
    cm = costmap_from_map(grid, params)
    # the TurtleBot3 world: an arena around (-0.5, 0); go from its west side to its east side
    free = np.argwhere(cm.costs == 0)
    xy = np.column_stack([cm.origin[0] + (free[:, 1] + 0.5) * cm.resolution,
                          cm.origin[1] + (free[:, 0] + 0.5) * cm.resolution])
    inside = xy[(np.abs(xy[:, 1]) < 0.3)]
    start, goal = inside[inside[:, 0].argmin()], inside[inside[:, 0].argmax()]
    for planner in (GridPlanner(), ThetaStarPlanner()):
        result = compute_path_to_pose((*start, 0.0), (*goal, 0.0), cm, planner=planner)
        assert result.ok
        points = path_to_points(result.path)
        dense = np.vstack([np.linspace(a, b, 10) for a, b in itertools.pairwise(points)])
        cells = np.floor((dense - cm.origin) / cm.resolution).astype(int)
        assert (cm.costs[cells[:, 1], cells[:, 0]] < 253).all()
        assert path_length(points) >= np.linalg.norm(goal - start) - 1e-9


# ---------------------------------------------------------------- Nav2's planner options

def reachable_by_flood(costs, start):
    """The cells an 8-connected walk without corner cutting reaches from ``start`` (scipy's
    labelling of the free cells, the corners handled by a walk): the reference for
    ``GridSearch.reachable``."""
    from collections import deque

    free = costs < 253
    seen = np.zeros_like(free)
    seen[start] = True
    queue = deque([start])
    while queue:
        r, c = queue.popleft()
        for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)):
            rr, cc = r + dr, c + dc
            if not (0 <= rr < free.shape[0] and 0 <= cc < free.shape[1]) or seen[rr, cc] or \
                    not free[rr, cc]:
                continue
            if dr and dc and not (free[r + dr, c] and free[r, c + dc]):
                continue
            seen[rr, cc] = True
            queue.append((rr, cc))
    return seen


def test_the_goal_tolerance_ends_the_path_at_navfns_nearest_reachable_point():
    """NavFn's ``tolerance``: a goal that cannot be reached gives a path to the reachable
    point nearest it within ``tolerance`` in x and y (Nav2's NavfnPlanner::makePlan)."""
    cm = room()
    closed = np.array(cm.costs)
    closed[40:46, 50] = 254                              # the door shut
    shut = Costmap(closed, 0.1, (-1.0, -2.0))
    goal = (4.5, -1.0, 0.0)                              # just behind the wall, x = 4.05
    assert not compute_path_to_pose((0.0, -1.0, 0.0), goal, shut).ok
    short = compute_path_to_pose((0.0, -1.0, 0.0), goal, shut,
                                 planner=GridPlanner(tolerance=0.3))
    assert not short.ok and "within tolerance" in short.error_msg
    result = compute_path_to_pose((0.0, -1.0, 0.0), goal, shut,
                                  planner=GridPlanner(tolerance=0.6))
    assert result.ok
    end = path_to_points(result.path)[-1]
    # the reference: every reachable cell centre in the 0.6 m square, the nearest to the goal
    reach = reachable_by_flood(closed, shut.world_to_cell(0.0, -1.0))
    rows, cols = np.nonzero(reach)
    x = shut.origin[0] + (cols + 0.5) * 0.1
    y = shut.origin[1] + (rows + 0.5) * 0.1
    inside = (np.abs(x - goal[0]) <= 0.6) & (np.abs(y - goal[1]) <= 0.6)
    d2 = (x - goal[0]) ** 2 + (y - goal[1]) ** 2
    best = np.flatnonzero(inside & (d2 == d2[inside].min()))
    assert end.tolist() == pytest.approx([x[best[0]], y[best[0]]])
    # a goal in the wall itself: the same rule, no GOAL_OCCUPIED
    inwall = compute_path_to_pose((0.0, -1.0, 0.0), (4.05, -1.0, 0.0), shut,
                                  planner=GridPlanner(tolerance=0.6))
    assert inwall.ok and path_to_points(inwall.path)[-1][0] < 4.0


def test_downsampling_plans_on_the_costliest_cell_of_each_block():
    cm = room()
    planner = GridPlanner(downsampling_factor=2)
    coarse = planner.grid(cm)
    assert (coarse.resolution, coarse.origin, coarse.costs.shape) == (0.2, cm.origin, (30, 50))
    blocks = [cm.costs[r:r + 2, c:c + 2].max() for r in range(0, 60, 2) for c in range(0, 100, 2)]
    assert coarse.costs.ravel().tolist() == [int(b) for b in blocks]
    result = compute_path_to_pose((0.0, -1.0, 0.0), (7.0, -1.0, 0.0), cm, planner=planner)
    inner = path_to_points(result.path)[1:-1]
    assert result.ok and np.allclose(((inner - cm.origin) / 0.2) % 1.0, 0.5)   # coarse centres


def test_max_iterations_stops_a_search_and_says_so():
    cm = room()
    result = compute_path_to_pose((0.0, -1.0, 0.0), (7.0, -1.0, 0.0), cm,
                                  planner=GridPlanner(max_iterations=50))
    assert not result.ok and "within max_iterations = 50" in result.error_msg
    assert result.searches[0].expanded == 50
    with pytest.raises(ValueError, match="max_iterations must be a positive whole number"):
        GridPlanner(max_iterations=0)
    with pytest.raises(ValueError, match="downsampling_factor must be a whole number"):
        GridPlanner(downsampling_factor=0)
    with pytest.raises(ValueError, match="tolerance must be a non-negative"):
        GridPlanner(tolerance=-0.1)


def test_the_final_approach_orientation_faces_the_way_the_path_arrives():
    result = compute_path_to_pose((0.05, 0.05, 0.0), (0.05, 0.95, 0.0),
                                  Costmap(np.zeros((10, 3), np.uint8), 0.1),
                                  planner=GridPlanner(use_final_approach_orientation=True))
    last = result.path.poses[-1].pose.orientation
    assert float(geometry.quaternion_to_yaw([last.x, last.y, last.z, last.w])) == \
        pytest.approx(math.pi / 2)
