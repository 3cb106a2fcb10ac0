"""Costmaps in Nav2's model: inflation equal to Nav2's formula cell for cell (against an
independent computation from scipy's Euclidean distance transform), footprints, the static
layer's value rules and the keep-out filter."""

import math

import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt

from kit import maps, msgs
from kit.planning import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap,
    apply_keepout,
    footprint_from_radius,
    footprint_radii,
    inflate,
    inflate_reference,
    inflation_cost,
    pad_footprint,
    robot_footprint,
    static_layer,
)
from kit.planning._layered import DEFAULT_PADDING


def nav2_inflation_by_edt(costs, resolution, inscribed, inflation_radius, scaling,
                          inflate_unknown=False, inflate_around_unknown=False):
    """Nav2's inflation written from its documentation and source, on scipy's exact EDT:
    cost 254 at the obstacle, 253 within the inscribed radius, 252·exp(−k (d − r)) beyond,
    cells farther than ceil(inflation_radius / resolution) cells untouched, unknown cells
    overwritten only by inscribed or lethal costs (any cost with inflate_unknown)."""
    source = costs == 254
    if inflate_around_unknown:
        source |= costs == 255
    if not source.any():
        return costs.copy()
    cells = distance_transform_edt(~source)
    d = cells * resolution
    with np.errstate(over="ignore"):
        decay = np.floor(252.0 * np.exp(-scaling * (d - inscribed)))
    cost = np.where(cells == 0, 254, np.where(d <= inscribed, 253, decay))
    reach = cells <= math.ceil(inflation_radius / resolution)
    out = costs.astype(np.int64)
    unknown = out == 255
    threshold = 1 if inflate_unknown else 253
    write_unknown = reach & unknown & (cost >= threshold)
    write_known = reach & ~unknown
    out[write_unknown] = cost[write_unknown]
    out[write_known] = np.maximum(out[write_known], cost[write_known])
    return out.astype(np.uint8)


# ROBOTIS' turtlebot3_navigation2/param/burger.yaml: robot_radius 0.1, inflation_radius 0.55,
# cost_scaling_factor 3.0. The Uiabot: its footprint from hardware/robots with Nav2's default
# inflation (inflation_radius 0.55, cost_scaling_factor 10.0).
ROBOTS = {"turtlebot3_burger": (footprint_from_radius(0.1), 0.55, 3.0),
          "uiabot": (robot_footprint("uiabot"), 0.55, 10.0)}


@pytest.mark.dataset
@pytest.mark.parametrize("robot", sorted(ROBOTS))
@pytest.mark.parametrize("track_unknown_space", [False, True])
@pytest.mark.parametrize("map_yaml", ["nav2-map-server-testmap/testmap.yaml",
                                      "turtlebot3-world-nav2/map.yaml"])
def test_inflation_equals_nav2s_formula_on_real_maps(shared_data, robot, track_unknown_space,
                                                    map_yaml):
    grid = maps.read_map(shared_data / "maps" / map_yaml)
    costs = static_layer(grid, track_unknown_space=track_unknown_space)
    footprint, radius, scaling = ROBOTS[robot]
    inscribed, _ = footprint_radii(pad_footprint(footprint, DEFAULT_PADDING))
    res = grid.info.resolution
    expected = nav2_inflation_by_edt(costs, res, inscribed, radius, scaling)
    got = inflate(costs, res, inscribed_radius=inscribed, inflation_radius=radius,
                  cost_scaling_factor=scaling)
    np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(inflate_reference(costs, res, inscribed_radius=inscribed,
                                                    inflation_radius=radius,
                                                    cost_scaling_factor=scaling), expected)
    lethal = costs == LETHAL_OBSTACLE
    assert (got[lethal] == LETHAL_OBSTACLE).all()
    near = (distance_transform_edt(~lethal) * res <= inscribed) & ~lethal
    assert (got[near & (costs != NO_INFORMATION)] == INSCRIBED_INFLATED_OBSTACLE).all()
    assert len(np.unique(got[(got > 0) & (got < 253)])) >= 3      # a real gradient


def test_compiled_inflation_equals_the_reference_with_every_option():
    rng = np.random.default_rng(4)
    for _ in range(60):
        costs = rng.choice(np.array([0, 0, 0, 0, 40, 100, 253, 254, 255], np.uint8),
                           tuple(rng.integers(1, 30, 2)))
        kw = dict(inscribed_radius=float(rng.uniform(0, 0.3)),
                  inflation_radius=float(rng.uniform(0, 0.9)),
                  cost_scaling_factor=float(rng.uniform(0, 12)),
                  inflate_unknown=bool(rng.integers(2)),
                  inflate_around_unknown=bool(rng.integers(2)))
        res = float(np.float32(rng.choice([0.03, 0.05, 0.1])))
        expected = nav2_inflation_by_edt(costs, res, kw["inscribed_radius"],
                                         kw["inflation_radius"], kw["cost_scaling_factor"],
                                         kw["inflate_unknown"], kw["inflate_around_unknown"])
        np.testing.assert_array_equal(inflate(costs, res, **kw), expected)
        np.testing.assert_array_equal(inflate_reference(costs, res, **kw), expected)


