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

It prints the metrics, and writes ``demo_map.yaml``/``.pgm`` (the SLAM map), ``demo_loop.png``
(the map, the true and estimated paths, the plans, the people, AMCL's particle cloud),
``demo_loop.html`` (an animation) and ``demo_loop/``, an MCAP ROS 2 bag with ``/map``,
``/scan``, ``/odom``, ``/tf``, ``/tf_static``, ``/plan`` and ``/cmd_vel``.
"""

from __future__ import annotations

import math
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from kit import msgs
from kit.bag import BagWriter
from kit.slam.offline import read_bag_recording, run_bag
from sim import demo, scenarios
from sim.runner import Node, ProgressNode, Published, Runner, WheelOdometryNode
from sim.simulation import Simulation

__all__ = ["main", "navigate_on_map"]

TOPICS = ("/scan", "/odom", "/tf", "/plan", "/cmd_vel")
GOALS = ((16.45, 9.0, math.pi / 2), (4.45, 9.0, math.pi / 2), (1.5, 6.0, math.pi))
"""The navigation phase's goals: the two offices the mapping drive entered, then home (the
south rooms are not on its map)."""
"""What the navigation phase's bag records (with ``/map`` and ``/tf_static`` once)."""


class Snapshots(Node):
    """The truth, the people and the particle cloud twice a second, for the pictures."""

    rate = 2.0

    def __init__(self, localization: scenarios.AmclLocalization) -> None:
        self.localization = localization
        self.frames: list[dict[str, Any]] = []

    def start(self, sim: Simulation, robot: int) -> Published:
        self.sim, self.frames = sim, []
        return ()

    def on_tick(self, time: float) -> Published:
        f = self.localization.amcl.filter
        self.frames.append({
            "time": time, "truth": self.sim.ground_truth().pose.copy(),
            "people": self.sim.people_positions().copy(),
            "particles": None if f is None else f.poses[::10, :2].copy()})
        return ()


def navigate_on_map(grid: msgs.OccupancyGrid, seed: int, bag_path: Path | None,
                    bar: Any = None) -> dict[str, Any]:
    """The office tour on ``grid`` with AMCL among people; rows, frames and counts. ``bar``:
    a progress bar (tqdm) moved on in simulated seconds, its total the run's time limit."""
    route = scenarios.Route("office", (1.0, 6.0, 0.0), GOALS, 5,
                            "the mapped offices and home, among five people")
    world = scenarios.load_world("office")
    setup = scenarios.EpisodeSetup(route, "uiabot", world, grid,
                                   world.occupancy_grid(0.05, layer="glass"))
    setup.shortest = scenarios.shortest_lengths(world, "uiabot", route)
    sim = Simulation(world=world, robot="uiabot", seed=seed, people=route.people,
                     start=route.start)
    d = sim.description()
    loc = scenarios.AmclLocalization(grid, seed)
    nav = scenarios.Navigator(grid, d, keepout=setup.keepout)
    limits = [30.0 + 4.0 * x / d.cruise_velocity for x in setup.shortest]
    node = scenarios.NavigationNode(nav, loc, route.goals, limits, 0, setup.shortest)
    bag = BagWriter(bag_path) if bag_path is not None else None
    recorder = demo.BagRecorder(TOPICS, bag)
    shots = Snapshots(loc)
    seconds = sum(limits) + 1.0
    progress = []
    if bar is not None:
        bar.reset(total=seconds)
        progress = [ProgressNode(bar)]
    runner = Runner(sim, [WheelOdometryNode(), node, recorder, shots, *progress],
                    record_rate=1.0)
    if bag is not None:
        bag.__enter__()
    try:
        recorder.on_message("/tf_static", sim.static_transforms(), 0.0)
        recorder.on_message("/map", grid, 0.0)
        runner.run(seconds, until=lambda r: node.done)
    finally:
        if bag is not None:
            bag.__exit__(None, None, None)
    return {"sim": sim, "rows": node.results, "trail": np.array(node.trail),
            "frames": shots.frames, "counts": recorder.counts, "navigator": nav}


