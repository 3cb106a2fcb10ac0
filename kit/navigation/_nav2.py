"""A Nav2 parameter file (``nav2_params.yaml``, a robot vendor's) read into the navigator's
configuration, every key accounted for.

:func:`load_nav2_params` reads the nodes the kit mirrors — ``amcl``, ``controller_server``
(``FollowPath`` with Regulated Pure Pursuit or DWB, its critics and their parameters, the
goal and progress checkers), ``planner_server`` (NavFn, Smac 2-D, Theta*), the global and
local costmaps (static, obstacle and voxel layers, inflation, keep-out), ``behavior_server``
and ``bt_navigator`` — into a :class:`~kit.navigation.NavigationConfig`. Its ``report`` says
what became of each key: used (and what it set), or not used and why, named once — a plugin
the kit does not have, ROS's plumbing (topics, frames, QoS, timeouts) that has no effect in
the simulator, a node the kit does not mirror. A parameter the file does not set keeps the
kit's value for the robot (a planner or checker plugin the file names starts from that
plugin's Nav2 defaults); where that value is not Nav2's default, or is one of the kit's own
parameters, the report lists it as kept.

Semantics follow Nav2's documentation and sources (Humble and Jazzy); where the kit's
mirror is simpler, the report says so for the keys concerned.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from kit.nav2params import Nav2File, ParameterReport, Section
from kit.navigation._config import (
    BehaviorParameters,
    NavigationConfig,
    NavigatorParameters,
    PlannerParameters,
)
from kit.navigation._dwb import CRITICS, DwbParameters
from kit.navigation._pursuit import RppParameters
from kit.planning import CostmapParams, footprint_radii, pad_footprint
from kit.planning._layered import NO_EFFECT, read_costmap
from kit.robots import RobotDescription

__all__ = ["load_nav2_params"]

DEFAULT_TREE = "navigate_to_pose_w_replanning_and_recovery.xml"
THROUGH_TREE = "navigate_through_poses_w_replanning_and_recovery.xml"

MIRRORED = ("amcl", "controller_server", "planner_server", "behavior_server", "bt_navigator",
            "global_costmap/global_costmap", "local_costmap/local_costmap")

OTHER_NODES = {
    "recoveries_server": "Galactic's name for behavior_server: Nav2 Humble and later have no "
                         "such node, so its keys reach no recovery in ROS either",
    "smoother_server": "the default tree smooths no path",
    "velocity_smoother": "the kit sends the controller's commands as they are",
    "collision_monitor": "the kit has no collision monitor (the controllers check the "
                         "footprint themselves)",
    "waypoint_follower": "the scenarios give goals one by one",
    "map_server": "the scenario gives the map",
    "map_saver": "the kit saves maps with kit.maps",
    "docking_server": "the kit has no docking",
    "route_server": "the kit has no route server",
    "loopback_simulator": "the kit has its own simulator",
    "robot_state_publisher": "the robot's description comes from hardware/robots",
    "slam_toolbox": "the kit's SLAM has its own configuration (kit.slam.SlamConfig)",
    "lifecycle_manager": "the kit has no lifecycle nodes",
}


# ---------------------------------------------------------------------- helpers

def _fixed(s: Section, name: str, kit_value: Any, what: str) -> None:
    """A parameter whose only value the kit implements is ``kit_value``: the file's value
    is used when it is that one, reported as not supported otherwise."""
    if not s.has(name):
        return
    value = s.get(name, kit_value, what)
    if value != kit_value:
        s.report.unuse(s.key(name), f"not supported: the kit's {what}")


def _kept(report: ParameterReport, prefix: str, s: Section, kit: Any,
          nav2_defaults: Mapping[str, Any], kit_only: Mapping[str, str] = {},
          names: Mapping[str, str] | None = None) -> None:
    """List as kept each parameter the file does not set whose kit value differs from
    Nav2's default (``nav2_defaults``), and each of the kit's own (``kit_only``: name →
    what it does). ``names`` maps a field of ``kit`` to the file's key when they differ."""
    names = names or {}
    for field_name, default in nav2_defaults.items():
        key = names.get(field_name, field_name)
        if s.has(key):
            continue
        value = getattr(kit, field_name)
        if not _same(value, default):
            report.keep(f"{prefix}{key}", f"{_show(value)} (Nav2's default: {_show(default)})")
    for field_name, what in kit_only.items():
        if s.has(field_name):
            continue
        report.keep(f"{prefix}{field_name}", f"{_show(getattr(kit, field_name))} — the kit's "
                                             f"own parameter: {what}")


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) or isinstance(b, float):
        try:
            return math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=1e-12)
        except (TypeError, ValueError):
            return False
    return bool(a == b)


def _show(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, dict):
        return ", ".join(f"{k} {_show(v)}" for k, v in value.items())
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(map(str, value)) + "]"
    return str(value)


def _type_name(plugin: str) -> str:
    """``nav2_navfn_planner/NavfnPlanner`` and ``nav2_navfn_planner::NavfnPlanner`` →
    ``NavfnPlanner``."""
    return plugin.replace("/", "::").split("::")[-1]


def _build(make: Callable[..., Any], report: ParameterReport, where: str, fallback: Any,
           **values: Any) -> Any:
    """``make(**values)``, or ``fallback`` with the error reported."""
    try:
        return make(**values)
    except (ValueError, TypeError) as exc:
        report.errors.append(f"{where}: {exc}")
        return fallback


# ---------------------------------------------------------------------- the controller

