"""The whole see–think–act loop, headless (``make demo``).

1. **Map** — the Uiabot drives the demo's route through the office (:mod:`sim.demo`: steered
   by its odometry, as a tele-operator would drive it) while nobody is about, recording a
   bag; the kit's SLAM (:func:`kit.slam.offline.run_bag`) turns the bag into a map, saved as
   map_server files. (People walking through a mapping run leave their traces in the map:
   with the demo's four people in it, the corridor of the map came out cluttered enough to
   stop the navigation; the kit's SLAM does not filter moving objects.)
2. **Navigate** — on that saved map, among walking people, the navigation stack
   (:class:`sim.scenarios.NavigationNode`: the kit's AMCL from the known start, costmaps,
   the planner at 1 Hz, Regulated Pure Pursuit at 20 Hz, recoveries) takes the Uiabot through
   the office tour's goals; the glass of the meeting room, which the lidar (and so the map)
   does not see, is kept out with a keep-out mask.

The navigation is configured by a Nav2 parameter file, :data:`PARAMS` (the kit's own for the
Uiabot, in Nav2's format: a course edits that one file, or passes its own with ``--params``).

It prints the metrics, and writes ``demo_map.yaml``/``.pgm`` (the SLAM map), ``demo_loop.png``
(the known part of the map, the path driven, every ``/plan`` the planner made, AMCL's particle
clouds along the way, where the people walked, the goals), ``demo_loop.html`` (an animation
that plays offline: footprint and heading, lidar returns, plan, particles, people, at a stated
speed) and ``demo_loop/``, an MCAP ROS 2 bag that Humble and Jazzy open as it is: ``/clock``,
``/map``, ``/scan``, ``/odom``, ``/tf``, ``/tf_static``, ``/cmd_vel``, ``/plan``,
``/local_plan``, ``/amcl_pose``, ``/particlecloud``, ``/global_costmap/costmap``,
``/local_costmap/costmap`` and ``/robot_description`` (:mod:`sim.navtopics`).
"""

from __future__ import annotations

import math
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from kit import geometry, msgs, perception
from kit.bag import BagWriter
from kit.liveview import LiveView
from kit.navigation import NavigationConfig
from kit.slam.offline import read_bag_recording, run_bag
from sim import demo, navtopics, scenarios
from sim.live import LiveNode
from sim.runner import Node, ProgressNode, Published, Runner, WheelOdometryNode
from sim.simulation import Simulation

__all__ = ["CLOCK_PERIOD", "GOALS", "PARAMS", "TOPICS", "main", "navigate_on_map"]

PARAMS = Path(__file__).resolve().parent / "params" / "uiabot_nav2_params.yaml"
"""The demo's navigation parameters: the kit's configuration for the Uiabot, in Nav2's format
(the same as the kit's defaults, :meth:`kit.navigation.NavigationConfig.for_robot`, and the
scenarios' AMCL)."""

TOPICS = ("/scan", "/odom", "/tf", "/plan", "/cmd_vel", *navtopics.TOPICS)
"""What the navigation phase's bag records (with ``/map`` and ``/tf_static`` once, and
``/clock``)."""
GOALS = ((16.45, 9.0, math.pi / 2), (4.45, 9.0, math.pi / 2), (1.5, 6.0, math.pi))
"""The navigation phase's goals: the two offices the mapping drive entered, then home (the
south rooms are not on its map)."""
CLOCK_PERIOD = 0.01
"""Seconds between the bags' ``/clock`` messages (the simulation's time; replay with
``use_sim_time:=true``)."""
FRAME_PERIOD = 0.5
"""Simulated seconds between the snapshots the figure and the animation are drawn from."""


