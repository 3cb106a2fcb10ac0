"""Every kit message round-trips through the real ROS 2 Humble definitions (rosbags)."""

import dataclasses
from typing import ClassVar

import numpy as np
import pytest

from kit import msgs, rosconv

stamp = msgs.Time(sec=12, nanosec=345_000_000)
header = msgs.Header(stamp, "odom")
quat = msgs.Quaternion(0.0, 0.0, 0.3826834323650898, 0.9238795325112867)
pose = msgs.Pose(msgs.Point(1.5, -2.25, 0.0), quat)
twist = msgs.Twist(msgs.Vector3(0.4, 0.0, 0.0), msgs.Vector3(0.0, 0.0, -0.7))
cov = np.arange(36, dtype=float) * 0.01
transform = msgs.TransformStamped(header, "base_link",
                                  msgs.Transform(msgs.Vector3(1.0, 2.0, 0.0), quat))

SAMPLES = [
    stamp,
    header,
    msgs.Vector3(1.0, 2.0, 3.0),
    msgs.Point(-1.0, 0.5, 0.25),
    quat,
    pose,
    msgs.PoseWithCovariance(pose, cov),
    msgs.PoseStamped(msgs.Header(stamp, "map"), pose),
    twist,
    msgs.TwistWithCovariance(twist, cov[::-1].copy()),
    msgs.Transform(msgs.Vector3(0.1, 0.0, 0.13), quat),
    transform,
    msgs.Odometry(header, "base_link", msgs.PoseWithCovariance(pose, cov),
                  msgs.TwistWithCovariance(twist, cov)),
    msgs.Path(msgs.Header(stamp, "map"), (msgs.PoseStamped(header, pose),
                                          msgs.PoseStamped(header, msgs.Pose()))),
    msgs.MapMetaData(stamp, 0.05, 4, 3, pose),
    msgs.OccupancyGrid(msgs.Header(stamp, "map"), msgs.MapMetaData(stamp, 0.05, 4, 3, pose),
                       np.array([-1, 0, 100, 50] * 3, dtype=np.int8)),
    msgs.LaserScan(msgs.Header(stamp, "laser_link"), angle_min=-np.pi, angle_max=np.pi,
                   angle_increment=2 * np.pi / 360, time_increment=1 / 2000, scan_time=1 / 5.5,
                   range_min=0.15, range_max=12.0,
                   ranges=np.array([1.0, np.inf, 0.5, np.nan], dtype=np.float32),
                   intensities=np.array([47, 0, 12, 0], dtype=np.float32)),
    msgs.Imu(msgs.Header(stamp, "imu_link"), quat, np.eye(3).ravel() * 1e-3,
             msgs.Vector3(0, 0, 0.1), np.eye(3).ravel() * 4e-6,
             msgs.Vector3(0.2, 0, 9.81), np.eye(3).ravel() * 2.5e-3),
    msgs.JointState(header, ("right_wheel_joint", "left_wheel_joint"), [1.0, 2.0],
                    [0.5, -0.5], []),
    msgs.TFMessage((transform, transform)),
    msgs.PoseWithCovarianceStamped(msgs.Header(stamp, "map"), msgs.PoseWithCovariance(pose, cov)),
    msgs.String("<robot name='uiabot'/>"),
    msgs.Clock(stamp),
    msgs.PoseArray(msgs.Header(stamp, "map"), (pose, msgs.Pose())),
]


def test_every_listed_type_has_a_sample():
    assert {type(m) for m in SAMPLES} == set(msgs.MESSAGE_TYPES.values())


@pytest.mark.parametrize("message", SAMPLES, ids=lambda m: type(m).__name__)
def test_message_round_trips_through_ros2_cdr(message):
    data = rosconv.serialize_cdr(message)
    back = rosconv.deserialize_cdr(data, message.ROS_TYPE)
    assert back == message
    assert type(back) is type(message)


@pytest.mark.parametrize("message", SAMPLES, ids=lambda m: type(m).__name__)
def test_message_field_names_match_ros_definitions(message):
    store = rosconv.typestore()
    ros_names = [name for name, _ in store.fielddefs[message.ROS_TYPE][1]]
    assert [f.name for f in dataclasses.fields(message)] == ros_names


def test_drifted_field_name_is_caught():
    @dataclasses.dataclass(frozen=True, eq=False)
    class BadTwist(msgs.Message):
        ROS_TYPE = "geometry_msgs/msg/Twist"
        linear: msgs.Vector3 = dataclasses.field(default_factory=msgs.Vector3)
        angluar: msgs.Vector3 = dataclasses.field(default_factory=msgs.Vector3)

    with pytest.raises(TypeError, match="angluar"):
        rosconv.to_ros(BadTwist())


