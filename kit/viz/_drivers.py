"""What the drivers read: Lab 03."""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from numpy.typing import ArrayLike

from kit.viz._base import axes as _axes

__all__ = ["plot_lidar_turn"]


def plot_lidar_turn(angles: ArrayLike, ranges: ArrayLike, ax: Axes | None = None,
                    title: str = "") -> Axes:
    """The returns of one lidar turn as points in the sensor's frame (x forward, y left).

    Parameters
    ----------
    angles : array_like, shape (N,)
        Beam angles [rad], counter-clockwise from x (REP-103; an RPLidar's clockwise degrees
        ``alpha`` are ``-radians(alpha)``).
    ranges : array_like, shape (N,)
        Distances [m]; zero, negative or non-finite ranges (no return) are left out.
    """
    a = np.asarray(angles, dtype=float)
    r = np.asarray(ranges, dtype=float)
    if a.shape != r.shape or a.ndim != 1:
        raise ValueError(f"angles and ranges must be 1-D of equal length; got shapes "
                         f"{a.shape} and {r.shape}")
    ax = _axes(ax, equal=True)
    hit = np.isfinite(r) & (r > 0)
    ax.scatter(r[hit] * np.cos(a[hit]), r[hit] * np.sin(a[hit]), s=4, label="returns")
    ax.plot(0, 0, "k^", label="sensor")
    ax.set_xlabel("x [m] (forward)")
    ax.set_ylabel("y [m] (left)")
    if title:
        ax.set_title(title)
    ax.grid(True, alpha=0.3)
    return ax
