"""grader.standin: the student's function where it runs, the kit's (with a one-line notice)
where it is not done yet or cannot run its first public case."""

from __future__ import annotations

import numpy as np
import pytest

from grader.spec import load_lab
from grader.standin import Yours


def normalize_log_weights(log_weights):
    raise NotImplementedError()


def should_resample(weights, threshold):
    return bool(1 / np.sum(np.square(weights)) < threshold * len(weights))


def low_variance_resample(weights, n, r):
    return np.searchsorted(weights, 1.0, "weird")     # raises ValueError


def test_a_stub_and_a_broken_function_give_way_to_the_kits_with_a_notice(capsys):
    yours = Yours("lab07")
    pieces = yours.pieces(normalize_log_weights, should_resample, low_variance_resample)
    assert pieces == (None, should_resample, None)
    out = capsys.readouterr().out.splitlines()
    assert out == [
        "`normalize_log_weights` (exercise 5) is not done yet: the kit's version stands in",
        "`low_variance_resample` (exercise 7) raises ValueError on its first public case: the "
        "kit's version stands in"]


def test_a_function_stands_in_with_the_exercises_own_signature(capsys):
    yours = Yours("lab07")
    standin = yours.function(normalize_log_weights)
    assert standin is load_lab("lab07").exercise("normalize_log_weights").reference
    np.testing.assert_allclose(standin(np.log([1.0, 3.0])), [0.25, 0.75])
    assert "not done yet" in capsys.readouterr().out
    assert yours.function(should_resample) is should_resample
    assert yours.done(should_resample) and not yours.done(should_resample,
                                                          normalize_log_weights)
    assert capsys.readouterr().out == ""


def test_a_function_that_is_no_exercise_is_named():
    def helper(x):
        return x

    with pytest.raises(ValueError, match="helper is not an exercise of lab07"):
        Yours("lab07").pieces(helper)


def test_a_function_whose_earlier_exercise_is_not_done_names_that_one(capsys):
    def beam_angles(angle_min, angle_increment, n):
        raise NotImplementedError()

    def scan_to_points(ranges, angle_min, angle_increment, range_min, range_max, T):
        return beam_angles(angle_min, angle_increment, len(ranges))

    yours = Yours("lab06")
    assert yours.function(scan_to_points) is yours.reference(scan_to_points)
    assert capsys.readouterr().out == ("`scan_to_points` (exercise 3) needs `beam_angles` "
                                       "(exercise 1), not done yet: the kit's version stands "
                                       "in\n")
