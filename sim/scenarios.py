"""Navigation scenarios: goal sequences in the aisle and the office among walking people,
seeded episodes, and the metrics navigation papers report.

One episode: the robot starts at the route's start, a :class:`NavigationNode` (the kit's
:class:`~kit.navigation.Navigator` with a localization source) is given the route's goals one
after the other (``NavigateToPose`` each), and per goal the runner gathers

``episode, goal, reached, seconds, path_length, shortest_length, collisions_static,
collisions_people, min_person_distance, reason``

— the time from the goal being given to the navigator reporting it reached, the path the
robot really drove, the shortest collision-free path for its footprint (any-angle, on the
world's true walls, glass included), the contacts the simulator counted with walls, boxes
and glass and with people, and the smallest gap between the robot's footprint and a person's
body (0 at contact). A goal not reached within its time limit, or given up by the navigator,
ends with ``reached`` 0 and the reason; the next goal is then given from where the robot is.

Localization, as the Uiabot paper's tests: ``truth`` (the simulator's pose: navigation alone
measured), ``amcl`` (the kit's particle filter on the map a lidar sees — no glass — from the
known start, with wheel odometry), ``slam`` (the kit's SLAM building the map while the robot
navigates on it, its ``map → odom`` with the odometry).

``python -m sim navigate --world office|aisle --robot uiabot|igv --episodes N --seed S
[--localization truth|amcl|slam] [--controller dwb|rpp] [--route tour|glass|waypoints]
[--people N] [--keepout] [--params nav2_params.yaml [--namespace NS]]
--out FILE.csv``: ``--params`` configures the navigator (and AMCL) from a Nav2 parameter file
(:func:`load_params`).
"""

from __future__ import annotations

import csv
import dataclasses
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from kit import geometry, msgs, perception
from kit.localization import Amcl, AmclParameters
from kit.mapping import OccupancyGridMap
from kit.navigation import (
    RUNNING,
    SUCCEEDED,
    Controller,
    NavigationConfig,
    NavigationCostmap,
    Navigator,
    arc_poses,
    load_nav2_params,
)
from kit.planning import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    Costmap,
    PlanningError,
    ThetaStarPlanner,
    compute_path_to_pose,
    path_length,
    points_to_path,
)
from kit.planning import path_to_points as _points
from kit.progress import progress
from kit.robots import RobotDescription
from kit.slam import Slam, SlamConfig
from kit.tf import RigidTransform
from sim.runner import Node, Published, Runner, WheelOdometryNode, odometry_pose
from sim.simulation import Simulation
from sim.world import World, load_world

__all__ = ["AMCL", "COLUMNS", "DEFAULT_ROUTES", "LOCALIZATIONS", "ROUTES",
           "AmclLocalization", "GoalResult", "NavigationNode", "Route", "SlamLocalization",
           "TruthLocalization", "default_route", "episode", "load_params",
           "localization_source", "navigate", "on_canvas", "run_episode", "unknown_canvas",
           "write_table"]

FloatArray = NDArray[np.float64]
HALF_PI = math.pi / 2

LOCALIZATIONS = ("truth", "amcl", "slam")
"""The localization sources of an episode."""

COLUMNS = ("episode", "goal", "reached", "seconds", "path_length", "shortest_length",
           "collisions_static", "collisions_people", "min_person_distance", "reason")
"""The table's columns, in order (the header's first line)."""


@dataclass(frozen=True)
class Route:
    """A world, a start pose and goals ``(x, y, yaw)`` visited in order, and its people."""

    world: str
    start: tuple[float, float, float]
    goals: tuple[tuple[float, float, float], ...]
    people: int
    description: str


