"""The obstacle layer (marking and ray-trace clearing from scans), the layered costmap's
combination of layers, and Nav2 parameter files read as they are."""

import math

import numpy as np
import pytest

from kit import maps, msgs
from kit.nav2params import ParameterReport
from kit.planning import (
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    CostmapParams,
    InflationLayerParams,
    KeepoutFilterParams,
    LayeredCostmap,
    ObservationSource,
    ObstacleLayer,
    ObstacleLayerParams,
    StaticLayerParams,
    costmap_from_map,
    inflate,
    load_costmap_params,
    raytrace_line,
    robot_footprint,
    static_layer,
)

RES = 0.05
WALL_X = 3.02          # a wall across the room, seen from a scanner at (1, 1)


def wall_scan(n=181, range_max=5.0):
    """A 180° scan from (1, 1) facing +x: the wall x = WALL_X where a beam meets it within
    range_max, +inf (nothing seen, REP-117) elsewhere."""
    angles = np.linspace(-math.pi / 2, math.pi / 2, n)
    with np.errstate(divide="ignore"):
        r = (WALL_X - 1.0) / np.cos(angles)
    r = np.where((np.cos(angles) > 1e-9) & (r <= range_max), r, np.inf)
    return msgs.LaserScan(msgs.Header(frame_id="laser_link"), angle_min=-math.pi / 2,
                          angle_max=math.pi / 2, angle_increment=math.pi / (n - 1),
                          range_min=0.1, range_max=range_max, ranges=r.astype(np.float32))


def test_marking_puts_returns_within_obstacle_max_range_on_the_wall():
    layer = ObstacleLayer((80, 100), RES, (0.0, 0.0), track_unknown_space=True)
    scan = wall_scan()
    traced, marked = layer.update(scan, (1.0, 1.0, 0.0), (ObservationSource(marking=True),))
    assert traced == 0
    rows, cols = np.nonzero(layer.costs == LETHAL_OBSTACLE)
    assert set(cols) == {int(WALL_X / RES)}
    # beams up to acos(2.02 / 2.5) off axis are within obstacle_max_range = 2.5 m
    reach = math.sqrt(2.5 ** 2 - (WALL_X - 1.0) ** 2)
    y = (rows + 0.5) * RES
    assert y.min() > 1.0 - reach - RES and y.max() < 1.0 + reach + RES
    assert marked >= len(rows)
    assert (layer.costs[layer.costs != LETHAL_OBSTACLE] == NO_INFORMATION).all()


def test_clearing_frees_the_cells_a_beam_passed_and_stops_at_raytrace_max_range():
    layer = ObstacleLayer((80, 100), RES, (0.0, 0.0), track_unknown_space=True)
    layer.costs[20, 30] = LETHAL_OBSTACLE            # an old obstacle on the axis, now gone
    source = ObservationSource(clearing=True, marking=True)
    layer.update(wall_scan(), (1.0, 1.0, 0.0), (source,))
    axis = layer.costs[20]                           # the beam straight ahead (y = 1.0)
    assert (axis[20:60] == 0).all() and axis[60] == LETHAL_OBSTACLE
    assert axis[61] == NO_INFORMATION                # nothing seen behind the wall
    # beams longer than range_max are +inf: they clear nothing without inf_is_valid
    assert (layer.costs[25:, 20] == NO_INFORMATION).all()      # straight up from the laser
    infinite = ObstacleLayer((80, 100), RES, (0.0, 0.0), track_unknown_space=True)
    infinite.update(wall_scan(), (1.0, 1.0, 0.0),
                    (ObservationSource(clearing=True, marking=False, inf_is_valid=True),))
    up = infinite.costs[:, 20]                       # the beam straight up (+y), +inf
    assert (up[20:20 + 61] == 0).all()               # raytrace_max_range: 3.0 m = 60 cells
    assert (up[20 + 61:] == NO_INFORMATION).all()


