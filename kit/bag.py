"""ROS 2 bags: write kit messages as an MCAP rosbag2 folder, read any ROS 2 (or ROS 1) bag
back into kit messages.

Writing goes through ``rosbags``' rosbag2 writer with the MCAP storage plugin and the ROS 2
Humble type store, in the form ROS 2 Humble's own reader takes and Jazzy's still reads:

* ``metadata.yaml`` version 8, whose ``offered_qos_profiles`` is a YAML *string* with the
  policies as numbers — Humble's reader decodes that field as a string and fails on the list
  that version 9 writes (rosbag2 issue 2013) — and ``ros_distro: humble`` (the type store the
  messages were serialized with), in the file and in the MCAP's own ``rosbag2`` record;
* every topic's offered QoS stated, as ``ros2 bag record`` stores it: reliable, and the
  latched topics (:data:`LATCHED_TOPICS`: ``/tf_static``, ``/map``, ``/robot_description``,
  the costmaps, ``/amcl_pose``) transient local with depth 1, as their ROS publishers offer
  them, so ``ros2 bag play`` latches them for RViz's and Foxglove's late subscribers;
* MCAP chunks compressed with zstd (which the MCAP storage plugin of every ROS 2 release
  reads; the metadata's ``compression_mode`` stays empty, as for ``ros2 bag record``'s
  storage presets);
* with ``clock_period``, ``/clock`` (``rosgraph_msgs/Clock``) before the messages it covers,
  for a bag stamped in simulation time (replay with ``use_sim_time:=true``).

Reading uses ``rosbags``' reader, which also takes the sqlite3 bags ROS 2 records by default
and ROS 1 bags. An MCAP rosbag2 folder is read from its ``.mcap`` files, whose channels carry
their own QoS (``rosbags`` pairs a folder's ``metadata.yaml`` with the file's channels only
when both spell the QoS the same, and yields nothing otherwise).

``rosbags`` is imported only when a bag is opened: ``import kit`` stays light.
Messages travel as ``(topic, time_ns, message)`` both ways: :func:`read_bag` yields what
:func:`write_bag` takes.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from functools import lru_cache
from io import StringIO
from pathlib import Path
from types import TracebackType
from typing import Any

from kit import msgs, rosconv

__all__ = ["LATCHED_TOPICS", "METADATA_VERSION", "ROS_DISTRO", "BagWriter", "bag_topics",
           "check_topic", "describe_topics", "read_bag", "write_bag"]

LATCHED_TOPICS = ("/tf_static", "/map", "/robot_description", "/global_costmap/costmap",
                  "/local_costmap/costmap", "/amcl_pose")
"""Topics offered transient local (latched), as their ROS publishers offer them:
``robot_state_publisher`` (``/tf_static``, ``/robot_description``), ``map_server``, Nav2's
costmap publisher and AMCL."""

METADATA_VERSION = 8
"""The rosbag2 metadata version written: the newest whose ``offered_qos_profiles`` Humble's
reader decodes (a string); Jazzy reads it too."""

ROS_DISTRO = "humble"
"""The distribution whose message definitions the bags are written with."""

CLOCK_TOPIC = "/clock"


def _qos(latched: bool) -> Any:
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    # RMW_DURATION_INFINITE, as Humble's recorder writes a default deadline, lifespan, lease
    never = QosTime(sec=9223372036, nsec=854775807)
    durability = QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE
    return Qos(QosHistory.KEEP_LAST, 1 if latched else 10, QosReliability.RELIABLE,
               durability, never, never, QosLiveliness.AUTOMATIC, never, False)


def _with_distro(info: dict[str, Any]) -> dict[str, Any]:
    """rosbags' ``rosbag2_bagfile_information`` with the real distribution and an empty
    ``custom_data`` map where it wrote ``null``."""
    info["ros_distro"] = ROS_DISTRO
    if info.get("custom_data") is None:
        info["custom_data"] = {}
    return info


def _yaml(text: str, change: Any) -> str:
    from ruamel.yaml import YAML

    yaml = YAML(typ="safe")
    yaml.default_flow_style = False
    out = StringIO()
    yaml.dump(change(yaml.load(text)), out)
    return out.getvalue()


@lru_cache(maxsize=1)
def _writer_class() -> Any:
    """rosbags' rosbag2 ``Writer`` with the distribution written as it is."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.storage_mcap import McapWriter

    class HumbleMcapWriter(McapWriter):
        def close(self, version: int, metadata: str) -> None:
            super().close(version, _yaml(metadata, _with_distro).strip())

    class HumbleWriter(Writer):
        STORAGE_PLUGINS = {  # noqa: RUF012 (rosbags' own attribute, read only)
            **Writer.STORAGE_PLUGINS, StoragePlugin.MCAP: HumbleMcapWriter}

        def close(self) -> None:
            super().close()
            text = self.metapath.read_text(encoding="utf-8")
            self.metapath.write_text(_yaml(text, lambda d: {
                "rosbag2_bagfile_information": _with_distro(d["rosbag2_bagfile_information"])}),
                encoding="utf-8")

    return HumbleWriter