ROUTES: dict[tuple[str, str], Route] = {
    ("office", "tour"): Route(
        "office", (1.0, 6.0, 0.0),
        ((15.0, 9.5, HALF_PI), (9.0, 2.5, -HALF_PI), (3.0, 9.5, HALF_PI),
         (17.5, 2.5, 0.0), (1.5, 6.0, math.pi)),
        5, "the corridor, the north-east office, the middle south room, the north-west "
           "office, the south-east room and back, among five people walking the corridor "
           "both ways and into the rooms"),
    ("office", "glass"): Route(
        "office", (6.0, 9.5, 0.0), ((15.0, 9.5, 0.0),), 0,
        "from the north-west office to the north-east one: straight through the glass "
        "meeting room on a map made by a lidar, round by the corridor with a keep-out mask"),
    ("aisle", "tour"): Route(
        "aisle", (0.75, 0.75, 0.0), ((29.25, 30.5, HALF_PI), (1.0, 0.75, math.pi)), 4,
        "the 60 m aisle to its far end past the static boxes and back, among four people "
        "walking it both ways"),
    ("aisle", "waypoints"): Route(
        "aisle", (1.25, 0.75, 0.0), ((28.0, 0.75, 0.0), (29.25, 30.5, HALF_PI)), 4,
        "the Uiabot paper's test: a waypoint at the end of the aisle's first section, the "
        "next at the end of the second, among four people walking it both ways"),
}
"""The scenarios by (world, route)."""

DEFAULT_ROUTES: dict[tuple[str, str], str] = {("aisle", "igv"): "waypoints"}
"""A world's route for a robot when none is named (else ``tour``). The IGV cannot do the
aisle tour: its ``base_link`` is the front axle, 0.75 m ahead of its rear corners, so it
cannot turn round in the 1.5 m aisle (turning in place sweeps a disc 1.72 m across); it
drives the paper's one-way test instead."""


def default_route(world: str, robot: str | RobotDescription) -> str:
    """The route a world's episodes take for a robot (a name or a description) when none is
    named."""
    name = robot if isinstance(robot, str) else robot.name
    return DEFAULT_ROUTES.get((world, name), "tour")


@dataclass
class GoalResult:
    """One row of the table."""

    episode: int
    goal: int
    reached: bool
    seconds: float
    path_length: float
    shortest_length: float
    collisions_static: int
    collisions_people: int
    min_person_distance: float
    reason: str = ""

    def row(self) -> list[Any]:
        return [self.episode, self.goal, int(self.reached), f"{self.seconds:.2f}",
                f"{self.path_length:.3f}", f"{self.shortest_length:.3f}",
                self.collisions_static, self.collisions_people,
                f"{self.min_person_distance:.3f}", self.reason]


Observers = Callable[[int, "NavigationNode", Simulation, msgs.OccupancyGrid], Sequence[Node]]
"""``(episode index, navigation node, simulation, map) -> nodes`` run beside an episode."""


# ---------------------------------------------------------------- localization sources

class TruthLocalization:
    """The simulator's own pose (no estimation error: navigation alone is measured)."""

    name = "truth"

    def start(self, sim: Simulation, robot: int, odom_pose: FloatArray) -> None:
        self._sim, self._robot = sim, robot

    def on_scan(self, scan: msgs.LaserScan, odom_pose: FloatArray,
                velocity: ArrayLike = (0.0, 0.0), time: float | None = None) -> None:
        pass

    def pose(self, odom_pose: FloatArray) -> FloatArray:
        return self._sim.ground_truth(self._robot).pose


AMCL = AmclParameters(base_frame_id="base_link", laser_max_range=12.0, max_particles=2000,
                      min_particles=500, laser_model_type="likelihood_field_prob",
                      sigma_hit=0.3, update_min_d=0.1, update_min_a=0.2)
"""The scenarios' AMCL: Nav2's defaults but for the simulated lidar's 12 m range, the
likelihood field with the probabilistic beams' normalisation, σ 0.3 m and an update every
0.1 m (a parameter file's ``amcl`` sets what it names; the rest stays this)."""


class AmclLocalization:
    """The kit's AMCL on ``grid`` from the known start, with the wheel odometry."""

    name = "amcl"

    def __init__(self, grid: msgs.OccupancyGrid, seed: int,
                 params: AmclParameters | None = None) -> None:
        self.grid = grid
        self.params = params or AMCL
        self.seed = seed

    def start(self, sim: Simulation, robot: int, odom_pose: FloatArray) -> None:
        self.amcl = Amcl(self.grid, self.params, seed=self.seed)
        self.amcl.initialize(sim.ground_truth(robot).pose,
                             np.diag([0.05 ** 2, 0.05 ** 2, math.radians(3) ** 2]))
        self.mount = _laser_mount(sim.description(robot))
        self.map_to_odom = geometry.compose(sim.ground_truth(robot).pose,
                                            geometry.inverse(odom_pose))

    def on_scan(self, scan: msgs.LaserScan, odom_pose: FloatArray,
                velocity: ArrayLike = (0.0, 0.0), time: float | None = None) -> None:
        if self.amcl.process(scan, odom_pose, self.mount) and self.amcl.map_to_odom is not None:
            self.map_to_odom = self.amcl.map_to_odom

    def pose(self, odom_pose: FloatArray) -> FloatArray:
        return geometry.compose(self.map_to_odom, odom_pose)


