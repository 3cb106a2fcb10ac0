"""Bags that ROS 2 Humble and Jazzy open as they are.

The metadata is parsed here with the rules of Humble's own reader (rosbag2 0.15,
``rosbag2_storage/src/rosbag2_storage/metadata_io.cpp`` and
``rosbag2_transport/src/rosbag2_transport/qos.cpp`` on the ``humble`` branch) and of Jazzy's
(``rosbag2_storage/include/rosbag2_storage/yaml.hpp`` and ``qos.cpp``): which keys each
version must have and how yaml-cpp converts each node (``as<std::string>`` takes a scalar and
refuses a sequence — rosbag2 issue 2013 —, ``as<uint64_t>`` an unsigned integer, ``as<bool>``
YAML 1.1's words). The rules are checked against a bag Humble itself recorded (the Gazebo
TurtleBot3 bag in ``../shared/data``) and against the version 9 that rosbags writes by default,
which Humble refuses. The MCAP file is read with the ``mcap`` package, the messages with
rosbags' Humble type store.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from ruamel.yaml import YAML

from kit import msgs
from kit.bag import LATCHED_TOPICS, BagWriter

DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "ros2-bags"

# rmw_qos_*_policy_t values (rmw/types.h)
TRANSIENT_LOCAL, VOLATILE = 1, 2
RELIABLE = 1


class Refused(Exception):
    """What yaml-cpp throws (``TypedBadConversion``, ``InvalidNode``) where Humble's reader
    would fail to open the bag."""


# ------------------------------------------------------------------ yaml-cpp's conversions

def _node(text: str) -> Any:
    """A YAML document as yaml-cpp holds it: every scalar kept as its text."""
    return YAML(typ="base").load(text)


def _key(node: Any, key: str, where: str) -> Any:
    if not isinstance(node, dict):
        raise Refused(f"{where}: not a map")
    if key not in node:
        raise Refused(f"{where}.{key}: missing (yaml-cpp InvalidNode)")
    return node[key]


def as_string(node: Any, where: str) -> str:
    # yaml-cpp 0.7 as<std::string>: a scalar's text, "null" for a null node, else refused
    if isinstance(node, (list, dict)):
        raise Refused(f"{where}: a {type(node).__name__}, read as a string "
                      f"(TypedBadConversion<std::string>)")
    return "null" if node in ("~", "null", "Null", "NULL", "") else node


_INTEGER = re.compile(r"[+-]?(0[xX][0-9a-fA-F]+|0[0-7]*|[1-9][0-9]*)\Z")


def as_integer(node: Any, where: str, bits: int, signed: bool) -> int:
    # yaml-cpp reads integers with a stream whose base follows the prefix (0x, 0); unsigned
    # types refuse a leading minus
    text = as_string(node, where)
    if not _INTEGER.match(text) or (not signed and text.startswith("-")):
        raise Refused(f"{where}: {text!r} is not a{'n' if signed else 'n unsigned'} integer")
    body = text.lstrip("+-")
    base = 16 if body[:2].lower() == "0x" else 8 if len(body) > 1 and body[0] == "0" else 10
    value = int(text, base) if base != 8 else int(text[:len(text) - len(body)] + body[1:], 8)
    low, high = (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if signed else (0, 2 ** bits - 1)
    if not low <= value <= high:
        raise Refused(f"{where}: {value} out of range")
    return value


def as_bool(node: Any, where: str) -> bool:
    text = as_string(node, where)
    for words, value in ((("y", "yes", "true", "on"), True), (("n", "no", "false", "off"), False)):
        if text.lower() in words and text in (*words, *(w.capitalize() for w in words),
                                              *(w.upper() for w in words)):
            return value
    raise Refused(f"{where}: {text!r} is not a bool")


def as_sequence(node: Any, where: str) -> list[Any]:
    if not isinstance(node, list):
        raise Refused(f"{where}: not a sequence")
    return node


# ------------------------------------------------------------------ the readers' rules

def humble_qos(text: str, where: str) -> list[dict[str, Any]]:
    """``YAML::Load(offered_qos_profiles).as<std::vector<Rosbag2QoS>>()`` in Humble's
    player: every policy a number."""
    profiles = []
    for i, p in enumerate(as_sequence(_node(text) if text else [], where)):
        w = f"{where}[{i}]"

        def time(key: str, p: Any = p, w: str = w) -> tuple[int, int]:
            t = _key(p, key, w)
            return (as_integer(_key(t, "sec", w), f"{w}.{key}.sec", 64, False),
                    as_integer(_key(t, "nsec", w), f"{w}.{key}.nsec", 64, False))

        profiles.append({
            **{k: as_integer(_key(p, k, w), f"{w}.{k}", 32, True)
               for k in ("history", "reliability", "durability", "liveliness", "depth")},
            **{k: time(k) for k in ("deadline", "lifespan", "liveliness_lease_duration")},
            "avoid_ros_namespace_conventions": as_bool(
                _key(p, "avoid_ros_namespace_conventions", w), w)})
    return profiles


def humble_metadata(text: str) -> dict[str, Any]:
    """``MetadataIo::read_metadata`` of rosbag2 0.15 (Humble), then the player's QoS."""
    info = _key(_node(text), "rosbag2_bagfile_information", "metadata.yaml")
    w = "rosbag2_bagfile_information"
    version = as_integer(_key(info, "version", w), f"{w}.version", 32, True)
    out: dict[str, Any] = {
        "version": version,
        "storage_identifier": as_string(_key(info, "storage_identifier", w), w),
        "duration": as_integer(_key(_key(info, "duration", w), "nanoseconds", w), w, 64, False),
        "starting_time": as_integer(_key(_key(info, "starting_time", w),
                                         "nanoseconds_since_epoch", w), w, 64, False),
        "message_count": as_integer(_key(info, "message_count", w), w, 64, False),
        "relative_file_paths": [as_string(p, w) for p in
                                as_sequence(_key(info, "relative_file_paths", w), w)],
        "topics": {}}
    for i, t in enumerate(as_sequence(_key(info, "topics_with_message_count", w), w)):
        tw = f"{w}.topics_with_message_count[{i}]"
        meta = _key(t, "topic_metadata", tw)
        name = as_string(_key(meta, "name", tw), f"{tw}.name")
        qos = (as_string(_key(meta, "offered_qos_profiles", tw), f"{name}: offered_qos_profiles")
               if version >= 4 else "")
        out["topics"][name] = {
            "type": as_string(_key(meta, "type", tw), tw),
            "serialization_format": as_string(_key(meta, "serialization_format", tw), tw),
            "qos": humble_qos(qos, f"{name}: offered_qos_profiles"),
            "message_count": as_integer(_key(t, "message_count", tw), tw, 64, False)}
    if version >= 3:
        for k in ("compression_format", "compression_mode"):
            out[k] = as_string(_key(info, k, w), f"{w}.{k}")
    if version >= 5:
        out["files"] = [{
            "path": as_string(_key(f, "path", w), w),
            "starting_time": as_integer(_key(_key(f, "starting_time", w),
                                             "nanoseconds_since_epoch", w), w, 64, False),
            "duration": as_integer(_key(_key(f, "duration", w), "nanoseconds", w), w, 64, False),
            "message_count": as_integer(_key(f, "message_count", w), w, 64, False)}
            for f in as_sequence(_key(info, "files", w), f"{w}.files")]
    return out