class Snapshots(Node):
    """Twice a second, for the pictures: the truth, the people, AMCL's particles (x, y, yaw;
    at most 300), the current plan and the last scan's returns placed at the estimate."""

    rate = 1.0 / FRAME_PERIOD
    subscriptions = ("/scan",)

    def __init__(self, navigation: scenarios.NavigationNode) -> None:
        self.navigation = navigation
        self.frames: list[dict[str, Any]] = []
        self.plans: list[np.ndarray] = []
        self.scan: msgs.LaserScan | None = None

    def start(self, sim: Simulation, robot: int) -> Published:
        self.sim, self.frames, self.plans, self.scan = sim, [], [], None
        self.mount = np.array(sim.description(robot).sensor_mount("lidar"), dtype=float)
        return ()

    def on_message(self, topic: str, message: Any, time: float) -> Published:
        self.scan = message
        return ()

    def on_tick(self, time: float) -> Published:
        nav = self.navigation
        f = nav.localization.amcl.filter
        plan = np.array(nav.navigator.path, dtype=float).reshape(-1, 2)
        if len(plan) and (not self.plans or not np.array_equal(plan, self.plans[-1])):
            self.plans.append(plan)
        estimate = nav.localization.pose(nav.odom_pose)
        scan = (np.zeros((0, 2)) if self.scan is None else perception.scan_to_points(
            self.scan, geometry.compose(estimate, self.mount)))
        self.frames.append({
            "time": time, "truth": self.sim.ground_truth().pose.copy(),
            "people": self.sim.people_positions().copy(), "plan": plan, "scan": scan,
            "particles": None if f is None else f.poses[::max(1, len(f.poses) // 300)].copy()})
        return ()


def navigate_on_map(grid: msgs.OccupancyGrid, seed: int, bag_path: Path | None,
                    config: NavigationConfig | None = None, live: LiveView | None = None,
                    speed: float | None = None, bar: Any = None) -> dict[str, Any]:
    """The office tour on ``grid`` with AMCL among people; rows, frames and counts.
    ``config``: the navigator's (and AMCL's) configuration (default: the kit's). With
    ``live``, the topics go to that live view too, the simulation paced at ``speed`` times
    real time. ``bar``: a progress bar (tqdm) moved on in simulated seconds, its total the
    run's time limit."""
    route = scenarios.Route("office", (1.0, 6.0, 0.0), GOALS, 5,
                            "the mapped offices and home, among five people")
    world = scenarios.load_world("office")
    setup = scenarios.EpisodeSetup(route, "uiabot", world, grid,
                                   world.occupancy_grid(0.05, layer="glass"))
    setup.shortest = scenarios.shortest_lengths(world, "uiabot", route)
    sim = Simulation(world=world, robot="uiabot", seed=seed, people=route.people,
                     start=route.start)
    d = sim.description()
    loc = scenarios.AmclLocalization(grid, seed, config.amcl if config is not None else None)
    nav = scenarios.Navigator(grid, d, keepout=setup.keepout, config=config)
    limits = [30.0 + 4.0 * x / d.cruise_velocity for x in setup.shortest]
    node = scenarios.NavigationNode(nav, loc, route.goals, limits, 0, setup.shortest)
    bag = BagWriter(bag_path, clock_period=CLOCK_PERIOD) if bag_path is not None else None
    recorder = demo.BagRecorder(TOPICS, bag)
    shots = Snapshots(node)
    topics = navtopics.NavigationTopics(node, navtopics.robot_description_xml(d))
    viewer = [] if live is None else [LiveNode(live, TOPICS, speed)]
    seconds = sum(limits) + 1.0
    progress = []
    if bar is not None:
        bar.reset(total=seconds)
        progress = [ProgressNode(bar)]
    runner = Runner(sim, [WheelOdometryNode(), node, topics, recorder, shots, *viewer,
                          *progress],
                    record_rate=1.0)
    if bag is not None:
        bag.__enter__()
    try:
        for sink in (recorder, *viewer):
            sink.on_message("/tf_static", sim.static_transforms(), 0.0)
            sink.on_message("/map", grid, 0.0)
        runner.run(seconds, until=lambda r: node.done)
    finally:
        if bag is not None:
            bag.__exit__(None, None, None)
    return {"sim": sim, "rows": node.results, "trail": np.array(node.trail),
            "frames": shots.frames, "plans": shots.plans, "counts": recorder.counts,
            "navigator": nav, "footprint": np.asarray(d.footprint, dtype=float)}


def _figure(grid: msgs.OccupancyGrid, result: dict[str, Any], png: Path) -> None:
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    from kit import viz

    fig, ax = plt.subplots(figsize=(11, 7))
    viz.plot_grid(grid, ax=ax)
    frames = result["frames"]
    people = np.array([p for f in frames for p in f["people"]]).reshape(-1, 2)
    ax.scatter(people[:, 0], people[:, 1], s=10, color="tab:orange", alpha=0.25, lw=0,
               label="people (every 0.5 s)")
    for i, plan in enumerate(result["plans"]):
        ax.plot(plan[:, 0], plan[:, 1], color="tab:green", lw=1.0, alpha=0.35,
                label="/plan (each new one)" if i == 0 else None)
    trail = result["trail"]
    ax.plot(trail[:, 0], trail[:, 1], color="tab:blue", lw=1.5, label="path driven (true)")
    clouds = [f for f in frames if f["particles"] is not None][::20]   # every 10 s
    for i, f in enumerate(clouds):
        p = f["particles"]
        ax.quiver(p[:, 0], p[:, 1], np.cos(p[:, 2]), np.sin(p[:, 2]), color="tab:purple",
                  angles="xy", scale_units="xy", scale=8.0, width=0.002, alpha=0.6,
                  label="AMCL particles, every 10 s" if i == 0 else None)
    for i, g in enumerate(GOALS):
        ax.plot(g[0], g[1], marker="*", markersize=16, color="gold", markeredgecolor="black",
                zorder=5, label="goals (in order)" if i == 0 else None)
        ax.annotate(str(i + 1), (g[0], g[1]), xytext=(7, 7), textcoords="offset points",
                    fontsize=10, fontweight="bold")
    viz.crop_to_known(ax, grid)
    _cloud_inset(ax, frames, result["footprint"])
    handles, labels = ax.get_legend_handles_labels()
    handles = [Line2D([], [], marker="o", ls="", color="tab:orange") if lab.startswith("people")
               else h for h, lab in zip(handles, labels, strict=True)]
    ax.legend(handles, labels, loc="lower right", fontsize=8, framealpha=0.9)
    ax.set_title("Uiabot on its SLAM map: AMCL, planner, Regulated Pure Pursuit, people")
    fig.savefig(png, dpi=100, bbox_inches="tight")
    plt.close(fig)


def _cloud_inset(ax: Any, frames: list[dict[str, Any]], footprint: np.ndarray) -> None:
    """The widest particle cloud of the run, enlarged in a corner: each particle's pose as
    an arrow, the robot's true footprint and heading."""
    clouds = [f for f in frames if f["particles"] is not None]
    if not clouds:
        return
    f = max(clouds, key=lambda g: float(np.ptp(g["particles"][:, :2], axis=0).max()))
    p, truth = f["particles"], f["truth"]
    inset = ax.inset_axes((0.015, 0.015, 0.3, 0.36))
    inset.quiver(p[:, 0], p[:, 1], np.cos(p[:, 2]), np.sin(p[:, 2]), color="tab:purple",
                 angles="xy", scale_units="xy", scale=12.0, width=0.005, alpha=0.7)
    outline = geometry.transform_points(truth, footprint)
    inset.fill(outline[:, 0], outline[:, 1], color="tab:blue", alpha=0.3)
    inset.plot(*np.vstack([truth[:2], truth[:2] + 0.3 * np.array(
        [math.cos(truth[2]), math.sin(truth[2])])]).T, color="tab:blue", lw=2)
    half = max(0.5, 0.6 * float(np.ptp(p[:, :2], axis=0).max()))
    centre = p[:, :2].mean(axis=0)
    inset.set_xlim(centre[0] - half, centre[0] + half)
    inset.set_ylim(centre[1] - half, centre[1] + half)
    inset.set_aspect("equal")
    inset.tick_params(labelsize=7)
    inset.set_title(f"widest particle cloud, t = {f['time']:.0f} s (robot: blue)", fontsize=8)
    ax.indicate_inset_zoom(inset, edgecolor="black")


def _animation(grid: msgs.OccupancyGrid, result: dict[str, Any], html: Path) -> None:
    from kit import viz
    from sim.html_animation import write_html_animation

    write_html_animation(
        html, grid, result["frames"], result["footprint"], GOALS,
        viz.known_extent(grid), FRAME_PERIOD, speed=5.0,
        title="Uiabot on its SLAM map: AMCL, planner, Regulated Pure Pursuit, people")


def _bar(desc: str, total: float, unit: str, quiet: bool) -> Any:
    """A progress bar on standard error, as the kit's commands draw them: on a terminal,
    unless ``quiet`` (``KIT_FAST`` plays no part: it shortens notebooks, not this)."""
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, leave=False, file=sys.stderr, delay=0.5,
                disable=quiet or not sys.stderr.isatty(),
                bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} {unit} "
                           "[{elapsed}<{remaining}]")


def main(out_dir: Path, seed: int = 7, config: NavigationConfig | None = None,
         live: LiveView | None = None, speed: float | None = None, quiet: bool = False) -> int:
    """Both phases; with ``live``, each is also served to that live view (Foxglove) at
    ``speed`` times real time; ``config``: the navigation's configuration; ``quiet``: no
    progress bars."""
    import matplotlib

    matplotlib.use("Agg")
    start = time.perf_counter()
    out_dir.mkdir(parents=True, exist_ok=True)
    mapping_bag = out_dir / "demo_office"
    if mapping_bag.exists():
        shutil.rmtree(mapping_bag)
    viewer = [] if live is None else [LiveNode(live, demo.TOPICS, speed)]
    drive_seconds = 240.0                   # demo.run's limit; the route ends sooner
    with _bar("1. mapping drive", drive_seconds, "s simulated", quiet) as bar:
        drive = demo.run(drive_seconds, seed=seed, people=0, bag_path=mapping_bag,
                         nodes=[*viewer, ProgressNode(bar)], clock_period=CLOCK_PERIOD)
    recording = read_bag_recording(mapping_bag)
    with _bar("1. SLAM", len(recording.scans), "scans", quiet) as bar:
        slam = run_bag(recording, progress=bar.update)
    occupancy = slam.occupancy_map(0.05)
    occupancy.save(out_dir / "demo_map.yaml")
    grid = occupancy.to_msg()
    print(f"1. mapped the office ({time.perf_counter() - start:.0f} s): {drive['reached']} of "
          f"{len(demo.ROUTE)} route points driven, {len(slam.records)} scans, "
          f"{len(slam.loop_closures)} loop closures; wrote {out_dir / 'demo_map.yaml'}")
    nav_bag = out_dir / "demo_loop"
    if nav_bag.exists():
        shutil.rmtree(nav_bag)
    if live is not None:
        live.server.clear_session()       # the mapping drive's frames are done with
    with _bar("2. navigating", 0, "s simulated", quiet) as bar:
        result = navigate_on_map(grid, seed, nav_bag, config, live, speed, bar)
    rows = result["rows"]
    figures = scenarios.summary(rows, 0.5)
    print(f"2. navigated on the SLAM map with AMCL among 5 people: "
          f"{sum(r.reached for r in rows)} of {len(rows)} goals reached, "
          f"{sum(r.collisions_static for r in rows)} contacts with walls, "
          f"{sum(r.collisions_people for r in rows)} with people, median time "
          f"{figures['median_time_ratio']:.2f} x the shortest path at cruise speed")
    for r in rows:
        print(f"   goal {r.goal}: {'reached' if r.reached else 'NOT reached'} in "
              f"{r.seconds:.1f} s, {r.path_length:.1f} m driven (shortest "
              f"{r.shortest_length:.1f} m){'; ' + r.reason if r.reason else ''}")
    _figure(grid, result, out_dir / "demo_loop.png")
    _animation(grid, result, out_dir / "demo_loop.html")
    counts = result["counts"]
    print("bag topics: " + ", ".join(f"{t} ({n})" for t, n in sorted(counts.items()))
          + f", /clock (every {CLOCK_PERIOD:g} s)")
    print(f"wrote {out_dir / 'demo_loop.png'}, {out_dir / 'demo_loop.html'}, {nav_bag}/ "
          f"(MCAP ROS 2 bag) in {time.perf_counter() - start:.0f} s")
    return 0 if math.isfinite(figures["reached"]) else 1
