"""Planning plots draw what they are given: the costs, the path, the expanded cells."""

import matplotlib.pyplot as plt
import numpy as np

from kit import viz
from kit.planning import Costmap, astar, compute_path_to_pose


def test_plot_costmap_shows_the_costs_in_the_map_frame():
    costs = np.zeros((20, 30), np.uint8)
    costs[5:8, 10:12] = 254
    cm = Costmap(costs, 0.1, origin=(-1.0, 2.0))
    ax = viz.plot_costmap(cm, colorbar=True)
    image = ax.get_images()[0]
    np.testing.assert_array_equal(image.get_array(), costs)
    assert tuple(image.get_extent()) == (-1.0, 2.0, 2.0, 4.0)
    colours = viz.costmap_colors()
    assert colours(254)[:3] == (0.0, 0.0, 0.0) and colours(0)[:3] == (1.0, 1.0, 1.0)
    plt.close("all")


def test_plot_path_and_plot_search_draw_the_path_and_the_expansions():
    costs = np.zeros((20, 30), np.uint8)
    costs[:15, 15] = 254
    cm = Costmap(costs, 0.1)
    result = compute_path_to_pose((0.05, 0.05, 0.0), (2.95, 0.05, 0.0), cm)
    ax = viz.plot_path(result.path, label="A*")
    xy = ax.get_lines()[0].get_xydata()
    assert xy[0].tolist() == [0.05, 0.05] and xy[-1].tolist() == [2.95, 0.05]
    search = astar(costs, (0, 0), (0, 29))
    ax = viz.plot_search(search, costs, label="A*")
    assert len(ax.collections[0].get_offsets()) == search.expanded
    line = ax.get_lines()[0].get_xydata()
    np.testing.assert_array_equal(line[:, ::-1], search.cells)      # (x, y) = (col, row)
    assert ax.get_title().startswith(f"A*: {search.expanded} cells expanded")
    plt.close("all")


def test_importing_kit_viz_does_not_load_the_planners():
    import subprocess
    import sys

    code = "import sys, kit.viz; print('numba' in sys.modules, 'kit.planning' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["False", "False"]