def test_raytrace_line_stays_within_half_a_cell_of_the_true_line():
    rng = np.random.default_rng(2)
    for _ in range(200):
        a = tuple(int(v) for v in rng.integers(0, 40, 2))
        b = tuple(int(v) for v in rng.integers(0, 40, 2))
        cells = raytrace_line(a, b)
        assert tuple(cells[0]) == a and tuple(cells[-1]) == b
        steps = np.abs(np.diff(cells, axis=0))
        assert (steps.max(axis=1) == 1).all() if len(cells) > 1 else True
        (r0, c0), (r1, c1) = a, b
        if abs(c1 - c0) >= abs(r1 - r0) and c1 != c0:   # x dominant: one cell per column
            exact = r0 + (cells[:, 1] - c0) * (r1 - r0) / (c1 - c0)
        elif r1 != r0:
            exact = c0 + (cells[:, 0] - r0) * (c1 - c0) / (r1 - r0)
            assert (np.abs(cells[:, 1] - exact) <= 0.5 + 1e-9).all()
            continue
        else:
            continue
        assert (np.abs(cells[:, 0] - exact) <= 0.5 + 1e-9).all()
    assert len(raytrace_line((0, 0), (0, 30), max_length=10)) == 11
    assert raytrace_line((0, 0), (0, 30), min_length=25)[0].tolist() == [0, 25]
    assert len(raytrace_line((0, 0), (0, 3), min_length=5)) == 0


def test_observation_sources_are_checked():
    with pytest.raises(ValueError, match="reads LaserScan only"):
        ObservationSource(data_type="PointCloud2")
    with pytest.raises(ValueError, match="raytrace_max_range must be a non-negative"):
        ObservationSource(raytrace_max_range=-1.0)


def room_map(width=100, height=80):
    """A walled room as a map_server map would give it (0 free, 100 walls), 0.05 m cells."""
    values = np.zeros((height, width), np.int8)
    values[0, :] = values[-1, :] = values[:, 0] = values[:, -1] = 100
    info = msgs.MapMetaData(resolution=RES, width=width, height=height,
                            origin=msgs.Pose(msgs.Point(0.0, 0.0, 0.0)))
    return msgs.OccupancyGrid(msgs.Header(frame_id="map"), info, values.ravel())


def test_layered_costmap_combines_static_obstacles_inflation_and_keepout():
    grid = room_map()
    params = CostmapParams(robot_radius=0.1, filters=(KeepoutFilterParams(),),
                           layers=(StaticLayerParams(),
                                   ObstacleLayerParams(observation_sources=(
                                       ObservationSource(clearing=True),)),
                                   InflationLayerParams(inflation_radius=0.3,
                                                        cost_scaling_factor=5.0)))
    layered = LayeredCostmap(params, grid)
    first = layered.update()
    static = static_layer(grid)
    np.testing.assert_array_equal(first.costs, inflate(
        static, RES, inscribed_radius=layered.inscribed_radius, inflation_radius=0.3,
        cost_scaling_factor=5.0))
    layered.update_scan(wall_scan(), (1.0, 1.0, 0.0))
    second = layered.update()
    assert second.costs[20, 60] == LETHAL_OBSTACLE and first.costs[20, 60] == 0
    assert second.costs[20, 58] > 0                   # the new obstacle is inflated
    mask = msgs.OccupancyGrid(grid.header, grid.info, np.where(
        np.arange(grid.data.size) % 100 >= 80, 100, 0).astype(np.int8))
    layered.set_keepout_mask(mask)
    third = layered.update()
    assert (third.costs[1:-1, 80:-1] == LETHAL_OBSTACLE).all()
    assert third.costs[40, 79] == second.costs[40, 79]      # keep-out is not inflated
    assert (third.frame_id, third.resolution, third.origin) == ("map", grid.info.resolution,
                                                                (0.0, 0.0))


