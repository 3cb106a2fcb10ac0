"""Path following: pure pursuit, and Nav2's Regulated Pure Pursuit.

Pure pursuit steers along the arc through the robot and the *carrot*, the point a lookahead
distance ``L`` ahead on the path: in the robot's frame the carrot is ``(x, y)`` and the arc's
curvature is ``κ = 2 y / (x² + y²)``, so ``ω = v κ`` (Coulter, 1992).

Regulated Pure Pursuit (Macenski et al., 2023; Nav2's ``RegulatedPurePursuitController``) adds
what a robot among people needs: the lookahead grows with speed (``L = v · lookahead_time``,
clamped), the speed drops on tight curves (radius below ``regulated_linear_scaling_min_radius``)
and near obstacles (the inflation cost under the robot), it slows down approaching the goal,
it rotates in place towards the path when the carrot is far off its heading, and it refuses a
command whose arc — or turn in place — would hit a lethal cell within
``max_allowed_time_to_collision_up_to_carrot``.
Parameter names and defaults are Nav2's.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry
from kit.navigation._costmap import collides_from, outline_points
from kit.navigation._path import (
    ControlError,
    check_path,
    closest_index,
    lookahead_point,
    remaining_length,
    require_positive,
)
from kit.planning import FREE_SPACE, NO_INFORMATION, Costmap, footprint_radii
from kit.robots import RobotDescription

__all__ = ["PurePursuit", "RegulatedPurePursuit", "RppParameters", "arc_poses",
           "pure_pursuit_curvature"]

FloatArray = NDArray[np.float64]


def pure_pursuit_curvature(pose: ArrayLike, carrot: ArrayLike) -> float:
    """Curvature [1/m] of the arc from ``pose`` (x, y, θ) through ``carrot`` (x, y):
    ``2 y / (x² + y²)`` with the carrot in the robot's frame (positive turns left).

    >>> round(pure_pursuit_curvature((0.0, 0.0, 0.0), (1.0, 1.0)), 6)   # a quarter circle
    1.0
    """
    p = geometry.check_pose(pose, "pose")
    local = geometry.transform_points(geometry.inverse(p), np.asarray(carrot, float)[None, :2])
    x, y = float(local[0, 0]), float(local[0, 1])
    d2 = x * x + y * y
    return 0.0 if d2 < 1e-12 else 2.0 * y / d2


class PurePursuit:
    """Plain pure pursuit at a constant speed with a fixed lookahead.

    ``compute_velocity_commands(pose, velocity, costmap)`` returns ``(v, ω)`` [m/s, rad/s];
    the costmap is not used (pure pursuit sees no obstacles), the angular speed is clipped to
    ``max_angular_velocity``.
    """

    def __init__(self, speed: float = 0.3, lookahead: float = 0.6,
                 max_angular_velocity: float = 2.0) -> None:
        if not (speed > 0 and lookahead > 0 and max_angular_velocity > 0):
            raise ValueError("speed, lookahead and max_angular_velocity must be positive")
        self.speed, self.lookahead = float(speed), float(lookahead)
        self.max_angular_velocity = float(max_angular_velocity)
        self.path: FloatArray = np.zeros((0, 2))
        self._index = 0

    def set_plan(self, path: ArrayLike) -> None:
        self.path = check_path(path)
        self._index = 0

    def compute_velocity_commands(self, pose: ArrayLike, velocity: ArrayLike = (0.0, 0.0),
                                  costmap: Costmap | None = None) -> tuple[float, float]:
        if len(self.path) == 0:
            raise ControlError("no path to follow")
        p = geometry.check_pose(pose, "pose")
        self._index = closest_index(self.path, p, self._index, 2.0)
        carrot = lookahead_point(self.path, p, self.lookahead, self._index)
        w = self.speed * pure_pursuit_curvature(p, carrot)
        return self.speed, float(np.clip(w, -self.max_angular_velocity,
                                         self.max_angular_velocity))


@dataclass(frozen=True)
class RppParameters:
    """Nav2's ``RegulatedPurePursuitController`` parameters (names, meaning, defaults: two of
    them the kit's — ``use_cost_regulated_linear_velocity_scaling`` off and
    ``cost_scaling_dist`` 0.3 m, where Nav2's are on and 0.6 m; a Nav2 file that leaves them
    out is reported as keeping the kit's), and one of the kit's:
    ``gentler_arcs_when_colliding`` — when the arc to the lookahead point would collide, try
    it at 1/2, 1/4, 1/8 and 1/16 of its curvature and straight on, and drive the first that
    is free, instead of failing at once as Nav2 does (the default).
    :meth:`for_robot` turns it on for a robot whose rear is more than 0.5 m behind its
    ``base_link`` (the IGV's front axle, 0.75 m ahead of its rear corners): such a robot
    swings its rear out on every turn, and near a wall, turning back toward the middle of a
    corridor touches it, while a wide arc leaves the wall before the rear gets there. For a
    robot turning about its middle (the Uiabot) it is left off: there, driving on past a
    blocked turn led into walls a recovery would have kept it from (SLAM while navigating
    the office, seed 5: 17 wall contacts with it, none without)."""

    desired_linear_vel: float = 0.5
    lookahead_dist: float = 0.6
    min_lookahead_dist: float = 0.3
    max_lookahead_dist: float = 0.9
    lookahead_time: float = 1.5
    rotate_to_heading_angular_vel: float = 1.8
    use_velocity_scaled_lookahead_dist: bool = False
    min_approach_linear_velocity: float = 0.05
    approach_velocity_scaling_dist: float = 0.6
    use_collision_detection: bool = True
    max_allowed_time_to_collision_up_to_carrot: float = 1.0
    use_regulated_linear_velocity_scaling: bool = True
    use_cost_regulated_linear_velocity_scaling: bool = False
    regulated_linear_scaling_min_radius: float = 0.9
    regulated_linear_scaling_min_speed: float = 0.25
    use_rotate_to_heading: bool = True
    rotate_to_heading_min_angle: float = 0.785
    stateful: bool = True
    """Once the goal has come within the goal checker's tolerance, keep turning to its heading
    until a new path (Nav2's ``stateful``, Jazzy)."""
    max_angular_accel: float = 3.2
    cost_scaling_dist: float = 0.3
    cost_scaling_gain: float = 1.0
    inflation_cost_scaling_factor: float = 3.0
    max_linear_accel: float = 2.5
    controller_frequency: float = 20.0
    max_robot_pose_search_dist: float = 2.0
    """m along the path from the last closest point within which the robot's closest point is
    looked for (Nav2's default: half the local costmap's larger side)."""
    gentler_arcs_when_colliding: bool = False

    def __post_init__(self) -> None:
        require_positive(self, ("desired_linear_vel", "lookahead_dist", "min_lookahead_dist",
                                "max_lookahead_dist", "lookahead_time",
                                "max_robot_pose_search_dist",
                                "rotate_to_heading_angular_vel", "controller_frequency",
                                "max_angular_accel", "max_linear_accel"))
        if self.min_lookahead_dist > self.max_lookahead_dist:
            raise ValueError("min_lookahead_dist must not exceed max_lookahead_dist")

    @classmethod
    def for_robot(cls, robot: RobotDescription, **overrides: float | bool) -> RppParameters:
        """Defaults with the robot's speed and acceleration limits."""
        base = cls(desired_linear_vel=robot.cruise_velocity,
                   max_linear_accel=robot.max_linear_acceleration,
                   rotate_to_heading_angular_vel=min(1.8, robot.max_angular_velocity),
                   gentler_arcs_when_colliding=bool(-np.min(robot.footprint[:, 0]) > 0.5))
        return replace(base, **overrides)  # type: ignore[arg-type]


class RegulatedPurePursuit:
    """Nav2's Regulated Pure Pursuit controller.

    ``curvature(pose, carrot) -> κ`` [1/m] and ``speed(curvature, remaining, desired,
    min_radius, min_speed, approach_dist, min_approach) -> v`` [m/s] (the parameters Nav2's
    ``desired_linear_vel``, ``regulated_linear_scaling_min_radius``,
    ``regulated_linear_scaling_min_speed``, ``approach_velocity_scaling_dist`` and
    ``min_approach_linear_velocity``), when given, take the place of the controller's own
    curvature and of its curvature and approach regulation — a student's functions (Lab 10)
    inside the whole controller. The cost regulation has no place in such a ``speed``: it
    must then be off.

    >>> c = RegulatedPurePursuit()
    >>> c.set_plan([(0.0, 0.0), (5.0, 0.0)])
    >>> v, w = c.compute_velocity_commands((0.0, 0.0, 0.0), (0.5, 0.0))
    >>> round(v, 3), round(w, 3)
    (0.5, 0.0)
    """

    def __init__(self, params: RppParameters | None = None,
                 footprint: ArrayLike | None = None, *,
                 curvature: Callable[[ArrayLike, ArrayLike], float] | None = None,
                 speed: Callable[..., float] | None = None) -> None:
        self.params = params or RppParameters()
        if speed is not None and self.params.use_cost_regulated_linear_velocity_scaling:
            raise ValueError("a speed function replaces the curvature and approach "
                             "regulation only: turn use_cost_regulated_linear_velocity_scaling"
                             " off to use one")
        self.curvature, self.speed = curvature, speed
        self.footprint = (np.asarray(footprint, dtype=np.float64) if footprint is not None
                          else np.array([[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.2, -0.2]]))
        self.path: FloatArray = np.zeros((0, 2))
        self.goal_yaw: float | None = None
        self._index = 0
        self._outline: FloatArray | None = None
        self.last_carrot: FloatArray = np.zeros(2)
        self.goal_dist_tol = 0.25
        """The goal checker's ``xy_goal_tolerance`` [m]: the controller turns to the goal's
        heading once the lookahead point (the goal, near the end) is closer than this, as
        Nav2's does; the navigator sets it from its goal checker (0.25 m: Nav2's value before
        the first update)."""
        self._reached_xy = False
        self._inscribed = footprint_radii(self.footprint)[0]
        """The footprint's inscribed radius, as Nav2's costmap computes it (the nearest vertex
        or edge): cost regulation reads a cost as a distance beyond it."""

    def set_plan(self, path: ArrayLike, goal_yaw: float | None = None) -> None:
        """A new path ((N, 2) [m], map frame) and, optionally, the goal's heading."""
        self.path = check_path(path)
        self.goal_yaw = goal_yaw
        self._index = 0
        self._reached_xy = False

    def reset(self) -> None:
        """Forget that the goal was within tolerance (Nav2's ``reset``, on a new goal)."""
        self._reached_xy = False

    def lookahead(self, speed: float) -> float:
        p = self.params
        if not p.use_velocity_scaled_lookahead_dist:
            return p.lookahead_dist
        return float(np.clip(abs(speed) * p.lookahead_time, p.min_lookahead_dist,
                             p.max_lookahead_dist))

    def compute_velocity_commands(self, pose: ArrayLike, velocity: ArrayLike,
                                  costmap: Costmap | None = None) -> tuple[float, float]:
        """``(v, ω)`` [m/s, rad/s] from the robot's ``pose`` (x, y, θ) and ``velocity``
        (v, ω); raises :class:`ControlError` when the arc ahead would collide."""
        if len(self.path) == 0:
            raise ControlError("no path to follow")
        p = self.params
        pose_ = geometry.check_pose(pose, "pose")
        v_now, w_now = (float(x) for x in np.asarray(velocity, dtype=float)[:2])
        self._index = closest_index(self.path, pose_, self._index, p.max_robot_pose_search_dist)
        carrot = lookahead_point(self.path, pose_, self.lookahead(v_now), self._index)
        self.last_carrot = carrot
        local = geometry.transform_points(geometry.inverse(pose_), carrot[None, :])[0]
        dt = 1.0 / p.controller_frequency
        remaining = remaining_length(self.path, pose_, self._index)
        if p.use_rotate_to_heading:
            # Nav2's shouldRotateToGoalHeading: the lookahead point within the goal tolerance
            near = math.hypot(float(local[0]), float(local[1])) < self.goal_dist_tol
            self._reached_xy = (self._reached_xy or near) if p.stateful else near
            to_goal = self.goal_yaw is not None and self._reached_xy
            angle = (float(geometry.wrap_angle(self.goal_yaw - pose_[2])) if to_goal
                     and self.goal_yaw is not None else math.atan2(local[1], local[0]))
            if to_goal or abs(angle) > p.rotate_to_heading_min_angle:
                w = self._rotate(angle, w_now, dt)
                if p.use_collision_detection and costmap is not None:
                    self._check_collision(pose_, 0.0, w, 0.0, costmap)
                return 0.0, w
        d2 = float(local @ local)
        if self.curvature is not None:
            curvature = float(self.curvature((float(pose_[0]), float(pose_[1]),
                                              float(pose_[2])),
                                             (float(carrot[0]), float(carrot[1]))))
        else:
            curvature = 0.0 if d2 < 1e-12 else 2.0 * float(local[1]) / d2
        v = self._regulate(curvature, remaining, pose_, costmap)
        v = float(np.clip(v, v_now - p.max_linear_accel * dt, v_now + p.max_linear_accel * dt))
        v = max(v, 0.0)
        w = v * curvature
        if p.use_collision_detection and costmap is not None:
            try:
                self._check_collision(pose_, v, w, math.sqrt(d2), costmap)
            except ControlError:
                if not (p.gentler_arcs_when_colliding and abs(w) > 1e-9):
                    raise
                for share in (0.5, 0.25, 0.125, 0.0625, 0.0):
                    try:
                        self._check_collision(pose_, v, w * share, math.sqrt(d2), costmap)
                    except ControlError:
                        continue
                    return v, w * share
                raise
        return v, w

    def _rotate(self, angle: float, w_now: float, dt: float) -> float:
        """Nav2's rotateToHeading: ``rotate_to_heading_angular_vel`` within what
        ``max_angular_accel`` reaches in a period, then no faster than what stops on the
        heading at that acceleration (this last cap may brake harder, as Nav2's does)."""
        p = self.params
        sign = 1.0 if angle > 0.0 else -1.0
        step = p.max_angular_accel * dt
        w = float(np.clip(sign * p.rotate_to_heading_angular_vel, w_now - step, w_now + step))
        stop = math.sqrt(2 * p.max_angular_accel * abs(angle))
        if abs(w) > stop:
            w = sign * stop if stop > 0.0 else 0.0
        return w

    def _regulate(self, curvature: float, remaining: float, pose: FloatArray,
                  costmap: Costmap | None) -> float:
        p = self.params
        if self.speed is not None:
            return float(self.speed(curvature, remaining, p.desired_linear_vel,
                                    p.regulated_linear_scaling_min_radius,
                                    p.regulated_linear_scaling_min_speed,
                                    p.approach_velocity_scaling_dist,
                                    p.min_approach_linear_velocity))
        v = p.desired_linear_vel
        # Nav2's applyConstraints: the lower of the curvature and the cost constraints, each
        # of the desired speed, then no slower than regulated_linear_scaling_min_speed
        curvature_v = cost_v = v
        if p.use_regulated_linear_velocity_scaling and abs(curvature) > 1e-9:
            radius = 1.0 / abs(curvature)
            if radius < p.regulated_linear_scaling_min_radius:
                curvature_v = v * radius / p.regulated_linear_scaling_min_radius
        if p.use_cost_regulated_linear_velocity_scaling and costmap is not None:
            row, col = costmap.world_to_cell(float(pose[0]), float(pose[1]), "robot")
            cost = float(costmap.costs[row, col])
            if cost not in (float(NO_INFORMATION), float(FREE_SPACE)):   # Jazzy's costConstraint
                k = p.inflation_cost_scaling_factor
                distance = (k * self._inscribed - math.log(cost) + math.log(253.0)) / k
                if distance < p.cost_scaling_dist:
                    cost_v = v * (p.cost_scaling_gain * distance / p.cost_scaling_dist)
        v = min(curvature_v, cost_v)
        if v < p.desired_linear_vel:
            v = max(v, p.regulated_linear_scaling_min_speed)
        if remaining < p.approach_velocity_scaling_dist:
            v = max(min(v, v * remaining / p.approach_velocity_scaling_dist),
                    p.min_approach_linear_velocity)
        return v

    def _check_collision(self, pose: FloatArray, v: float, w: float, carrot_distance: float,
                         costmap: Costmap) -> None:
        p = self.params
        if self._outline is None:
            self._outline = outline_points(self.footprint, costmap.resolution)
        horizon = p.max_allowed_time_to_collision_up_to_carrot
        if abs(v) > 1e-6:
            horizon = min(horizon, carrot_distance / abs(v))
        elif abs(w) < 1e-6:
            return
        step = costmap.resolution / max(abs(v), 1e-6)
        if abs(w) > 1e-6:
            step = min(step, 0.05 / abs(w))   # a turn sweeps the corners faster than the centre
        times: FloatArray = np.arange(step, horizon + 1e-9, step, dtype=np.float64)
        if len(times) == 0 or times[-1] < horizon - 1e-9:
            # creeping (a step longer than the horizon) is checked at the horizon too, or a
            # robot starting from standstill beside a wall is never checked at all
            times = np.append(times, horizon)
        poses = arc_poses(pose, v, w, times)
        hit = collides_from(costmap, pose, poses, self._outline)
        if np.any(hit):
            t = float(times[int(np.argmax(hit))])
            raise ControlError(f"collision ahead: the footprint meets an obstacle in {t:.2f} s "
                               f"on this arc")


def arc_poses(pose: FloatArray, v: float, w: float, times: FloatArray) -> FloatArray:
    """Poses (T, 3) after driving ``(v, ω)`` from ``pose`` for each of ``times``."""
    th = pose[2] + w * times
    if abs(w) < 1e-9:
        x = pose[0] + v * times * math.cos(pose[2])
        y = pose[1] + v * times * math.sin(pose[2])
    else:
        r = v / w
        x = pose[0] + r * (np.sin(th) - math.sin(pose[2]))
        y = pose[1] - r * (np.cos(th) - math.cos(pose[2]))
    return np.column_stack([np.broadcast_to(x, times.shape), np.broadcast_to(y, times.shape),
                            th])
