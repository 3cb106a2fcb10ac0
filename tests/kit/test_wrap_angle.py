"""kit.geometry.wrap_angle: the float fast path gives the array path's numbers."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from kit.geometry import wrap_angle


@given(st.floats(-1e6, 1e6, allow_nan=False))
def test_a_python_float_wraps_exactly_as_an_array_does(angle):
    fast = float(wrap_angle(angle))
    assert fast == float(wrap_angle(np.array([angle]))[0])
    assert -math.pi <= fast < math.pi


def test_multiples_of_pi_land_in_the_half_open_interval():
    for k in range(-6, 7):
        assert float(wrap_angle(k * math.pi)) == (0.0 if k % 2 == 0 else -math.pi)


def test_an_infinite_or_nan_angle_wraps_to_nan_without_a_warning():
    import warnings

    from kit.geometry import transform_points

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.isnan(wrap_angle(np.array([np.inf, -np.inf, np.nan]))).all()
        assert math.isnan(float(wrap_angle(math.inf)))
        points = transform_points(np.array([1.0, 2.0, 0.3]),
                                  np.array([[np.inf, np.inf], [1.0, 0.0]]))
    assert not np.isfinite(points[0]).any()
    assert np.allclose(points[1], [1.0 + math.cos(0.3), 2.0 + math.sin(0.3)])