def jazzy_extras(text: str) -> dict[str, Any]:
    """What Jazzy's reader adds for versions 6 to 8: ``custom_data`` (iterated as a map),
    ``type_description_hash`` (7) and ``ros_distro`` (8)."""
    info = _key(_node(text), "rosbag2_bagfile_information", "metadata.yaml")
    version = int(info["version"])
    out: dict[str, Any] = {}
    if version >= 6:
        custom = _key(info, "custom_data", "custom_data")
        if isinstance(custom, list):
            raise Refused("custom_data: a sequence, iterated as a map")
        out["custom_data"] = {} if custom in ("", "~", "null") else {
            as_string(k, "custom_data"): as_string(v, "custom_data") for k, v in custom.items()}
    if version >= 7:
        out["hashes"] = {as_string(t["topic_metadata"]["name"], "name"): as_string(
            _key(t["topic_metadata"], "type_description_hash", "topic_metadata"), "hash")
            for t in info["topics_with_message_count"]}
    if version >= 8:
        out["ros_distro"] = as_string(_key(info, "ros_distro", "ros_distro"), "ros_distro")
    return out


# ------------------------------------------------------------------ a kit bag

def _a_bag(path: Path) -> Path:
    scan = msgs.LaserScan(header=msgs.Header(msgs.Time(0, 0), "laser_link"), angle_min=-1.0,
                          angle_increment=0.5, ranges=np.array([1.0, 2.0, np.inf]))
    grid = msgs.OccupancyGrid(msgs.Header(msgs.Time(0, 0), "map"),
                              msgs.MapMetaData(resolution=0.05, width=2, height=1),
                              np.array([0, 100], dtype=np.int8))
    with BagWriter(path, clock_period=0.05) as bag:
        bag.write("/map", grid, 0)
        bag.write("/robot_description", msgs.String("<robot name='r'/>"), 0)
        for i in range(46):                                 # 50 Hz for 0.9 s
            bag.write("/scan", scan, i * 20_000_000)
        bag.custom_data("kit.note", "written by a test")
    return path