class SlamLocalization:
    """The kit's SLAM mapping while the robot navigates (the Uiabot paper's fourth test):
    each scan goes to :class:`kit.slam.Slam` with the wheel odometry (de-skewed along the
    current velocity); its pose gives ``map → odom``, and every ``map_update_interval``
    seconds (SLAM Toolbox's default: 5 s) its map is published to the navigator, drawn on
    ``canvas`` — the global costmap's fixed extent — with unknown space left unknown (which
    the planner may cross, as Nav2's ``allow_unknown``). The map frame is the start pose's
    frame in the world's coordinates, so that goals given in the world mean the same.

    People are not part of the building, and a scan matcher cannot tell them from walls: a
    person walking beside the robot drags the match along. So before a scan reaches SLAM,
    its returns that end in space the last published map has seen free — farther than
    ``dynamic_margin`` from anything not free — are dropped (set to NaN, "no reading") as
    something that moves; returns in unknown space, and near walls, are kept.

    Every scan is matched (``minimum_travel_distance`` and ``_heading`` 0; SLAM Toolbox's
    0.5 m and 0.5 rad skip the scans in between): the office's corridor has an oil patch on
    which the wheels slip, and the wheel odometry alone turned the estimate by tens of
    degrees between two matched scans there."""

    name = "slam"

    def __init__(self, canvas: msgs.OccupancyGrid, map_update_interval: float = 5.0,
                 config: SlamConfig | None = None, minimum_travel_distance: float = 0.0,
                 minimum_travel_heading: float = 0.0, dynamic_margin: float = 0.15) -> None:
        self.canvas = canvas
        self.dynamic_margin = float(dynamic_margin)
        self.map_update_interval = float(map_update_interval)
        self.config = config
        self.minimum_travel_distance = float(minimum_travel_distance)
        self.minimum_travel_heading = float(minimum_travel_heading)

    def start(self, sim: Simulation, robot: int, odom_pose: FloatArray) -> None:
        self.mount = np.array(sim.description(robot).sensor_mount("lidar"), dtype=float)
        self.slam = Slam(tuple(self.mount), self.config)
        self.seen_free: NDArray[np.bool_] | None = None  # canvas cells far inside free space
        self.dropped = 0       # returns dropped as moving things
        self.start_offset = geometry.compose(sim.ground_truth(robot).pose,
                                             geometry.inverse(odom_pose))
        self.map_to_odom = self.start_offset
        self.next_map = -math.inf
        self.maps = 0
        self.last_odom: FloatArray | None = None

    def on_scan(self, scan: msgs.LaserScan, odom_pose: FloatArray,
                velocity: ArrayLike = (0.0, 0.0), time: float | None = None) -> None:
        if self.last_odom is not None:
            # as SLAM Toolbox: a scan is processed once the odometry has moved enough since
            # the last one (minimum_travel_distance / _heading); in between, map → odom holds
            step = geometry.relative(self.last_odom, odom_pose)
            if math.hypot(step[0], step[1]) < self.minimum_travel_distance and \
                    abs(step[2]) < self.minimum_travel_heading:
                return
        self.last_odom = np.asarray(odom_pose, dtype=float).copy()
        scan = self._without_moving_things(scan, self.pose(odom_pose))
        now = scan.header.stamp.to_sec() if time is None else float(time)
        v, w = (float(x) for x in np.asarray(velocity, dtype=float)[:2])
        motion = arc_poses(np.zeros(3), v, w, perception.beam_times(scan) - now)
        odom_in_map = geometry.compose(self.start_offset, odom_pose)
        pose = self.slam.add_scan(scan, odom_in_map, now, motion)
        self.map_to_odom = geometry.compose(pose, geometry.inverse(odom_pose))

    def pose(self, odom_pose: FloatArray) -> FloatArray:
        return geometry.compose(self.map_to_odom, odom_pose)

    def _without_moving_things(self, scan: msgs.LaserScan, pose: FloatArray) -> msgs.LaserScan:
        if self.seen_free is None:
            return scan
        kept, dropped = drop_returns_in(scan, geometry.compose(pose, self.mount),
                                        self.seen_free, self.canvas.info)
        self.dropped += dropped
        return kept

    def new_map(self, time: float) -> msgs.OccupancyGrid | None:
        """SLAM's map on the canvas when one is due, else ``None``."""
        if time < self.next_map or not self.slam.nodes:
            return None
        self.next_map = time + self.map_update_interval
        self.maps += 1
        grid = on_canvas(self.slam.occupancy_map(self.canvas.info.resolution), self.canvas)
        self.seen_free = seen_free(grid, self.dynamic_margin)
        return grid


