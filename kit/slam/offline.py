"""SLAM over a whole recording: a CARMEN log or a ROS 2 bag, fed to :class:`Slam` in order.

A bag needs ``/scan`` (``sensor_msgs/LaserScan``), ``/odom`` (``nav_msgs/Odometry``) and the
static transform from the odometry's child frame to the scan's frame on ``/tf_static`` (or
``/tf``). Scans and odometry are paired by their *header* stamps — a Gazebo bag stamps them
with simulation time while the bag records wall-clock time — and the odometry is interpolated
at each scan's stamp (and at each beam's time, to de-skew a scan taken while turning).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs, tf
from kit.slam.carmen import CarmenLog, laser_to_scan
from kit.slam.frontend import Slam, SlamConfig

__all__ = ["BagRecording", "odometry_at", "read_bag_recording", "run_bag", "run_carmen"]

FloatArray = NDArray[np.float64]


def run_carmen(log: CarmenLog, config: SlamConfig | None = None,
               progress: Callable[[int], object] | None = None,
               odometry: ArrayLike | None = None) -> Slam:
    """SLAM over a CARMEN log's laser messages with their odometry fields (FLASER's
    ``odom_*``; ROBOTLASER1's robot pose), the laser mounted as the log says.

    ``odometry`` ``(N, 3)``, one pose per laser message, replaces the log's (for instance
    :func:`kit.slam.evaluate.perturb_odometry` of a log whose poses are already corrected).
    """
    if not log.lasers:
        raise ValueError("the log has no laser messages")
    first = log.lasers[0]
    mount = geometry.relative(first.robot_pose, first.laser_pose)
    odom = np.array([r.robot_pose for r in log.lasers]) if odometry is None else \
        geometry.check_pose(odometry, "odometry")
    if odom.shape != (len(log.lasers), 3):
        raise ValueError(f"odometry needs one pose per laser message, shape "
                         f"({len(log.lasers)}, 3); got {odom.shape}")
    slam = Slam(mount, config)
    for record, pose in zip(log.lasers, odom, strict=True):
        slam.add_scan(laser_to_scan(record), pose, record.timestamp)
        if progress is not None:
            progress(1)
    slam.optimize()
    return slam


@dataclass
class BagRecording:
    """What SLAM needs from a bag."""

    scans: list[msgs.LaserScan] = field(default_factory=list)
    odometry_times: FloatArray = field(default_factory=lambda: np.zeros(0))
    odometry: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    """``T_odom_base`` (x, y, θ) at each odometry time; θ unwrapped for interpolation."""
    base_to_laser: FloatArray = field(default_factory=lambda: np.zeros(3))
    base_frame: str = ""
    laser_frame: str = ""


def read_bag_recording(path: str | Path, scan_topic: str = "/scan",
                       odom_topic: str = "/odom") -> BagRecording:
    """Read scans, odometry and the laser's mounting from a ROS 2 (or ROS 1) bag.

    Raises
    ------
    ValueError
        No scans or no odometry on the topics, or no transform from the odometry's child
        frame to the scan's frame.
    """
    from kit.bag import read_bag  # rosbags is imported only when a bag is read

    tree = tf.TransformTree(cache_time=1e9)
    scans: list[msgs.LaserScan] = []
    times, poses, child = [], [], ""
    for topic, _, message in read_bag(path, [scan_topic, odom_topic, "/tf_static", "/tf"]):
        if topic == scan_topic and isinstance(message, msgs.LaserScan):
            scans.append(message)
        elif topic == odom_topic and isinstance(message, msgs.Odometry):
            p = message.pose.pose
            times.append(message.header.stamp.to_sec())
            poses.append((p.position.x, p.position.y, float(geometry.quaternion_to_yaw(
                [p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w]))))
            child = message.child_frame_id
        elif topic == "/tf_static" and isinstance(message, msgs.TFMessage):
            tree.add_message(message, static=True)
        elif topic == "/tf" and isinstance(message, msgs.TFMessage):
            for t in message.transforms:  # a static mount re-published on /tf (ROS 1)
                if t.child_frame_id in {s.header.frame_id for s in scans[-1:]}:
                    tree.add_message(msgs.TFMessage((t,)), static=True)
    if not scans or not times:
        raise ValueError(f"{path}: SLAM needs {scan_topic} (LaserScan) and {odom_topic} "
                         f"(Odometry); found {len(scans)} scans, {len(times)} odometry messages")
    laser = scans[0].header.frame_id
    try:
        mount = tree.lookup_transform(child, laser).to_pose2d()
    except tf.TransformError as exc:
        raise ValueError(f"{path}: no static transform from the odometry's {child!r} to the "
                         f"scan's {laser!r} ({exc})") from None
    order = np.argsort(times)
    odom = np.array(poses)[order]
    odom[:, 2] = np.unwrap(odom[:, 2])
    return BagRecording(scans, np.array(times)[order], odom, mount, child, laser)


def odometry_at(times: FloatArray, recording: BagRecording) -> FloatArray:
    """``T_odom_base`` interpolated at ``times`` [s] (linear, the angle unwrapped), ``(K, 3)``;
    NaN outside the odometry's time span."""
    t = np.asarray(times, dtype=np.float64)
    out = np.column_stack([np.interp(t, recording.odometry_times, recording.odometry[:, k],
                                     left=np.nan, right=np.nan) for k in range(3)])
    out[:, 2] = geometry.wrap_angle(out[:, 2])
    return out


def run_bag(recording: BagRecording, config: SlamConfig | None = None, deskew: bool = True,
            progress: Callable[[int], object] | None = None) -> Slam:
    """SLAM over a bag's scans; scans outside the odometry's time span are skipped."""
    slam = Slam(recording.base_to_laser, config)
    for scan in recording.scans:
        stamp = scan.header.stamp.to_sec()
        n = len(scan.ranges)
        beam_times = np.asarray(stamp + float(scan.time_increment) * np.arange(n), dtype=np.float64)
        odom = odometry_at(np.array([stamp, beam_times[-1]]), recording)
        if progress is not None:
            progress(1)
        if not np.all(np.isfinite(odom)):
            continue
        motion = None
        if deskew and scan.time_increment > 0:
            at_beams = odometry_at(beam_times, recording)
            if np.all(np.isfinite(at_beams)):
                motion = geometry.relative(odom[0], at_beams)
        slam.add_scan(scan, odom[0], stamp, motion)
    if not slam.records:
        raise ValueError("no scan fell within the odometry's time span")
    slam.optimize()
    return slam
