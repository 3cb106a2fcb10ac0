"""Conversion between kit messages and the ROS 2 message classes of the ``rosbags`` package.

The conversion is driven by the ROS field definitions in a ``rosbags`` type store, not by a
table of our own: a kit field that is missing, extra, renamed, or holds the wrong element type
raises ``TypeError`` naming the field. That is what keeps :mod:`kit.msgs` honest.

``rosbags`` is imported only when a type store is needed, so ``import kit`` stays light.
"""

from __future__ import annotations

import dataclasses
from functools import lru_cache
from typing import Any

import numpy as np

from kit import msgs

__all__ = ["deserialize_cdr", "from_ros", "serialize_cdr", "to_ros", "typestore"]

_BASE_PY = {"bool": bool, "string": str}


@lru_cache(maxsize=1)
def typestore() -> Any:
    """The ROS 2 Humble type store of ``rosbags``."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def _fields(store: Any, typename: str) -> list[tuple[str, tuple[Any, Any]]]:
    try:
        return list(store.fielddefs[typename][1])
    except KeyError:
        raise TypeError(f"ROS type {typename!r} is not in the type store") from None


def _check_names(msg: msgs.Message, ros_fields: list[str]) -> None:
    ours = [f.name for f in dataclasses.fields(msg)]  # type: ignore[arg-type]
    if ours != ros_fields:
        raise TypeError(
            f"{type(msg).__name__} fields {ours} do not match {msg.ROS_TYPE} fields {ros_fields}")


def _base_to_ros(value: Any, base: str, where: str) -> Any:
    if base == "string":
        if not isinstance(value, str):
            raise TypeError(
                f"{where} must be a str for ROS type string; got {type(value).__name__}")
        return value
    if base == "bool":
        return bool(value)
    kind = np.dtype(base).kind
    if kind in "iu":
        if isinstance(value, float):
            raise TypeError(f"{where} must be an integer for ROS type {base}; got float {value}")
        info = np.iinfo(np.dtype(base))
        if not info.min <= int(value) <= info.max:
            raise TypeError(f"{where}={value} does not fit ROS type {base}")
        return int(value)
    return float(value)


def _array_to_ros(value: Any, base: str, where: str) -> Any:
    if base == "string":
        return [_base_to_ros(v, base, where) for v in value]
    if not isinstance(value, np.ndarray) or value.dtype != np.dtype(base):
        got = value.dtype if isinstance(value, np.ndarray) else type(value).__name__
        raise TypeError(f"{where} must be a numpy array of {base} (as in ROS); got {got}")
    return np.array(value)


def to_ros(msg: msgs.Message, store: Any | None = None) -> Any:
    """Convert a kit message to the ``rosbags`` class of the same ROS type."""
    store = store if store is not None else typestore()
    typename = msg.ROS_TYPE
    fields = _fields(store, typename)
    _check_names(msg, [name for name, _ in fields])
    kwargs: dict[str, Any] = {}
    for name, (nodetype, spec) in fields:
        value = getattr(msg, name)
        where = f"{type(msg).__name__}.{name}"
        kind = nodetype.name
        if kind == "NAME":
            kwargs[name] = to_ros(value, store)
        elif kind == "BASE":
            kwargs[name] = _base_to_ros(value, spec[0], where)
        elif kind in ("ARRAY", "SEQUENCE"):
            (inner_type, inner_spec), _length = spec
            if inner_type.name == "NAME":
                kwargs[name] = [to_ros(v, store) for v in value]
            else:
                kwargs[name] = _array_to_ros(value, inner_spec[0], where)
        else:  # pragma: no cover - ROS 2 has no other node types in these messages
            raise TypeError(f"{where}: unsupported ROS field kind {kind}")
    return store.types[typename](**kwargs)


def from_ros(obj: Any, store: Any | None = None) -> msgs.Message:
    """Convert a ``rosbags`` message object (e.g. from a bag) to the kit message."""
    store = store if store is not None else typestore()
    typename = getattr(obj, "__msgtype__", None)
    if typename not in msgs.MESSAGE_TYPES:
        raise TypeError(f"no kit message for ROS type {typename!r}; "
                        f"supported: {sorted(msgs.MESSAGE_TYPES)}")
    kwargs: dict[str, Any] = {}
    for name, (nodetype, spec) in _fields(store, typename):
        value = getattr(obj, name)
        kind = nodetype.name
        if kind == "NAME":
            kwargs[name] = from_ros(value, store)
        elif kind == "BASE":
            kwargs[name] = value
        else:
            (inner_type, inner_spec), _length = spec
            if inner_type.name == "NAME":
                kwargs[name] = tuple(from_ros(v, store) for v in value)
            elif inner_spec[0] == "string":
                kwargs[name] = tuple(value)
            else:
                kwargs[name] = np.asarray(value, dtype=np.dtype(inner_spec[0]))
    return msgs.MESSAGE_TYPES[typename](**kwargs)


def serialize_cdr(msg: msgs.Message) -> bytes:
    """CDR bytes of a kit message, as a ROS 2 node would put them on the wire or in a bag."""
    store = typestore()
    return bytes(store.serialize_cdr(to_ros(msg, store), msg.ROS_TYPE))


def deserialize_cdr(data: bytes, typename: str) -> msgs.Message:
    """Kit message from CDR bytes of ROS type ``typename``."""
    store = typestore()
    return from_ros(store.deserialize_cdr(data, typename), store)