def test_obstacle_layer_clears_under_the_footprint_and_combines_with_max():
    layered = LayeredCostmap(CostmapParams(track_unknown_space=True), room_map(),
                             footprint=robot_footprint("uiabot"))
    layer = layered.obstacles["obstacle_layer"]
    layer.costs[40, 50] = LETHAL_OBSTACLE                     # a ghost under the robot
    assert layered.update().costs[40, 50] == LETHAL_OBSTACLE
    costs = layered.update(robot_pose=(50 * RES + 0.02, 40 * RES + 0.02, 0.3)).costs
    assert layer.costs[40, 50] == 0 and costs[40, 50] == 0


def test_costmap_from_map_uses_nav2_defaults():
    grid = room_map()
    cm = costmap_from_map(grid)
    inscribed = LayeredCostmap(None, grid).inscribed_radius
    np.testing.assert_array_equal(cm.costs, inflate(static_layer(grid), RES,
                                                    inscribed_radius=inscribed))


NAV2_YAML = """\
global_costmap:
  global_costmap:
    ros__parameters:
      update_frequency: 1.0
      global_frame: map
      robot_base_frame: base_link
      use_sim_time: True
      robot_radius: 0.1
      resolution: 0.05
      track_unknown_space: true
      plugins: ["static_layer", "obstacle_layer", "voxel_layer", "inflation_layer"]
      filters: ["keepout_filter", "speed_filter"]
      obstacle_layer:
        plugin: "nav2_costmap_2d::ObstacleLayer"
        enabled: True
        observation_sources: scan
        scan:
          topic: /scan
          max_obstacle_height: 2.0
          clearing: True
          marking: True
          data_type: "LaserScan"
          raytrace_max_range: 3.0
          obstacle_max_range: 2.5
      voxel_layer:
        plugin: "nav2_costmap_2d::VoxelLayer"
        enabled: True
      static_layer:
        plugin: "nav2_costmap_2d::StaticLayer"
        map_subscribe_transient_local: True
      inflation_layer:
        plugin: "nav2_costmap_2d::InflationLayer"
        cost_scaling_factor: 3.0
        inflation_radius: 0.55
      keepout_filter:
        plugin: "nav2_costmap_2d::KeepoutFilter"
        enabled: True
        filter_info_topic: "keepout_costmap_filter_info"
      speed_filter:
        plugin: "nav2_costmap_2d::SpeedFilter"
        enabled: True
      always_send_full_costmap: True
  global_costmap_client:
    ros__parameters:
      use_sim_time: False
"""


def test_a_nav2_parameter_file_loads_as_it_is(tmp_path):
    (tmp_path / "nav2_params.yaml").write_text(NAV2_YAML)
    report = ParameterReport()
    p = load_costmap_params(tmp_path / "nav2_params.yaml", report=report)
    assert (p.robot_radius, p.resolution, p.track_unknown_space) == (0.1, 0.05, True)
    assert [type(layer).__name__ for layer in p.layers] == [
        "StaticLayerParams", "ObstacleLayerParams", "ObstacleLayerParams",
        "InflationLayerParams"]
    obstacle, voxel, inflation = p.layers[1], p.layers[2], p.layers[3]
    assert obstacle.observation_sources == (ObservationSource(
        name="scan", topic="/scan", marking=True, clearing=True, raytrace_max_range=3.0,
        obstacle_max_range=2.5),)
    assert voxel.name == "voxel_layer" and voxel.observation_sources == ()   # none declared
    assert (inflation.inflation_radius, inflation.cost_scaling_factor) == (0.55, 3.0)
    assert p.filters == (KeepoutFilterParams("keepout_filter", True),)
    assert p.ignored == ("speed_filter (nav2_costmap_2d::SpeedFilter)",)
    assert p.footprint is None and p.robot_footprint().shape == (16, 2)
    node = "global_costmap/global_costmap"
    assert report.ignored[f"{node}:speed_filter.enabled"].startswith("not supported")
    assert report.ignored[f"{node}:obstacle_layer.scan.max_obstacle_height"] == \
        "no effect: the kit's obstacle layers are 2-D"
    assert f"{node}:voxel_layer.enabled" in report.used
    assert sum("VoxelLayer is read as a 2-D obstacle layer" in n for n in report.notes) == 1