def test_wrong_element_type_is_caught():
    @dataclasses.dataclass(frozen=True, eq=False)
    class BadGrid(msgs.Message):
        ROS_TYPE = "nav_msgs/msg/OccupancyGrid"
        ARRAYS: ClassVar[dict] = {"data": (np.int16, None)}
        header: msgs.Header = dataclasses.field(default_factory=msgs.Header)
        info: msgs.MapMetaData = dataclasses.field(default_factory=msgs.MapMetaData)
        data: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.int16))

    with pytest.raises(TypeError, match="int8"):
        rosconv.to_ros(BadGrid())


def test_messages_and_their_arrays_are_immutable():
    scan = SAMPLES[16]
    with pytest.raises(dataclasses.FrozenInstanceError):
        scan.angle_min = 0.0
    with pytest.raises(ValueError, match="read-only"):
        scan.ranges[0] = 3.0


def test_float32_fields_are_rounded_like_ros():
    scan = msgs.LaserScan(angle_increment=0.1)
    assert scan.angle_increment == float(np.float32(0.1))


def test_time_from_and_to_seconds():
    t = msgs.Time.from_sec(12.345)
    assert (t.sec, t.nanosec) == (12, 345_000_000)
    assert t.to_sec() == pytest.approx(12.345)
    assert msgs.Time.from_sec(-0.5) == msgs.Time(-1, 500_000_000)
    with pytest.raises(ValueError, match="nanosec"):
        msgs.Time(0, 1_000_000_000)


def test_bad_shapes_are_rejected_with_the_field_name():
    with pytest.raises(ValueError, match=r"PoseWithCovariance.covariance must have shape \(36,\)"):
        msgs.PoseWithCovariance(covariance=np.zeros(9))
    with pytest.raises(ValueError, match="4 x 3"):
        msgs.OccupancyGrid(info=msgs.MapMetaData(width=4, height=3), data=np.zeros(5))


@pytest.mark.dataset
def test_reads_a_real_turtlebot4_bag_into_kit_messages(shared_data):
    """The TurtleBot 4 bag of ../shared/data/ros2-bags decodes into kit messages whose
    contents match the figures its README publishes."""
    from rosbags.highlevel import AnyReader

    bag = shared_data / "ros2-bags" / "turtlebot4-real-olin-mac-first-floor"
    scans, odoms = [], []
    with AnyReader([bag], default_typestore=rosconv.typestore()) as reader:
        conns = [c for c in reader.connections if c.topic in ("/scan", "/odom")]
        for conn, _t, raw in reader.messages(connections=conns):
            m = rosconv.from_ros(reader.deserialize(raw, conn.msgtype))
            (scans if conn.topic == "/scan" else odoms).append(m)
    assert len(scans) == 357 and len(odoms) == 920
    assert all(isinstance(s, msgs.LaserScan) and len(s.ranges) == 720 for s in scans)
    assert scans[0].header.frame_id == "rplidar_link"
    np.testing.assert_allclose(scans[0].ranges[:5], [3.148, 3.14, 3.14, 3.14, 3.14], atol=5e-4)
    r = scans[0].ranges
    valid = np.isfinite(r) & (r >= scans[0].range_min) & (r <= scans[0].range_max)
    assert valid.sum() == 539  # the README's count: finite ranges above range_max are invalid
    from kit.geometry import quaternion_to_yaw

    first, last = odoms[0].pose.pose, odoms[-1].pose.pose
    np.testing.assert_allclose([first.position.x, first.position.y], [6.5396, -8.8584], atol=1e-4)
    np.testing.assert_allclose([last.position.x, last.position.y], [8.1388, -14.6815], atol=1e-4)
    yaw = [float(quaternion_to_yaw([o.x, o.y, o.z, o.w])) for o in (first.orientation,
                                                                     last.orientation)]
    np.testing.assert_allclose(yaw, [1.7055, -1.0183], atol=1e-4)
    xy = np.array([[o.pose.pose.position.x, o.pose.pose.position.y] for o in odoms])
    assert np.linalg.norm(np.diff(xy, axis=0), axis=1).sum() == pytest.approx(8.35, abs=0.01)


def test_trusted_construction_equals_the_checked_one():
    """The simulator builds its high-rate messages with Message.trusted: same messages."""
    from sim import Simulation

    sim = Simulation("square", "uiabot", seed=3)
    out = sim.run(0.5, msgs.Twist(linear=msgs.Vector3(0.3, 0.0, 0.0)))
    kinds = set()
    for _, m in out:
        rebuilt = type(m)(**{f.name: getattr(m, f.name) for f in dataclasses.fields(m)})
        assert rebuilt == m
        assert repr(rebuilt) == repr(m)
        kinds.add(type(m).__name__)
    assert kinds == {"LaserScan", "Imu", "JointState"}
    with pytest.raises(TypeError, match="takes 3 values"):
        msgs.Vector3.trusted(1.0, 2.0)
