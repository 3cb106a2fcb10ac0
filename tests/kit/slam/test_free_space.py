"""The free space recent scans have seen, and the test that takes a return in it for
something that moves: a sensor in a room sweeping its beams to the walls many times."""

from __future__ import annotations

import numpy as np
import pytest

from kit.slam.free_space import FreeSpace

ROOM = 4.0
"""A square room [0, 4] m × [0, 4] m."""


def sweep(free: FreeSpace, sensor=(1.0, 2.0), beams=720, scans=5) -> None:
    """``scans`` full turns of beams from ``sensor`` to the room's walls."""
    s = np.asarray(sensor, dtype=float)
    angles = np.linspace(-np.pi, np.pi, beams, endpoint=False)
    d = np.column_stack([np.cos(angles), np.sin(angles)])
    with np.errstate(divide="ignore"):
        reach = np.min(np.column_stack([np.where(d[:, 0] > 0, (ROOM - s[0]) / d[:, 0], np.inf),
                                        np.where(d[:, 0] < 0, -s[0] / d[:, 0], np.inf),
                                        np.where(d[:, 1] > 0, (ROOM - s[1]) / d[:, 1], np.inf),
                                        np.where(d[:, 1] < 0, -s[1] / d[:, 1], np.inf)]),
                       axis=1)
    for _ in range(scans):
        free.insert(s, s + d * reach[:, None], np.ones(beams, dtype=bool))


def test_a_return_in_the_middle_of_swept_space_moves_one_at_a_wall_does_not():
    free = FreeSpace(resolution=0.05, margin=0.15)
    sweep(free)
    points = np.array([[2.5, 2.0],    # in the open, crossed by many beams: a person
                       [3.99, 2.0],   # on the wall
                       [3.9, 2.0],    # 0.1 m from the wall: within the margin of it
                       [6.0, 2.0]])   # behind the wall: never seen
    assert free.moving(points).tolist() == [True, False, False, False]


def test_one_sweep_is_not_enough_to_call_space_free():
    """A cell is seen free below 25 % occupancy: one pass of a beam (40 %) is not enough."""
    free = FreeSpace(resolution=0.05, margin=0.15)
    sweep(free, scans=1)
    assert not free.moving([[2.5, 2.0]]).any()
    sweep(free, scans=2)
    assert free.moving([[2.5, 2.0]]).all()


def test_a_beam_that_ended_on_something_moving_still_clears_but_marks_nothing():
    """A person's return given as no hit: the beam clears up to it and the cell stays
    free, so the next scan's return there is taken for moving again."""
    free = FreeSpace(resolution=0.05, margin=0.15)
    sweep(free)
    person = np.array([[2.5, 2.0]])
    free.insert([1.0, 2.0], person, [False])
    assert free.moving(person).all()
    free.insert([1.0, 2.0], np.repeat(person, 5, axis=0), np.ones(5, bool))
    assert not free.moving(person).any()      # taken as a hit five times: now occupied


def test_long_beams_clear_only_up_to_max_range():
    free = FreeSpace(resolution=0.05, margin=0.1, max_range=2.0)
    fan = np.radians(np.linspace(-15, 15, 121))
    for _ in range(6):      # a fan of beams ending on a wall 10 m away
        free.insert([0.0, 0.0], 10.0 * np.column_stack([np.cos(fan), np.sin(fan)]),
                    np.ones(len(fan), dtype=bool))
    assert free.moving([[1.5, 0.0]]).all()
    assert not free.moving([[3.0, 0.0]]).any()


def test_nothing_moves_before_the_first_scan_and_after_clear():
    free = FreeSpace()
    assert not free.moving([[1.0, 1.0]]).any()
    sweep(free)
    free.clear()
    assert free.scans == 0 and not free.moving([[2.5, 2.0]]).any()


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="free_probability"):
        FreeSpace(free_probability=0.6)
    with pytest.raises(ValueError, match="margin"):
        FreeSpace(margin=-1.0)


def test_the_compiled_test_answers_as_numpys_for_every_point_near_and_far():
    """Points everywhere, inside the swept room, on and behind its walls, off the grid: the
    compiled test (each point stops at its first cell not seen free) and numpy's (every cell
    of every point) agree, with a margin of 0 and of 0.15 m."""
    rng = np.random.default_rng(3)
    points = rng.uniform(-1.0, 5.0, (4000, 2))
    for margin in (0.0, 0.15):
        free = FreeSpace(resolution=0.05, margin=margin)
        sweep(free, sensor=(1.5, 1.0))
        sweep(free, sensor=(2.5, 3.0), scans=3)
        compiled = free.moving(points)
        assert compiled.dtype == bool and 200 < compiled.sum() < 3800
        assert np.array_equal(compiled, free.moving(points, compiled=False))