def test_defaults_and_footprint_strings_follow_nav2(tmp_path):
    p = load_costmap_params({"resolution": 0.1,
                             "footprint": "[[0.2, 0.1], [-0.2, 0.1], [-0.2, -0.1], [0.2, -0.1]]"})
    assert [layer.name for layer in p.layers] == ["static_layer", "obstacle_layer",
                                                  "inflation_layer"]
    assert p.layers[1].observation_sources == ()          # Nav2 declares none by default
    assert p.layers[2].inflation_radius == 0.55 and p.layers[2].cost_scaling_factor == 10.0
    np.testing.assert_allclose(p.robot_footprint()[0], [0.21, 0.11], atol=1e-7)


def test_a_parameter_file_s_unknown_and_inscribed_values_reach_the_static_layer():
    """``unknown_cost_value: -1`` (ROS 1's, in many files) is Nav2's byte 255: unknown cells
    stay unknown; ``inscribed_obstacle_cost_value`` (Lyrical's key) names the value read as
    253."""
    info = msgs.MapMetaData(resolution=0.1, width=4, height=1)
    grid = msgs.OccupancyGrid(msgs.Header(frame_id="map"), info,
                              np.array([0, 99, 100, -1], dtype=np.int8))
    base = {"resolution": 0.1, "track_unknown_space": True, "plugins": ["static_layer"],
            "static_layer": {"plugin": "nav2_costmap_2d::StaticLayer"}}
    p = load_costmap_params({**base, "unknown_cost_value": -1})
    assert costmap_from_map(grid, p).costs.tolist() == [[0, 253, 254, 255]]
    p = load_costmap_params({**base, "inscribed_obstacle_cost_value": 50})
    assert p.inscribed_obstacle_cost_value == 50
    assert costmap_from_map(grid, p).costs.tolist() == [[0, 0, 254, 255]]


@pytest.mark.parametrize(("text", "message"), [
    ("other:\n  ros__parameters:\n    a: 1\n", "no 'global_costmap' section"),
    ("global_costmap:\n  global_costmap:\n    ros__parameters:\n      track_unknown_space: "
     "MAYBE\n", "track_unknown_space must be true or false; got 'MAYBE'"),
    ("global_costmap:\n  global_costmap:\n    ros__parameters:\n      use_maximum: "
     "$(var max)\n", "use_maximum must be true or false; got .* .a launch-file substitution"),
    ("global_costmap:\n  global_costmap:\n    ros__parameters:\n      resolution: fine\n",
     "resolution must be a number"),
    ("global_costmap:\n  global_costmap:\n    ros__parameters:\n      footprint: '[[1, 2]]'\n",
     "three or more"),
    ("global_costmap:\n  global_costmap:\n    ros__parameters:\n      plugins: [[a, b]]\n",
     "plugins must be a list of names"),
    ("global_costmap: [unclosed\n", "not valid YAML"),
])
def test_bad_parameter_files_name_the_problem(tmp_path, text, message):
    (tmp_path / "p.yaml").write_text(text)
    with pytest.raises(ValueError, match=message):
        load_costmap_params(tmp_path / "p.yaml")


@pytest.mark.dataset
def test_turtlebot3_world_costmap_with_its_own_parameters(shared_data, tmp_path):
    (tmp_path / "nav2_params.yaml").write_text(NAV2_YAML)
    params = load_costmap_params(tmp_path / "nav2_params.yaml")
    grid = maps.read_map(shared_data / "maps" / "turtlebot3-world-nav2" / "map.yaml")
    cm = costmap_from_map(grid, params)
    assert (cm.height, cm.width) == (384, 384)
    assert int((cm.costs == LETHAL_OBSTACLE).sum()) == 795     # the map's occupied cells
    assert int((cm.costs == NO_INFORMATION).sum()) < 138722    # unknown next to walls inflated


