"""Estimates against the truth: odometry drift (Lab 02) and filters (Lab 05)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.axes import Axes
from numpy.typing import ArrayLike

from kit.viz._base import axes as _axes

__all__ = ["plot_headings", "plot_kalman_track", "plot_odometry_drift"]


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


def plot_kalman_track(time: ArrayLike, truth: ArrayLike, measured: ArrayLike,
                      estimate: ArrayLike, sigma: ArrayLike, ax: Axes | None = None,
                      ylabel: str = "position [m]") -> Axes:
    """A filter tracking one quantity: measurements (dots), the truth, the estimate and its
    ±2σ band. All arrays have shape (N,) over ``time`` [s]."""
    ax = _axes(ax)
    t = np.asarray(time, dtype=float)
    est = np.asarray(estimate, dtype=float)
    two_sigma = 2 * np.asarray(sigma, dtype=float)
    ax.plot(t, np.asarray(measured, dtype=float), ".", color="0.6", label="measured")
    ax.plot(t, np.asarray(truth, dtype=float), label="true")
    ax.plot(t, est, label="estimate")
    ax.fill_between(t, est - two_sigma, est + two_sigma, alpha=0.2, label="±2σ")
    ax.set_xlabel("time [s]")
    ax.set_ylabel(ylabel)
    ax.legend(loc="best")
    ax.grid(True, alpha=0.3)
    return ax


def plot_headings(time: ArrayLike, true_yaw: ArrayLike, estimates: Mapping[str, ArrayLike],
                  ax: Axes | None = None) -> Axes:
    """Headings over time in degrees, unwrapped so that a turn past ±180° stays a smooth
    line: the truth (dashed) and each estimate. Yaws [rad] of shape (N,) over ``time`` [s]."""
    ax = _axes(ax)
    t = np.asarray(time, dtype=float)
    for name, yaw in estimates.items():
        ax.plot(t, np.degrees(np.unwrap(np.asarray(yaw, dtype=float))), label=name)
    ax.plot(t, np.degrees(np.unwrap(np.asarray(true_yaw, dtype=float))), "k--", label="true")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("heading [deg]")
    ax.legend(loc="best")
    ax.grid(True, alpha=0.3)
    return ax
