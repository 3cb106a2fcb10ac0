"""Recovery behaviours (spin, back up, wait) and the controller server's checkers (progress,
goal), in Nav2's design with Nav2's parameter names and defaults.

A behaviour is ticked at the controller's rate with the time, the robot's pose and the local
costmap; each tick returns ``(status, (v, ω))`` with status ``RUNNING``, ``SUCCEEDED`` or
``FAILED`` (and ``reason`` set). Spin and back-up check the footprint ahead of the motion on
the costmap, ``simulate_ahead_time`` seconds, and fail rather than collide, as Nav2's do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry
from kit.navigation._costmap import collides_from, outline_points
from kit.planning import Costmap

__all__ = ["FAILED", "RUNNING", "SUCCEEDED", "BackUp", "Behavior", "GoalChecker",
           "ProgressChecker", "Spin", "Unavailable", "Wait"]

RUNNING, SUCCEEDED, FAILED = "RUNNING", "SUCCEEDED", "FAILED"
FloatArray = NDArray[np.float64]


class Behavior:
    """A recovery behaviour: ``start(time, pose)``, then ``tick`` until it ends."""

    name = "behavior"

    def __init__(self, time_allowance: float = 10.0, footprint: ArrayLike | None = None,
                 simulate_ahead_time: float = 2.0) -> None:
        self.time_allowance = float(time_allowance)
        self.footprint = (np.asarray(footprint, dtype=np.float64) if footprint is not None
                          else np.array([[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.2, -0.2]]))
        self.simulate_ahead_time = float(simulate_ahead_time)
        self.reason = ""
        self._t0 = 0.0
        self._start: FloatArray = np.zeros(3)

    def start(self, time: float, pose: ArrayLike) -> None:
        self._t0 = float(time)
        self._start = geometry.check_pose(pose, "pose").copy()
        self.reason = ""

    def _timed_out(self, time: float) -> bool:
        if time - self._t0 > self.time_allowance:
            self.reason = f"{self.name}: ran out of its {self.time_allowance:g} s"
            return True
        return False

    def _blocked(self, costmap: Costmap | None, poses: FloatArray) -> bool:
        if costmap is None:
            return False
        return bool(np.any(collides_from(costmap, poses[0], poses[1:],
                                         outline_points(self.footprint, costmap.resolution))))

    def tick(self, time: float, pose: ArrayLike, costmap: Costmap | None
             ) -> tuple[str, tuple[float, float]]:
        raise NotImplementedError  # pragma: no cover - every behaviour overrides it


class Spin(Behavior):
    """Turn in place by ``spin_dist`` radians (Nav2: 1.57), at up to
    ``max_rotational_vel`` (1.0 rad/s), accelerating at ``rotational_acc_lim`` (3.2 rad/s²)."""

    name = "spin"

    def __init__(self, spin_dist: float = 1.57, max_rotational_vel: float = 1.0,
                 min_rotational_vel: float = 0.4, rotational_acc_lim: float = 3.2,
                 **kw: float | ArrayLike) -> None:
        super().__init__(**kw)  # type: ignore[arg-type]
        self.spin_dist = float(spin_dist)
        self.max_w, self.min_w = float(max_rotational_vel), float(min_rotational_vel)
        self.acc = float(rotational_acc_lim)
        self._turned = 0.0
        self._last_yaw = 0.0

    def start(self, time: float, pose: ArrayLike) -> None:
        super().start(time, pose)
        self._turned, self._last_yaw = 0.0, float(self._start[2])

    def tick(self, time: float, pose: ArrayLike, costmap: Costmap | None
             ) -> tuple[str, tuple[float, float]]:
        p = geometry.check_pose(pose, "pose")
        self._turned += float(geometry.wrap_angle(p[2] - self._last_yaw))
        self._last_yaw = float(p[2])
        left = abs(self.spin_dist) - abs(self._turned)
        if left <= 0.0:
            return SUCCEEDED, (0.0, 0.0)
        if self._timed_out(time):
            return FAILED, (0.0, 0.0)
        w = min(self.max_w, max(self.min_w, math.sqrt(2.0 * self.acc * left)))
        w = math.copysign(w, self.spin_dist)
        ahead = np.linspace(0.0, min(left, abs(w) * self.simulate_ahead_time), 8)
        poses = np.column_stack([np.full(8, p[0]), np.full(8, p[1]),
                                 p[2] + np.sign(self.spin_dist) * ahead])
        if self._blocked(costmap, poses):
            self.reason = "spin: an obstacle is in the way of turning"
            return FAILED, (0.0, 0.0)
        return RUNNING, (0.0, w)


class BackUp(Behavior):
    """Drive straight back ``backup_dist`` metres (Nav2's BT: 0.30) at ``backup_speed``
    (0.05 m/s)."""

    name = "backup"

    def __init__(self, backup_dist: float = 0.30, backup_speed: float = 0.05,
                 **kw: float | ArrayLike) -> None:
        super().__init__(**kw)  # type: ignore[arg-type]
        self.distance, self.speed = abs(float(backup_dist)), abs(float(backup_speed))

    def tick(self, time: float, pose: ArrayLike, costmap: Costmap | None
             ) -> tuple[str, tuple[float, float]]:
        p = geometry.check_pose(pose, "pose")
        moved = math.hypot(p[0] - self._start[0], p[1] - self._start[1])
        if moved >= self.distance:
            return SUCCEEDED, (0.0, 0.0)
        if self._timed_out(time):
            return FAILED, (0.0, 0.0)
        reach = min(self.distance - moved, self.speed * self.simulate_ahead_time)
        back = np.linspace(0.0, reach, 6)
        poses = np.column_stack([p[0] - back * math.cos(p[2]), p[1] - back * math.sin(p[2]),
                                 np.full(6, p[2])])
        if self._blocked(costmap, poses):
            self.reason = "backup: an obstacle is behind the robot"
            return FAILED, (0.0, 0.0)
        return RUNNING, (-self.speed, 0.0)


class Unavailable(Behavior):
    """A recovery the behaviour server does not offer: it fails at once (as Nav2's tree node
    fails when its action server is missing)."""

    def __init__(self, name: str) -> None:
        super().__init__()
        self.name = name

    def tick(self, time: float, pose: ArrayLike, costmap: Costmap | None
             ) -> tuple[str, tuple[float, float]]:
        self.reason = f"{self.name}: not among the behaviour server's behavior_plugins"
        return FAILED, (0.0, 0.0)


class Wait(Behavior):
    """Stand still for ``wait_duration`` seconds (Nav2's BT: 5 s)."""

    name = "wait"

    def __init__(self, wait_duration: float = 5.0, **kw: float | ArrayLike) -> None:
        super().__init__(**kw)  # type: ignore[arg-type]
        self.duration = float(wait_duration)

    def tick(self, time: float, pose: ArrayLike, costmap: Costmap | None
             ) -> tuple[str, tuple[float, float]]:
        if time - self._t0 >= self.duration:
            return SUCCEEDED, (0.0, 0.0)
        return RUNNING, (0.0, 0.0)


@dataclass
class ProgressChecker:
    """Nav2's ``SimpleProgressChecker``: the robot must move ``required_movement_radius``
    metres from where it last did within ``movement_time_allowance`` seconds; with
    ``required_movement_angle`` [rad], Nav2's ``PoseProgressChecker``: turning that far
    counts too."""

    required_movement_radius: float = 0.5
    movement_time_allowance: float = 10.0
    required_movement_angle: float | None = None

    def __post_init__(self) -> None:
        self._anchor: FloatArray | None = None
        self._since = 0.0

    def reset(self) -> None:
        self._anchor = None

    def _moved(self, p: FloatArray) -> bool:
        assert self._anchor is not None
        if math.hypot(p[0] - self._anchor[0], p[1] - self._anchor[1]) > \
                self.required_movement_radius:
            return True
        return self.required_movement_angle is not None and len(p) > 2 and abs(float(
            geometry.wrap_angle(p[2] - self._anchor[2]))) > self.required_movement_angle

    def check(self, time: float, pose: ArrayLike) -> bool:
        """False once the robot has been stuck for longer than the allowance."""
        p = np.asarray(pose, dtype=float)
        if self._anchor is None or self._moved(p):
            self._anchor, self._since = p.copy(), float(time)
            return True
        return time - self._since <= self.movement_time_allowance


@dataclass
class GoalChecker:
    """Nav2's ``SimpleGoalChecker``: within ``xy_goal_tolerance`` metres and
    ``yaw_goal_tolerance`` radians; ``stateful``: once inside the xy tolerance it stays so
    while the robot turns. With ``trans_stopped_velocity`` [m/s], Nav2's
    ``StoppedGoalChecker``: the robot must also be slower than that and than
    ``rot_stopped_velocity`` [rad/s]."""

    xy_goal_tolerance: float = 0.25
    yaw_goal_tolerance: float = 0.25
    stateful: bool = True
    trans_stopped_velocity: float | None = None
    rot_stopped_velocity: float = 0.25

    def __post_init__(self) -> None:
        self._xy_reached = False

    def reset(self) -> None:
        self._xy_reached = False

    def is_goal_reached(self, pose: ArrayLike, goal: ArrayLike,
                        velocity: ArrayLike = (0.0, 0.0)) -> bool:
        p, g = np.asarray(pose, dtype=float), np.asarray(goal, dtype=float)
        if not self._xy_reached:
            if math.hypot(p[0] - g[0], p[1] - g[1]) > self.xy_goal_tolerance:
                return False
            self._xy_reached = self.stateful
        if abs(float(geometry.wrap_angle(g[2] - p[2]))) > self.yaw_goal_tolerance:
            return False
        if self.trans_stopped_velocity is None:
            return True
        v, w = (float(x) for x in np.asarray(velocity, dtype=float)[:2])
        return abs(v) <= self.trans_stopped_velocity and abs(w) <= self.rot_stopped_velocity