def test_a_kit_bag_opens_under_humbles_reading_rules(tmp_path):
    bag = _a_bag(tmp_path / "run")
    meta = humble_metadata((bag / "metadata.yaml").read_text(encoding="utf-8"))
    assert meta["version"] == 8 and meta["storage_identifier"] == "mcap"
    assert [(bag / p).is_file() for p in meta["relative_file_paths"]] == [True]
    # /clock at 0, 0.06, 0.12, ... 0.90 s: at the first message 0.05 s after the last tick
    assert meta["topics"]["/clock"]["message_count"] == 16
    assert meta["message_count"] == 46 + 2 + 16
    assert meta["duration"] == 900_000_000 and meta["starting_time"] == 0
    topics = meta["topics"]
    assert {t: v["type"] for t, v in topics.items()} == {
        "/clock": "rosgraph_msgs/msg/Clock", "/map": "nav_msgs/msg/OccupancyGrid",
        "/robot_description": "std_msgs/msg/String", "/scan": "sensor_msgs/msg/LaserScan"}
    assert {v["serialization_format"] for v in topics.values()} == {"cdr"}  # one, as Humble needs
    for name, t in topics.items():
        (qos,) = t["qos"]
        assert qos["reliability"] == RELIABLE
        assert qos["durability"] == (TRANSIENT_LOCAL if name in LATCHED_TOPICS else VOLATILE)
    assert topics["/map"]["qos"][0]["depth"] == 1
    assert meta["files"][0]["message_count"] == meta["message_count"]


def test_a_kit_bag_carries_jazzys_fields_and_a_real_distribution(tmp_path):
    bag = _a_bag(tmp_path / "run")
    extras = jazzy_extras((bag / "metadata.yaml").read_text(encoding="utf-8"))
    assert extras["ros_distro"] == "humble"
    assert extras["custom_data"] == {"kit.note": "written by a test"}
    assert all(h.startswith("RIHS01_") for h in extras["hashes"].values())


def test_the_mcap_file_says_the_same_to_humbles_mcap_plugin(tmp_path):
    """Humble's MCAP plugin takes each topic's type from its schema and its QoS from the
    channel's ``offered_qos_profiles``; Jazzy's reads the ``rosbag2`` metadata record."""
    from mcap.reader import make_reader

    bag = _a_bag(tmp_path / "run")
    with (bag / "run.mcap").open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert reader.get_header().profile == "ros2"
        assert {c.compression for c in summary.chunk_indexes} == {"zstd"}
        channels = {c.topic: c for c in summary.channels.values()}
        for topic, c in channels.items():
            schema = summary.schemas[c.schema_id]
            assert (c.message_encoding, schema.encoding) == ("cdr", "ros2msg")
            (qos,) = humble_qos(c.metadata["offered_qos_profiles"], topic)
            assert qos["durability"] == (TRANSIENT_LOCAL if topic in LATCHED_TOPICS
                                         else VOLATILE)
        (record,) = [m for m in reader.iter_metadata() if m.name == "rosbag2"]
        serialized = record.metadata["serialized_metadata"]
    wrapped = "rosbag2_bagfile_information:\n" + "".join(
        f"  {line}\n" for line in serialized.splitlines())
    assert humble_metadata(wrapped)["topics"].keys() == channels.keys()
    assert jazzy_extras(wrapped)["ros_distro"] == "humble"


