"""Drawing the simulation with matplotlib, headless: still pictures, animations that play in
JupyterLab (as JavaScript HTML, no X server), and a tele-operation panel (ipywidgets).

The physics never imports this module; it only reads the simulation's state.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.patches import Circle, Polygon, Rectangle
from numpy.typing import NDArray

from kit import geometry, msgs
from sim.simulation import Simulation
from sim.world import World

__all__ = ["Snapshot", "animation_html", "plot_scene", "plot_world", "scan_points",
           "snapshot", "teleop_panel"]

FloatArray = NDArray[np.float64]


def plot_world(world: World, ax: Axes | None = None) -> Axes:
    """Walls (black), glass (light blue), boxes and pillars (grey), oil (brown)."""
    if ax is None:
        _, ax = plt.subplots(figsize=(8, 6))
    for x0, y0, x1, y1 in world.oil:
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, color="tab:brown", alpha=0.25,
                               label=None))
    for x0, y0, x1, y1 in world.boxes:
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, color="0.6"))
    for cx, cy, r in world.circles:
        ax.add_patch(Circle((cx, cy), r, color="0.4"))
    for seg, glass in zip(world.segments, world.segment_glass, strict=True):
        ax.plot(seg[[0, 2]], seg[[1, 3]], color="tab:cyan" if glass else "k",
                linewidth=3 if glass else 1.5, solid_capstyle="round")
    ax.set_aspect("equal", adjustable="box")
    x0, y0, x1, y1 = world.bounds
    ax.set_xlim(x0 - 0.5, x1 + 0.5)
    ax.set_ylim(y0 - 0.5, y1 + 0.5)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    return ax


def scan_points(scan: msgs.LaserScan, pose: Sequence[float],
                mount: Sequence[float] = (0.0, 0.0, 0.0)) -> FloatArray:
    """World coordinates (N, 2) of a scan's finite returns, taken from ``pose`` (the
    scan's own per-beam motion ignored) with the lidar at ``mount`` (x, y, yaw) in base_link."""
    r = scan.ranges.astype(np.float64)
    ok = np.isfinite(r)
    angles = scan.angles()[ok]
    local = np.column_stack([r[ok] * np.cos(angles), r[ok] * np.sin(angles)])
    laser = geometry.compose(np.asarray(pose, float), np.asarray(mount, float))
    return geometry.transform_points(laser, local)


@dataclass(frozen=True)
class Snapshot:
    """What one animation frame shows."""

    time: float
    poses: FloatArray
    """(R, 3) robot poses."""
    people: FloatArray
    """(P, 2) pedestrian positions."""
    points: FloatArray
    """(N, 2) lidar returns in the world."""


def _mount(sim: Simulation, robot: int) -> tuple[float, float, float]:
    lidar = sim.robots[robot].lidar
    return lidar.mount if lidar is not None else (0.0, 0.0, 0.0)


def snapshot(sim: Simulation, scan: msgs.LaserScan | None = None, robot: int = 0) -> Snapshot:
    """The simulation's state now, with ``scan``'s returns drawn from the robot's pose."""
    poses = np.array([r.pose for r in sim.robots])
    points = scan_points(scan, poses[robot], _mount(sim, robot)) if scan is not None else \
        np.empty((0, 2))
    return Snapshot(sim.time, poses, sim.people_positions(), points)


def _draw_robots(ax: Axes, sim: Simulation, poses: FloatArray) -> list[Any]:
    artists: list[Any] = []
    for r, pose in zip(sim.robots, poses, strict=True):
        corners = geometry.transform_points(pose, r.description.footprint)
        artists.append(ax.add_patch(Polygon(corners, closed=True, fill=False,
                                            edgecolor="tab:blue", linewidth=1.5)))
        tip = geometry.transform_points(pose, np.array([[0.3, 0.0]]))[0]
        artists.extend(ax.plot([pose[0], tip[0]], [pose[1], tip[1]], color="tab:blue"))
    return artists


