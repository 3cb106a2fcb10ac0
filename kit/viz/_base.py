"""Shared helpers of the plotting modules."""

from __future__ import annotations

import matplotlib.pyplot as plt
from matplotlib.axes import Axes

__all__ = ["axes"]


def axes(ax: Axes | None, equal: bool = False) -> Axes:
    """``ax``, or a new figure's axes when ``None``; ``equal`` sets a 1:1 aspect (maps, paths)."""
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4.5))
    if equal:
        ax.set_aspect("equal", adjustable="datalim")
    return ax