_RPP_NAV2 = {"desired_linear_vel": 0.5, "lookahead_dist": 0.6, "min_lookahead_dist": 0.3,
             "max_lookahead_dist": 0.9, "lookahead_time": 1.5,
             "rotate_to_heading_angular_vel": 1.8, "use_velocity_scaled_lookahead_dist": False,
             "min_approach_linear_velocity": 0.05, "approach_velocity_scaling_dist": 0.6,
             "use_collision_detection": True, "max_allowed_time_to_collision_up_to_carrot": 1.0,
             "use_regulated_linear_velocity_scaling": True,
             "use_cost_regulated_linear_velocity_scaling": True,
             "regulated_linear_scaling_min_radius": 0.9,
             "regulated_linear_scaling_min_speed": 0.25, "use_rotate_to_heading": True,
             "rotate_to_heading_min_angle": 0.785, "max_angular_accel": 3.2,
             "stateful": True, "cost_scaling_dist": 0.6, "cost_scaling_gain": 1.0,
             "inflation_cost_scaling_factor": 3.0}
"""Nav2's defaults of the Regulated Pure Pursuit parameters the kit implements."""

_RPP_KIT_ONLY = {
    "max_linear_accel": "the speed changes by at most this much per second [m/s²] (Nav2's "
                        "RPP has no such limit)",
}


def _read_rpp(fp: Section, base: RppParameters, frequency: float, robot: RobotDescription,
              local_extent: float) -> RppParameters:
    values: dict[str, Any] = {}
    for name in (*_RPP_NAV2, "max_linear_accel", "gentler_arcs_when_colliding",
                 "max_robot_pose_search_dist"):
        values[name] = fp.get(name, getattr(base, name))
    values["controller_frequency"] = frequency
    _fixed(fp, "allow_reversing", False, "RPP never drives backwards along a path")
    _fixed(fp, "use_interpolation", True, "RPP puts the carrot on the path between its points")
    _fixed(fp, "use_fixed_curvature_lookahead", False, "RPP takes the curvature at the carrot")
    _fixed(fp, "interpolate_curvature_after_goal", False, "RPP takes the curvature at the "
                                                          "carrot")
    _fixed(fp, "min_distance_to_obstacle", 0.0, "RPP checks collisions along the arc only")
    fp.ignore_all(NO_EFFECT, ("transform_tolerance",))
    fp.ignore_all("no effect: the kit's goals are not cancelled mid-way",
                  ("use_cancel_deceleration", "cancel_deceleration"))
    fp.ignore_all("not a Regulated Pure Pursuit parameter the kit knows")
    rpp = _build(RppParameters, fp.report, fp.key("").rstrip("."), base, **values)
    kit_only = dict(_RPP_KIT_ONLY)
    if rpp.gentler_arcs_when_colliding:
        kit_only["gentler_arcs_when_colliding"] = (
            "a colliding arc is tried at 1/2, 1/4, … of its curvature and straight on (on for "
            f"the {robot.name}, whose rear is more than 0.5 m behind base_link)")
    _kept(fp.report, fp.key(""), fp, rpp, {**_RPP_NAV2,
                                           "max_robot_pose_search_dist": local_extent},
          kit_only)
    return rpp


_DWB_NAV2 = {"min_vel_x": 0.0, "max_vel_x": 0.0, "max_vel_theta": 0.0, "acc_lim_x": 0.0,
             "decel_lim_x": 0.0, "acc_lim_theta": 0.0, "decel_lim_theta": 0.0,
             "vx_samples": 20, "vtheta_samples": 20, "sim_time": 1.7,
             "linear_granularity": 0.5, "angular_granularity": 0.025,
             "xy_goal_tolerance": 0.25, "trans_stopped_velocity": 0.25,
             "prune_distance": 2.0, "max_speed_xy": 0.0, "min_speed_xy": 0.0,
             "min_speed_theta": 0.0}
"""Nav2's defaults of the DWB parameters the kit implements (0 for most limits: Nav2's files
set them)."""

_DWB_CRITIC_PARAMS = {
    ("PathAlign", "forward_point_distance"): ("forward_point_distance", 0.325),
    ("GoalAlign", "forward_point_distance"): ("goal_align_forward_point_distance", 0.325),
    ("RotateToGoal", "slowing_factor"): ("slowing_factor", 5.0),
    ("RotateToGoal", "lookahead_time"): ("rotate_lookahead_time", -1.0),
    ("BaseObstacle", "sum_scores"): ("sum_scores", False),
    ("Oscillation", "oscillation_reset_dist"): ("oscillation_reset_dist", 0.05),
    ("Oscillation", "oscillation_reset_angle"): ("oscillation_reset_angle", 0.2),
}
"""The critic parameters the kit's DWB implements: (critic, parameter) → (field, Nav2's
default)."""


