"""OccupancyGridMap with a log-odds update handed in as a function (a lab's
update_log_odds): the textbook's per-scan update — each cell's changes summed, then one
clamped update — gives the kit's beam-by-beam grid wherever the two rules agree, and a
broken update shows in the map."""

from __future__ import annotations

import numpy as np
import pytest

from kit import mapping, msgs


def scan(ranges) -> msgs.LaserScan:
    r = np.asarray(ranges, dtype=np.float32)
    return msgs.LaserScan(angle_min=-0.6, angle_max=-0.6 + 0.1 * (len(r) - 1),
                          angle_increment=0.1, range_min=0.1, range_max=6.0, ranges=r)


def build(update=None, scans=3) -> mapping.OccupancyGridMap:
    grid = mapping.OccupancyGridMap(0.05, update=update)
    for k in range(scans):
        grid.insert_scan(scan(np.full(13, 3.0 + 0.01 * k)), [0.0, 0.2 * k, 0.0])
    return grid


def test_per_scan_update_matches_the_beam_by_beam_grid_where_no_cell_is_both_hit_and_passed():
    kit, per_scan = build(), build(mapping.update_log_odds)
    np.testing.assert_allclose(per_scan.log_odds, kit.log_odds, atol=1e-12)
    assert kit.log_odds.max() > 0 and kit.log_odds.min() < 0


def test_a_cell_passed_several_times_in_one_scan_gets_every_pass_then_one_clamp():
    m = mapping.InverseSensorModel()
    calls = []

    def spy(l, change, l_min, l_max):  # noqa: E741
        calls.append(np.asarray(change).copy())
        return mapping.update_log_odds(l, change, l_min, l_max)

    grid = build(spy, scans=1)
    assert len(calls) == 1                         # one update per scan
    origin_cell = grid.cells([0.0, 0.0])[0]
    # the sensor's own cell is passed by all 13 beams: 13 · l_free, clamped once
    assert grid.log_odds[origin_cell[1], origin_cell[0]] == pytest.approx(
        max(13 * m.l_free, m.l_min))
    assert np.isclose(calls[0], 13 * m.l_free).sum() >= 1


def test_an_update_that_forgets_to_clamp_grows_without_bound():
    unclamped = build(lambda l, c, lo, hi: np.asarray(l) + np.asarray(c), scans=12)  # noqa: E741
    assert unclamped.log_odds.min() < mapping.InverseSensorModel().l_min - 1.0


def test_an_update_of_the_wrong_shape_is_refused():
    with pytest.raises(ValueError, match="one log-odds per cell"):
        build(lambda l, c, lo, hi: np.zeros(3))  # noqa: E741