# ---------------------------------------------------------------- one costmap for all

def scattered_points(n=300, seed=5, spread=4.0, centre=(2.5, 2.0)):
    rng = np.random.default_rng(seed)
    angles = rng.uniform(-math.pi, math.pi, n)
    ranges = rng.uniform(0.1, spread, n)
    return np.column_stack([centre[0] + ranges * np.cos(angles),
                            centre[1] + ranges * np.sin(angles)])


def test_the_compiled_ray_trace_clears_the_cells_of_nav2s_steps_beam_by_beam():
    """All beams in one compiled loop against Nav2's raytraceFreespace as written (beams
    shortened at the grid's edge, Bresenham from raytrace_min_range to raytrace_max_range)."""
    points = scattered_points()                  # many of them beyond the 5 x 4 m grid
    source = ObservationSource(clearing=True, raytrace_min_range=0.3, raytrace_max_range=2.2)
    fast = ObstacleLayer((80, 100), RES, (0.0, 0.0))
    slow = ObstacleLayer((80, 100), RES, (0.0, 0.0))
    fast.costs[:] = slow.costs[:] = LETHAL_OBSTACLE
    assert fast.clear(points, (2.5, 2.0), source) == slow.clear_reference(points, (2.5, 2.0),
                                                                           source) == 300
    np.testing.assert_array_equal(fast.costs, slow.costs)
    assert 500 < np.count_nonzero(fast.costs == 0) < 8000


def test_a_beam_leaving_two_edges_is_clipped_along_its_own_direction():
    """Nav2's raytraceFreespace takes the beam's direction once, then shortens it at each edge
    it leaves. From (0.05, 0.05) to (1.04, 3.81) on a 1 × 1 m grid the beam leaves the right
    edge, then the top: it ends at x = 0.05 + 0.99 · 0.95 / 3.76 = 0.300 (column 3). Taking the
    direction again after the first edge ended it at x = 0.29999 (column 2)."""
    source = ObservationSource(clearing=True, raytrace_max_range=10.0)
    fast = ObstacleLayer((10, 10), 0.1, (0.0, 0.0))
    slow = ObstacleLayer((10, 10), 0.1, (0.0, 0.0))
    fast.costs[:] = slow.costs[:] = LETHAL_OBSTACLE
    beam = np.array([[1.04, 3.81]])
    fast.clear(beam, (0.05, 0.05), source)
    slow.clear_reference(beam, (0.05, 0.05), source)
    np.testing.assert_array_equal(fast.costs, slow.costs)
    assert fast.costs[9, 3] == 0 and fast.costs[9, 2] == LETHAL_OBSTACLE


def test_the_kits_rules_trace_whole_beams_and_mark_by_metres():
    """``clip_rays=False``: each beam is traced to its own end cell, the cells beyond the grid
    dropped; ``range_in_cells=False``: a return marks when it is within the ranges in metres."""
    points = scattered_points(seed=6)
    sensor = (2.5, 2.0)
    source = ObservationSource(clearing=True, marking=True, obstacle_max_range=2.0)
    layer = ObstacleLayer((80, 100), RES, (0.0, 0.0), clip_rays=False, range_in_cells=False)
    layer.costs[:] = LETHAL_OBSTACLE
    layer.update_points(points, sensor, (source,))
    expected = np.full((80, 100), LETHAL_OBSTACLE, np.uint8)
    start = (math.floor(sensor[1] / RES), math.floor(sensor[0] / RES))
    for x, y in points:
        cells = raytrace_line(start, (math.floor(y / RES), math.floor(x / RES)),
                              max_length=math.ceil(3.0 / RES))
        on = (cells[:, 0] >= 0) & (cells[:, 0] < 80) & (cells[:, 1] >= 0) & (cells[:, 1] < 100)
        expected[cells[on, 0], cells[on, 1]] = 0
    near = points[np.hypot(*(points - sensor).T) <= 2.0]
    expected[np.floor(near[:, 1] / RES).astype(int), np.floor(near[:, 0] / RES).astype(int)] = \
        LETHAL_OBSTACLE
    np.testing.assert_array_equal(layer.costs, expected)


