"""Compare a student's output with the expected one and say, in a sentence, what is wrong.

:func:`compare` returns ``None`` when the output is right (within the tolerances) and
otherwise a message for the student: which part of the output is off, expected against got,
and a hint when the difference looks like a classic robotics bug — degrees for radians, an
angle off by a multiple of 2π, the two wheels swapped, a sign flipped, a matrix transposed.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from kit import msgs

__all__ = ["compare", "generic_hint"]

_NUMERIC = (int, float, np.integer, np.floating, np.bool_)


PRECISION = 6
"""decimals of the numbers in a message."""


def _without_negative_zero(value: np.ndarray) -> np.ndarray:
    """``value`` as printed: rounded to :data:`PRECISION` decimals, and every zero unsigned.

    The sign of a zero (and of a value that rounds to zero) depends on the order of the
    floating-point operations, which depends on the CPU's vector instructions; a message must
    not say ``-0.`` on one machine and ``0.`` on another.
    """
    if value.dtype.kind not in "fc":
        return value
    shown = np.round(value, PRECISION)
    return shown + np.zeros((), dtype=shown.dtype)  # -0.0 + 0.0 is +0.0


def _fmt(value: Any) -> str:
    if isinstance(value, np.ndarray):
        with np.printoptions(precision=PRECISION, suppress=True, threshold=12, edgeitems=3):
            return np.array2string(_without_negative_zero(value), separator=", ")
    if isinstance(value, (float, np.floating)):
        return f"{float(value) + 0.0:.6g}"  # + 0.0: no negative zero
    text = repr(value)
    return text if len(text) <= 200 else text[:200] + "…"


def _as_array(value: Any) -> np.ndarray | None:
    if isinstance(value, (bool, np.bool_)):
        return None
    if isinstance(value, (np.ndarray, *_NUMERIC)):
        return np.asarray(value)
    if isinstance(value, (list, tuple)):
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            return None
        return arr
    return None


SHOWN_CELLS = 3
"""differing cells of an integer or boolean array a message names."""


def _value(value: Any, kind: str) -> str:
    if kind == "b":
        return str(bool(value))
    number = float(value)
    return str(int(number)) if number.is_integer() else _fmt(number)


def _exact_cells(e_arr: np.ndarray, g_arr: np.ndarray, e_f: np.ndarray, g_f: np.ndarray,
                 path: str) -> str | None:
    """Integers or booleans compared cell by cell: ``None`` when all are equal, else how many
    differ and the first few, each at its index with what was expected and what came back
    (a printed array elides its middle, where the differences often are)."""
    differ = (e_f != g_f) & ~(np.isnan(e_f) & np.isnan(g_f))
    count = int(np.count_nonzero(differ))
    if not count:
        return None
    kind = e_arr.dtype.kind
    cells = np.argwhere(differ)[:SHOWN_CELLS]
    shown = "; ".join(
        f"at {tuple(int(i) for i in cell)} expected {_value(e_arr[tuple(cell)], kind)}, got "
        f"{_value(g_arr[tuple(cell)], kind if g_arr.dtype.kind == 'b' else 'f')}"
        for cell in cells)
    more = f"; … and {count - len(cells)} more" if count > len(cells) else ""
    what = "booleans" if kind == "b" else "exact integers"
    whole = (f" (expected {_fmt(e_arr)}, got {_fmt(g_arr)})"
             if e_arr.size <= 12 else "")
    return (f"{path}: {count} of {e_arr.size} values differ ({what}){whole}: "
            f"{shown}{more}")


def generic_hint(expected: np.ndarray, got: np.ndarray, rtol: float, atol: float) -> str:
    """A hint when ``got`` relates to ``expected`` the way a known mistake would."""
    with np.errstate(all="ignore"):  # inf or NaN among the values: no warning, no hint
        return _generic_hint(np.asarray(expected, dtype=np.float64),
                             np.asarray(got, dtype=np.float64), rtol, atol)


def _generic_hint(e: np.ndarray, g: np.ndarray, rtol: float, atol: float) -> str:

    def close(a: np.ndarray, b: np.ndarray) -> bool:
        return a.shape == b.shape and bool(np.allclose(a, b, rtol=max(rtol, 1e-6),
                                                       atol=max(atol, 1e-9)))

    if not np.any(e):
        return ""
    if close(g, np.degrees(e)):
        return "the values are the expected ones in degrees: work in radians"
    if close(g, np.radians(e)):
        return "the values are the expected ones converted to radians twice (or from radians)"
    diff = g - e
    turns = diff / (2 * np.pi)
    if e.shape == g.shape and np.any(np.abs(diff) > 1.0) and np.allclose(
            turns, np.round(turns), atol=1e-6):
        return "an angle is off by a multiple of 2π: wrap it with wrap_angle to [-π, π)"
    if close(g, -e):
        return "every value has the wrong sign: check the direction convention (REP-103: " \
               "x forward, y left, counter-clockwise positive)"
    if e.ndim >= 1 and e.shape[-1] == 2 and close(g, e[..., ::-1]):
        return "the two entries are swapped: the kit orders wheels (right, left)"
    if e.ndim == 2 and close(g, e.T):
        return "the matrix is transposed"
    return ""


def _compare_bytes(expected: bytes, got: Any, path: str) -> str | None:
    if not isinstance(got, (bytes, bytearray)):
        return f"{path} should be bytes; got {type(got).__name__}"
    if bytes(got) == expected:
        return None
    got = bytes(got)
    first = next((i for i, (a, b) in enumerate(zip(expected, got, strict=False)) if a != b),
                 min(len(expected), len(got)))
    return (f"{path}: expected {expected.hex(' ').upper()}, got {got.hex(' ').upper()} "
            f"({len(got)} bytes instead of {len(expected)}; first difference at byte "
            f"{first})" if len(got) != len(expected) else
            f"{path}: expected {expected.hex(' ').upper()}, got {got.hex(' ').upper()} "
            f"(first difference at byte {first})")


def _big_integers(expected: Any, got: Any) -> bool:
    """Two Python integers (not booleans), one of them outside int64: a CRC or a counter
    that was never cut to its width grows without bound in Python."""
    return (all(isinstance(v, int) and not isinstance(v, bool) for v in (expected, got))
            and not all(-(2**63) <= v < 2**63 for v in (expected, got)))


def compare(expected: Any, got: Any, rtol: float = 1e-6, atol: float = 1e-9,
            path: str = "the output", hints: bool = True) -> str | None:
    """``None`` if ``got`` matches ``expected`` within the tolerances, else a message."""
    if got is None and expected is not None:
        return f"{path} is None: did the function forget to return its result?"

    if isinstance(expected, msgs.Message):
        if type(got) is not type(expected):
            return (f"{path} should be a {type(expected).__name__} message; "
                    f"got {type(got).__name__}")
        for f in dataclasses.fields(expected):  # type: ignore[arg-type]
            problem = compare(getattr(expected, f.name), getattr(got, f.name), rtol, atol,
                              f"{path}.{f.name}" if path != "the output" else f.name, hints)
            if problem:
                return problem
        return None

    if isinstance(expected, bytes):
        return _compare_bytes(expected, got, path)

    if isinstance(expected, str):
        if got != expected:
            return f"{path}: expected {expected!r}, got {_fmt(got)}"
        return None

    if isinstance(expected, tuple) and not all(isinstance(v, _NUMERIC) for v in expected):
        if not isinstance(got, (tuple, list)) or len(got) != len(expected):
            n = len(got) if isinstance(got, (tuple, list)) else "not a tuple"
            return f"{path} should be a tuple of {len(expected)} values; got {n}"
        for i, (e, g) in enumerate(zip(expected, got, strict=True)):
            problem = compare(e, g, rtol, atol, f"{path}[{i}]", hints)
            if problem:
                return problem
        return None

    if _big_integers(expected, got):   # beyond int64: numpy would hold them as objects
        return None if got == expected else \
            f"{path}: expected {_fmt(expected)}, got {_fmt(got)} (exact integers)"

    e_arr = _as_array(expected)
    if e_arr is None:  # some other plain value
        return None if got == expected else f"{path}: expected {_fmt(expected)}, got {_fmt(got)}"
    g_arr = _as_array(got)
    if g_arr is None:
        return f"{path} should be a number or array of numbers; got {type(got).__name__}"
    if g_arr.shape != e_arr.shape:
        if g_arr.size == e_arr.size:
            return (f"{path} has shape {g_arr.shape} but should have shape {e_arr.shape} "
                    f"(same values in the wrong layout?)")
        return f"{path} has shape {g_arr.shape} but should have shape {e_arr.shape}"
    if g_arr.dtype.kind not in "biuf":
        return f"{path} should hold numbers; got dtype {g_arr.dtype}"
    with np.errstate(all="ignore"):  # an inf or NaN answer is reported, never warned about
        return _compare_numbers(e_arr, g_arr, got, expected, rtol, atol, path, hints)


def _compare_numbers(e_arr: np.ndarray, g_arr: np.ndarray, got: Any, expected: Any,
                     rtol: float, atol: float, path: str, hints: bool) -> str | None:
    """:func:`compare` for two arrays of numbers of the same shape."""
    g_f = g_arr.astype(np.float64)
    e_f = e_arr.astype(np.float64)
    if e_arr.dtype.kind in "biu" and e_arr.ndim:
        return _exact_cells(e_arr, g_arr, e_f, g_f, path)
    if np.any(np.isnan(g_f) & ~np.isnan(e_f)):
        idx = np.argwhere(np.isnan(g_f) & ~np.isnan(e_f))[0]
        where = f" at index {tuple(idx.tolist())}" if g_f.ndim else ""
        return f"{path} contains NaN{where} where {_fmt(e_f[tuple(idx)])} was expected"
    if np.any(np.isinf(g_f) & np.isfinite(e_f)):
        return f"{path} contains an infinite value where a finite one was expected"
    if e_arr.dtype.kind in "biu" and not np.array_equal(g_f, e_f):
        return f"{path}: expected {_fmt(e_arr)}, got {_fmt(g_arr)} (exact integers)"
    if np.allclose(g_f, e_f, rtol=rtol, atol=atol, equal_nan=True):
        return None
    err = np.abs(np.where(np.isfinite(e_f), g_f - e_f, 0.0))
    message = f"{path}: expected {_fmt(e_arr)}, got {_fmt(g_arr)}"
    if isinstance(got, (list, tuple)) and isinstance(expected, np.ndarray):
        message += f" (a {type(got).__name__} was returned; a numpy array is expected)"
    if g_f.ndim:
        # the first of the (nearly) largest errors: which of two equal errors is larger in
        # the last bit depends on the machine, the message must not
        first = int(np.flatnonzero(err.ravel() >= err.max() * (1.0 - 1e-9))[0])
        worst = tuple(int(v) for v in np.unravel_index(first, err.shape))
        message += f" (largest error {float(err[worst]):.3g} at index {worst})"
    hint = generic_hint(e_f, g_f, rtol, atol) if hints else ""
    return f"{message}; hint: {hint}" if hint else message


def matches(expected: Any, got: Any, rtol: float, atol: float) -> bool:
    """True when :func:`compare` finds nothing wrong."""
    return compare(expected, got, rtol, atol) is None