def _read_dwb(fp: Section, base: DwbParameters, frequency: float) -> DwbParameters:
    values: dict[str, Any] = {name: fp.get(name, getattr(base, name)) for name in _DWB_NAV2}
    values["controller_frequency"] = frequency
    for name in ("min_vel_y", "max_vel_y", "acc_lim_y", "decel_lim_y"):
        _fixed(fp, name, 0.0, "DWB drives a differential drive: no sideways velocity")
    flat = all(fp.raw(n, 0.0) in (0, 0.0) for n in ("min_vel_y", "max_vel_y"))
    if flat:
        fp.ignore_all("no effect: with min_vel_y and max_vel_y 0 every y sample is 0",
                      ("vy_samples",))
    else:
        fp.ignore_all("not supported: the kit's DWB samples no sideways velocity",
                      ("vy_samples",))
    critics = fp.get_list("critics", list(base.critics))
    if not fp.has("critics"):
        fp.report.note(f"{fp.key('critics').replace(':', '.')} is not set (Nav2's DWB refuses "
                       f"to start without critics): the kit's {', '.join(base.critics)}")
    known = [c for c in critics if c in CRITICS]
    dropped = [c for c in critics if c not in CRITICS]
    if dropped:
        fp.report.note(f"{fp.key('critics').replace(':', '.')}: the kit's DWB has no "
                       f"{', '.join(dropped)} critic; it scores with {', '.join(known)}")
    values["critics"] = tuple(known)
    scales = dict(base.scales)
    for name in CRITICS:
        if name in known:
            scales[name] = fp.get(f"{name}.scale", scales[name])
        else:
            fp.ignore_all(f"not used: {name} is not in critics", [
                n for n in fp.names() if n.startswith(f"{name}.")])
    values["scales"] = scales
    for (critic, param), (field_name, _) in _DWB_CRITIC_PARAMS.items():
        if critic in known:
            values[field_name] = fp.get(f"{critic}.{param}", getattr(base, field_name))
    for name in dropped:
        fp.ignore_all(f"not supported: the kit's DWB has no {name} critic",
                      [n for n in fp.names() if n.startswith(f"{name}.")])
    for critic in ("PathDist", "GoalDist", "PathAlign", "GoalAlign"):
        if critic in known:
            _fixed(fp, f"{critic}.aggregation_type", "last", f"{critic} scores the "
                                                             f"trajectory's last pose")
    if "Oscillation" in known:
        _fixed(fp, "Oscillation.oscillation_reset_time", -1.0,
               "Oscillation forgets flips by distance and angle only")
    _fixed(fp, "prune_plan", True, "DWB follows the path from the point nearest the robot")
    _fixed(fp, "shorten_transformed_plan", True, "DWB's local plan ends at the costmap's edge")
    _fixed(fp, "include_last_point", True, "DWB scores every trajectory to its last pose")
    _fixed(fp, "discretize_by_time", False, "DWB steps trajectories by distance and angle")
    _fixed(fp, "limit_vel_cmd_in_traj", False, "DWB commands the sampled velocity")
    _fixed(fp, "trajectory_generator_name", "dwb_plugins::StandardTrajectoryGenerator",
           "DWB's trajectories are the standard generator's")
    fp.ignore_all("no effect: the kit's DWB scores every trajectory, which gives the same "
                  "best one", ("short_circuit_trajectory_evaluation",))
    fp.ignore_all("not a parameter of Nav2's DWB (Nav2 ignores it too)", ("stateful",))
    fp.ignore_all(NO_EFFECT, ("debug_trajectory_details", "transform_tolerance",
                              "default_critic_namespaces", "publish_evaluation",
                              "publish_global_plan", "publish_transformed_plan",
                              "publish_local_plan", "publish_trajectories",
                              "publish_cost_grid_pc", "marker_lifetime"))
    fp.ignore_all("no effect unless discretize_by_time", ("time_granularity",))
    fp.ignore_all("not a DWB parameter the kit knows")
    dwb = _build(DwbParameters, fp.report, fp.key("").rstrip("."), base, **values)
    nav2 = {**_DWB_NAV2, **{f: d for (c, _), (f, d) in _DWB_CRITIC_PARAMS.items()
                            if c in known}}
    names = {f: f"{c}.{p}" for (c, p), (f, _) in _DWB_CRITIC_PARAMS.items()}
    _kept(fp.report, fp.key(""), fp, dwb, nav2, names=names)
    for name in known:
        if not fp.has(f"{name}.scale") and not _same(dwb.scales[name], 1.0):
            fp.report.keep(f"{fp.key(name)}.scale",
                           f"{_show(dwb.scales[name])} (Nav2's default: 1)")
    return dwb


_CONTROLLER_TYPES = {"DWBLocalPlanner": "dwb", "RegulatedPurePursuitController": "rpp"}


def _read_controller_server(s: Section, base: NavigationConfig, robot: RobotDescription,
                            requested: str | None, local_extent: float
                            ) -> tuple[dict[str, Any], str, RppParameters, DwbParameters]:
    nav = base.navigator
    out: dict[str, Any] = {}
    out["controller_frequency"] = s.get("controller_frequency", nav.controller_frequency)
    out["min_x_velocity_threshold"] = s.get("min_x_velocity_threshold",
                                            nav.min_x_velocity_threshold)
    out["min_theta_velocity_threshold"] = s.get("min_theta_velocity_threshold",
                                                nav.min_theta_velocity_threshold)
    s.ignore_all("no effect: a differential drive has no sideways velocity",
                 ("min_y_velocity_threshold",))
    out["failure_tolerance"] = s.get("failure_tolerance", nav.failure_tolerance)
    _kept(s.report, s.key(""), s, NavigatorParameters(**{**dataclasses.asdict(nav), **out}),
          {"min_x_velocity_threshold": 0.0001, "min_theta_velocity_threshold": 0.0001,
           "failure_tolerance": 0.0})
    out.update(_read_progress_checker(s, nav))
    out.update(_read_goal_checker(s, nav))
    controller, rpp, dwb = _read_follow_path(s, base, robot, requested, local_extent,
                                             out["controller_frequency"])
    s.ignore_all(NO_EFFECT, ("use_sim_time", "odom_topic", "speed_limit_topic",
                             "costmap_update_timeout", "use_realtime_priority",
                             "enable_stamped_cmd_vel", "publish_zero_velocity",
                             "bond_heartbeat_period", "introspection_mode",
                             "service_introspection_mode", "odom_duration"))
    return out, controller, rpp, dwb


