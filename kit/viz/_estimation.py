"""Estimates against the truth: odometry drift (Lab 02) and filters (Lab 05)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.axes import Axes
from numpy.typing import ArrayLike

from kit.viz._base import axes as _axes

__all__ = ["plot_odometry_drift"]


def plot_odometry_drift(true_path: ArrayLike, estimated_paths: Mapping[str, ArrayLike],
                        ax: Axes | None = None) -> Axes:
    """Position error of each estimate against the true path, over distance travelled.

    All paths have shape (N, 3) and share their sample times.
    """
    ax = _axes(ax)
    truth = np.asarray(true_path, dtype=float)
    travelled = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(truth[:, :2], axis=0),
                                                                axis=1))])
    for name, path in estimated_paths.items():
        est = np.asarray(path, dtype=float)
        ax.plot(travelled, np.linalg.norm(est[:, :2] - truth[:, :2], axis=1), label=name)
    ax.set_xlabel("distance travelled [m]")
    ax.set_ylabel("position error [m]")
    ax.legend(loc="best")
    ax.grid(True, alpha=0.3)
    return ax
