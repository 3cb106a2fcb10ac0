"""The robot, its paths and its wheels: Labs 01 and 02."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.patches import Polygon
from numpy.typing import ArrayLike

from kit import geometry
from kit.viz._base import axes as _axes

__all__ = ["plot_icc", "plot_robot", "plot_trajectories", "plot_wheel_commands"]


def plot_robot(pose: ArrayLike, footprint: ArrayLike, ax: Axes | None = None,
               color: str = "tab:blue", label: str | None = None) -> Axes:
    """The robot's footprint polygon (base_link coordinates) at ``pose``, with a heading tick."""
    ax = _axes(ax, equal=True)
    p = geometry.check_pose(pose)
    corners = geometry.transform_points(p, np.asarray(footprint, dtype=float))
    ax.add_patch(Polygon(corners, closed=True, fill=False, edgecolor=color, label=label))
    reach = float(np.max(np.linalg.norm(np.asarray(footprint, float), axis=1)))
    tip = geometry.transform_points(p, np.array([[reach, 0.0]]))[0]
    ax.plot([p[0], tip[0]], [p[1], tip[1]], color=color)
    ax.autoscale_view()
    return ax


def plot_trajectories(paths: Mapping[str, ArrayLike], ax: Axes | None = None,
                      title: str = "", mark_ends: bool = True) -> Axes:
    """Several (N, 3) or (N, 2) paths in one frame [m], labelled by the mapping's keys."""
    ax = _axes(ax, equal=True)
    for name, path in paths.items():
        xy = np.asarray(path, dtype=float)[:, :2]
        line, = ax.plot(xy[:, 0], xy[:, 1], label=name)
        if mark_ends and len(xy):
            ax.plot(*xy[-1], marker="o", color=line.get_color())
    ax.plot(0, 0, marker="+", color="k")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if title:
        ax.set_title(title)
    ax.legend(loc="best")
    ax.grid(True, alpha=0.3)
    return ax


def plot_wheel_commands(times: ArrayLike, wheel_speeds: ArrayLike, ax: Axes | None = None,
                        limit: float | None = None,
                        labels: Sequence[str] = ("right", "left"),
                        unit: str = "rad/s") -> Axes:
    """Wheel speeds over time, (N, 2) ordered (right, left), with an optional ±limit band."""
    ax = _axes(ax)
    t = np.asarray(times, dtype=float)
    w = np.asarray(wheel_speeds, dtype=float)
    for column, name in enumerate(labels):
        ax.plot(t, w[:, column], label=name)
    if limit is not None:
        for sign in (1, -1):
            ax.axhline(sign * limit, color="k", linestyle="--", linewidth=0.8)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"wheel speed [{unit}]")
    ax.legend(loc="best")
    ax.grid(True, alpha=0.3)
    return ax


def plot_icc(linear: float, angular: float, footprint: ArrayLike, duration: float = 3.0,
             ax: Axes | None = None) -> Axes:
    """The robot at the origin, its instantaneous centre of curvature and the arc it drives
    in ``duration`` seconds at (v, ω)."""
    ax = _axes(ax, equal=True)
    plot_robot([0.0, 0.0, 0.0], footprint, ax)
    t = np.linspace(0.0, duration, 100)
    theta = angular * t
    if angular == 0.0:
        x, y = linear * t, np.zeros_like(t)
        ax.set_title(f"v = {linear:g} m/s, ω = 0: straight, R = ∞")
    else:
        radius = linear / angular
        x, y = radius * np.sin(theta), radius * (1 - np.cos(theta))
        ax.plot(0.0, radius, marker="x", color="tab:red", markersize=10, label="ICC")
        ax.plot([0.0, 0.0], [0.0, radius], color="tab:red", linestyle=":")
        ax.set_title(f"v = {linear:g} m/s, ω = {angular:g} rad/s: R = {radius:.3g} m")
    ax.plot(x, y, color="tab:green", label="path")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="best")
    ax.grid(True, alpha=0.3)
    return ax