def _read_progress_checker(s: Section, nav: NavigatorParameters) -> dict[str, Any]:
    """Humble's ``progress_checker_plugin`` or Jazzy's ``progress_checker_plugins``."""
    out: dict[str, Any] = {}
    if s.has("progress_checker_plugins"):
        ids = s.get_list("progress_checker_plugins", ["progress_checker"])
    else:
        ids = [s.get("progress_checker_plugin", "progress_checker")]
    ids = ids or ["progress_checker"]
    for other in ids[1:]:
        s.sub(other).ignore_all(f"not used: the kit's controller server uses the first "
                                f"progress checker, {ids[0]}")
    pc = s.sub(ids[0])
    kind = _type_name(pc.get("plugin", "nav2_controller::SimpleProgressChecker"))
    if kind in ("SimpleProgressChecker", "PoseProgressChecker"):
        out["required_movement_radius"] = pc.get("required_movement_radius",
                                                 nav.required_movement_radius)
        out["movement_time_allowance"] = pc.get("movement_time_allowance",
                                                nav.movement_time_allowance)
        out["required_movement_angle"] = pc.get("required_movement_angle", 0.5) \
            if kind == "PoseProgressChecker" else None
        pc.ignore_all(f"not a {kind} parameter the kit knows")
    else:
        pc.report.unuse(pc.key("plugin"), "")
        pc.ignore_all(f"not supported: the kit's progress checkers are Nav2's "
                      f"SimpleProgressChecker and PoseProgressChecker, not {kind}")
    return out


def _read_goal_checker(s: Section, nav: NavigatorParameters) -> dict[str, Any]:
    """The goal checker: the default tree names none, Nav2 then needs exactly one."""
    out: dict[str, Any] = {}
    ids = s.get_list("goal_checker_plugins", ["goal_checker"]) or ["goal_checker"]
    if s.has("goal_checker_plugin"):           # Galactic's singular name
        s.ignore("goal_checker_plugin", "not used: Nav2 Humble and later read "
                                        "goal_checker_plugins")
    for other in ids[1:]:
        s.sub(other).ignore_all(f"not used: the default tree names no goal checker; the "
                                f"kit uses the first, {ids[0]} (Nav2 would refuse two)")
    gc = s.sub(ids[0])
    kind = _type_name(gc.get("plugin", "nav2_controller::SimpleGoalChecker"))
    if kind in ("SimpleGoalChecker", "StoppedGoalChecker"):
        out["xy_goal_tolerance"] = gc.get("xy_goal_tolerance", nav.xy_goal_tolerance)
        out["yaw_goal_tolerance"] = gc.get("yaw_goal_tolerance", nav.yaw_goal_tolerance)
        out["stateful"] = gc.get("stateful", nav.stateful)
        out["goal_checker"] = "stopped" if kind == "StoppedGoalChecker" else "simple"
        if kind == "StoppedGoalChecker":
            out["trans_stopped_velocity"] = gc.get("trans_stopped_velocity", 0.25)
            out["rot_stopped_velocity"] = gc.get("rot_stopped_velocity", 0.25)
        gc.ignore_all(f"not a {kind} parameter the kit knows")
    else:
        gc.report.unuse(gc.key("plugin"), "")
        gc.ignore_all(f"not supported: the kit's goal checkers are Nav2's SimpleGoalChecker "
                      f"and StoppedGoalChecker, not {kind}")
    return out


def _tree_plugin(s: Section, key: str, default: str, verb: str) -> str:
    """The plugin of ``key`` (``controller_plugins``, ``planner_plugins``) that Nav2's default
    behaviour tree uses: ``default`` when listed, else the first (said in a note); the others
    are reported as not used."""
    ids = s.get_list(key, [default]) or [default]
    chosen = default if default in ids else ids[0]
    if chosen != default:
        s.report.note(f"{s.node}: no {default} among {key} (the default tree {verb} "
                      f"{default}): the kit uses {chosen}")
    for other in ids:
        if other != chosen:
            s.sub(other).ignore_all(f"not used: the default tree {verb} {chosen}")
    return chosen


def _read_follow_path(s: Section, base: NavigationConfig, robot: RobotDescription,
                      requested: str | None, local_extent: float, frequency: float
                      ) -> tuple[str, RppParameters, DwbParameters]:
    """The controller: the default tree calls FollowPath."""
    chosen = _tree_plugin(s, "controller_plugins", "FollowPath", "calls")
    fp = s.sub(chosen)
    plugin = fp.get("plugin", "dwb_core::DWBLocalPlanner")
    controller_kind = _CONTROLLER_TYPES.get(_type_name(plugin))
    rpp = dataclasses.replace(base.rpp, controller_frequency=frequency)
    dwb = dataclasses.replace(base.dwb, controller_frequency=frequency)
    if controller_kind is None:
        fallback = requested or "rpp"
        fp.report.unuse(fp.key("plugin"), "")
        fp.ignore_all(f"not supported: {_type_name(plugin)} is not one of the kit's "
                      f"controllers (Regulated Pure Pursuit, DWB); the kit runs its "
                      f"{'DWB' if fallback == 'dwb' else 'Regulated Pure Pursuit'} with its "
                      f"own parameters for the {robot.name}")
        fp.report.note(f"{s.node}.{chosen}: {plugin} is not supported: the kit's "
                       f"{'DWB' if fallback == 'dwb' else 'Regulated Pure Pursuit'} drives")
        return fallback, rpp, dwb
    if requested is not None and requested != controller_kind:
        s.report.errors.append(f"the controller asked for is {requested!r}, but the file's "
                               f"{chosen} is {plugin}: drop one of the two")
    if controller_kind == "rpp":
        rpp = _read_rpp(fp, rpp, frequency, robot, local_extent)
    else:
        dwb = _read_dwb(fp, dwb, frequency)
    return controller_kind, rpp, dwb