def _figure(grid: msgs.OccupancyGrid, result: dict[str, Any], png: Path) -> None:
    import matplotlib.pyplot as plt

    from kit import viz

    fig, ax = plt.subplots(figsize=(11, 7))
    viz.plot_grid(grid, ax=ax)
    trail = result["trail"]
    ax.plot(trail[:, 0], trail[:, 1], color="tab:blue", label="true path")
    last = result["frames"][-1]
    if last["particles"] is not None:
        cloud = last["particles"]
        ax.scatter(cloud[:, 0], cloud[:, 1], s=1, color="tab:red", alpha=0.3,
                   label="AMCL particles (last)")
    people = np.array([p for f in result["frames"] for p in f["people"]])
    if len(people):
        ax.scatter(people[:, 0], people[:, 1], s=4, color="tab:orange", alpha=0.3,
                   label="people over time")
    for g in GOALS:
        ax.plot(g[0], g[1], marker="*", markersize=14, color="tab:green")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title("Uiabot on its SLAM map: AMCL, planner, Regulated Pure Pursuit, people")
    fig.savefig(png, dpi=100)
    plt.close(fig)


def _animation(grid: msgs.OccupancyGrid, result: dict[str, Any], html: Path,
               quiet: bool = False) -> None:
    import matplotlib.pyplot as plt
    from matplotlib import animation

    from kit import viz

    frames = result["frames"]
    fig, ax = plt.subplots(figsize=(8, 5))
    viz.plot_grid(grid, ax=ax)
    robot = ax.plot([], [], marker="o", color="tab:blue")[0]
    people = ax.scatter([], [], s=60, color="tab:orange")
    cloud = ax.scatter([], [], s=1, color="tab:red", alpha=0.3)

    def draw(i: int) -> list[Any]:
        f = frames[i]
        robot.set_data([f["truth"][0]], [f["truth"][1]])
        people.set_offsets(f["people"] if len(f["people"]) else np.empty((0, 2)))
        if f["particles"] is not None:
            cloud.set_offsets(f["particles"])
        ax.set_title(f"t = {f['time']:.0f} s")
        return [robot, people, cloud]

    shown = range(0, len(frames), 2)
    anim = animation.FuncAnimation(fig, draw, frames=shown, interval=100, blit=True)
    # what Animation.to_jshtml(fps=10, default_mode="once") writes, saved with a progress bar
    writer = animation.HTMLWriter(fps=10, embed_frames=True, default_mode="once")
    with _bar("3. animation", len(shown), "frame", quiet) as bar:
        anim.save(str(html), writer=writer, progress_callback=lambda i, n: bar.update(1))
    plt.close(fig)


def _bar(desc: str, total: float, unit: str, quiet: bool) -> Any:
    """A progress bar on standard error, as the kit's commands draw them: on a terminal,
    unless ``quiet`` (``KIT_FAST`` plays no part: it shortens notebooks, not this)."""
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, leave=False, file=sys.stderr, delay=0.5,
                disable=quiet or not sys.stderr.isatty(),
                bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} {unit} "
                           "[{elapsed}<{remaining}]")


def main(out_dir: Path, seed: int = 7, quiet: bool = False) -> int:
    import matplotlib

    matplotlib.use("Agg")
    start = time.perf_counter()
    matplotlib.rcParams["animation.embed_limit"] = 40.0
    out_dir.mkdir(parents=True, exist_ok=True)
    mapping_bag = out_dir / "demo_office"
    if mapping_bag.exists():
        shutil.rmtree(mapping_bag)
    drive_seconds = 240.0                   # demo.run's limit; the route ends sooner
    with _bar("1. mapping drive", drive_seconds, "s simulated", quiet) as bar:
        drive = demo.run(drive_seconds, seed=seed, people=0, bag_path=mapping_bag,
                         nodes=[ProgressNode(bar)])
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
    with _bar("2. navigating", 0, "s simulated", quiet) as bar:
        result = navigate_on_map(grid, seed, nav_bag, bar)
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
    _animation(grid, result, out_dir / "demo_loop.html", quiet)
    counts = result["counts"]
    print("bag topics: " + ", ".join(f"{t} ({n})" for t, n in sorted(counts.items())))
    print(f"wrote {out_dir / 'demo_loop.png'}, {out_dir / 'demo_loop.html'}, {nav_bag}/ "
          f"(MCAP ROS 2 bag) in {time.perf_counter() - start:.0f} s")
    return 0 if math.isfinite(figures["reached"]) else 1
