"""What Nav2's servers publish while a robot navigates, for bags and the live view.

:class:`sim.scenarios.NavigationNode` publishes ``/cmd_vel``, ``/plan`` and ``map → odom``;
:class:`NavigationTopics` runs beside it and publishes the rest of what a Nav2 robot shows in
RViz or Foxglove, from the navigation node's own state:

============================  ========================================  =======================
topic                         type                                      when
============================  ========================================  =======================
``/robot_description``        ``std_msgs/String`` (the URDF, latched)   once, at the start
``/amcl_pose``                ``geometry_msgs/PoseWithCovarianceStamped``  after each AMCL update
``/particlecloud``            ``geometry_msgs/PoseArray``               after each AMCL update
``/local_plan``               ``nav_msgs/Path``                         10 Hz
``/global_costmap/costmap``   ``nav_msgs/OccupancyGrid`` (latched)      1 Hz
``/local_costmap/costmap``    ``nav_msgs/OccupancyGrid`` (latched)      2 Hz
============================  ========================================  =======================

The costmaps' rates are Nav2's ``publish_frequency`` defaults, their values Nav2's costmap
publisher's (0–100, −1 unknown). The local plan is the part of ``/plan`` ahead of the robot
inside the local costmap, as Regulated Pure Pursuit publishes it. The particle cloud is a
``PoseArray`` — as ROS 1's ``amcl`` published it and as rosbags' Humble types read it —
of at most :data:`MAX_CLOUD` particles, evenly strided.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from kit import geometry, msgs
from kit.robots import RobotDescription
from sim.runner import Node, Published
from sim.simulation import Simulation

__all__ = ["MAX_CLOUD", "TOPICS", "NavigationTopics", "robot_description_xml"]

MAX_CLOUD = 2000
"""At most this many particles in one ``/particlecloud`` message."""

TOPICS = ("/robot_description", "/amcl_pose", "/particlecloud", "/local_plan",
          "/global_costmap/costmap", "/local_costmap/costmap")
"""What :class:`NavigationTopics` publishes."""


def robot_description_xml(robot: RobotDescription, xacro_args: dict[str, str] | None = None,
                          package_paths: dict[str, Path] | None = None) -> str | None:
    """The robot's URDF as ``robot_state_publisher`` would publish it (xacro expanded);
    ``None`` when its description has no URDF file the kit can read back."""
    from kit import description_files

    source = Path(robot.source)
    if source.suffix == ".toml" and "urdf" in robot.parameters:
        source = source.parent / str(robot.parameters["urdf"])
    if source.is_file() and source.suffix in (".urdf", ".xacro"):
        return description_files.read_urdf(source, xacro_args, package_paths)[0]
    if source.exists() and source.suffix not in (".toml",):
        try:
            return description_files.read_bag_description(source)[0]
        except ValueError:
            return None
    return None


def _pose(p: np.ndarray) -> msgs.Pose:
    q = geometry.yaw_to_quaternion(float(p[2]))
    return msgs.Pose(msgs.Point(float(p[0]), float(p[1]), 0.0), msgs.Quaternion(*map(float, q)))


def local_plan(path: np.ndarray, pose: np.ndarray, half_width: float) -> np.ndarray:
    """The part of ``path`` (N, 2) [m] from its point nearest ``pose`` onwards, up to the
    first point farther than ``half_width`` from the robot along either axis."""
    if len(path) == 0:
        return path
    start = int(np.argmin(np.hypot(*(path - pose[:2]).T)))
    ahead = path[start:]
    outside = np.nonzero(np.max(np.abs(ahead - pose[:2]), axis=1) > half_width)[0]
    return ahead[:outside[0]] if len(outside) else ahead


class NavigationTopics(Node):
    """Publishes what Nav2's AMCL, controller and costmaps publish (see the module's table),
    read from ``navigation`` (a :class:`sim.scenarios.NavigationNode`).

    Parameters
    ----------
    navigation
        The navigation node whose state is published.
    urdf
        The robot's URDF text for ``/robot_description`` (none published when ``None``).
    """

    rate = 10.0

    def __init__(self, navigation: Any, urdf: str | None = None) -> None:
        self.navigation = navigation
        self.urdf = urdf
        self._updates = -1
        self._costmaps_due = {"/global_costmap/costmap": 0.0, "/local_costmap/costmap": 0.0}

    def start(self, sim: Simulation, robot: int) -> Published:
        self.sim, self._updates = sim, -1
        self._costmaps_due = dict.fromkeys(self._costmaps_due, sim.time)
        return [] if self.urdf is None else [("/robot_description", msgs.String(self.urdf))]

    def on_tick(self, time: float) -> Published:
        nav = self.navigation
        if getattr(nav, "done", False) or not hasattr(nav, "odom_pose"):
            return []
        stamp = msgs.Time.from_sec(time)
        pose = np.asarray(nav.localization.pose(nav.odom_pose), dtype=float)
        out: list[tuple[str, Any]] = [*self._amcl(stamp)]
        navigator = nav.navigator
        half = 0.5 * navigator.params.local_width
        plan = local_plan(np.asarray(navigator.path, dtype=float), pose, half)
        out.append(("/local_plan", msgs.Path(msgs.Header(stamp, "map"), tuple(
            msgs.PoseStamped(msgs.Header(stamp, "map"), _pose(np.array([x, y, 0.0])))
            for x, y in plan))))
        for topic, period in (("/global_costmap/costmap", 1.0), ("/local_costmap/costmap", 0.5)):
            if time + 1e-9 >= self._costmaps_due[topic]:
                self._costmaps_due[topic] = time + period
                costmap = (navigator.global_costmap.costmap(pose) if topic.startswith("/global")
                           else navigator.local_costmap_now(time, pose))
                grid = costmap.to_occupancy_grid()
                out.append((topic, msgs.OccupancyGrid(msgs.Header(stamp, grid.header.frame_id),
                                                      grid.info, grid.data)))
        return out

    def _amcl(self, stamp: msgs.Time) -> Published:
        amcl = getattr(self.navigation.localization, "amcl", None)
        if amcl is None or amcl.updates == self._updates or amcl.estimate is None:
            return []
        self._updates = amcl.updates
        poses = amcl.filter.poses
        cloud = poses[::max(1, math.ceil(len(poses) / MAX_CLOUD))]
        header = msgs.Header(stamp, "map")
        estimate = amcl.pose_message()
        return [("/amcl_pose", msgs.PoseWithCovarianceStamped(header, estimate.pose)),
                ("/particlecloud", msgs.PoseArray(header, tuple(_pose(p) for p in cloud)))]