# ---------------------------------------------------------------------- the planner

NAVFN_COST_TRAVEL = 0.016 * 252
"""NavFn's cost of a cell, ``50 + 0.8 c``, in the kit's form ``1 + m · c / 252`` (×50):
``m = 4.032``."""


def _read_planner(s: Section, base: PlannerParameters) -> PlannerParameters:
    chosen = _tree_plugin(s, "planner_plugins", "GridBased", "plans with")
    g = s.sub(chosen)
    plugin = g.get("plugin", "nav2_navfn_planner/NavfnPlanner")
    kind = _type_name(plugin)
    out: PlannerParameters = base
    if kind == "NavfnPlanner":
        out = _build(PlannerParameters, s.report, g.key("").rstrip("."), base, kind="grid",
                     use_astar=g.get("use_astar", False),
                     allow_unknown=g.get("allow_unknown", True),
                     tolerance=g.get("tolerance", 0.5),
                     cost_travel_multiplier=NAVFN_COST_TRAVEL,
                     use_final_approach_orientation=g.get("use_final_approach_orientation",
                                                          False))
        s.report.note(f"{g.key('plugin').replace(':', '.')}: NavFn is planned as a grid "
                      f"search on NavFn's cell costs (50 + 0.8 c, i.e. cost_travel_multiplier "
                      f"{NAVFN_COST_TRAVEL:.3f}), the path through cell centres (NavFn "
                      f"descends its potential's gradient)")
        g.ignore_all("not a NavfnPlanner parameter the kit knows")
    elif kind == "SmacPlanner2D":
        factor = g.get("downsampling_factor", 1)
        down = g.get("downsample_costmap", False)
        if not down and g.has("downsampling_factor"):
            g.report.unuse(g.key("downsampling_factor"),
                           "no effect: downsample_costmap is false")
        max_iterations = g.get("max_iterations", 1000000)
        out = _build(PlannerParameters, s.report, g.key("").rstrip("."), base, kind="grid",
                     use_astar=True, allow_unknown=g.get("allow_unknown", True),
                     tolerance=g.get("tolerance", 0.125),
                     cost_travel_multiplier=g.get("cost_travel_multiplier", 1.0),
                     downsampling_factor=factor if down else 1,
                     max_iterations=max_iterations if max_iterations > 0 else None,
                     use_final_approach_orientation=g.get("use_final_approach_orientation",
                                                          False))
        g.ignore_all("no effect: the kit never bounds planning by the clock (its runs must "
                     "not depend on the machine's speed)",
                     ("max_planning_time", "terminal_checking_interval"))
        g.ignore_all("not supported: the kit's Smac 2-D stops at the goal's cell or, with "
                     "tolerance, at the nearest reachable cell", ("max_on_approach_iterations",))
        g.ignore_all("not supported: the kit's Smac 2-D does not smooth its path",
                     [n for n in g.names() if n.startswith("smoother.")])
        _fixed(g, "motion_model_for_search", "MOORE", "Smac 2-D searches 8 neighbours")
        g.ignore_all("not a SmacPlanner2D parameter the kit knows")
    elif kind == "ThetaStarPlanner":
        out = _build(PlannerParameters, s.report, g.key("").rstrip("."), base,
                     kind="theta_star", how_many_corners=g.get("how_many_corners", 8),
                     w_euc_cost=g.get("w_euc_cost", 1.0),
                     w_traversal_cost=g.get("w_traversal_cost", 2.0),
                     allow_unknown=g.get("allow_unknown", True),
                     use_final_approach_orientation=g.get("use_final_approach_orientation",
                                                          False))
        g.ignore_all("no effect: the kit never bounds planning by the clock",
                     ("terminal_checking_interval",))
        g.ignore_all("not a ThetaStarPlanner parameter the kit knows")
    else:
        g.report.unuse(g.key("plugin"), "")
        g.ignore_all(f"not supported: {kind} is not one of the kit's planners (NavFn, "
                     f"Smac 2-D, Theta*); the kit plans with its A* grid search")
        s.report.note(f"{s.node}.{chosen}: {plugin} is not supported: the kit's A* grid "
                      f"search plans")
    s.ignore_all("no effect: the default tree plans at 1 Hz", ("expected_planner_frequency",))
    s.ignore_all(NO_EFFECT, ("use_sim_time", "costmap_update_timeout",
                             "introspection_mode", "service_introspection_mode",
                             "bond_heartbeat_period"))
    return out


# ---------------------------------------------------------------------- recoveries, tree

_TREE_BEHAVIORS = {"spin": "Spin", "backup": "BackUp", "wait": "Wait"}