def test_a_rolling_window_takes_the_map_where_it_reaches_and_its_default_elsewhere():
    """Nav2's static layer in a rolling window writes only where the map is; beyond it the
    master grid keeps its default, free (or unknown with track_unknown_space)."""
    grid = room_map()                                     # 5 m x 4 m, walls round it
    for track, outside in ((False, 0), (True, NO_INFORMATION)):
        params = CostmapParams(rolling_window=True, width=2.0, height=2.0, resolution=RES,
                               track_unknown_space=track,
                               layers=(StaticLayerParams(),))
        window = LayeredCostmap(params, grid).update((0.52, 0.52, 0.0))
        assert window.origin == pytest.approx((-0.5, -0.5)) and window.costs.shape == (40, 40)
        static = static_layer(grid, track_unknown_space=track)
        np.testing.assert_array_equal(window.costs[10:, 10:], static[:30, :30])
        assert (window.costs[:10, :] == outside).all() and (window.costs[:, :10] == outside).all()


def test_a_rolling_window_at_another_resolution_reads_the_map_cell_by_cell():
    grid = room_map()
    params = CostmapParams(rolling_window=True, width=1.8, height=1.8, resolution=0.06,
                           layers=(StaticLayerParams(),))
    window = LayeredCostmap(params, grid).update((4.6, 3.6, 0.0))
    static = static_layer(grid)
    rows, cols = np.indices(window.costs.shape)
    x = window.origin[0] + (cols + 0.5) * 0.06
    y = window.origin[1] + (rows + 0.5) * 0.06
    mx, my = np.floor(x / RES).astype(int), np.floor(y / RES).astype(int)
    on = (mx < 100) & (my < 80)
    np.testing.assert_array_equal(window.costs[on], static[my[on], mx[on]])
    assert (window.costs[~on] == 0).all() and (~on).any()


def test_a_keepout_filter_among_the_plugins_is_inflated_and_among_the_filters_is_not():
    grid = room_map()
    mask = msgs.OccupancyGrid(grid.header, grid.info, np.where(
        np.arange(grid.data.size) % 100 == 50, 100, 0).astype(np.int8))     # a line x = 2.5 m
    inflation = InflationLayerParams(inflation_radius=0.3, cost_scaling_factor=5.0)
    layered = CostmapParams(robot_radius=0.1, layers=(StaticLayerParams(),
                                                      KeepoutFilterParams(), inflation))
    filtered = CostmapParams(robot_radius=0.1, layers=(StaticLayerParams(), inflation),
                             filters=(KeepoutFilterParams(),))
    costs = {}
    for name, params in (("layer", layered), ("filter", filtered)):
        cm = LayeredCostmap(params, grid)
        cm.set_keepout_mask(mask)
        costs[name] = cm.update().costs
    assert (costs["layer"][1:-1, 50] == LETHAL_OBSTACLE).all()
    assert (costs["filter"][1:-1, 50] == LETHAL_OBSTACLE).all()
    assert costs["layer"][40, 52] > 0 and costs["filter"][40, 52] == 0


def test_the_static_layers_footprint_clearing_frees_the_map_under_the_robot():
    grid = room_map()
    params = CostmapParams(robot_radius=0.2, layers=(StaticLayerParams(
        footprint_clearing_enabled=True),))
    costs = LayeredCostmap(params, grid).update((0.1, 0.1, 0.0)).costs
    assert costs[0, 0] == 0 and costs[0, 20] == LETHAL_OBSTACLE
