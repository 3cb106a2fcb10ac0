"""Nav2's own parameter files (Humble, Jazzy, a keep-out test) and two robot vendors'
(TurtleBot 3, TurtleBot 4), loaded as they are (``tests/data/nav2_params``, sources in its
README): every key used or reported by name exactly once, the file's values reaching the
navigator, a navigation episode run from each in the simulator, and files the kit has not
seen — namespaced, wildcarded, anchored, with strings for numbers, unknown plugins, random
ones — loading or failing with a ValueError, never another exception."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from ruamel.yaml import YAML

from kit.localization import AmclParameters
from kit.nav2params import Nav2File
from kit.navigation import (
    NavigationConfig,
    Navigator,
    RppParameters,
    load_nav2_params,
)
from kit.planning import (
    KeepoutFilterParams,
    ObservationSource,
    ObstacleLayerParams,
    load_costmap_params,
)
from kit.robots import load
from sim import navdemo, scenarios

DATA = Path(__file__).resolve().parents[2] / "data" / "nav2_params"
HUMBLE = DATA / "nav2-humble" / "nav2_params.yaml"
JAZZY = DATA / "nav2-jazzy" / "nav2_params.yaml"
KEEPOUT = DATA / "nav2-humble-keepout" / "keepout_params.yaml"
BURGER = DATA / "turtlebot3-humble" / "burger.yaml"
WAFFLE = DATA / "turtlebot3-humble" / "waffle.yaml"
TB4 = DATA / "turtlebot4-humble" / "nav2.yaml"
FILES = [HUMBLE, JAZZY, KEEPOUT, BURGER, WAFFLE, TB4]
UIABOT = load("uiabot")


def yaml_load(path):
    return YAML(typ="safe", pure=True).load(path.read_text(encoding="utf-8"))


def check_accounted(config, source):
    """Every key of the file used or not used (with a reason), none both, none twice in the
    printed groups, and nothing the file does not have."""
    report = config.report
    keys = Nav2File(source).keys()
    assert len(keys) == len(set(keys))
    used, ignored = set(report.used), set(report.ignored)
    assert used | ignored == set(keys)
    assert not used & ignored
    grouped = [key for names in report.unused_groups().values() for key in names]
    assert sorted(grouped) == sorted(ignored)
    assert all(reason for reason in report.ignored.values())
    text = "\n".join(report.lines())
    assert text.startswith(f"Nav2 parameters from {report.origin}: {len(used)} keys used")
    return report


@pytest.mark.parametrize("path", FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_every_key_of_a_stock_file_is_used_or_reported_by_name_once(path):
    check_accounted(load_nav2_params(path, UIABOT), path)


@pytest.mark.parametrize("costmap", ["global_costmap", "local_costmap"])
def test_a_costmap_configured_one_level_too_high_is_refused_with_the_fix(tmp_path, costmap):
    """Nav2's costmap node is /global_costmap/global_costmap: parameters under a one-level
    ``global_costmap:`` configure a node Nav2 does not have, and Nav2 silently runs the costmap
    with its defaults. The kit read them; it now says what is wrong and how to nest them."""
    data = yaml_load(HUMBLE)
    data[costmap] = data[costmap][costmap]          # ros__parameters one level up
    path = tmp_path / "flat.yaml"
    with path.open("w", encoding="utf-8") as f:
        YAML(typ="safe", pure=True).dump(data, f)
    message = (rf"under /{costmap} configure a node /{costmap}, which Nav2 does not have: its "
               rf"costmap node is /{costmap}/{costmap}.* \({costmap}: {costmap}: ros__parameters")
    with pytest.raises(ValueError, match=message):
        load_nav2_params(path, UIABOT)
    with pytest.raises(ValueError, match=message):
        load_costmap_params(path, costmap)


def test_humbles_file_sets_dwb_its_critics_the_checkers_navfn_and_the_costmaps():
    c = load_nav2_params(HUMBLE, UIABOT)
    used = c.report.used
    assert c.controller == "dwb"
    d = c.dwb
    assert (d.min_vel_x, d.max_vel_x, d.max_vel_theta, d.acc_lim_x, d.decel_lim_x,
            d.acc_lim_theta, d.decel_lim_theta) == (0.0, 0.26, 1.0, 2.5, -2.5, 3.2, -3.2)
    assert (d.vx_samples, d.vtheta_samples, d.sim_time, d.linear_granularity,
            d.angular_granularity) == (20, 20, 1.7, 0.05, 0.025)
    assert (d.max_speed_xy, d.min_speed_xy, d.min_speed_theta) == (0.26, 0.0, 0.0)
    assert d.critics == ("RotateToGoal", "Oscillation", "BaseObstacle", "GoalAlign",
                         "PathAlign", "PathDist", "GoalDist")
    assert d.scales == {"BaseObstacle": 0.02, "PathAlign": 32.0, "PathDist": 32.0,
                        "GoalAlign": 24.0, "GoalDist": 24.0, "RotateToGoal": 32.0,
                        "Oscillation": 1.0}
    assert (d.forward_point_distance, d.goal_align_forward_point_distance, d.slowing_factor,
            d.rotate_lookahead_time) == (0.1, 0.1, 5.0, -1.0)
    for key in ("FollowPath.critics", "FollowPath.BaseObstacle.scale",
                "FollowPath.PathAlign.forward_point_distance",
                "FollowPath.RotateToGoal.slowing_factor", "FollowPath.RotateToGoal.lookahead_time",
                "progress_checker.required_movement_radius",
                "general_goal_checker.xy_goal_tolerance", "failure_tolerance"):
        assert f"controller_server:{key}" in used, key
    n = c.navigator
    assert (n.controller_frequency, n.xy_goal_tolerance, n.yaw_goal_tolerance, n.stateful,
            n.required_movement_radius, n.movement_time_allowance, n.failure_tolerance,
            n.min_x_velocity_threshold, n.min_theta_velocity_threshold) == (
        20.0, 0.25, 0.25, True, 0.5, 10.0, 0.3, 0.001, 0.001)
    p = c.planner
    assert (p.kind, p.use_astar, p.tolerance, p.allow_unknown) == ("grid", False, 0.5, True)
    assert "planner_server:GridBased.tolerance" in used
    local = c.local_costmap
    assert (local.rolling_window, local.width, local.height, local.resolution,
            local.robot_radius, local.footprint) == (True, 3.0, 3.0, 0.05, 0.22, None)
    assert [layer.name for layer in local.layers] == ["voxel_layer", "inflation_layer"]
    voxel = local.layers[0]
    assert isinstance(voxel, ObstacleLayerParams)
    assert voxel.observation_sources == (ObservationSource(
        "scan", "/scan", "LaserScan", True, True, 2.5, 0.0, 3.0, 0.0, False),)
    assert (local.layers[1].inflation_radius, local.layers[1].cost_scaling_factor) == (0.55, 3.0)
    assert "local_costmap/local_costmap:voxel_layer.scan.obstacle_max_range" in used
    glob = c.global_costmap
    assert glob.track_unknown_space and not glob.rolling_window
    assert [layer.name for layer in glob.layers] == ["static_layer", "obstacle_layer",
                                                     "inflation_layer"]
    b = c.behaviors
    assert (b.simulate_ahead_time, b.max_rotational_vel, b.min_rotational_vel,
            b.rotational_acc_lim) == (2.0, 1.0, 0.4, 3.2)
    a = c.amcl
    assert isinstance(a, AmclParameters)
    assert (a.laser_model_type, a.laser_max_range, a.max_particles, a.sigma_hit,
            a.update_min_d, a.base_frame_id) == ("likelihood_field", 100.0, 2000, 0.2, 0.25,
                                                 "base_footprint")


def test_the_kits_own_amcl_parameters_are_reported_as_kept_for_a_stock_amcl_section():
    kept = load_nav2_params(HUMBLE, UIABOT).report.kept
    for name in ("ess_threshold", "deskew", "recovery_reset"):
        assert f"amcl:{name}" in kept and "the kit's own parameter" in kept[f"amcl:{name}"]
    assert kept["controller_server:FollowPath.BaseObstacle.sum_scores"] == \
        "true (Nav2's default: false)"
    assert kept["local_costmap/local_costmap:footprint_padding"] == \
        "0.05 m (Nav2's default: 0.01)"


def test_jazzys_mppi_controller_is_reported_and_the_kits_controller_drives():
    c = load_nav2_params(JAZZY, UIABOT)
    assert c.controller == "rpp"
    assert c.rpp == RppParameters.for_robot(UIABOT, controller_frequency=20.0)
    ignored = c.report.ignored
    mppi = [k for k in Nav2File(JAZZY).keys() if k.startswith("controller_server:FollowPath.")]
    assert len(mppi) == 72                # the "key: value" lines under its FollowPath:
    assert all(ignored[k].startswith("not supported: MPPIController is not one of the kit's "
                                     "controllers") for k in mppi)
    assert any("MPPIController is not supported" in note for note in c.report.notes)
    assert load_nav2_params(JAZZY, UIABOT, controller="dwb").controller == "dwb"
    assert c.planner.use_astar is False                       # nav2_navfn_planner::NavfnPlanner
    assert c.local_costmap.layers[1].inflation_radius == 0.70
    assert ignored["route_server:operations"].startswith("not used: the kit does not mirror "
                                                         "route_server")


def test_a_controller_asked_for_that_contradicts_the_file_is_refused():
    with pytest.raises(ValueError, match="the controller asked for is 'rpp', but the file's "
                                         "FollowPath is dwb_core::DWBLocalPlanner"):
        load_nav2_params(HUMBLE, UIABOT, controller="rpp")


def test_turtlebot3s_galactic_leftovers_and_two_obstacle_layers():
    c = load_nav2_params(BURGER, UIABOT)
    ignored = c.report.ignored
    assert ignored["recoveries_server:max_rotational_vel"].startswith(
        "not used: the kit does not mirror recoveries_server (Galactic's name")
    assert ignored["controller_server:FollowPath.stateful"] == \
        "not a parameter of Nav2's DWB (Nav2 ignores it too)"
    assert ignored["local_costmap/local_costmap:static_layer.map_subscribe_transient_local"] == \
        "not used: static_layer is not in plugins or filters"
    assert ignored["bt_navigator:default_bt_xml_filename"].startswith(
        "not used: Galactic's name")
    assert c.navigator.controller_frequency == 10.0 and c.dwb.controller_frequency == 10.0
    assert (c.dwb.xy_goal_tolerance, c.dwb.vtheta_samples, c.dwb.sim_time) == (0.05, 40, 1.5)
    assert [layer.name for layer in c.local_costmap.layers] == ["obstacle_layer",
                                                                "voxel_layer",
                                                                "inflation_layer"]
    assert c.local_costmap.layers[0].observation_sources[0] == ObservationSource(
        "scan", "/scan", "LaserScan", True, True)                # Nav2's default ranges
    assert c.local_costmap.robot_radius == 0.1
    assert any("reaches 0.171 m from base_link, the uiabot's 0.297 m" in note
               for note in c.report.notes)


def test_turtlebot4s_costmaps_at_another_resolution_than_the_map():
    c = load_nav2_params(TB4, UIABOT)
    assert c.amcl is None and c.local_costmap.resolution == 0.06
    node = "global_costmap/global_costmap"
    assert c.report.ignored[f"{node}:resolution"].startswith("no effect: with a static layer")
    grid = scenarios.load_world("office").occupancy_grid(0.05, layer="lidar")
    nav = Navigator(grid, UIABOT, config=c)
    assert nav.global_costmap.resolution == pytest.approx(0.05)
    local = nav.local_costmap.update((5.0, 6.0, 0.0))
    assert local.resolution == 0.06 and local.costs.shape == (50, 50)
    # the window reads the 0.05 m map cell by cell: a wall of it at the same place
    wall = nav.global_costmap.update()
    for (x, y) in ((4.0, 4.55), (6.0, 7.45)):
        assert (local.costs[local.world_to_cell(x, y)] >= 253) == \
            (wall.costs[wall.world_to_cell(x, y)] >= 253)


def test_the_keepout_files_filter_keeps_the_mask_out_after_the_inflation():
    c = load_nav2_params(KEEPOUT, UIABOT)
    assert c.global_costmap.filters == (KeepoutFilterParams("keepout_filter", True),)
    assert c.local_costmap.filters == (KeepoutFilterParams("keepout_filter", True),)
    assert c.report.ignored["global_costmap/global_costmap:keepout_filter.filter_info_topic"] \
        .startswith("no effect: the kit takes the keep-out mask from the scenario")
    world = scenarios.load_world("office")
    grid, glass = world.occupancy_grid(0.05, layer="lidar"), world.occupancy_grid(
        0.05, layer="glass")
    nav = Navigator(grid, UIABOT, keepout=glass, config=c)
    assert nav.global_costmap.params.layers == c.global_costmap.layers   # no kit layer added
    costs = nav.global_costmap.update().costs
    mask = np.asarray(glass.data).reshape(costs.shape) == 100
    assert mask.sum() > 100 and np.all(costs[mask] == 254)
    # Nav2's filter comes after the inflation: beside the glass the costs are the map's own
    plain = Navigator(grid, UIABOT, config=c).global_costmap.update().costs
    np.testing.assert_array_equal(costs[~mask], plain[~mask])


def test_the_demos_file_is_the_kits_own_configuration_for_the_uiabot():
    c = scenarios.load_params(navdemo.PARAMS, "uiabot")
    kit = NavigationConfig.for_robot(UIABOT)
    assert c.report.kept == {} and c.report.errors == []
    assert c.report.ignored == {}                                 # every key used
    assert (c.controller, c.navigator, c.rpp, c.planner, c.behaviors) == (
        kit.controller, kit.navigator, kit.rpp, kit.planner, kit.behaviors)
    assert c.amcl == scenarios.AMCL
    assert c.local_costmap.same_as(kit.local_costmap)
    # the global one lists the keep-out layer the navigator adds to the kit's own
    world = scenarios.load_world("office")
    grid, glass = world.occupancy_grid(0.05, layer="lidar"), world.occupancy_grid(
        0.05, layer="glass")
    ours, theirs = Navigator(grid, UIABOT, keepout=glass, config=c), \
        Navigator(grid, UIABOT, keepout=glass)
    assert ours.global_costmap.params.layers == theirs.global_costmap.params.layers
    np.testing.assert_array_equal(ours.global_costmap.update().costs,
                                  theirs.global_costmap.update().costs)
    rng = np.random.default_rng(4)
    pose = np.array([1.0, 6.0, 0.0])
    for nav in (ours, theirs):
        nav.navigate_to_pose((15.0, 9.5, math.pi / 2))
    for k in range(40):
        points = pose[:2] + rng.uniform(-2.5, 2.5, (60, 2))
        commands = []
        for nav in (ours, theirs):
            nav.on_points(points, pose[:2], pose)
            commands.append(nav.tick(k / 20, pose, (0.3, 0.0)))
        assert commands[0] == commands[1]
        np.testing.assert_array_equal(ours.path, theirs.path)
        pose = pose + np.array([0.02, 0.0, 0.0])


# ---------------------------------------------------------------- episodes from the files

def short_episode(config, localization):
    """Down the office corridor, 4 m, nobody about: one goal's row and the node."""
    route = scenarios.Route("office", (1.0, 6.0, 0.0), ((5.0, 6.0, 0.0),), 0,
                            "along the corridor")
    world = scenarios.load_world("office")
    setup = scenarios.EpisodeSetup(route, "uiabot", world,
                                   world.occupancy_grid(0.05, layer="lidar"),
                                   world.occupancy_grid(0.05, layer="glass"))
    setup.shortest = scenarios.shortest_lengths(world, "uiabot", route)
    source = scenarios.localization_source(setup, localization, 3, config.amcl)
    return scenarios.run_episode(setup, 0, 3, source, config=config)