def _read_behaviors(s: Section, base: BehaviorParameters, robot: RobotDescription
                    ) -> BehaviorParameters:
    values = {name: s.get(name, getattr(base, name)) for name in (
        "simulate_ahead_time", "max_rotational_vel", "min_rotational_vel",
        "rotational_acc_lim")}
    default_ids = ["spin", "backup", "drive_on_heading", "wait"]
    ids = s.get_list("behavior_plugins", default_ids)
    missing = []
    for name in ids:
        b = s.sub(name)
        kind = _type_name(b.get("plugin", f"nav2_behaviors/{_TREE_BEHAVIORS.get(name, '')}"))
        if name in _TREE_BEHAVIORS and kind == _TREE_BEHAVIORS[name]:
            b.ignore_all(f"not a {kind} parameter the kit knows")
        elif name in _TREE_BEHAVIORS:
            b.report.unuse(b.key("plugin"), "")
            b.ignore_all(f"not supported: the default tree's {name} is Nav2's "
                         f"{_TREE_BEHAVIORS[name]}, not {kind}")
            missing.append(name)
        else:
            b.report.unuse(b.key("plugin"), "")
            b.ignore_all(f"not used: the default tree does not call {name}")
    for name in _TREE_BEHAVIORS:
        if name not in ids and s.has("behavior_plugins"):
            missing.append(name)
    if missing:
        s.report.note(f"{s.node}: behavior_plugins has no {', '.join(missing)}: the default "
                      f"tree's recoveries of those names fail at once, in the kit as in Nav2")
    s.ignore_all("not supported: the kit ticks recoveries at the controller's rate",
                 ("cycle_frequency",))
    s.ignore_all(NO_EFFECT, ("use_sim_time", "costmap_topic", "footprint_topic",
                             "local_costmap_topic", "global_costmap_topic",
                             "local_footprint_topic", "global_footprint_topic",
                             "global_frame", "local_frame", "robot_base_frame",
                             "transform_tolerance", "transform_timeout",
                             "enable_stamped_cmd_vel", "bond_heartbeat_period"))
    s.ignore_all("not a behavior_server parameter the kit knows")
    values["unavailable"] = tuple(missing)
    out = _build(BehaviorParameters, s.report, s.node, base,
                 **{**dataclasses.asdict(base), **values})
    _kept(s.report, s.key(""), s, out, {"max_rotational_vel": 1.0})
    if out.max_rotational_vel > robot.max_angular_velocity:
        s.report.note(f"{s.node}.max_rotational_vel {out.max_rotational_vel:g} rad/s is more "
                      f"than the {robot.name} turns ({robot.max_angular_velocity:g} rad/s)")
    return out


def _read_bt_navigator(s: Section) -> None:
    s.ignore_all("not used: Galactic's name; Nav2 Humble and later read "
                 "default_nav_to_pose_bt_xml", ("default_bt_xml_filename",))
    for key in ("default_nav_to_pose_bt_xml", "default_nav_through_poses_bt_xml"):
        if not s.has(key):
            continue
        value = str(s.raw(key))
        name = value.replace("\\", "/").rsplit("/", 1)[-1]
        if name in (DEFAULT_TREE, THROUGH_TREE, ""):
            s.use(key, "the kit's navigator is Nav2's default tree")
        else:
            s.ignore(key, f"not supported: the kit's navigator is Nav2's default tree "
                          f"({DEFAULT_TREE}), not {name}")
    for key in ("global_frame", "robot_base_frame"):
        s.ignore_all(NO_EFFECT, (key,))
    s.ignore_all("not supported: the kit ticks its tree at the controller's rate",
                 ("bt_loop_duration",))
    s.ignore_all("no effect: the kit's tree is built in (no plugin libraries to load)",
                 ["plugin_lib_names", *[n for n in s.names()
                                        if n.startswith(("navigators", "navigate_to_pose.",
                                                         "navigate_through_poses."))]])
    s.ignore_all(NO_EFFECT, ("use_sim_time", "odom_topic", "default_server_timeout",
                             "wait_for_service_timeout", "action_server_result_timeout",
                             "enable_groot_monitoring", "groot_zmq_publisher_port",
                             "groot_zmq_server_port", "groot_server_port",
                             "transform_tolerance", "filter_duration", "always_reload_bt_xml",
                             "goal_blackboard_id", "goals_blackboard_id",
                             "path_blackboard_id", "error_code_names",
                             "error_code_name_prefixes", "bond_heartbeat_period",
                             "introspection_mode"))
    s.ignore_all("not a bt_navigator parameter the kit knows")


# ---------------------------------------------------------------------- AMCL

_AMCL_NO_EFFECT = ("use_sim_time", "scan_topic", "map_topic", "global_frame_id",
                   "odom_frame_id", "base_frame_id", "tf_broadcast", "transform_tolerance",
                   "save_pose_rate", "allow_parameter_qos_overrides", "first_map_only",
                   "always_reset_initial_pose", "initialize_at_saved_pose",
                   "saved_pose_filepath", "freespace_downsampling", "map_subscribe_transient_local")
_AMCL_KIT_ONLY = {
    "ess_threshold": "resample only when the effective sample size falls below this share "
                     "of the particles (Nav2 resamples every resample_interval updates)",
    "recovery_reset": "restart the recovery averages after random particles were drawn "
                      "(Nav2's rule)",
    "deskew": "each beam placed where the scanner was at that beam's time (Nav2 takes the "
              "whole scan from the pose at its stamp)",
}