def test_inflation_cost_follows_nav2s_formula():
    d = np.array([0.0, 0.05, 0.1, 0.15, 0.5])
    expected = [254, 253, 253, math.floor(252 * math.exp(-3.0 * 0.05)),
                math.floor(252 * math.exp(-3.0 * 0.4))]
    assert inflation_cost(d, 0.1, 3.0).tolist() == expected
    assert inflation_cost([0.2], 0.1, 0.0).tolist() == [252]       # no decay: MAX_NON_OBSTACLE


def test_a_cell_exactly_at_the_inscribed_radius_is_inscribed_in_double_precision():
    costs = np.zeros((1, 4), np.uint8)
    costs[0, 0] = LETHAL_OBSTACLE
    # 2 cells x 0.05 m = 0.1 exactly in double precision: inscribed
    assert inflate(costs, 0.05, inscribed_radius=0.1)[0, 2] == INSCRIBED_INFLATED_OBSTACLE
    # a map's float32 resolution makes the same cell 0.1000000015 m away: not inscribed
    res32 = float(np.float32(0.05))
    assert inflate(costs, res32, inscribed_radius=0.1)[0, 2] == 251


def test_unknown_cells_take_only_inscribed_or_lethal_costs_unless_inflate_unknown():
    costs = np.array([[254, 255, 255, 255, 255]], np.uint8)
    plain = inflate(costs, 0.1, inscribed_radius=0.1, inflation_radius=0.4,
                    cost_scaling_factor=1.0)
    assert plain.tolist() == [[254, 253, 255, 255, 255]]
    eager = inflate(costs, 0.1, inscribed_radius=0.1, inflation_radius=0.4,
                    cost_scaling_factor=1.0, inflate_unknown=True)
    assert eager[0, 2:].tolist() == [228, 206, 186]
    around = inflate(np.array([[255, 0, 0]], np.uint8), 0.1, inscribed_radius=0.1,
                     inflation_radius=0.2, inflate_around_unknown=True)
    assert around.tolist() == [[254, 253, 92]]    # the unknown source itself turns lethal


def test_inflation_inputs_are_checked():
    with pytest.raises(ValueError, match="uint8 array"):
        inflate(np.zeros((3, 3)), 0.05, inscribed_radius=0.1)
    with pytest.raises(ValueError, match="resolution must be a positive"):
        inflate(np.zeros((3, 3), np.uint8), 0.0, inscribed_radius=0.1)
    with pytest.raises(ValueError, match="inflation_radius must be a non-negative"):
        inflate(np.zeros((3, 3), np.uint8), 0.05, inscribed_radius=0.1, inflation_radius=-1)


def polygon_distances_by_sampling(points, n=20001):
    """Smallest and largest distance from the origin to a polygon's boundary, by sampling
    each edge densely (independent of Nav2's vertex/edge formula)."""
    p = np.asarray(points)
    t = np.linspace(0, 1, n)[:, None]
    samples = np.vstack([a + t * (b - a) for a, b in zip(p, np.roll(p, -1, axis=0),
                                                         strict=True)])
    d = np.hypot(samples[:, 0], samples[:, 1])
    return d.min(), d.max()


@pytest.mark.parametrize("footprint", [footprint_from_radius(0.1), footprint_from_radius(0.22),
                                       robot_footprint("uiabot"), robot_footprint("igv"),
                                       robot_footprint("eddie")])
def test_footprint_radii_are_the_nearest_and_farthest_boundary_points(footprint):
    padded = pad_footprint(footprint, DEFAULT_PADDING)
    inscribed, circumscribed = footprint_radii(padded)
    lo, hi = polygon_distances_by_sampling(padded)
    assert inscribed == pytest.approx(lo, abs=1e-6)
    assert circumscribed == pytest.approx(hi, abs=1e-9)


def test_nav2_footprint_conventions():
    circle = footprint_from_radius(0.2)
    assert circle.shape == (16, 2) and np.allclose(np.hypot(*circle.T), 0.2)
    inscribed, circumscribed = footprint_radii(circle)
    assert inscribed == pytest.approx(0.2 * math.cos(math.pi / 16))
    assert circumscribed == pytest.approx(0.2)
    np.testing.assert_allclose(pad_footprint([[1, 0], [0, -2], [-1, 1]], 0.5),
                               [[1.5, 0], [0, -2.5], [-1.5, 1.5]])
    uiabot = footprint_radii(pad_footprint(robot_footprint("uiabot"), 0.01))
    assert uiabot == pytest.approx((0.19, math.hypot(0.23, 0.21)))
    assert DEFAULT_PADDING == np.float32(0.01) and DEFAULT_PADDING != 0.01
    with pytest.raises(ValueError, match=r"\(N, 2\) polygon of N >= 3"):
        footprint_radii([[0, 0], [1, 1]])
    with pytest.raises(ValueError, match="robot_radius must be a positive"):
        footprint_from_radius(0.0)


