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