def test_clock_leads_the_messages_it_covers(tmp_path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    bag = _a_bag(tmp_path / "run")
    store = get_typestore(Stores.ROS2_HUMBLE)
    clock = []
    with AnyReader([bag], default_typestore=store) as reader:
        for conn, t, raw in reader.messages():
            if conn.topic == "/clock":
                m = reader.deserialize(raw, conn.msgtype)
                clock.append((t, m.clock.sec * 10**9 + m.clock.nanosec))
            elif conn.topic == "/scan":
                assert clock and clock[-1][1] <= t < clock[-1][1] + 50_000_000
    assert all(t == c for t, c in clock)
    assert len(clock) == 16 and np.all(np.diff([c for _, c in clock]) == 60_000_000)


def test_humbles_rules_refuse_the_version_9_list_of_profiles(tmp_path):
    """The rules can fail: rosbags' default version 9 lists the QoS, which Humble reads as a
    string (rosbag2 issue 2013)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from kit.bag import _qos

    store = get_typestore(Stores.ROS2_HUMBLE)
    with Writer(tmp_path / "v9", version=9, storage_plugin=StoragePlugin.MCAP) as w:
        c = w.add_connection("/map", "std_msgs/msg/String", typestore=store,
                             offered_qos_profiles=[_qos(True)])
        w.write(c, 0, store.serialize_cdr(store.types["std_msgs/msg/String"]("x"),
                                          "std_msgs/msg/String"))
    with pytest.raises(Refused, match="offered_qos_profiles: a list, read as a string"):
        humble_metadata((tmp_path / "v9" / "metadata.yaml").read_text(encoding="utf-8"))


@pytest.mark.dataset
def test_the_rules_take_a_bag_humble_itself_recorded():
    meta_path = DATA / "turtlebot3-burger-gazebo-walker" / "metadata.yaml"
    if not meta_path.exists():
        pytest.skip("../shared/data is not beside the checkout")
    meta = humble_metadata(meta_path.read_text(encoding="utf-8"))
    assert meta["version"] == 5 and meta["message_count"] == 9882
    assert meta["topics"]["/scan"]["qos"][0]["reliability"] == RELIABLE
    assert meta["topics"]["/robot_description"]["qos"][0]["durability"] == TRANSIENT_LOCAL


@pytest.mark.slow
def test_the_demos_bags_open_under_humbles_rules(demo_run):
    """make demo's two bags (the run the demo's own test makes): the mapping bag's and the
    navigation bag's metadata under Humble's rules; in the navigation bag the latched topics
    transient local, /clock leading."""
    from sim import navdemo

    _, _, tmp_path = demo_run
    mapping = humble_metadata((tmp_path / "demo_office" / "metadata.yaml").read_text("utf-8"))
    assert {"/clock", "/scan", "/tf_static"} <= mapping["topics"].keys()
    meta = humble_metadata((tmp_path / "demo_loop" / "metadata.yaml").read_text("utf-8"))
    topics = meta["topics"]
    assert set(navdemo.TOPICS) | {"/clock", "/map", "/tf_static"} == topics.keys()
    durable = {t for t, v in topics.items() if v["qos"][0]["durability"] == TRANSIENT_LOCAL}
    assert durable == {"/map", "/tf_static", "/robot_description", "/amcl_pose",
                       "/global_costmap/costmap", "/local_costmap/costmap"}
    # a /clock message before each step that publishes (odometry at 50 Hz, commands at
    # 20 Hz, the lidar's 5.5 Hz: about 60 per simulated second)
    assert topics["/clock"]["message_count"] > 50 * meta["duration"] / 1e9
    assert jazzy_extras((tmp_path / "demo_loop" / "metadata.yaml").read_text("utf-8")
                        )["ros_distro"] == "humble"
