"""Costmaps, paths and searches (Lab 09).

``kit.planning`` (and with it numba) is imported only when a plot needs it, so that importing
``kit.viz`` stays quick for the labs that do not plan.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import ListedColormap
from numpy.typing import ArrayLike, NDArray

from kit import msgs
from kit.viz._base import axes as _axes

if TYPE_CHECKING:
    from kit.planning import Costmap, SearchResult

__all__ = ["costmap_colors", "plot_costmap", "plot_path", "plot_search"]


def costmap_colors() -> ListedColormap:
    """One colour per cost 0–255: free white, inflation from pale yellow to dark red, inscribed
    (253) cyan, lethal (254) black, unknown (255) grey."""
    from matplotlib import colormaps

    table = np.ones((256, 4))
    table[1:253] = colormaps["YlOrRd"](np.linspace(0.05, 1.0, 252))
    table[253] = (0.0, 0.8, 0.9, 1.0)
    table[254] = (0.0, 0.0, 0.0, 1.0)
    table[255] = (0.6, 0.6, 0.65, 1.0)
    return ListedColormap(table, name="nav2_costs")


def _extent(costmap: Costmap) -> tuple[float, float, float, float]:
    x0, y0 = costmap.origin
    return (x0, x0 + costmap.width * costmap.resolution, y0,
            y0 + costmap.height * costmap.resolution)


def plot_costmap(costmap: Costmap | ArrayLike, ax: Axes | None = None,
                 colorbar: bool = False) -> Axes:
    """A costmap in its frame (metres, row 0 at the bottom), or a bare ``(H, W)`` array of
    costs in cells with row 0 at the top (a Moving AI grid), in :func:`costmap_colors`."""
    from kit.planning import Costmap

    ax = _axes(ax, equal=True)
    if isinstance(costmap, Costmap):
        image = ax.imshow(costmap.costs, origin="lower", extent=_extent(costmap),
                          cmap=costmap_colors(), vmin=0, vmax=255, interpolation="nearest")
        ax.set_xlabel(f"x [m] ({costmap.frame_id})")
        ax.set_ylabel(f"y [m] ({costmap.frame_id})")
    else:
        image = ax.imshow(np.asarray(costmap), origin="upper", cmap=costmap_colors(), vmin=0,
                          vmax=255, interpolation="nearest")
        ax.set_xlabel("col (x)")
        ax.set_ylabel("row (y)")
    if colorbar:
        ax.figure.colorbar(image, ax=ax, label="cost (253 inscribed, 254 lethal, 255 unknown)")
    return ax


def plot_path(path: msgs.Path | ArrayLike, ax: Axes | None = None, label: str | None = None,
              color: str = "tab:blue", markers: bool = False) -> Axes:
    """A path (``nav_msgs/Path`` or ``(N, 2)`` points [m]) as a line from start (circle) to
    goal (star)."""
    from kit.planning import path_to_points

    ax = _axes(ax, equal=True)
    points = path_to_points(path) if isinstance(path, msgs.Path) else np.asarray(path, float)
    if len(points) == 0:
        return ax
    ax.plot(points[:, 0], points[:, 1], "-" + ("." if markers else ""), color=color,
            label=label, linewidth=2)
    ax.plot(*points[0], "o", color=color)
    ax.plot(*points[-1], "*", color=color, markersize=12)
    if label:
        ax.legend(loc="best")
    return ax


def _cells_to_xy(cells: NDArray[np.int64], costmap: Costmap | None) -> NDArray[np.float64]:
    if costmap is None:
        return np.column_stack([cells[:, 1], cells[:, 0]]).astype(float)
    return np.column_stack([costmap.origin[0] + (cells[:, 1] + 0.5) * costmap.resolution,
                            costmap.origin[1] + (cells[:, 0] + 0.5) * costmap.resolution])


def plot_search(result: SearchResult, costmap: Costmap | ArrayLike, ax: Axes | None = None,
                label: str | None = None) -> Axes:
    """A search on its grid: the costs, the expanded cells coloured by the order they were
    expanded (dark first), and the path found. ``costmap`` as in :func:`plot_costmap`."""
    from kit.planning import Costmap

    ax = plot_costmap(costmap, ax)
    grid = costmap if isinstance(costmap, Costmap) else None
    if result.expanded:
        xy = _cells_to_xy(result.expanded_cells, grid)
        size = 4.0 if len(xy) < 20000 else 1.0
        ax.scatter(xy[:, 0], xy[:, 1], c=np.arange(len(xy)), cmap="viridis", s=size,
                   marker="s", linewidths=0, alpha=0.6)
    if result.found:
        xy = _cells_to_xy(result.cells, grid)
        ax.plot(xy[:, 0], xy[:, 1], "-", color="tab:blue", linewidth=2)
    title = f"{result.expanded} cells expanded"
    title += f", length {result.length:.2f} cells" if result.found else ", no path"
    ax.set_title(f"{label}: {title}" if label else title)
    return ax