@pytest.mark.slow
@pytest.mark.parametrize("path", FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_a_navigation_episode_runs_from_each_file(path):
    config = scenarios.load_params(path, "uiabot")
    localization = "amcl" if config.amcl is not None else "truth"
    node = short_episode(config, localization)
    assert node.rate == config.navigator.controller_frequency
    kind = {"rpp": "RegulatedPurePursuit", "dwb": "DwbController"}[config.controller]
    assert type(node.navigator.controller).__name__ == kind
    if localization == "amcl":
        assert node.localization.amcl.params == config.amcl
    (row,) = node.results
    assert row.reached, row.reason
    assert row.collisions_static == 0 and math.isfinite(row.seconds)


# ---------------------------------------------------------------- files the kit has not seen

def test_a_file_namespaced_wildcarded_and_with_strings_for_numbers_loads_the_same(tmp_path):
    data = yaml_load(HUMBLE)
    plain = load_nav2_params(HUMBLE, UIABOT)

    def strings(node):
        if isinstance(node, dict):
            return {k: strings(v) for k, v in node.items()}
        if isinstance(node, float) and not isinstance(node, bool):
            return repr(node)
        return node

    nested = {"robot1": {name: strings(value) for name, value in data.items()},
              "/**": {"ros__parameters": {"use_sim_time": True}}}
    path = tmp_path / "namespaced.yaml"
    with path.open("w") as f:
        YAML(typ="safe", pure=True).dump(nested, f)
    c = load_nav2_params(path, UIABOT)
    check_accounted(c, path)
    assert (c.dwb, c.navigator, c.planner, c.behaviors, c.amcl) == (
        plain.dwb, plain.navigator, plain.planner, plain.behaviors, plain.amcl)
    assert c.local_costmap.same_as(plain.local_costmap)
    assert any("is given as the string '0.26': read as 0.26" in n for n in c.report.notes)
    assert c.report.ignored["**:use_sim_time"].startswith("no effect")


def test_unknown_plugins_everywhere_are_reported_and_the_kits_own_drive(tmp_path):
    data = yaml_load(HUMBLE)
    cs = data["controller_server"]["ros__parameters"]
    cs["FollowPath"] = {"plugin": "teb_local_planner::TebLocalPlannerROS", "max_vel_x": 0.4}
    cs["goal_checker_plugins"] = ["precise", "general_goal_checker"]
    cs["precise"] = {"plugin": "my_robot::FancyGoalChecker", "xy_goal_tolerance": 0.1}
    ps = data["planner_server"]["ros__parameters"]
    ps["GridBased"] = {"plugin": "nav2_smac_planner/SmacPlannerHybrid", "tolerance": 0.2}
    lc = data["local_costmap"]["local_costmap"]["ros__parameters"]
    lc["plugins"] = ["denoise_layer", "voxel_layer", "inflation_layer"]
    lc["denoise_layer"] = {"plugin": "nav2_costmap_2d::DenoiseLayer", "minimal_group_size": 2}
    lc["filters"] = ["speed_filter"]
    lc["speed_filter"] = {"plugin": "nav2_costmap_2d::SpeedFilter", "speed_limit_topic": "/x"}
    path = tmp_path / "custom.yaml"
    with path.open("w") as f:
        YAML(typ="safe", pure=True).dump(data, f)
    c = load_nav2_params(path, UIABOT)
    report = check_accounted(c, path)
    assert c.controller == "rpp" and c.planner.kind == "grid" and c.planner.tolerance == 0.0
    assert report.ignored["controller_server:FollowPath.max_vel_x"].startswith(
        "not supported: TebLocalPlannerROS")
    assert report.ignored["controller_server:precise.xy_goal_tolerance"].startswith(
        "not supported: the kit's goal checkers")
    assert report.ignored["planner_server:GridBased.tolerance"].startswith(
        "not supported: SmacPlannerHybrid")
    node = "local_costmap/local_costmap"
    assert report.ignored[f"{node}:denoise_layer.minimal_group_size"].startswith(
        "not supported: denoise_layer is a nav2_costmap_2d::DenoiseLayer")
    assert report.ignored[f"{node}:speed_filter.speed_limit_topic"].startswith(
        "not supported")
    assert [layer.name for layer in c.local_costmap.layers] == ["voxel_layer",
                                                                "inflation_layer"]


@pytest.mark.parametrize(("edit", "message"), [
    (lambda d: d["amcl"]["ros__parameters"].update(max_particles="many"),
     "amcl.max_particles must be an integer; got 'many'"),
    (lambda d: d["controller_server"]["ros__parameters"]["FollowPath"].update(
        decel_lim_x=2.5), "decel_lim_x and decel_lim_theta are negative"),
    (lambda d: d["local_costmap"]["local_costmap"]["ros__parameters"].update(
        footprint="[[0.1, 0.1]]"), "footprint must have three or more"),
    (lambda d: d["local_costmap"]["local_costmap"]["ros__parameters"]["voxel_layer"]["scan"]
     .update(data_type="PointCloud2"), "reads LaserScan only; got 'PointCloud2'"),
    (lambda d: d["planner_server"]["ros__parameters"]["GridBased"].update(tolerance=-1.0),
     "tolerance must be a non-negative number"),
    (lambda d: d["controller_server"]["ros__parameters"].update(controller_frequency=0),
     "controller_frequency must be a positive number of Hz"),
])
def test_values_the_kit_cannot_use_are_named_in_one_error(tmp_path, edit, message):
    data = copy.deepcopy(yaml_load(HUMBLE))
    edit(data)
    with pytest.raises(ValueError, match=message):
        load_nav2_params(data, UIABOT)


PARAMETER_NAMES = sorted({key.split(":", 1)[1].split(".")[-1] for path in FILES
                          for key in Nav2File(path).keys()} | {"plugin", "plugins",
                                                               "observation_sources"})
NODES = ["amcl", "controller_server", "planner_server", "behavior_server", "bt_navigator",
         "local_costmap", "global_costmap", "velocity_smoother", "/**", "robot1"]
VALUES = st.one_of(st.none(), st.booleans(), st.integers(-5, 100), st.floats(-10, 10),
                   st.sampled_from(["", "scan", "0.5", "true", "[]", "nav2_costmap_2d::"
                                    "VoxelLayer", "dwb_core::DWBLocalPlanner",
                                    "nav2_regulated_pure_pursuit_controller::"
                                    "RegulatedPurePursuitController", "$(var x)",
                                    "[[0.2, 0.2], [-0.2, 0.2], [0.0, -0.3]]"]),
                   st.lists(st.sampled_from(["static_layer", "voxel_layer", "scan",
                                             "FollowPath", "BaseObstacle", "GridBased"]),
                            max_size=3))
PARAMS = st.recursive(st.dictionaries(st.sampled_from(PARAMETER_NAMES), VALUES, max_size=6),
                      lambda inner: st.dictionaries(
                          st.sampled_from(["FollowPath", "GridBased", "voxel_layer", "scan",
                                           "obstacle_layer", "inflation_layer", "spin",
                                           "general_goal_checker", "progress_checker"]),
                          inner, max_size=3), max_leaves=25)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.dictionaries(st.sampled_from(NODES), PARAMS, min_size=1, max_size=4))
