"""Occupancy grids, maps with trajectories, and scans: Lab 08."""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from numpy.typing import ArrayLike

from kit import msgs, perception
from kit.mapping import OccupancyGridMap
from kit.viz._base import axes as _axes

__all__ = ["crop_to_known", "known_extent", "plot_grid", "plot_map_trajectory", "plot_scan"]


def _image(grid: OccupancyGridMap | msgs.OccupancyGrid
           ) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """Occupancy probability [row, col] (NaN unknown) and the extent in metres."""
    if isinstance(grid, OccupancyGridMap):
        p = grid.probability()
        x0, y0, res = float(grid.origin[0]), float(grid.origin[1]), grid.resolution
    else:
        info = grid.info
        cells = grid.data.reshape(info.height, info.width).astype(float)
        p = np.where(cells < 0, np.nan, cells / 100.0)
        x0, y0, res = info.origin.position.x, info.origin.position.y, info.resolution
    rows, cols = p.shape
    return p, (x0, x0 + cols * res, y0, y0 + rows * res)


def known_extent(grid: OccupancyGridMap | msgs.OccupancyGrid, margin: float = 0.5,
                 stray: float = 0.001) -> tuple[float, float, float, float]:
    """``(x_min, x_max, y_min, y_max)`` [m] of the grid's known cells, ``margin`` metres
    wider (the whole grid when nothing is known). The ``stray`` share of known cells farthest
    out on each side (beams through a window, a lone reflection) is left out."""
    p, (x0, x1, y0, y1) = _image(grid)
    rows, cols = np.nonzero(~np.isnan(p))
    if len(rows) == 0:
        return x0, x1, y0, y1
    res = (x1 - x0) / p.shape[1]
    c0, c1 = np.quantile(cols, [stray, 1 - stray])
    r0, r1 = np.quantile(rows, [stray, 1 - stray])
    return (max(x0, x0 + c0 * res - margin), min(x1, x0 + (c1 + 1) * res + margin),
            max(y0, y0 + r0 * res - margin), min(y1, y0 + (r1 + 1) * res + margin))


def crop_to_known(ax: Axes, grid: OccupancyGridMap | msgs.OccupancyGrid,
                  margin: float = 0.5) -> Axes:
    """Show only the grid's known part (:func:`known_extent`) at a 1:1 aspect; call it again
    after other ``plot_*`` calls on the same axes, which let the limits follow their data."""
    x0, x1, y0, y1 = known_extent(grid, margin)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    return ax


def plot_grid(grid: OccupancyGridMap | msgs.OccupancyGrid, ax: Axes | None = None,
              title: str = "", crop: bool = False) -> Axes:
    """A grid in the map frame [m]: white free, black occupied, grey unknown; ``crop`` shows
    only its known part (:func:`known_extent`)."""
    ax = _axes(ax, equal=True)
    p, extent = _image(grid)
    shown = np.where(np.isnan(p), 0.5, p)
    ax.imshow(1.0 - shown, cmap="gray", vmin=0.0, vmax=1.0, origin="lower", extent=extent,
              interpolation="nearest")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if crop:
        crop_to_known(ax, grid)
    if title:
        ax.set_title(title)
    return ax


def plot_map_trajectory(grid: OccupancyGridMap | msgs.OccupancyGrid, poses: ArrayLike,
                        ax: Axes | None = None, label: str = "trajectory",
                        color: str = "tab:red", title: str = "") -> Axes:
    """The map with a trajectory ``(N, 3)`` or ``(N, 2)`` [m] drawn over it."""
    ax = plot_grid(grid, ax, title)
    xy = np.asarray(poses, dtype=float).reshape(-1, np.shape(poses)[-1])[:, :2]
    ax.plot(xy[:, 0], xy[:, 1], color=color, lw=1.0, label=label)
    if len(xy):
        ax.plot(*xy[0], marker="o", color=color)
    ax.legend(loc="best")
    return ax


def plot_scan(scan: msgs.LaserScan, pose: ArrayLike = (0.0, 0.0, 0.0), ax: Axes | None = None,
              color: str = "tab:blue", label: str = "scan", rays: bool = False) -> Axes:
    """A scan's valid returns as points, taken with its sensor at ``pose`` (x, y, θ) [m, rad];
    ``rays`` also draws the beams from the sensor."""
    ax = _axes(ax, equal=True)
    p = np.asarray(pose, dtype=float)
    pts = perception.scan_to_points(scan, p)
    if rays and len(pts):
        segments = np.stack([np.broadcast_to(p[:2], pts.shape), pts], axis=1)
        for seg in segments:
            ax.plot(seg[:, 0], seg[:, 1], color=color, lw=0.2, alpha=0.3)
    ax.plot(pts[:, 0], pts[:, 1], ".", ms=2, color=color, label=label)
    ax.plot(*p[:2], marker="^", color=color)
    return ax