def grid_of(values, resolution=0.05, origin=(0.0, 0.0)):
    values = np.asarray(values, dtype=np.int8)
    info = msgs.MapMetaData(resolution=resolution, width=values.shape[1],
                            height=values.shape[0],
                            origin=msgs.Pose(msgs.Point(origin[0], origin[1], 0.0)))
    return msgs.OccupancyGrid(msgs.Header(frame_id="map"), info, values.ravel())


def test_static_layer_interprets_values_as_nav2s_static_layer():
    grid = grid_of([[0, 50, 99, 100, -1]])
    assert static_layer(grid).tolist() == [[0, 0, 253, 254, 0]]
    assert static_layer(grid, track_unknown_space=True).tolist() == [[0, 0, 253, 254, 255]]
    assert static_layer(grid, trinary_costmap=False,
                        lethal_cost_threshold=60).tolist() == [[0, 211, 253, 254, 0]]
    assert static_layer(grid, trinary_costmap=False).tolist() == [[0, 127, 253, 254, 0]]
    # Jazzy and Humble: no inscribed value, 99 is a value like any other
    jazzy = static_layer(grid, inscribed_obstacle_cost_value=None, trinary_costmap=False)
    assert jazzy.tolist() == [[0, 127, 251, 254, 0]]
    assert static_layer(grid, inscribed_obstacle_cost_value=None).tolist() == [[0, 0, 0, 254, 0]]


@pytest.mark.parametrize("unknown", [-1, 255])
def test_unknown_cost_value_is_a_byte_as_in_nav2(unknown):
    """Nav2 keeps ``unknown_cost_value`` in an unsigned char, so ROS 1's -1 is its default 255:
    unknown cells stay unknown (or free), never lethal."""
    grid = grid_of([[0, 100, -1]])
    assert static_layer(grid, unknown_cost_value=unknown,
                        track_unknown_space=True).tolist() == [[0, 254, 255]]
    assert static_layer(grid, unknown_cost_value=unknown).tolist() == [[0, 254, 0]]


@pytest.mark.dataset
def test_static_layer_of_the_turtlebot3_map_counts_its_cells(shared_data):
    grid = maps.read_map(shared_data / "maps" / "turtlebot3-world-nav2" / "map.yaml")
    costs = static_layer(grid, track_unknown_space=True)
    counts = {int(v): int(n) for v, n in zip(*np.unique(costs, return_counts=True),
                                             strict=True)}
    assert counts == {0: 7939, 254: 795, 255: 138722}     # the data's README
    assert int((static_layer(grid) == 0).sum()) == 7939 + 138722


def test_keepout_mask_raises_costs_by_nav2s_rule():
    costs = np.array([[0, 0, 0, 0, 200, 255]], np.uint8)
    mask = grid_of([[100, 50, 75, -1, 50, 10]], resolution=0.1)
    out = apply_keepout(costs, mask, 0.1, (0.0, 0.0))
    # round(254 v / 100) halves away from zero: 75 -> 190.5 -> 191; -1 leaves the cell,
    # 127 < 200 leaves it, an unknown cell takes any mask cost
    assert out.tolist() == [[254, 127, 191, 0, 200, 25]]


def test_keepout_mask_of_another_resolution_and_origin_is_looked_up_at_cell_centres():
    costs = np.zeros((4, 6), np.uint8)
    mask = grid_of([[100, 0], [0, 0]], resolution=0.1, origin=(0.05, 0.0))
    out = apply_keepout(costs, mask, 0.05, (0.0, 0.0))
    expected = np.zeros((4, 6), np.uint8)
    expected[0:2, 1:3] = 254              # centres x 0.075, 0.125 and y 0.025, 0.075
    np.testing.assert_array_equal(out, expected)


def test_costmap_value_type_checks_and_converts():
    cm = Costmap(np.array([[0, 100, 253], [254, 255, 1]], np.uint8), 0.05, (1.0, 2.0))
    assert cm.world_to_cell(1.06, 2.07) == (1, 1)
    assert cm.cell_to_world(1, 1) == pytest.approx((1.075, 2.075))
    with pytest.raises(ValueError, match=r"goal \(0.9, 2\) is off the map"):
        cm.world_to_cell(0.9, 2.0, "goal")
    assert cm.to_occupancy_grid().data.tolist() == [0, 39, 99, 100, -1, 1]
    assert not cm.costs.flags.writeable
    with pytest.raises(ValueError, match="resolution must be a positive"):
        Costmap(np.zeros((2, 2), np.uint8), -0.1)
    with pytest.raises(ValueError, match=r"non-empty \(height, width\)"):
        Costmap(np.zeros(4, np.uint8), 0.1)