def seen_free(grid: msgs.OccupancyGrid, margin: float) -> NDArray[np.bool_]:
    """The cells of ``grid`` (rows from its origin) that are free and farther than ``margin``
    [m] from every cell that is not (occupied or unknown)."""
    info = grid.info
    free = np.asarray(grid.data).reshape(info.height, info.width) == 0
    return np.asarray(ndimage.distance_transform_edt(free) * info.resolution > margin)


def drop_returns_in(scan: msgs.LaserScan, laser_pose: ArrayLike, mask: NDArray[np.bool_],
                    info: msgs.MapMetaData) -> tuple[msgs.LaserScan, int]:
    """``scan`` with the returns that end in a ``mask`` cell set to NaN (no reading), the
    scanner at ``laser_pose`` in the map; and how many were dropped."""
    valid = np.flatnonzero(perception.valid_returns(scan))
    ends = perception.scan_to_points(scan, laser_pose)
    col = np.floor((ends[:, 0] - info.origin.position.x) / info.resolution).astype(np.int64)
    row = np.floor((ends[:, 1] - info.origin.position.y) / info.resolution).astype(np.int64)
    inside = (row >= 0) & (row < info.height) & (col >= 0) & (col < info.width)
    moving = np.zeros(len(ends), dtype=bool)
    moving[inside] = mask[row[inside], col[inside]]
    if not moving.any():
        return scan, 0
    r = np.asarray(scan.ranges, dtype=np.float32).copy()
    r[valid[moving]] = np.nan
    return dataclasses.replace(scan, ranges=r), int(moving.sum())


def on_canvas(grid: OccupancyGridMap, canvas: msgs.OccupancyGrid) -> msgs.OccupancyGrid:
    """``grid``'s trinary map copied into ``canvas``'s extent (same resolution, cells aligned;
    unknown elsewhere, and what lies outside the canvas dropped)."""
    info = canvas.info
    res = float(info.resolution)
    out = np.full((info.height, info.width), -1, dtype=np.int8)
    data = grid.trinary()
    c0 = round((float(grid.origin[0]) - info.origin.position.x) / res)
    r0 = round((float(grid.origin[1]) - info.origin.position.y) / res)
    rows, cols = data.shape
    rs, re = max(r0, 0), min(r0 + rows, info.height)
    cs, ce = max(c0, 0), min(c0 + cols, info.width)
    if rs < re and cs < ce:
        out[rs:re, cs:ce] = data[rs - r0:re - r0, cs - c0:ce - c0]
    return msgs.OccupancyGrid(canvas.header, info, out.ravel())


def unknown_canvas(canvas: msgs.OccupancyGrid) -> msgs.OccupancyGrid:
    """``canvas``'s extent with every cell unknown (what SLAM knows before its first scan)."""
    return msgs.OccupancyGrid(canvas.header, canvas.info,
                              np.full(len(canvas.data), -1, dtype=np.int8))


def _laser_mount(robot: RobotDescription) -> RigidTransform:
    return RigidTransform.from_pose2d(robot.sensor_mount("lidar"))


# ---------------------------------------------------------------- the node