def _read_amcl(s: Section, base: Any) -> Any:
    from kit.localization import AmclParameters

    d = AmclParameters()
    values: dict[str, Any] = {}
    for f in dataclasses.fields(AmclParameters):
        name = f.name
        key = name
        if name.startswith("initial_pose_") and not s.has(name):
            key = "initial_pose." + name[len("initial_pose_"):]
        values[name] = s.get(key, getattr(base, name))
    if values["do_beamskip"]:
        s.report.unuse(s.key("do_beamskip"), "not supported: the kit's AMCL skips no beams")
        values["do_beamskip"] = False
    for name in ("beam_skip_distance", "beam_skip_error_threshold", "beam_skip_threshold"):
        s.report.unuse(s.key(name), "no effect: the kit's AMCL skips no beams (do_beamskip)")
    if _type_name(str(values["robot_model_type"])) not in ("DifferentialMotionModel",
                                                           "differential"):
        s.report.unuse(s.key("robot_model_type"), "not supported: the kit's AMCL has the "
                                                  "differential-drive motion model only")
        values["robot_model_type"] = base.robot_model_type
    # read into the parameters (they are AMCL's), but without effect in the simulator
    for names, reason in ((_AMCL_NO_EFFECT, NO_EFFECT),
                          (["set_initial_pose", *[n for n in s.names()
                                                  if n.startswith("initial_pose")]],
                           "no effect: the scenario starts AMCL at the robot's known start, "
                           "as an /initialpose would"),
                          (("random_seed",), "no effect: each episode seeds AMCL with its own "
                                             "seed")):
        for name in names:
            s.report.unuse(s.key(name), reason)
    s.ignore_all("not an amcl parameter the kit knows")
    amcl = _build(AmclParameters, s.report, s.node, base, **values)
    nav2 = {f.name: getattr(d, f.name) for f in dataclasses.fields(AmclParameters)
            if f.name not in _AMCL_KIT_ONLY and f.name not in _AMCL_NO_EFFECT and
            not f.name.startswith("initial_pose") and f.name not in (
                "set_initial_pose", "random_seed")}
    _kept(s.report, s.key(""), s, amcl, nav2, _AMCL_KIT_ONLY)
    return amcl


# ---------------------------------------------------------------------- costmaps

def _read_costmaps(global_: Section, local: Section, base: NavigationConfig,
                   robot: RobotDescription, nav: dict[str, Any]
                   ) -> tuple[CostmapParams, CostmapParams]:
    out = []
    for s, kit, rolling in ((global_, base.global_costmap, False),
                            (local, base.local_costmap, True)):
        if not s.params:
            s.report.note(f"the file has no {s.node.split('/')[0]}: the kit's own, for the "
                          f"{robot.name}")
            out.append(kit)
            continue
        params = read_costmap(s)
        changes: dict[str, Any] = {}
        if not s.has("footprint") and not s.has("robot_radius"):
            changes["footprint"] = kit.footprint
            s.report.keep(s.key("footprint"), f"the {robot.name}'s polygon from its "
                                              f"description (Nav2's default: robot_radius 0.1)")
        if not s.has("footprint_padding"):
            changes["footprint_padding"] = kit.footprint_padding
            if not _same(kit.footprint_padding, params.footprint_padding):
                s.report.keep(s.key("footprint_padding"), f"{kit.footprint_padding:g} m "
                                                          f"(Nav2's default: 0.01)")
        if rolling != params.rolling_window:
            s.report.unuse(s.key("rolling_window"),
                           f"not supported: the kit's {s.node.split('/')[0]} "
                           f"{'is' if rolling else 'is not'} a rolling window")
            if rolling:
                s.report.note(f"{s.node}: rolling_window is not true: the kit's local costmap "
                              f"rolls with the robot ({params.width:g} × "
                              f"{params.height:g} m)")
            changes["rolling_window"] = rolling
        if rolling:
            for key in ("origin_x", "origin_y"):
                s.report.unuse(s.key(key), "no effect: a rolling window is centred on the "
                                           "robot")
            if s.has("global_frame"):
                s.report.unuse(s.key("global_frame"), "no effect: the kit keeps the local "
                                                      "costmap in the map frame, as its poses")
            changes["global_frame"] = "map"
            nav["local_update_frequency"] = s.get("update_frequency",
                                                  base.navigator.local_update_frequency)
        else:
            s.report.unuse(s.key("update_frequency"), "no effect: the kit updates the global "
                                                      "costmap each time it plans (the default "
                                                      "tree's 1 Hz)")
            if any(layer.__class__.__name__ == "StaticLayerParams" for layer in params.layers):
                for key in ("resolution", "width", "height", "origin_x", "origin_y"):
                    s.report.unuse(s.key(key), "no effect: with a static layer the global "
                                               "costmap takes the map's size, resolution and "
                                               "origin, as in Nav2")
        params = dataclasses.replace(params, **changes)
        padded = pad_footprint(params.footprint if params.footprint is not None
                               else _circle(params.robot_radius), params.footprint_padding)
        robot_reach = footprint_radii(np.asarray(robot.footprint))[1]
        _, reach = footprint_radii(padded)
        if reach + 1e-9 < robot_reach:
            s.report.note(f"{s.node}: the footprint reaches {reach:.3f} m from base_link, the "
                          f"{robot.name}'s {robot_reach:.3f} m: its corners can touch what "
                          f"the costmap says is clear")
        inflation = next((layer for layer in params.layers
                          if layer.__class__.__name__ == "InflationLayerParams"), None)
        if inflation is not None and inflation.inflation_radius < reach:  # type: ignore[union-attr]
            s.report.note(f"{s.node}: inflation_radius {inflation.inflation_radius:g} m is "  # type: ignore[union-attr]
                          f"less than the footprint's circumscribed radius {reach:.3f} m (Nav2 "
                          f"warns of it too): the controllers check every pose's outline")
        out.append(params)
    return out[0], out[1]


def _circle(radius: float) -> Any:
    from kit.planning import footprint_from_radius

    return footprint_from_radius(radius)


# ---------------------------------------------------------------------- the whole file