def plot_scene(sim: Simulation, scan: msgs.LaserScan | None = None, ax: Axes | None = None,
               paths: dict[str, FloatArray] | None = None, robot: int = 0,
               rays: bool = False) -> Axes:
    """The world, the robots' footprints, the people, a scan's returns (and optionally its
    rays) and any paths (name → (N, 2+) array)."""
    ax = plot_world(sim.world, ax)
    shot = snapshot(sim, scan, robot)
    for name, path in (paths or {}).items():
        xy = np.asarray(path, float)
        ax.plot(xy[:, 0], xy[:, 1], label=name)
    for p in shot.people:
        ax.add_patch(Circle((p[0], p[1]), 0.25, color="tab:orange", alpha=0.8))
    _draw_robots(ax, sim, shot.poses)
    if len(shot.points):
        if rays:
            laser = geometry.compose(shot.poses[robot], np.asarray(_mount(sim, robot)))
            for point in shot.points[::4]:
                ax.plot([laser[0], point[0]], [laser[1], point[1]], color="tab:red",
                        linewidth=0.3, alpha=0.4)
        ax.scatter(shot.points[:, 0], shot.points[:, 1], s=3, color="tab:red", label="lidar")
    ax.set_title(f"{sim.world.name}, t = {sim.time:.2f} s")
    if paths or len(shot.points):
        ax.legend(loc="upper right", fontsize=8)
    return ax


def animation_html(sim: Simulation, frames: Sequence[Snapshot], interval_ms: int = 100,
                   trail: bool = True) -> str:
    """An HTML/JavaScript animation of ``frames`` (show it with ``IPython.display.HTML``)."""
    from matplotlib.animation import FuncAnimation

    fig, ax = plt.subplots(figsize=(8, 6))
    plot_world(sim.world, ax)
    robot_patches = [Polygon(r.description.footprint, closed=True, fill=False,
                             edgecolor="tab:blue", linewidth=1.5) for r in sim.robots]
    for patch in robot_patches:
        ax.add_patch(patch)
    people = ax.scatter([], [], s=120, color="tab:orange")
    points = ax.scatter([], [], s=3, color="tab:red")
    track, = ax.plot([], [], color="tab:blue", linewidth=0.8)
    history: list[FloatArray] = []

    def draw(i: int) -> list[Any]:
        shot = frames[i]
        for patch, r, pose in zip(robot_patches, sim.robots, shot.poses, strict=True):
            patch.set_xy(geometry.transform_points(pose, r.description.footprint))
        people.set_offsets(shot.people if len(shot.people) else np.empty((0, 2)))
        points.set_offsets(shot.points if len(shot.points) else np.empty((0, 2)))
        if i == 0:
            history.clear()
        history.append(shot.poses[0, :2])
        if trail:
            xy = np.array(history)
            track.set_data(xy[:, 0], xy[:, 1])
        ax.set_title(f"t = {shot.time:.1f} s")
        return [*robot_patches, people, points, track]

    anim = FuncAnimation(fig, draw, frames=len(frames), interval=interval_ms, blit=False)
    html = str(anim.to_jshtml(default_mode="once"))
    plt.close(fig)
    return html


def teleop_panel(sim: Simulation, step_seconds: float = 0.5, speed: float | None = None,
                 turn_rate: float | None = None) -> Any:
    """Buttons that drive robot 0 for ``step_seconds`` per press and redraw the scene."""
    import ipywidgets as widgets
    from IPython.display import display

    d = sim.description()
    v = speed if speed is not None else 0.5 * d.max_linear_velocity
    w = turn_rate if turn_rate is not None else 0.5 * d.max_angular_velocity
    output = widgets.Output()
    last_scan: list[msgs.LaserScan | None] = [None]

    def drive(linear: float, angular: float) -> None:
        messages = sim.run(step_seconds, msgs.Twist(msgs.Vector3(linear, 0.0, 0.0),
                                                    msgs.Vector3(0.0, 0.0, angular)))
        scans = [m for t, m in messages if t.endswith("/scan")]
        if scans:
            last_scan[0] = scans[-1]
        with output:
            output.clear_output(wait=True)
            fig, ax = plt.subplots(figsize=(7, 5))
            plot_scene(sim, last_scan[0], ax=ax)
            display(fig)
            plt.close(fig)

    buttons = []
    for label, lin, ang in (("◀ left", 0.0, w), ("▲ forward", v, 0.0), ("▶ right", 0.0, -w),
                            ("▼ back", -v, 0.0), ("■ stop", 0.0, 0.0)):
        button = widgets.Button(description=label)
        button.on_click(lambda _b, lin=lin, ang=ang: drive(lin, ang))
        buttons.append(button)
    drive(0.0, 0.0)
    return widgets.VBox([widgets.HBox(buttons), output])