class NavigationNode(Node):
    """The navigation stack as one node: localization, costmaps, planner, controller,
    recoveries; it drives the route's goals in turn and gathers each goal's metrics.

    Subscribes ``/scan`` and ``/odom``; publishes ``/cmd_vel`` at the controller's 20 Hz and
    ``/plan`` (``nav_msgs/Path``) when it replans and ``map → odom`` on ``/tf`` with every
    scan (from the localization).
    """

    subscriptions = ("/scan", "/odom")
    rate = 20.0

    def __init__(self, navigator: Navigator, localization: Any, goals: Sequence[ArrayLike],
                 time_limits: Sequence[float], episode: int = 0,
                 shortest: Sequence[float] = ()) -> None:
        self.navigator = navigator
        self.rate = float(navigator.params.controller_frequency)
        self.localization = localization
        self.goals = [geometry.check_pose(g, "goal") for g in goals]
        self.time_limits = list(time_limits)
        self.shortest = list(shortest)
        self.episode = episode
        self.results: list[GoalResult] = []
        self.trail: list[FloatArray] = []
        self.pose_errors: list[float] = []
        """Distance [m] between the localization's pose and the truth, every tick."""
        self.done = False

    def start(self, sim: Simulation, robot: int) -> Published:
        self.sim, self.robot = sim, robot
        self.mount_pose = np.array(sim.description(robot).sensor_mount("lidar"), dtype=float)
        self.footprint = np.asarray(sim.description(robot).footprint, dtype=float)
        self.reach = float(np.max(np.hypot(self.footprint[:, 0], self.footprint[:, 1])))
        self.odom_pose = sim.ground_truth(robot).pose.copy()
        self.velocity = np.zeros(2)
        self.localization.start(sim, robot, self.odom_pose)
        self.index = -1
        self._next_goal(sim.time)
        return ()

    def _next_goal(self, time: float) -> None:
        self.index += 1
        if self.index >= len(self.goals):
            self.done = True
            return
        self.goal_start = time
        self.collisions_before = len(self.sim.collisions)
        self.distance = 0.0
        self.min_gap = math.inf
        self.last_xy = self.sim.ground_truth(self.robot).pose[:2].copy()
        self.navigator.navigate_to_pose(self.goals[self.index], time)

    def on_message(self, topic: str, message: Any, time: float) -> Published:
        if topic == "/odom":
            self.odom_pose = odometry_pose(message)
            self.velocity = np.array([message.twist.twist.linear.x,
                                      message.twist.twist.angular.z])
            return ()
        self.localization.on_scan(message, self.odom_pose, self.velocity, time)
        update = getattr(self.localization, "new_map", None)
        grid = update(time) if update is not None else None
        if grid is not None:
            self.navigator.update_map(grid)
        base = self.localization.pose(self.odom_pose)
        points, sensor = deskewed_points(message, base, self.velocity, self.mount_pose, time)
        self.navigator.on_points(points, sensor, base)
        map_to_odom = geometry.compose(base, geometry.inverse(self.odom_pose))
        tf = msgs.TransformStamped(msgs.Header(msgs.Time.from_sec(time), "map"), "odom",
                                   RigidTransform.from_pose2d(map_to_odom).to_msg())
        return [("/tf", msgs.TFMessage((tf,)))]

    def on_tick(self, time: float) -> Published:
        if self.done:
            return [("/cmd_vel", msgs.Twist())]
        pose = self.localization.pose(self.odom_pose)
        self._measure(pose)
        before = len(self.navigator.events)
        v, w = self.navigator.tick(time, pose, self.velocity)
        out: list[tuple[str, Any]] = []
        if any(e.kind == "plan" for e in self.navigator.events[before:]):
            out.append(("/plan", points_to_path(self.navigator.path, "map",
                                                msgs.Time.from_sec(time))))
        status = self.navigator.status
        limit = self.time_limits[self.index]
        if status != RUNNING or time - self.goal_start > limit:
            reason = "" if status == SUCCEEDED else (self.navigator.reason if status != RUNNING
                                                     else f"time limit ({limit:.0f} s)")
            self._finish(time, status == SUCCEEDED, reason)
            v, w = 0.0, 0.0
        out.append(("/cmd_vel", msgs.Twist(msgs.Vector3(v, 0.0, 0.0), msgs.Vector3(0, 0, w))))
        return out

    def _measure(self, estimate: FloatArray) -> None:
        truth = self.sim.ground_truth(self.robot).pose
        self.trail.append(truth.copy())
        self.pose_errors.append(float(np.hypot(*(estimate[:2] - truth[:2]))))
        self.distance += float(np.hypot(*(truth[:2] - self.last_xy)))
        self.last_xy = truth[:2].copy()
        people = self.sim.people_positions()
        if len(people):
            # nobody nearer than the gap so far can lower it: skip the polygon then
            near = np.hypot(*(people - truth[:2]).T) - self.reach - 0.25 < self.min_gap
            if near.any():
                polygon = geometry.transform_points(truth, self.footprint)
                self.min_gap = min(self.min_gap, float(np.min(
                    polygon_distance(polygon, people[near]))) - 0.25)

    def _finish(self, time: float, reached: bool, reason: str) -> None:
        new = [c for c in self.sim.collisions[self.collisions_before:] if c.robot == self.robot]
        self.results.append(GoalResult(
            self.episode, self.index + 1, reached, time - self.goal_start, self.distance,
            self.shortest[self.index] if self.index < len(self.shortest) else math.nan,
            sum(c.other == "wall" for c in new), sum(c.other == "person" for c in new),
            max(self.min_gap, 0.0) if math.isfinite(self.min_gap) else math.nan, reason))
        self._next_goal(time)


