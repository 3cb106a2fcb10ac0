"""A safe codec for values crossing between the grader and a submission's process.

Outputs come back from untrusted code, so they travel as JSON with a few tagged forms —
never pickle, which would run code in the grader when loaded. Only plain data comes back:
numbers, strings, bytes, tuples, lists, string-keyed dicts, numeric numpy arrays and the kit's
message classes (rebuilt from their ROS type name, nothing else).
"""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

import numpy as np

from kit import msgs

__all__ = ["DecodeError", "EncodeError", "decode", "dumps", "encode", "loads"]

MAX_ELEMENTS = 5_000_000
MAX_DEPTH = 64


class EncodeError(TypeError):
    """A value of a type that cannot be sent back to the grader."""


class DecodeError(ValueError):
    """Bytes that are not a well-formed encoded value."""


BLOB_ELEMENTS = 64
"""arrays with more elements than this travel as raw bytes when a blob list is given."""


def encode(value: Any, depth: int = 0, blobs: list[bytes] | None = None) -> Any:
    """Turn ``value`` into JSON-compatible data with type tags. With ``blobs``, the data of
    larger arrays is appended there as raw bytes (a frame's binary part) instead of a list."""
    if depth > MAX_DEPTH:
        raise EncodeError("value is nested too deeply")
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, (bytes, bytearray)):
        if len(value) > MAX_ELEMENTS:
            raise EncodeError(f"{len(value)} bytes are too many to grade")
        return {"__bytes__": bytes(value).hex()}
    if isinstance(value, int):
        return {"__int__": str(value)} if abs(value) > 2**53 else value
    if isinstance(value, float):
        return value if math.isfinite(value) else {"__float__": repr(value)}
    if isinstance(value, np.generic):
        if value.dtype.kind not in "biuf":
            raise EncodeError(f"numpy scalar of dtype {value.dtype} cannot be graded")
        return {"__npscalar__": value.dtype.str, "value": encode(value.item(), depth + 1)}
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in "biuf":
            raise EncodeError(f"numpy array of dtype {value.dtype} cannot be graded "
                              f"(expected numbers)")
        if value.size > MAX_ELEMENTS:
            raise EncodeError(f"array of {value.size} elements is too large to grade")
        if blobs is not None and value.size > BLOB_ELEMENTS:
            blobs.append(np.ascontiguousarray(value).tobytes())
            return {"__ndarray__": {"blob": len(blobs) - 1}, "dtype": value.dtype.str,
                    "shape": list(value.shape)}
        flat = [encode(v, depth + 1) for v in value.ravel().tolist()]
        return {"__ndarray__": flat, "dtype": value.dtype.str, "shape": list(value.shape)}
    if isinstance(value, tuple):
        return {"__tuple__": [encode(v, depth + 1, blobs) for v in value]}
    if isinstance(value, list):
        return [encode(v, depth + 1, blobs) for v in value]
    if isinstance(value, dict):
        if not all(isinstance(k, str) for k in value):
            raise EncodeError("only dicts with string keys can be graded")
        return {"__dict__": {k: encode(v, depth + 1, blobs) for k, v in value.items()}}
    if isinstance(value, msgs.Message) and type(value) in msgs.MESSAGE_TYPES.values():
        fields = {f.name: encode(getattr(value, f.name), depth + 1, blobs)
                  for f in dataclasses.fields(value)}  # type: ignore[arg-type]
        return {"__msg__": value.ROS_TYPE, "fields": fields}
    raise EncodeError(f"a value of type {type(value).__name__} cannot be graded")


def decode(data: Any, depth: int = 0, blobs: list[bytes] | None = None) -> Any:
    """Inverse of :func:`encode` (``blobs``: the frame's binary part); raises
    :class:`DecodeError` on anything unexpected."""
    if depth > MAX_DEPTH:
        raise DecodeError("value is nested too deeply")
    if data is None or isinstance(data, (bool, int, float, str)):
        return data
    if isinstance(data, list):
        return [decode(v, depth + 1, blobs) for v in data]
    if not isinstance(data, dict) or len(data) == 0:
        raise DecodeError(f"unexpected encoded value of type {type(data).__name__}")
    try:
        if "__int__" in data:
            return int(data["__int__"])
        if "__bytes__" in data:
            return bytes.fromhex(data["__bytes__"])
        if "__float__" in data:
            text = data["__float__"]
            if text not in ("nan", "inf", "-inf"):
                raise DecodeError(f"bad float {text!r}")
            return float(text)
        if "__npscalar__" in data:
            dtype = np.dtype(data["__npscalar__"])
            if dtype.kind not in "biuf":
                raise DecodeError(f"bad dtype {dtype}")
            return dtype.type(decode(data["value"], depth + 1))
        if "__ndarray__" in data:
            dtype = np.dtype(data["dtype"])
            if dtype.kind not in "biuf":
                raise DecodeError(f"bad dtype {dtype}")
            shape = tuple(int(s) for s in data["shape"])
            if any(n < 0 for n in shape) or math.prod(shape) > MAX_ELEMENTS:
                raise DecodeError("array size does not match its shape")
            flat = data["__ndarray__"]
            if isinstance(flat, dict):
                return _array_from_blob(flat, dtype, shape, blobs)
            if len(flat) > MAX_ELEMENTS or math.prod(shape) != len(flat):
                raise DecodeError("array size does not match its shape")
            values = [decode(v, depth + 1) for v in flat]
            return np.array(values, dtype=dtype).reshape(shape)
        if "__tuple__" in data:
            return tuple(decode(v, depth + 1, blobs) for v in data["__tuple__"])
        if "__dict__" in data:
            return {str(k): decode(v, depth + 1, blobs) for k, v in data["__dict__"].items()}
        if "__msg__" in data:
            cls = msgs.MESSAGE_TYPES.get(data["__msg__"])
            if cls is None:
                raise DecodeError(f"unknown message type {data['__msg__']!r}")
            return cls(**{str(k): decode(v, depth + 1, blobs)
                          for k, v in data["fields"].items()})
    except DecodeError:
        raise
    except (KeyError, TypeError, ValueError, OverflowError) as exc:
        raise DecodeError(f"malformed encoded value: {exc}") from None
    raise DecodeError(f"unknown tag in encoded value: {sorted(data)[:3]}")


def _array_from_blob(ref: dict[str, Any], dtype: np.dtype[Any], shape: tuple[int, ...],
                     blobs: list[bytes] | None) -> np.ndarray:
    index = ref.get("blob")
    if blobs is None or not isinstance(index, int) or not 0 <= index < len(blobs):
        raise DecodeError("an array refers to data the frame does not hold")
    data = blobs[index]
    if len(data) != math.prod(shape) * dtype.itemsize:
        raise DecodeError("array size does not match its shape")
    return np.frombuffer(data, dtype=dtype).reshape(shape).copy()


def dumps(value: Any) -> str:
    return json.dumps(encode(value))


def loads(text: str | bytes) -> Any:
    try:
        data = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
        raise DecodeError(f"not JSON: {exc}") from None
    return decode(data)
