"""Particle clouds over a map, still or animated: Lab 07."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from numpy.typing import ArrayLike

from kit import msgs
from kit.viz._base import axes as _axes
from kit.viz._grid import plot_grid

__all__ = ["animate_particles", "animation_html", "plot_particles"]


def plot_particles(poses: ArrayLike, weights: ArrayLike | None = None, ax: Axes | None = None,
                   color: str = "tab:orange", label: str = "particles",
                   arrows: bool = False) -> Axes:
    """Particles ``(N, 3)`` (x [m], y [m], θ [rad]) as dots sized by their ``weights`` (equal
    when ``None``), or as short arrows along their headings with ``arrows=True``."""
    ax = _axes(ax, equal=True)
    p = np.asarray(poses, dtype=float).reshape(-1, 3)
    if len(p) == 0:
        return ax
    if arrows:
        ax.quiver(p[:, 0], p[:, 1], np.cos(p[:, 2]), np.sin(p[:, 2]), color=color, width=0.003,
                  scale=40, label=label)
        return ax
    w = np.full(len(p), 1.0 / len(p)) if weights is None else np.asarray(weights, float)
    size = 2.0 + 30.0 * w / max(float(w.max()), 1e-300)
    ax.scatter(p[:, 0], p[:, 1], s=size, color=color, alpha=0.5, linewidths=0, label=label)
    return ax


def animate_particles(grid: msgs.OccupancyGrid, clouds: Sequence[ArrayLike],
                      truth: ArrayLike | None = None, estimates: ArrayLike | None = None,
                      interval_ms: int = 200) -> Any:
    """A ``FuncAnimation`` of the particle ``clouds`` (one ``(N, 3)`` array per frame) over
    ``grid``, with the true pose and the estimate of each frame (``(F, 3)``) when given.
    In a notebook: ``IPython.display.HTML(animation_html(animation))``."""
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation

    fig, ax = plt.subplots(figsize=(8, 5))
    plot_grid(grid, ax)
    cloud = ax.scatter([], [], s=3, color="tab:orange", alpha=0.5, label="particles")
    true_dot, = ax.plot([], [], "o", color="tab:blue", label="truth")
    est_dot, = ax.plot([], [], "x", color="tab:red", markersize=9, label="estimate")
    ax.legend(loc="upper right", fontsize=8)
    t = None if truth is None else np.asarray(truth, float).reshape(-1, 3)
    e = None if estimates is None else np.asarray(estimates, float).reshape(-1, 3)

    def draw(k: int) -> list[Any]:
        p = np.asarray(clouds[k], float).reshape(-1, 3)
        cloud.set_offsets(p[:, :2])
        if t is not None:
            true_dot.set_data([t[k, 0]], [t[k, 1]])
        if e is not None and np.all(np.isfinite(e[k])):
            est_dot.set_data([e[k, 0]], [e[k, 1]])
        ax.set_title(f"frame {k + 1} of {len(clouds)}")
        return [cloud, true_dot, est_dot]

    animation = FuncAnimation(fig, draw, frames=len(clouds), interval=interval_ms, blit=False)
    plt.close(fig)
    return animation


def animation_html(animation: Any, desc: str = "drawing the animation") -> str:
    """``animation.to_jshtml()`` with a progress bar over its frames (:mod:`kit.progress`):
    drawing a few hundred frames takes a while."""
    import tempfile
    from pathlib import Path

    from matplotlib.animation import HTMLWriter

    from kit.progress import progress

    ticks: list[Any] = []

    def advance(frame: int, total: int | None) -> None:
        if not ticks:
            count = int(total or 0)
            ticks.append(iter(progress(range(count), desc=desc, total=count, unit="frame")))
        next(ticks[0], None)

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder, "animation.html")
        fps = max(1, round(1000.0 / float(getattr(animation, "_interval", 200))))
        animation.save(str(path), writer=HTMLWriter(fps=fps, embed_frames=True,
                                                    default_mode="loop"),
                       progress_callback=advance)
        if ticks:
            for _ in ticks[0]:
                pass
        return path.read_text()
