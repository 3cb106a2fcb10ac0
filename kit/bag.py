"""ROS 2 bags: write kit messages as an MCAP rosbag2 folder, read any ROS 2 (or ROS 1) bag
back into kit messages.

Writing goes through ``rosbags``' rosbag2 writer with the MCAP storage plugin and the ROS 2
Humble type store, so the bag opens in ``ros2 bag``, Foxglove and RViz; ``/tf_static`` is
offered with transient-local durability, as ``robot_state_publisher`` offers it, so
``ros2 bag play`` latches it for late subscribers. Reading uses ``rosbags``' reader, which
also takes the sqlite3 bags ROS 2 records by default and ROS 1 bags.

``rosbags`` is imported only when a bag is opened: ``import kit`` stays light.
Messages travel as ``(topic, time_ns, message)`` both ways: :func:`read_bag` yields what
:func:`write_bag` takes.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from kit import msgs, rosconv

__all__ = ["LATCHED_TOPICS", "BagWriter", "read_bag", "write_bag"]

LATCHED_TOPICS = ("/tf_static",)
"""topics offered transient-local (latched), as their ROS publishers offer them."""


def _latched_qos() -> Any:
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    never = QosTime(sec=2147483647, nsec=4294967295)  # rclcpp's "infinite" duration
    return Qos(QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL,
               never, never, QosLiveliness.AUTOMATIC, never, False)


class BagWriter:
    """Write kit messages to a new MCAP rosbag2 folder.

    >>> # with BagWriter("run1") as bag:
    >>> #     bag.write("/scan", scan_message, time_ns)
    """

    def __init__(self, path: str | Path) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer

        self.path = Path(path)
        if self.path.exists():
            raise FileExistsError(f"{self.path} exists; a bag is written to a new folder")
        self._writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        self._connections: dict[str, Any] = {}
        self._types: dict[str, str] = {}
        self.count = 0

    def __enter__(self) -> BagWriter:
        self._writer.open()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self._writer.close()

    def custom_data(self, key: str, value: str) -> None:
        """A ``key: value`` note in the bag's ``metadata.yaml`` (rosbag2's ``custom_data``,
        kept with the bag): what the recorder wants a reader of the bag to know."""
        if not isinstance(key, str) or not isinstance(value, str):
            raise TypeError(f"custom data is str: str; got {type(key).__name__}: "
                            f"{type(value).__name__}")
        self._writer.set_custom_data(key, value)

    def write(self, topic: str, message: msgs.Message, time_ns: int | None = None) -> None:
        """Add one message; ``time_ns`` defaults to the message's header stamp."""
        typename = message.ROS_TYPE
        if topic not in self._connections:
            qos = (_latched_qos(),) if topic in LATCHED_TOPICS else ()
            self._connections[topic] = self._writer.add_connection(
                topic, typename, typestore=rosconv.typestore(), offered_qos_profiles=qos)
            self._types[topic] = typename
        elif self._types[topic] != typename:
            raise TypeError(f"topic {topic} carries {self._types[topic]}, not {typename}")
        if time_ns is None:
            header = getattr(message, "header", None)
            if header is None:
                raise ValueError(f"{typename} has no header: pass time_ns")
            time_ns = header.stamp.to_nsec()
        self._writer.write(self._connections[topic], int(time_ns),
                           rosconv.serialize_cdr(message))
        self.count += 1


def write_bag(path: str | Path, messages: Iterable[tuple[str, int, msgs.Message]]) -> int:
    """Write ``(topic, time_ns, message)`` triples — the order :func:`read_bag` yields — to
    a new MCAP bag; returns the count.

    Raises
    ------
    TypeError
        A triple not in that order (a message where the time should be), or a topic that
        changes type.
    """
    with BagWriter(path) as bag:
        for topic, time_ns, message in messages:
            if not isinstance(time_ns, int) or isinstance(time_ns, bool):
                raise TypeError(f"{topic}: expected (topic, time_ns, message) with time_ns an "
                                f"int of nanoseconds; got {type(time_ns).__name__} as time")
            if not isinstance(message, msgs.Message):
                raise TypeError(f"{topic}: expected (topic, time_ns, message); got "
                                f"{type(message).__name__} as the message")
            bag.write(topic, message, time_ns)
        return bag.count


def read_bag(path: str | Path, topics: Sequence[str] | None = None
             ) -> Iterator[tuple[str, int, msgs.Message]]:
    """``(topic, time_ns, message)`` for every message of a type the kit knows, in time order.

    Topics of other types (``std_msgs/String``, ``rosgraph_msgs/Clock`` …) are skipped.
    """
    from rosbags.highlevel import AnyReader

    store = rosconv.typestore()
    with AnyReader([Path(path)], default_typestore=store) as reader:
        conns = [c for c in reader.connections if c.msgtype in msgs.MESSAGE_TYPES and
                 (topics is None or c.topic in topics)]
        for conn, time_ns, raw in reader.messages(connections=conns):
            yield conn.topic, int(time_ns), rosconv.from_ros(
                reader.deserialize(raw, conn.msgtype), store)