def deskewed_points(scan: msgs.LaserScan, pose: FloatArray, velocity: ArrayLike,
                    mount: FloatArray, now: float) -> tuple[FloatArray, FloatArray]:
    """The scan's valid returns in the map frame, each from where the scanner was when its
    beam was taken — the robot's ``pose`` at ``now`` driven back along its current
    ``velocity`` (v, ω) to the beam's time — and the scanner's position now."""
    valid = perception.valid_returns(scan)
    r = np.asarray(scan.ranges, dtype=float)[valid]
    angles = perception.beam_angles(scan)[valid]
    times = perception.beam_times(scan)[valid] - now
    v, w = (float(x) for x in np.asarray(velocity, dtype=float)[:2])
    base = arc_poses(pose, v, w, times)
    c, s = np.cos(base[:, 2]), np.sin(base[:, 2])
    lx = base[:, 0] + c * mount[0] - s * mount[1]
    ly = base[:, 1] + s * mount[0] + c * mount[1]
    heading = base[:, 2] + mount[2] + angles
    points = np.column_stack([lx + r * np.cos(heading), ly + r * np.sin(heading)])
    sensor = geometry.compose(pose, mount)[:2]
    return points, sensor


def polygon_distance(polygon: ArrayLike, points: ArrayLike) -> FloatArray:
    """Distance [m] from each of ``points`` (P, 2) to the polygon (N, 2) — 0 inside it."""
    poly = np.asarray(polygon, dtype=float)
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    ap = pts[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("pnk,nk->pn", ap, ab) / np.einsum("nk,nk->n", ab, ab), 0.0, 1.0)
    closest = a[None] + t[..., None] * ab[None]
    d = np.hypot(*(pts[:, None, :] - closest).transpose(2, 0, 1)).min(axis=1)
    # inside: an odd number of edge crossings of a ray to +x
    y0, y1 = a[:, 1][None], b[:, 1][None]
    px, py = pts[:, 0:1], pts[:, 1:2]
    crosses = ((y0 > py) != (y1 > py)) & (
        px < a[:, 0][None] + (py - y0) * (b[:, 0] - a[:, 0])[None] / np.where(
            y1 == y0, 1.0, y1 - y0))
    inside = crosses.sum(axis=1) % 2 == 1
    return np.where(inside, 0.0, d)


# ---------------------------------------------------------------- episodes

@dataclass
class EpisodeSetup:
    """What every episode of a scenario shares: the maps, the shortest paths."""

    route: Route
    robot: str | RobotDescription
    world: World
    nav_grid: msgs.OccupancyGrid
    keepout: msgs.OccupancyGrid | None
    shortest: list[float] = field(default_factory=list)


