"""Signals over time and step responses: Lab 04 (motor control) and the runs of later labs."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.axes import Axes
from numpy.typing import ArrayLike

from kit.viz._base import axes as _axes

__all__ = ["plot_signals", "plot_step_response"]


def plot_signals(time: ArrayLike, signals: Mapping[str, ArrayLike], ax: Axes | None = None,
                 ylabel: str = "", title: str = "", levels: Sequence[float] = ()) -> Axes:
    """Named signals over time [s] on one axes, with dashed horizontal ``levels`` (limits,
    set-points).

    Parameters
    ----------
    time : array_like, shape (N,)
        Sample times [s], shared by every signal.
    signals : mapping of label → array_like, shape (N,)
    """
    ax = _axes(ax)
    t = np.asarray(time, dtype=float)
    for label, values in signals.items():
        v = np.asarray(values, dtype=float)
        if v.shape != t.shape:
            raise ValueError(f"signal {label!r} has shape {v.shape}; the times have "
                             f"shape {t.shape}")
        ax.plot(t, v, label=label)
    for level in levels:
        ax.axhline(level, color="k", linestyle="--", linewidth=0.8)
    ax.set_xlabel("time [s]")
    if ylabel:
        ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    if signals:
        ax.legend(loc="best")
    ax.grid(True, alpha=0.3)
    return ax


def plot_step_response(time: ArrayLike, response: ArrayLike | Mapping[str, ArrayLike],
                       setpoint: float | None = None, ax: Axes | None = None,
                       ylabel: str = "wheel speed [rad/s]", title: str = "") -> Axes:
    """One step response (an array) or several (a mapping label → array) over time [s], with
    the set-point and its ±2 % settling band when ``setpoint`` is given."""
    signals = dict(response) if isinstance(response, Mapping) else {"response": response}
    ax = plot_signals(time, signals, ax, ylabel, title)
    if setpoint is not None:
        ax.axhline(setpoint, color="k", linestyle="--", linewidth=0.8, label="set-point")
        ax.axhspan(0.98 * setpoint, 1.02 * setpoint, color="0.5", alpha=0.15,
                   label="±2 % band")
        ax.legend(loc="best")
    elif not isinstance(response, Mapping):
        legend = ax.get_legend()
        if legend is not None:  # one unnamed response needs no legend
            legend.remove()
    return ax
