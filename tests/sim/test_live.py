"""The simulator live in Foxglove and ``python -m sim navigate``'s bags: a client on the
loopback address decodes the simulated robot's /scan and /tf; one bag per episode."""

from __future__ import annotations

import json
import struct
import time

import pytest

from kit import msgs
from kit.liveview import LiveView

websocket = pytest.importorskip("websocket")


def test_the_simulated_robot_streams_scan_and_tf_to_a_subscribed_client():
    from rosbags.typesys import Stores, get_typestore

    from sim.live import LiveNode
    from sim.runner import Runner, WheelOdometryNode
    from sim.simulation import Simulation

    store = get_typestore(Stores.ROS2_HUMBLE)
    sim = Simulation(world="office", robot="uiabot", seed=1, people=0)
    with LiveView(port=0) as view:
        # the channels exist once something was sent on them: a client subscribes to them
        view.publish("/scan", msgs.LaserScan(), 0)
        view.publish("/tf", msgs.TFMessage(), 0)
        ws = websocket.create_connection(f"ws://127.0.0.1:{view.port}",
                                         subprotocols=["foxglove.sdk.v1"], timeout=30)
        try:
            channels: dict[str, int] = {}
            while len(channels) < 2:
                m = ws.recv()
                if isinstance(m, str) and json.loads(m)["op"] == "advertise":
                    channels.update({c["topic"]: c["id"] for c in json.loads(m)["channels"]})
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": 1, "channelId": channels["/scan"]},
                {"id": 2, "channelId": channels["/tf"]}]}))
            deadline = time.monotonic() + 30.0
            while view.clients < 2:            # the server's thread takes the subscriptions
                assert time.monotonic() < deadline, "the subscriptions never arrived"
                time.sleep(0.01)
            Runner(sim, [WheelOdometryNode(), LiveNode(view, ("/scan", "/tf"), speed=None)]
                   ).run(0.5)
            got: dict[int, list] = {1: [], 2: []}
            while not (got[1] and got[2]):
                frame = ws.recv()
                if isinstance(frame, bytes) and frame[0] == 0x01:
                    sub, stamp = struct.unpack_from("<IQ", frame, 1)
                    got[sub].append((stamp, frame[13:]))
        finally:
            ws.close()
    stamp, payload = got[1][0]
    scan = store.deserialize_cdr(payload, "sensor_msgs/msg/LaserScan")
    assert scan.header.frame_id == "laser_link" and len(scan.ranges) == 360
    # logged at the simulated time its turn was complete, before the next one is; stamped at
    # its first beam
    first_beam = scan.header.stamp.sec * 10**9 + scan.header.stamp.nanosec
    assert scan.scan_time * 1e9 <= stamp - first_beam < 2 * scan.scan_time * 1e9
    tf = store.deserialize_cdr(got[2][0][1], "tf2_msgs/msg/TFMessage")
    assert [(t.header.frame_id, t.child_frame_id) for t in tf.transforms] == [("odom",
                                                                              "base_link")]


def test_speed_without_live_and_a_bad_address_are_refused(tmp_path, capsys):
    from sim.__main__ import main

    assert main(["navigate", "--episodes", "1", "--speed", "4", "--out", str(tmp_path)]) == 2
    assert "--speed paces the live view: give --live too" in capsys.readouterr().err
    assert main(["navigate", "--episodes", "1", "--live", "here:there", "--out",
                 str(tmp_path)]) == 2
    assert "a live view's address is HOST:PORT or PORT" in capsys.readouterr().err


@pytest.mark.slow
def test_navigate_writes_its_table_and_a_bag_per_episode_into_out(tmp_path, capsys):
    from kit.bag import bag_topics
    from sim.__main__ import main

    args = ["navigate", "--world", "office", "--episodes", "1", "--people", "0", "--bag",
            "--quiet", "--out", str(tmp_path / "runs")]
    assert main(args) == 0
    assert "navigate.csv and 1 bags" in capsys.readouterr().out
    assert (tmp_path / "runs" / "navigate.csv").read_text().startswith("episode,goal,")
    topics = bag_topics(tmp_path / "runs" / "episode_000")
    assert {"/clock", "/map", "/tf_static", "/scan", "/plan", "/local_plan",
            "/global_costmap/costmap", "/robot_description"} <= topics.keys()
    assert "/particlecloud" not in topics            # truth localization: no particles
    assert main(args) == 2
    assert "already holds episode_000" in capsys.readouterr().err


def test_kit_sim_is_the_simulators_command(capsys):
    """kit finds it through the kit.commands entry point (kit never imports sim)."""
    from kit.cli import main as kit_main

    with pytest.raises(SystemExit):
        kit_main(["sim", "navigate", "--help"])
    text = capsys.readouterr().out
    assert "--live [HOST:PORT]" in text and "navigate.csv" in text and "--quiet" in text
    assert kit_main(["sim", "navigate", "--episodes", "0", "--out", "x"]) == 2
    assert "kit: --episodes must be at least 1" in capsys.readouterr().err
