"""The live view: a WebSocket client on the loopback address subscribes as Foxglove Studio
does (the Foxglove WebSocket protocol) and decodes /scan and /tf with rosbags' Humble types."""

from __future__ import annotations

import json
import struct
import sys
import time

import numpy as np
import pytest

from kit import msgs
from kit.liveview import LiveView, parse_address

websocket = pytest.importorskip("websocket")  # websocket-client, a dev dependency

SUBPROTOCOL = "foxglove.sdk.v1"


def _connect(view: LiveView) -> tuple[object, dict[str, dict]]:
    ws = websocket.create_connection(f"ws://127.0.0.1:{view.port}", subprotocols=[SUBPROTOCOL],
                                     timeout=30)
    info = json.loads(ws.recv())
    assert info["op"] == "serverInfo" and "time" in info["capabilities"]
    return ws, {}


def _until(condition, what: str) -> None:
    """Wait for another thread (the server's) to get there; a deadline, not a measurement."""
    deadline = time.monotonic() + 30.0
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"never happened: {what}")
        time.sleep(0.01)


def _advertised(ws, topics: set[str]) -> dict[str, dict]:
    channels: dict[str, dict] = {}
    while not topics <= channels.keys():
        message = ws.recv()
        if isinstance(message, str) and json.loads(message)["op"] == "advertise":
            channels.update({c["topic"]: c for c in json.loads(message)["channels"]})
    return channels


def _subscribe(ws, view: LiveView, channels: dict[str, dict], topics: list[str]) -> dict[int, str]:
    before = view.clients
    ws.send(json.dumps({"op": "subscribe", "subscriptions": [
        {"id": 10 + i, "channelId": channels[t]["id"]} for i, t in enumerate(topics)]}))
    _until(lambda: view.clients == before + len(topics), "the server took the subscriptions")
    return {10 + i: t for i, t in enumerate(topics)}


def _messages(ws, subscriptions: dict[int, str], n: int) -> dict[str, tuple[int, bytes]]:
    """The next ``n`` message-data frames: opcode 1, subscription id (u32), log time (u64),
    the payload (little endian)."""
    got: dict[str, tuple[int, bytes]] = {}
    while len(got) < n:
        frame = ws.recv()
        if isinstance(frame, bytes) and frame[0] == 0x01:
            sub, stamp = struct.unpack_from("<IQ", frame, 1)
            got[subscriptions[sub]] = (stamp, frame[13:])
    return got


def _scan_and_tf() -> tuple[msgs.LaserScan, msgs.TFMessage]:
    stamp = msgs.Time(12, 500_000_000)
    scan = msgs.LaserScan(header=msgs.Header(stamp, "laser_link"), angle_min=-np.pi,
                          angle_increment=np.pi / 180, range_max=12.0,
                          ranges=np.array([1.0, np.inf, 2.5], dtype=np.float32))
    tf = msgs.TFMessage((msgs.TransformStamped(
        msgs.Header(stamp, "odom"), "base_link",
        msgs.Transform(msgs.Vector3(1.5, -0.25, 0.0), msgs.Quaternion(0.0, 0.0, 0.6, 0.8))),))
    return scan, tf


def test_a_client_subscribes_to_scan_and_tf_and_decodes_them_as_ros2():
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    scan, tf = _scan_and_tf()
    with LiveView(port=0) as view:
        view.publish("/scan", scan, 12_500_000_000)          # advertises the channels
        view.publish("/tf", tf, 12_500_000_000)
        ws, _ = _connect(view)
        try:
            channels = _advertised(ws, {"/scan", "/tf"})
            assert channels["/scan"]["encoding"] == "cdr"
            assert channels["/scan"]["schemaName"] == "sensor_msgs/msg/LaserScan"
            assert channels["/scan"]["schemaEncoding"] == "ros2msg"
            assert channels["/tf"]["schemaName"] == "tf2_msgs/msg/TFMessage"
            subs = _subscribe(ws, view, channels, ["/scan", "/tf"])
            view.publish("/scan", scan, 12_600_000_000)
            view.publish("/tf", tf, 12_600_000_000)
            got = _messages(ws, subs, 2)
        finally:
            ws.close()
    stamp, payload = got["/scan"]
    assert stamp == 12_600_000_000
    ros_scan = store.deserialize_cdr(payload, "sensor_msgs/msg/LaserScan")
    assert ros_scan.header.frame_id == "laser_link" and ros_scan.header.stamp.sec == 12
    np.testing.assert_array_equal(ros_scan.ranges, scan.ranges)
    ros_tf = store.deserialize_cdr(got["/tf"][1], "tf2_msgs/msg/TFMessage")
    (t,) = ros_tf.transforms
    assert (t.header.frame_id, t.child_frame_id) == ("odom", "base_link")
    assert (t.transform.translation.x, t.transform.rotation.z) == (1.5, 0.6)


def test_a_late_subscriber_gets_the_map_it_missed():
    """/map is latched (transient local in ROS): published before anyone listened, it is sent
    again to the client that subscribes to it."""
    from rosbags.typesys import Stores, get_typestore

    grid = msgs.OccupancyGrid(msgs.Header(msgs.Time(0, 0), "map"),
                              msgs.MapMetaData(resolution=0.05, width=3, height=1),
                              np.array([0, 100, -1], dtype=np.int8))
    with LiveView(port=0) as view:
        view.publish("/map", grid, 0)
        ws, _ = _connect(view)
        try:
            channels = _advertised(ws, {"/map"})
            subs = _subscribe(ws, view, channels, ["/map"])
            view.resend_latched()
            got = _messages(ws, subs, 1)
        finally:
            ws.close()
    back = get_typestore(Stores.ROS2_HUMBLE).deserialize_cdr(got["/map"][1],
                                                             "nav_msgs/msg/OccupancyGrid")
    assert back.data.tolist() == [0, 100, -1] and back.info.width == 3


def test_addresses_parse_and_a_bad_one_says_what_is_expected():
    assert parse_address("8765") == ("127.0.0.1", 8765)
    assert parse_address("0.0.0.0:9000") == ("0.0.0.0", 9000)
    assert parse_address(":0") == ("127.0.0.1", 0)
    with pytest.raises(ValueError, match=r"HOST:PORT or PORT .* got 'localhost:http'"):
        parse_address("localhost:http")
    with pytest.raises(ValueError, match="got '70000'"):
        parse_address("70000")


def test_a_port_in_use_is_refused_with_the_address():
    with LiveView(port=0) as view:
        with pytest.raises(ValueError, match=f"cannot serve the live view on 127.0.0.1:"
                                             f"{view.port}"):
            LiveView(port=view.port)


def test_without_the_live_extra_a_view_says_how_to_install_it(monkeypatch, capsys, tmp_path):
    """foxglove-sdk is the kit's ``live`` extra, not in the labs' install: asking for a live
    view without it is one line naming the extra and the command, exit code 2, no traceback."""
    from kit.cli import main as kit_main

    for name in ("foxglove", "foxglove.websocket"):
        monkeypatch.setitem(sys.modules, name, None)  # as if not installed
    with pytest.raises(ValueError, match=r"pip install -e '\.\[live\]'"):
        LiveView(port=0)
    assert kit_main(["sim", "navigate", "--episodes", "1", "--live", "--out",
                     str(tmp_path / "runs")]) == 2
    err = capsys.readouterr().err
    assert "live extra" in err and "make demo ARGS=--live" in err and "Traceback" not in err
