"""Occupancy grids: the line tracer, the inverse sensor model with REP-117 beams, the compiled
update against the plain one, growing bounds and map_server files."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kit import mapping, maps, msgs


def test_bresenham_lines_are_connected_end_to_end_and_hug_the_true_line():
    rng = np.random.default_rng(0)
    for _ in range(300):
        a, b = rng.integers(-40, 40, 2), rng.integers(-40, 40, 2)
        cells = mapping.bresenham(tuple(a), tuple(b))
        assert cells[0].tolist() == a.tolist() and cells[-1].tolist() == b.tolist()
        assert len(cells) == max(abs(b - a)) + 1
        steps = np.abs(np.diff(cells, axis=0))
        assert np.all(steps.max(axis=1) == 1)  # 8-connected, one cell at a time
        d = b - a
        if np.any(d):
            # distance of each cell centre from the ideal line, along the minor axis
            major = int(np.argmax(np.abs(d)))
            t = (cells[:, major] - a[major]) / d[major]
            ideal = a[1 - major] + t * d[1 - major]
            assert np.all(np.abs(cells[:, 1 - major] - ideal) <= 0.5 + 1e-9)


def test_log_odds_update_is_clamped_and_probability_inverts_log_odds():
    assert mapping.update_log_odds(3.4, 0.85, -2.0, 3.5) == 3.5
    assert mapping.update_log_odds(-1.9, -0.41, -2.0, 3.5) == -2.0
    p = np.array([0.1, 0.5, 0.9])
    assert np.allclose(mapping.probability(mapping.log_odds(p)), p)
    with pytest.raises(ValueError, match="strictly between 0 and 1"):
        mapping.log_odds(1.0)


def scan(ranges, angle_min=0.0, inc=np.pi / 2, range_max=5.0):
    return msgs.LaserScan(angle_min=angle_min, angle_increment=inc, range_min=0.2,
                          range_max=range_max, ranges=np.array(ranges, dtype=float))


def test_a_return_clears_the_beam_and_marks_its_end():
    m = mapping.OccupancyGridMap(0.1)
    m.insert_scan(scan([1.03]), [0.0, 0.0, 0.0])
    model = m.model
    assert m.probability_at([1.05, 0.05]) == pytest.approx(model.p_occupied)
    for x in (0.05, 0.45, 0.95):
        assert m.probability_at([x, 0.05]) == pytest.approx(model.p_free)
    assert m.probability_at([1.15, 0.05]) == 0.5  # behind the obstacle: unknown
    for _ in range(20):  # seen again and again, a cell saturates at the clamps
        m.insert_scan(scan([1.03]), [0.0, 0.0, 0.0])
    assert m.probability_at([1.05, 0.05]) == pytest.approx(model.p_max)
    assert m.probability_at([0.55, 0.05]) == pytest.approx(model.p_min)


def test_max_range_beams_clear_without_marking_and_invalid_beams_say_nothing():
    m = mapping.OccupancyGridMap(0.1)
    # +inf and a reading beyond range_max: nothing up to range_max; -inf, NaN: no information
    m.insert_scan(scan([np.inf, 7.0, -np.inf, np.nan]), [0.03, 0.03, 0.0])
    p = m.probability()
    assert p.max() == 0.5  # nothing marked anywhere (0.5: never seen)
    assert m.probability_at([4.95, 0.05]) == pytest.approx(m.model.p_free)   # +inf beam
    assert m.probability_at([0.05, 4.95]) == pytest.approx(m.model.p_free)   # 7 m > range_max
    assert m.probability_at([-1.0, 0.05]) == 0.5                             # -inf beam
    assert m.probability_at([0.05, -1.0]) == 0.5                             # NaN beam
    capped = mapping.OccupancyGridMap(0.1, model=mapping.InverseSensorModel(max_clear_range=2))
    capped.insert_scan(scan([np.inf]), [0.0, 0.0, 0.0])
    assert capped.probability_at([3.0, 0.05]) == 0.5


def test_compiled_update_equals_the_plain_one_cell_for_cell():
    rng = np.random.default_rng(1)
    a, b = mapping.OccupancyGridMap(0.05), mapping.OccupancyGridMap(0.05)
    for _ in range(15):
        ranges = rng.uniform(0.3, 6.0, 180)
        ranges[rng.random(180) < 0.1] = np.inf
        s = scan(ranges, -np.pi, 2 * np.pi / 180, 8.0)
        pose = [*rng.uniform(-2, 2, 2), rng.uniform(-np.pi, np.pi)]
        a.insert_scan(s, pose)
        b.insert_scan(s, pose, compiled=False)
    assert a.shape == b.shape and np.array_equal(a.log_odds, b.log_odds)
    assert a.log_odds.max() > 0 > a.log_odds.min()


def test_the_grid_grows_and_keeps_what_it_knew_in_place():
    m = mapping.OccupancyGridMap(0.1)
    m.insert_scan(scan([1.03]), [0.0, 0.0, 0.0])
    before = m.probability_at([1.05, 0.05])
    shape = m.shape
    m.insert_scan(scan([1.03]), [30.0, -40.0, np.pi])
    assert m.shape[0] > shape[0] and m.shape[1] > shape[1]
    assert m.probability_at([1.05, 0.05]) == before
    assert m.probability_at([28.95, -39.95]) > 0.5


def rectangle_scan(pose, size=(6.0, 4.0), beams=360):
    """Exact ranges from ``pose`` to the walls of the room [0, w] × [0, h]."""
    a = pose[2] + np.linspace(-np.pi, np.pi, beams, endpoint=False)
    c, s = np.cos(a), np.sin(a)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (size[0] - pose[0]) / c, np.where(c < 0, -pose[0] / c, np.inf))
        ty = np.where(s > 0, (size[1] - pose[1]) / s, np.where(s < 0, -pose[1] / s, np.inf))
    return scan(np.minimum(tx, ty), -np.pi, 2 * np.pi / beams, 10.0)


def test_a_room_mapped_from_known_poses_has_its_walls_where_they_are(tmp_path):
    m = mapping.OccupancyGridMap(0.05)
    for pose in ([1.0, 1.0, 0.0], [3.0, 2.0, 1.0], [5.0, 3.0, -2.0], [2.0, 3.0, 0.5]):
        m.insert_scan(rectangle_scan(np.array(pose)), pose)
    grid = m.trinary()
    rows, cols = np.nonzero(grid == 100)
    x = m.origin[0] + (cols + 0.5) * m.resolution
    y = m.origin[1] + (rows + 0.5) * m.resolution
    wall_distance = np.minimum(np.minimum(np.abs(x), np.abs(x - 6)),
                               np.minimum(np.abs(y), np.abs(y - 4)))
    assert len(x) > 300 and wall_distance.max() <= 0.05 * np.sqrt(2)
    inside = (grid == 0)
    assert inside.sum() > 0.8 * (6 * 4) / 0.05**2  # most of the room seen empty
    # saved as a map_server map it reads back as the same trinary grid
    m.save(tmp_path / "room.yaml")
    back = maps.read_map(tmp_path / "room.yaml")
    assert back.info.width == m.shape[1] and back.info.height == m.shape[0]
    assert np.array_equal(back.data.reshape(m.shape), grid)
    assert back.info.origin.position.x == pytest.approx(m.origin[0])
    loaded = mapping.OccupancyGridMap.load(tmp_path / "room.yaml")
    assert np.array_equal(loaded.trinary(), grid)


def test_bad_input_is_rejected():
    with pytest.raises(ValueError, match="resolution must be positive"):
        mapping.OccupancyGridMap(0.0)
    with pytest.raises(ValueError, match="p_min < p_free"):
        mapping.InverseSensorModel(p_free=0.6)
    m = mapping.OccupancyGridMap(0.1)
    with pytest.raises(ValueError, match="pose"):
        m.insert_scan(scan([1.0]), [0.0, 0.0])
    with pytest.raises(ValueError, match="one flag per endpoint"):
        m.insert_points([0, 0], [[1, 1], [2, 2]], [True])
    with pytest.raises(ValueError, match="finite"):
        m.insert_points([0, 0], [[np.nan, 1]], [True])
    with pytest.raises(ValueError, match="empty"):
        m.save("never.yaml")
    with pytest.raises(ValueError, match="thresholds"):
        m.trinary(0.7, 0.6)


def test_trinary_of_a_map_taller_than_its_row_blocks_is_map_servers_rule_on_every_cell():
    """trinary works through a large map a block of rows at a time (no float copy of the
    whole grid): every cell still gets map_server's rule, p > occupied_thresh → 100,
    p < free_thresh → 0, −1 between, at the block boundaries and at the thresholds too."""
    rng = np.random.default_rng(5)
    grid = mapping.OccupancyGridMap(0.05)
    grid.log_odds = rng.normal(0.0, 2.0, (700, 9)) * (rng.random((700, 9)) < 0.8)
    at = [math.log(0.65 / 0.35), math.log(0.196 / 0.804)]
    grid.log_odds[255:258, :2] = at  # across the first block boundary
    p = 1.0 / (1.0 + np.exp(-grid.log_odds))
    want = np.where(p > 0.65, 100, np.where(p < 0.196, 0, -1)).astype(np.int8)
    assert np.array_equal(grid.trinary(), want)
    assert set(np.unique(want).tolist()) == {-1, 0, 100}