def test_random_files_load_with_every_key_accounted_or_fail_with_a_value_error(nodes):
    data = {}
    for name, params in nodes.items():
        if name.endswith("costmap"):
            data[name] = {name: {"ros__parameters": params}}
        else:
            data[name] = {"ros__parameters": params}
    try:
        config = load_nav2_params(data, UIABOT)
    except ValueError:
        return
    report = config.report
    assert set(report.used) | set(report.ignored) == set(Nav2File(data).keys())
    grid = scenarios.load_world("office").occupancy_grid(0.05, layer="lidar")
    try:
        nav = Navigator(grid, UIABOT, config=config)
    except ValueError:
        return
    nav.navigate_to_pose((5.0, 6.0, 0.0))
    nav.on_points(np.array([[2.0, 6.0]]), (1.0, 6.0), (1.0, 6.0, 0.0))
    v, w = nav.tick(0.0, (1.0, 6.0, 0.0), (0.0, 0.0))
    assert math.isfinite(v) and math.isfinite(w)


def test_an_unknown_controller_asked_for_is_refused():
    with pytest.raises(ValueError, match="controller is 'rpp' or 'dwb'; got 'teb'"):
        load_nav2_params({"amcl": {"ros__parameters": {}}}, UIABOT, controller="teb")


def test_nodes_named_under_a_wildcard_namespace_are_read_and_reported_by_their_name():
    data = {"/**/amcl": {"ros__parameters": {"max_particles": 900}},
            "/**/velocity_smoother": {"ros__parameters": {"smoothing_frequency": 20.0}},
            "/**": {"ros__parameters": {"use_sim_time": True}}}
    c = load_nav2_params(data, UIABOT)
    assert c.amcl is not None and c.amcl.max_particles == 900
    assert c.report.ignored["**/velocity_smoother:smoothing_frequency"].startswith(
        "not used: the kit does not mirror velocity_smoother")
    assert c.report.ignored["**:use_sim_time"].startswith("no effect")


def test_a_costmap_too_large_to_hold_is_refused_before_it_is_made():
    data = copy.deepcopy(yaml_load(HUMBLE))
    data["local_costmap"]["local_costmap"]["ros__parameters"]["resolution"] = 1e-5
    config = load_nav2_params(data, UIABOT)
    grid = scenarios.load_world("office").occupancy_grid(0.05, layer="lidar")
    with pytest.raises(ValueError, match=r"a costmap of 300000 × 300000 cells is more than "
                                         r"the kit holds"):
        Navigator(grid, UIABOT, config=config)
