"""Occupancy grids, maps with trajectories, and scans: Lab 08."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.axes import Axes
from numpy.typing import ArrayLike

from kit import msgs, perception
from kit.mapping import OccupancyGridMap
from kit.maps import OCCUPIED_THRESH as OCCUPIED
from kit.viz._base import axes as _axes

__all__ = ["crop_to_known", "known_extent", "plot_grid", "plot_map_trajectory", "plot_scan"]


MAX_SIDE = 2048
"""The longest side [pixels] of the image :func:`plot_grid` hands to matplotlib: a grid with
more cells a side is shown in blocks of cells (a figure has fewer pixels across anyway)."""


def _geometry(grid: OccupancyGridMap | msgs.OccupancyGrid) -> tuple[float, float, float, int, int]:
    """``(x0, y0, resolution, rows, cols)`` of a grid."""
    if isinstance(grid, OccupancyGridMap):
        rows, cols = grid.shape
        return float(grid.origin[0]), float(grid.origin[1]), grid.resolution, rows, cols
    info = grid.info
    return (info.origin.position.x, info.origin.position.y, info.resolution, info.height,
            info.width)


def _known(grid: OccupancyGridMap | msgs.OccupancyGrid, occupied: bool = False) -> np.ndarray:
    """Which cells are known ``[row, col]``: a message's cells that are not −1 (every cell of
    a log-odds grid); with ``occupied`` only those above map_server's ``occupied_thresh``
    (0.65), as its trinary maps count them."""
    _, _, _, rows, cols = _geometry(grid)
    if isinstance(grid, OccupancyGridMap):
        if occupied:
            return grid.log_odds > math.log(OCCUPIED / (1.0 - OCCUPIED))
        return np.ones((rows, cols), dtype=bool)
    cells = grid.data.reshape(rows, cols)
    return cells > round(100 * OCCUPIED) if occupied else cells >= 0


def _blocks(values: np.ndarray, k: int, fill: float) -> np.ndarray:
    """The largest value of each ``k × k`` block (the grid padded with ``fill`` at its top
    and right), NaN ignored unless a block holds nothing else."""
    rows, cols = values.shape
    padded = np.full((-(-rows // k) * k, -(-cols // k) * k), fill, dtype=values.dtype)
    padded[:rows, :cols] = values
    shaped = padded.reshape(padded.shape[0] // k, k, padded.shape[1] // k, k)
    if np.issubdtype(values.dtype, np.floating):
        # keepdims=True: numpy 2.5's stubs lose reduce's plain overload when mypy checks
        # the kit as Python 3.10 (a fresh machine with Python >= 3.12 gets numpy 2.5)
        most = np.fmax.reduce(np.fmax.reduce(shaped, axis=3, keepdims=True), axis=1,
                              keepdims=True)
        return most[:, 0, :, 0]
    return shaped.max(axis=(1, 3))


def _image(grid: OccupancyGridMap | msgs.OccupancyGrid, max_side: int | None = None
           ) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """Occupancy probability [row, col] (NaN unknown) and the extent in metres. With
    ``max_side`` a grid longer than that on a side comes in blocks of ``k × k`` cells, each
    block its most occupied known cell (a wall one cell thick still shows; unknown only where
    the whole block is)."""
    x0, y0, res, rows, cols = _geometry(grid)
    k = 1 if max_side is None else max(1, -(-max(rows, cols) // max_side))
    if isinstance(grid, OccupancyGridMap):
        p = grid.probability()
        p[grid.log_odds == 0.0] = np.nan  # never observed
        if k > 1:
            p = _blocks(p, k, np.nan)
    else:
        cells = grid.data.reshape(rows, cols)
        if k > 1:  # the blocks of the int8 message first: no float copy of the whole grid
            cells = _blocks(cells, k, -1)
        p = np.where(cells < 0, np.nan, cells / 100.0)
    return p, (x0, x0 + p.shape[1] * k * res, y0, y0 + p.shape[0] * k * res)


def _quantile_of_index(counts: np.ndarray, q: float) -> float:
    """``np.quantile`` (linear) of the indices ``i`` repeated ``counts[i]`` times, without
    making the repeats (a map holds millions of known cells)."""
    cumulative = np.cumsum(counts)
    h = (int(cumulative[-1]) - 1) * q
    lo = math.floor(h)
    a, b = np.searchsorted(cumulative, [lo, min(lo + 1, int(cumulative[-1]) - 1)], side="right")
    t = h - lo
    return float(a + (b - a) * t) if t < 0.5 else float(b - (b - a) * (1.0 - t))


def known_extent(grid: OccupancyGridMap | msgs.OccupancyGrid, margin: float = 0.5,
                 stray: float = 0.001, occupied: bool = False
                 ) -> tuple[float, float, float, float]:
    """``(x_min, x_max, y_min, y_max)`` [m] of the grid's known cells, ``margin`` metres
    wider (the whole grid when nothing is known). The ``stray`` share of known cells farthest
    out on each side (beams through a window, a lone reflection) is left out. ``occupied``:
    of the occupied cells only (a building's walls, where the free space of long beams
    through windows and doors reaches far beyond them)."""
    x0, y0, res, rows, cols = _geometry(grid)
    x1, y1 = x0 + cols * res, y0 + rows * res
    known = _known(grid, occupied)
    per_col, per_row = known.sum(axis=0), known.sum(axis=1)
    if per_col.sum() == 0:
        return x0, x1, y0, y1
    c0, c1 = (_quantile_of_index(per_col, q) for q in (stray, 1 - stray))
    r0, r1 = (_quantile_of_index(per_row, q) for q in (stray, 1 - stray))
    return (max(x0, x0 + c0 * res - margin), min(x1, x0 + (c1 + 1) * res + margin),
            max(y0, y0 + r0 * res - margin), min(y1, y0 + (r1 + 1) * res + margin))


def crop_to_known(ax: Axes, grid: OccupancyGridMap | msgs.OccupancyGrid,
                  margin: float = 0.5, occupied: bool = False) -> Axes:
    """Show only the grid's known part (:func:`known_extent`; ``occupied``: its walls') at a
    1:1 aspect; call it again after other ``plot_*`` calls on the same axes, which let the
    limits follow their data."""
    x0, x1, y0, y1 = known_extent(grid, margin, occupied=occupied)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    return ax


def plot_grid(grid: OccupancyGridMap | msgs.OccupancyGrid, ax: Axes | None = None,
              title: str = "", crop: bool = False) -> Axes:
    """A grid in the map frame [m]: white free, black occupied, grey unknown; ``crop`` shows
    only its known part (:func:`known_extent`). A grid over :data:`MAX_SIDE` cells on a side
    is drawn in blocks, each as dark as its most occupied known cell."""
    ax = _axes(ax, equal=True)
    p, extent = _image(grid, MAX_SIDE)
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
