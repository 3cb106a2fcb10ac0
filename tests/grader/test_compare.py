"""grader.compare's messages for integer and boolean arrays and for inf/NaN answers."""

from __future__ import annotations

import warnings

import numpy as np

from grader.compare import compare, generic_hint


def test_integer_arrays_say_how_many_cells_differ_and_where():
    expected = np.zeros((30, 40), dtype=np.uint8)
    expected[10:20, 15:25] = 253
    got = expected.copy()
    got[12, 20] = 252                      # deep in the middle: elided from a printed array
    got[17, 16] = 0
    message = compare(expected, got)
    assert message is not None
    assert "2 of 1200 values differ (exact integers)" in message
    assert "at (12, 20) expected 253, got 252" in message
    assert "at (17, 16) expected 253, got 0" in message
    assert message.index("(12, 20)") < message.index("(17, 16)")     # row-major order


def test_only_the_first_three_differing_cells_are_shown():
    expected = np.arange(100, dtype=np.int64).reshape(10, 10)
    got = expected.copy()
    got[0, :7] += 1
    message = compare(expected, got)
    assert message is not None
    assert "7 of 100 values differ" in message and "… and 4 more" in message
    assert "(0, 2)" in message and "(0, 3)" not in message


def test_a_small_integer_array_is_also_printed_whole():
    message = compare(np.array([1, 2, 3]), np.array([1, 5, 3]))
    assert message == ("the output: 1 of 3 values differ (exact integers) (expected [1, 2, 3], "
                       "got [1, 5, 3]): at (1,) expected 2, got 5")


def test_boolean_arrays_name_the_cells_that_differ():
    expected = np.zeros((20, 20), dtype=bool)
    got = expected.copy()
    got[5, 7] = True
    message = compare(expected, got)
    assert message is not None
    assert "1 of 400 values differ (booleans): at (5, 7) expected False, got True" in message


def test_equal_integer_and_boolean_arrays_pass_whatever_the_dtype_returned():
    assert compare(np.array([[253, 0]], np.uint8), np.array([[253.0, 0.0]])) is None
    assert compare(np.array([True, False]), np.array([1, 0])) is None


def test_a_float_answer_for_integer_cells_shows_its_fraction():
    message = compare(np.array([1, 2], np.uint8), np.array([1.0, 2.5]))
    assert message is not None and "at (1,) expected 2, got 2.5" in message


def test_integer_scalars_keep_their_one_line_message():
    assert compare(np.int64(437), 436) == "the output: expected 437, got 436 (exact integers)"


def test_python_integers_beyond_int64_compare_exactly():
    """A CRC never cut to 16 bits grows past int64: it is compared (and shown) as the
    integer it is, not refused as an array of objects."""
    grown = 2**80 + 0x31C3
    assert compare(0x31C3, grown) == (f"the output: expected 12739, got {grown} "
                                      f"(exact integers)")
    assert compare(grown, grown) is None
    assert compare(2**70, 2**70 + 1) is not None
    assert compare(437, 436) == "the output: expected 437, got 436 (exact integers)"


def test_inf_and_nan_answers_raise_no_warning():
    cases = [
        (np.array([-np.inf, 1.0, -2.0]), np.array([-np.inf, np.nan, -3.0])),
        (np.array([-np.inf, 1.0]), np.array([-np.inf, 2.0])),
        (np.array([np.inf, 1.0]), np.array([1.0, 1.0])),
        (np.array([1.0, 2.0]), np.array([np.inf, -np.inf])),
        (np.array([3, 4], np.uint8), np.array([np.nan, np.inf])),
        (np.array([[0.5, np.nan]]), np.array([[np.inf, 0.0]])),
    ]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for expected, got in cases:
            assert compare(expected, got) is not None
        assert generic_hint(np.array([np.inf, 1.0]), np.array([np.inf, np.nan]), 1e-6,
                            1e-9) == ""
    assert "largest error 1 at index (1,)" in compare(np.array([-np.inf, 1.0]),
                                                      np.array([-np.inf, 2.0]))
