"""Local planning pictures: DWB's sampled trajectories coloured by their scores. Lab 10."""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from numpy.typing import ArrayLike

from kit.viz._base import axes as _axes

__all__ = ["plot_rollouts"]


def plot_rollouts(poses: ArrayLike, scores: ArrayLike, ax: Axes | None = None,
                  best: bool = True) -> Axes:
    """Sampled trajectories ``(S, T, 3)`` coloured by ``scores`` ``(S,)`` (low is good;
    ``inf`` — invalid, a collision — drawn grey and dashed), the best one thick."""
    ax = _axes(ax, equal=True)
    p = np.asarray(poses, dtype=float)
    s = np.asarray(scores, dtype=float)
    if p.ndim != 3 or p.shape[0] != len(s):
        raise ValueError(f"poses (S, T, 3) and scores (S,) must agree; got {p.shape} and "
                         f"{s.shape}")
    ok = np.isfinite(s)
    if np.any(~ok):
        ax.add_collection(LineCollection(list(p[~ok, :, :2]), colors="0.6", linestyles="--",
                                         linewidths=0.7, label="invalid (collision)"))
    if np.any(ok):
        lines = LineCollection(list(p[ok, :, :2]), cmap="viridis_r", linewidths=1.0)
        lines.set_array(s[ok])
        ax.add_collection(lines)
        ax.figure.colorbar(lines, ax=ax, label="score (lower is better)")
        if best:
            k = int(np.argmin(np.where(ok, s, np.inf)))
            ax.plot(p[k, :, 0], p[k, :, 1], color="tab:red", linewidth=2.5, label="chosen")
    ax.autoscale_view()
    return ax
