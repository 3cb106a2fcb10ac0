"""ROS 2 bags: record a run as MCAP and read any ROS 2 bag back into kit messages.

Writing goes through ``rosbags``' rosbag2 writer with the MCAP storage plugin and the ROS 2
Humble type store, so the bag opens in ``ros2 bag``, Foxglove and RViz. Reading uses
``rosbags``' reader, which also takes the sqlite3 bags ROS 2 records by default and ROS 1 bags.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from kit import msgs, rosconv

__all__ = ["BagWriter", "read_bag", "write_bag"]


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

    def write(self, topic: str, message: msgs.Message, time_ns: int | None = None) -> None:
        """Add one message; ``time_ns`` defaults to the message's header stamp."""
        typename = message.ROS_TYPE
        if topic not in self._connections:
            self._connections[topic] = self._writer.add_connection(
                topic, typename, typestore=rosconv.typestore())
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


def write_bag(path: str | Path, messages: Iterable[tuple[str, msgs.Message, int]]) -> int:
    """Write ``(topic, message, time_ns)`` triples to a new MCAP bag; returns the count."""
    with BagWriter(path) as bag:
        for topic, message, time_ns in messages:
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