def load_nav2_params(source: str | Path | Mapping[str, Any],
                     robot: RobotDescription | str, *, controller: str | None = None,
                     namespace: str | None = None, amcl: Any = None,
                     params: NavigatorParameters | None = None) -> NavigationConfig:
    """The navigator's configuration from a Nav2 parameter file, as it is.

    Parameters
    ----------
    source
        The file (``nav2_params.yaml``), or its parsed mapping.
    robot
        The robot (``kit.robots.load("uiabot")`` or its name): what the file does not set
        (its footprint, its speeds) comes from the kit's configuration for it
        (:meth:`NavigationConfig.for_robot`).
    controller
        ``"rpp"`` or ``"dwb"``: the controller to run when the file's ``FollowPath`` is not
        one the kit has (an error when the file's is the other one).
    namespace
        The robot's namespace when the file configures several robots.
    amcl
        The kit's AMCL parameters for what the file's ``amcl`` does not set (default:
        ``AmclParameters()``, Nav2's defaults).
    params
        The kit's navigator parameters the configuration starts from.

    Returns
    -------
    NavigationConfig
        With ``amcl`` (``None`` when the file has no ``amcl``) and ``report``
        (:class:`~kit.nav2params.ParameterReport`: used, not used, kept; ``report.lines()``
        prints it).

    Raises
    ------
    ValueError
        The file cannot be read, or values that cannot be used (all of them named in one
        message).
    """
    from kit import robots as robots_module

    description = robots_module.load(robot) if isinstance(robot, str) else robot
    if controller is not None and controller not in ("rpp", "dwb"):
        raise ValueError(f"controller is 'rpp' or 'dwb'; got {controller!r}")
    nav2 = Nav2File(source, namespace)
    report = nav2.report()
    base = NavigationConfig.for_robot(description, controller or "rpp", params)

    def section(name: str, *alternatives: str) -> Section:
        node, values, origin = nav2.node(name, *alternatives)
        return Section(report, node, values, origin=origin)

    nav_values: dict[str, Any] = {}
    report.errors.extend(filter(None, map(nav2.misnested_costmap,      # raised below, with
                                          ("global_costmap", "local_costmap"))))  # the rest
    global_costmap, local_costmap = _read_costmaps(
        section("global_costmap/global_costmap"), section("local_costmap/local_costmap"), base,
        description, nav_values)
    local_extent = max(local_costmap.width, local_costmap.height) / 2.0
    server = section("controller_server")
    values, name, rpp, dwb = _read_controller_server(server, base, description, controller,
                                                     local_extent)
    nav_values.update(values)
    planner = _read_planner(section("planner_server"), base.planner)
    behavior = section("behavior_server")
    behaviors = _read_behaviors(behavior, base.behaviors, description) \
        if behavior.params else base.behaviors
    _read_bt_navigator(section("bt_navigator"))
    amcl_section = section("amcl")
    amcl_params = None
    if amcl_section.params:
        from kit.localization import AmclParameters

        amcl_params = _read_amcl(amcl_section, amcl if amcl is not None else AmclParameters())
    _report_other_nodes(nav2, report)
    report.raise_errors()
    navigator = _build(NavigatorParameters, report, "navigator", base.navigator,
                       **{**dataclasses.asdict(base.navigator), **nav_values})
    report.raise_errors()
    return NavigationConfig(navigator, name, rpp, dwb, planner, global_costmap, local_costmap,
                            behaviors, amcl_params, report)


def _report_other_nodes(nav2: Nav2File, report: ParameterReport) -> None:
    """Every key no reader accounted for: a node the kit does not mirror, another robot's
    namespace, a wildcard no mirrored node reads, or an unknown parameter of a mirrored
    node."""
    mirrored = {tuple(name.split("/")) for name in MIRRORED} | {("local_costmap",),
                                                                ("global_costmap",)}
    namespaces: set[tuple[str, ...]] = set()
    for name in MIRRORED:
        namespaces.update(nav2.namespaces(name))
    for entry in nav2.entries:
        keys = [f"{entry.name}:{k}" for k in entry.params]
        pending = [k for k in keys if k not in report.used and k not in report.ignored]
        if not pending:
            continue
        pattern = entry.pattern
        rest = pattern
        while rest and rest[0] in ("*", "**"):
            rest = rest[1:]                     # /**/velocity_smoother: a node in any namespace
        if not rest or any(t in ("*", "**") for t in rest):
            reason = "no effect: set for many nodes by a wildcard; no node the kit mirrors " \
                     "reads it"
        else:
            reason = _node_reason(rest, mirrored, namespaces,
                                  nav2.namespace if rest == pattern else None)
        for key in pending:
            report.ignore(key, reason)


def _node_reason(pattern: tuple[str, ...], mirrored: set[tuple[str, ...]],
                 namespaces: set[tuple[str, ...]], chosen: list[str] | None) -> str:
    for node in sorted(mirrored, key=len, reverse=True):
        if pattern[len(pattern) - len(node):] == node:
            ns = pattern[:len(pattern) - len(node)]
            if chosen is not None and list(ns) != list(chosen):
                return f"not used: for the namespace /{'/'.join(ns)}, not /{'/'.join(chosen)}"
            return f"not a parameter of {'/'.join(node)} the kit knows"
    name = pattern[-1]
    for prefix, why in OTHER_NODES.items():
        if name == prefix or name.startswith(prefix):
            return f"not used: the kit does not mirror {name} ({why})"
    if name.endswith(("_rclcpp_node", "_client")):
        return f"not used: {name} is a helper node of Nav2's older releases"
    return f"not used: the kit does not mirror the node {name}"