class BagWriter:
    """Write kit messages to a new MCAP rosbag2 folder that ROS 2 Humble and Jazzy open.

    Parameters
    ----------
    path
        The bag's folder (must not exist).
    clock_period
        Seconds between ``/clock`` messages, for a bag stamped in simulation time; ``None``
        (default) writes no ``/clock`` (wall-clock stamps).
    latched
        Topics offered transient local beside :data:`LATCHED_TOPICS`.

    >>> # with BagWriter("run1", clock_period=0.01) as bag:
    >>> #     bag.write("/scan", scan_message, time_ns)
    """

    def __init__(self, path: str | Path, clock_period: float | None = None,
                 latched: Iterable[str] = ()) -> None:
        from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin

        self.path = Path(path)
        if self.path.exists():
            raise FileExistsError(f"{self.path} exists; a bag is written to a new folder")
        if clock_period is not None and not clock_period > 0:
            raise ValueError(f"clock_period is a positive number of seconds or None; got "
                             f"{clock_period!r}")
        self._writer = _writer_class()(self.path, version=METADATA_VERSION,
                                       storage_plugin=StoragePlugin.MCAP)
        # zstd-compressed MCAP chunks, as ros2 bag record's "zstd_fast" preset writes them
        self._writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        self._connections: dict[str, Any] = {}
        self._types: dict[str, str] = {}
        self.latched = frozenset((*LATCHED_TOPICS, *latched))
        self._clock_ns = None if clock_period is None else round(clock_period * 1e9)
        self._next_clock: int | None = None
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
        """Add one message; ``time_ns`` defaults to the message's header stamp. With a
        ``clock_period``, ``/clock`` is written first whenever the time reaches its next tick.
        """
        if time_ns is None:
            header = getattr(message, "header", None)
            if header is None:
                raise ValueError(f"{message.ROS_TYPE} has no header: pass time_ns")
            time_ns = header.stamp.to_nsec()
        time_ns = int(time_ns)
        if self._clock_ns is not None and topic != CLOCK_TOPIC and (
                self._next_clock is None or time_ns >= self._next_clock):
            self._write(CLOCK_TOPIC, msgs.Clock(msgs.Time(*divmod(time_ns, 1_000_000_000))),
                        time_ns)
            self._next_clock = time_ns + self._clock_ns
        self._write(topic, message, time_ns)

    def _write(self, topic: str, message: msgs.Message, time_ns: int) -> None:
        typename = message.ROS_TYPE
        if topic not in self._connections:
            self._connections[topic] = self._writer.add_connection(
                topic, typename, typestore=rosconv.typestore(),
                offered_qos_profiles=(_qos(topic in self.latched),))
            self._types[topic] = typename
        elif self._types[topic] != typename:
            raise TypeError(f"topic {topic} carries {self._types[topic]}, not {typename}")
        self._writer.write(self._connections[topic], time_ns, rosconv.serialize_cdr(message))
        self.count += 1


def write_bag(path: str | Path, messages: Iterable[tuple[str, int, msgs.Message]],
              clock_period: float | None = None) -> int:
    """Write ``(topic, time_ns, message)`` triples — the order :func:`read_bag` yields — to
    a new MCAP bag; returns the count (``/clock`` messages included).

    Raises
    ------
    TypeError
        A triple not in that order (a message where the time should be), or a topic that
        changes type.
    """
    with BagWriter(path, clock_period=clock_period) as bag:
        for topic, time_ns, message in messages:
            if not isinstance(time_ns, int) or isinstance(time_ns, bool):
                raise TypeError(f"{topic}: expected (topic, time_ns, message) with time_ns an "
                                f"int of nanoseconds; got {type(time_ns).__name__} as time")
            if not isinstance(message, msgs.Message):
                raise TypeError(f"{topic}: expected (topic, time_ns, message); got "
                                f"{type(message).__name__} as the message")
            bag.write(topic, message, time_ns)
        return bag.count


def _sources(path: Path) -> list[Path]:
    """What to open for ``path``: an MCAP rosbag2 folder's ``.mcap`` files themselves."""
    if not path.exists():
        raise ValueError(f"{path}: no such bag (a rosbag2 folder, an .mcap or .db3 file, or a "
                         f"ROS 1 .bag)")
    meta = path / "metadata.yaml"
    if path.is_dir() and meta.is_file():
        from ruamel.yaml import YAML, YAMLError

        try:
            info = YAML(typ="safe").load(meta.read_text(encoding="utf-8"))
            info = info["rosbag2_bagfile_information"]
            files = [path / f for f in info["relative_file_paths"]]
        except (YAMLError, KeyError, TypeError, UnicodeDecodeError):
            return [path]                 # rosbags will say what is wrong with it
        if info.get("storage_identifier") == "mcap" and files and all(
                f.suffix == ".mcap" and f.is_file() for f in files):
            return files
    return [path]