def setup(world: str = "office", robot: str | RobotDescription = "uiabot",
          route: str | None = None,
          keepout: bool | None = None) -> EpisodeSetup:
    """The scenario's maps (the lidar's: no glass; the glass as a keep-out mask when asked —
    by default for every route but ``glass``, which shows what happens without) and the
    shortest path of every goal. No route: :func:`default_route`."""
    route = default_route(world, robot) if route is None else route
    key = (world, route)
    if key not in ROUTES:
        raise ValueError(f"no route {route!r} in world {world!r}; the scenarios are "
                         f"{sorted(ROUTES)}")
    r = ROUTES[key]
    w = load_world(r.world)
    if keepout is None:
        keepout = route != "glass" and bool(np.any(w.segment_glass))
    s = EpisodeSetup(r, robot, w, w.occupancy_grid(0.05, layer="lidar"),
                     w.occupancy_grid(0.05, layer="glass") if keepout else None)
    s.shortest = shortest_lengths(w, robot, r)
    return s


def shortest_lengths(world: World, robot: str | RobotDescription, route: Route) -> list[float]:
    """Any-angle (Theta*) shortest collision-free length [m] of each leg of the route on the
    world's true walls (glass included), for the robot's footprint."""
    from kit.robots import load as load_robot

    d = robot if isinstance(robot, RobotDescription) else load_robot(robot)
    inflated = NavigationCostmap(world.occupancy_grid(0.05, layer="all"),
                                 d.footprint).costmap()
    # where the footprint's inscribed circle fits, free; elsewhere lethal: pure geometry
    costmap = Costmap(np.where(inflated.costs >= INSCRIBED_INFLATED_OBSTACLE,
                               LETHAL_OBSTACLE, FREE_SPACE).astype(np.uint8),
                      inflated.resolution, inflated.origin)
    out = []
    poses = [route.start, *route.goals]
    for a, b in itertools.pairwise(poses):
        try:
            result = compute_path_to_pose(a, b, costmap, planner=ThetaStarPlanner())
            out.append(path_length(_points(result.path)) if result.ok else math.nan)
        except PlanningError:
            out.append(math.nan)
    return out


def localization_source(s: EpisodeSetup, localization: str, seed: int,
                        amcl: AmclParameters | None = None) -> Any:
    """A fresh localization source by name (one of :data:`LOCALIZATIONS`); ``amcl``: AMCL's
    parameters (default :data:`AMCL`)."""
    if localization == "truth":
        return TruthLocalization()
    if localization == "amcl":
        return AmclLocalization(s.nav_grid, seed, amcl)
    if localization == "slam":
        return SlamLocalization(s.nav_grid)
    raise ValueError(f"localization is one of {', '.join(LOCALIZATIONS)}; got "
                     f"{localization!r}")


def run_episode(s: EpisodeSetup, index: int, seed: int, localization: Any,
                controller: str | Controller = "rpp", config: NavigationConfig | None = None,
                progress_bar: str | None = None,
                observers: Observers | None = None) -> NavigationNode:
    """One seeded episode with a localization source; the node (its ``results``, its
    ``pose_errors``, its ``trail``). With SLAM the navigator starts from unknown space.
    ``controller``: ``"rpp"``, ``"dwb"`` or a controller object (e.g. the kit's
    controllers with a student's functions in them, Lab 10); ``config``: the navigator's
    configuration (:func:`load_params`), else the kit's with ``controller``;
    ``progress_bar`` names a bar over the episode's simulated time
    (:func:`kit.progress.progress`); ``observers(index, node, sim, map)`` gives nodes that
    run beside it (a bag, a live view)."""
    route = s.route
    sim = Simulation(world=s.world, robot=s.robot, seed=seed, people=route.people,
                     start=route.start)
    d = sim.description()
    grid = unknown_canvas(s.nav_grid) if isinstance(localization, SlamLocalization) \
        else s.nav_grid
    nav = Navigator(grid, d, controller=controller if config is None else None,
                    keepout=s.keepout, config=config)
    cruise = d.cruise_velocity
    limits = [30.0 + 4.0 * (x if math.isfinite(x) else 30.0) / cruise for x in s.shortest]
    node = NavigationNode(nav, localization, route.goals, limits, index, s.shortest)
    extra = list(observers(index, node, sim, s.nav_grid)) if observers is not None else []
    runner = Runner(sim, [WheelOdometryNode(), node, *extra], record_rate=1.0)
    runner.run(sum(limits) + 1.0, until=lambda r: node.done, progress_bar=progress_bar)
    return node


