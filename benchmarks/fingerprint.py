"""The canonical hash both fingerprints (``sim_fingerprint.py``, ``slam_fingerprint.py``)
feed what a run produced into: a value's type and its exact bits."""

from __future__ import annotations

import struct
from typing import Any

import numpy as np

from kit import msgs


def feed(h: Any, value: Any) -> None:
    """Feed ``value`` to the hash ``h`` canonically: its type and its exact bits."""
    if isinstance(value, msgs.Message):
        h.update(b"M" + type(value).__name__.encode())
        for name, field_value in vars(value).items():
            h.update(b"f" + name.encode())
            feed(h, field_value)
    elif isinstance(value, np.ndarray):
        h.update(b"A" + value.dtype.str.encode() + repr(value.shape).encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, (tuple, list)):
        h.update(b"T" if isinstance(value, tuple) else b"L")
        h.update(struct.pack("<q", len(value)))
        for item in value:
            feed(h, item)
    elif isinstance(value, (bool, np.bool_)):
        h.update(b"B" + type(value).__name__.encode() + (b"1" if value else b"0"))
    elif isinstance(value, (int, np.integer)):
        h.update(b"I" + type(value).__name__.encode() + str(int(value)).encode() + b";")
    elif isinstance(value, (float, np.floating)):
        h.update(b"F" + type(value).__name__.encode() + struct.pack("<d", float(value)))
    elif isinstance(value, str):
        h.update(b"S" + struct.pack("<q", len(value)) + value.encode())
    elif value is None:
        h.update(b"N")
    else:
        raise TypeError(f"no canonical form for {type(value).__name__}: {value!r}")