def _open(path: Path) -> Any:
    from rosbags.highlevel import AnyReader

    return AnyReader(_sources(path), default_typestore=rosconv.typestore())


def _reading(path: Path, exc: Exception) -> ValueError:
    return ValueError(f"{path}: not a bag that can be read ({type(exc).__name__}: {exc}); "
                      f"expected a rosbag2 folder, an .mcap or .db3 file, or a ROS 1 .bag")


def bag_topics(path: str | Path) -> dict[str, tuple[str, int]]:
    """Every topic of a bag with its ROS type and message count.

    Raises
    ------
    ValueError
        No such file, or not a bag (the message names the file).
    """
    from rosbags.highlevel import AnyReaderError

    path = Path(path)
    try:
        with _open(path) as reader:
            topics: dict[str, tuple[str, int]] = {}
            for c in reader.connections:
                _, n = topics.get(c.topic, (c.msgtype, 0))
                topics[c.topic] = (c.msgtype, n + c.msgcount)
            return topics
    except AnyReaderError as exc:
        raise _reading(path, exc) from None


def describe_topics(topics: dict[str, tuple[str, int]]) -> str:
    """``/scan (sensor_msgs/msg/LaserScan, 357), ...`` — for messages."""
    return ", ".join(f"{t} ({typ}, {n})" for t, (typ, n) in sorted(topics.items())) or "none"


def check_topic(path: str | Path, topic: str, ros_type: str, option: str) -> None:
    """Make sure a bag has ``topic`` of ``ros_type`` before a command reads it.

    Raises
    ------
    ValueError
        Naming the bag, the topic, the bag's topics of that type and the command's
        ``option`` that chooses one (or, with none of that type, every topic it has).
    """
    topics = bag_topics(path)
    if topics.get(topic, ("", 0))[0] == ros_type:
        return
    short = ros_type.rsplit("/", 1)[-1]
    fits = sorted(t for t, (typ, _) in topics.items() if typ == ros_type)
    what = (f"topic {topic} is {topics[topic][0]}, not {short}" if topic in topics else
            f"no topic {topic}")
    if fits:
        raise ValueError(f"{path}: {what}; its {short} topics: {', '.join(fits)} (choose one "
                         f"with {option})")
    raise ValueError(f"{path}: {what}, and no {ros_type} on any topic; it has "
                     f"{describe_topics(topics)}")


def read_bag(path: str | Path, topics: Sequence[str] | None = None
             ) -> Iterator[tuple[str, int, msgs.Message]]:
    """``(topic, time_ns, message)`` for every message of a type the kit knows, in time order.

    Topics of other types (``rcl_interfaces/Log``, ``sensor_msgs/PointCloud2`` …) are skipped
    when ``topics`` is ``None``.

    Raises
    ------
    ValueError
        No such file, or not a bag; ``topics`` given and none of them in the bag, or one of
        them of a type the kit does not read. The message names the file, the topics asked
        for and the topics the bag has.
    """
    from rosbags.highlevel import AnyReaderError

    path = Path(path)
    try:
        with _open(path) as reader:
            conns = _connections(path, reader.connections, topics)
            if not conns:
                return
            store = rosconv.typestore()
            for conn, time_ns, raw in reader.messages(connections=conns):
                yield conn.topic, int(time_ns), rosconv.from_ros(
                    reader.deserialize(raw, conn.msgtype), store)
    except AnyReaderError as exc:
        raise _reading(path, exc) from None


def _connections(path: Path, connections: Sequence[Any], topics: Sequence[str] | None
                 ) -> list[Any]:
    """The connections to read; never an empty list when topics were asked for (rosbags
    reads an empty list as "every connection")."""
    if isinstance(topics, str):
        raise TypeError(f"topics is a list of topic names; got the string {topics!r}")
    known = [c for c in connections if c.msgtype in msgs.MESSAGE_TYPES]
    if topics is None:
        return known
    present = {c.topic: c.msgtype for c in connections}
    have = {c.topic: (c.msgtype, 0) for c in connections}
    for c in connections:
        have[c.topic] = (c.msgtype, have[c.topic][1] + c.msgcount)
    if not any(t in present for t in topics):
        asked = (f"no topic {topics[0]}" if len(topics) == 1 else
                 f"none of the topics {', '.join(topics)}")
        raise ValueError(f"{path}: {asked} in this bag; it has {describe_topics(have)}")
    for t in topics:
        if t in present and present[t] not in msgs.MESSAGE_TYPES:
            raise ValueError(f"{path}: topic {t} carries {present[t]}, which the kit does "
                             f"not read; it reads {', '.join(sorted(msgs.MESSAGE_TYPES))}")
    return [c for c in known if c.topic in topics]