def episode(s: EpisodeSetup, index: int, seed: int, localization: str = "truth",
            controller: str | Controller = "rpp", config: NavigationConfig | None = None,
            progress_bar: str | None = None,
            observers: Observers | None = None) -> list[GoalResult]:
    """One seeded episode; the route's rows."""
    amcl = config.amcl if config is not None else None
    return run_episode(s, index, seed, localization_source(s, localization, seed, amcl),
                       controller, config, progress_bar, observers).results


def load_params(path: str | Path, robot: str | RobotDescription,
                controller: str | None = None,
                namespace: str | None = None) -> NavigationConfig:
    """A Nav2 parameter file as the navigator's configuration for ``robot`` (a name or a
    description: :func:`kit.navigation.load_nav2_params`), AMCL's unset parameters the
    scenarios' (:data:`AMCL`); its ``report`` says what became of each key."""
    from kit.robots import load as load_robot

    description = robot if isinstance(robot, RobotDescription) else load_robot(robot)
    return load_nav2_params(path, description, controller=controller,
                            namespace=namespace, amcl=AMCL)


def navigate(world: str = "office", robot: str | RobotDescription = "uiabot", episodes: int = 20,
             seed: int = 0,
             localization: str = "truth", controller: str = "rpp", route: str | None = None,
             keepout: bool | None = None, bar: bool = True,
             people: int | None = None, config: NavigationConfig | None = None,
             observers: Observers | None = None) -> list[GoalResult]:
    """Seeded episodes ``seed, seed + 1, …``; every goal's row. ``people``: how many walk
    (default: the route's); ``config``: the navigator's configuration (from a Nav2 parameter
    file: :func:`load_params`; its controller then drives); ``observers``: see
    :func:`run_episode`."""
    if episodes < 1:
        raise ValueError(f"episodes must be at least 1; got {episodes}")
    if people is not None and (isinstance(people, bool) or not isinstance(people, int)
                               or people < 0):
        raise ValueError(f"people must be a whole number of at least 0; got {people!r}")
    if localization not in LOCALIZATIONS:
        raise ValueError(f"localization is one of {', '.join(LOCALIZATIONS)}; got "
                         f"{localization!r}")
    if controller not in ("rpp", "dwb"):
        raise ValueError(f"controller is 'rpp' or 'dwb'; got {controller!r}")
    s = setup(world, robot, route, keepout)
    if people is not None:
        s.route = dataclasses.replace(s.route, people=people)
    rows: list[GoalResult] = []
    indices = range(episodes)
    for i in progress(indices, desc=f"{world} episodes", total=episodes) if bar else indices:
        rows.extend(episode(s, i, seed + i, localization, controller, config,
                            observers=observers))
    return rows


def write_table(rows: Sequence[GoalResult], path: str | Path) -> Path:
    """The rows as CSV, header first."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(COLUMNS)
        writer.writerows(r.row() for r in rows)
    return out


def summary(rows: Sequence[GoalResult], cruise: float) -> dict[str, float]:
    """The issue's figures: share of goals reached, of episodes without a collision with a
    person, static collisions, and the median of time / (shortest / cruise)."""
    episodes = sorted({r.episode for r in rows})
    clean = [e for e in episodes if not any(r.collisions_people for r in rows
                                            if r.episode == e)]
    ratios = [r.seconds / (r.shortest_length / cruise) for r in rows
              if r.reached and r.shortest_length > 0]
    gaps = [r.min_person_distance for r in rows if math.isfinite(r.min_person_distance)]
    return {"goals": len(rows), "reached": float(np.mean([r.reached for r in rows])),
            "episodes": len(episodes),
            "episodes_without_person_collision": len(clean) / max(1, len(episodes)),
            "collisions_static": float(sum(r.collisions_static for r in rows)),
            "median_time_ratio": float(np.median(ratios)) if ratios else math.nan,
            "min_person_distance": min(gaps) if gaps else math.nan}
