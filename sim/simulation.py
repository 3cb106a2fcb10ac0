"""The simulation: robots with real traction in a pymunk world, sensors, walking people.

Traction follows pymunk's top-down technique (its ``tank`` example): gravity is zero, and each
driven wheel is tied to a kinematic "ground" body by a ``PivotJoint`` whose ``max_bias`` is 0
(it matches velocities, never positions) and whose ``max_force`` is the friction the floor can
give that wheel, ``μ N``. Every step the ground body under a wheel moves at the wheel's rim
speed along the robot's heading, and with zero sideways speed: as long as the force needed
stays under ``μ N`` the wheel neither skids nor slides; push harder — accelerate beyond
traction, drive onto oil — and it slips. The wheels are velocity servos with an acceleration
limit; the encoders count the servo's rotation, so they count the slip too.

Assumptions, stated once (``Physics``): tyre–floor friction 0.8, oil 0.05, 70 % of the weight
on the driven wheels, servos that can spin a wheel's rim up at 6 m/s².

Pedestrians are discs of 0.25 m and 70 kg that walk their routes at seeded speeds with the
same kind of foot traction, stepping aside for robots that come close (and round one ahead of
them, on the side away from it, never closing in on one faster than they could still stop
from, stepping back from one that comes at them; passing each other on the right, without
bumping); they push and can be pushed, and the lidar sees them. Held up by a robot they
cannot pass, they step into the nearest of the world's alcoves (a door off an aisle) on their
side of it and wait there until it has gone by; where there is none, they turn back.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pymunk
from numpy.typing import ArrayLike, NDArray
from pymunk._chipmunk_cffi import lib as _chipmunk

from kit import geometry, kinematics, msgs
from kit.control import DCMotor
from kit.robots import RobotDescription
from kit.robots import load as load_robot
from sim import _walk as _walk_rules
from sim.sensors import Imu, Lidar, encoder_counts, finish_scans, stamp_of
from sim.world import World, along_walls, free_distance, load_world

__all__ = ["Collision", "GroundTruth", "Physics", "Simulation"]

FloatArray = NDArray[np.float64]
ROBOT, WALL, PERSON = 1, 2, 3
_NO_DISCS = np.empty((0, 3))
_NO_DISCS.flags.writeable = False
_NO_EFFORT = np.empty(0)
_NO_EFFORT.flags.writeable = False
_WHEEL_JOINTS = ("right_wheel_joint", "left_wheel_joint")
Command = msgs.Twist | Sequence[float] | NDArray[np.float64] | None

# Chipmunk's own functions under pymunk (7.x) for the per-step reads and writes, on the
# bodies' C handles (``Body._body``): what pymunk's properties call, without their wrapping
# (tests/sim/test_simulation_speed.py checks they agree with the properties).
_body_angle = _chipmunk.cpBodyGetAngle
_body_position = _chipmunk.cpBodyGetPosition
_body_velocity = _chipmunk.cpBodyGetVelocity
_body_angular_velocity = _chipmunk.cpBodyGetAngularVelocity
_set_body_velocity = _chipmunk.cpBodySetVelocity
_space_step = _chipmunk.cpSpaceStep
_header = msgs.Header.trusted_builder()
_joint_state = msgs.JointState.trusted_builder()
_PI, _TWO_PI = math.pi, 2.0 * math.pi
_cos, _sin = math.cos, math.sin


@dataclass(frozen=True)
class Physics:
    dt: float = 0.01
    """physics step [s] (100 Hz)."""
    substeps: int = 2
    friction: float = 0.8
    """tyre on an indoor floor."""
    oil_friction: float = 0.05
    weight_on_wheels: float = 0.7
    """fraction of the robot's weight the driven wheels carry (the rest on casters)."""
    motor_acceleration: float = 6.0
    """m/s² at the wheel rim: how fast a servo spins its wheel up."""
    slip_variance: float = 0.0
    """m²/m: random micro-slip of each wheel — the wheel turns a little more or less than it
    rolls — with a variance that grows with the distance rolled (Siegwart's wheel-error
    model, the one ``kit.odometry`` propagates). Zero (the default) keeps the floor
    deterministic; the robot's own ``odometry_k`` makes the encoders err exactly as its
    odometry covariance says."""
    wheel_motor: DCMotor | None = None
    """a ``kit.control.DCMotor``: when given (with ``Simulation(wheel_controllers=...)``),
    each wheel is that gear-motor driven by its controller's voltage instead of an ideal
    servo. The motor's inductance is neglected (its 0.7 ms time constant is far below the
    10 ms step), its current is limited to ``peak_current``, and the ground's reaction is not
    fed back into the motor (the traction joints carry it)."""
    wheel_radius_errors: tuple[float, float] = (0.0, 0.0)
    """(right, left) fractions by which the wheels' true rolling radii differ from the
    nominal one the encoders are converted with (worn or unevenly loaded tyres: the
    systematic error UMBmark measures)."""
    gravity: float = 9.80665


@dataclass(frozen=True)
class GroundTruth:
    """What really happened; never part of any sensor output."""

    time: float
    pose: FloatArray
    """(x, y, yaw) of base_link in the world [m, m, rad]."""
    velocity: FloatArray
    """(v, ω) in base_link [m/s, rad/s]."""
    wheel_slip: FloatArray
    """(right, left): rim speed minus the wheel's speed over the ground [m/s]."""
    in_oil: bool


@dataclass(frozen=True)
class Collision:
    time: float
    robot: int
    other: str
    """"wall", "person" or "robot"."""


PERSON_RADIUS = 0.25
"""[m] a pedestrian's disc."""
WALK_PERIOD = 0.1
"""[s] how often people decide where to go."""


def _nearest_on_polygon(x: float, y: float, polygon: FloatArray) -> tuple[float, float, float]:
    """The distance [m] from (x, y) to the closed polygon's outline and the outline's nearest
    point (the distance is 0 on it; inside counts as the distance to the nearest edge, which
    never matters for a person outside a robot)."""
    best, bx, by = math.inf, x, y
    n = len(polygon)
    for i in range(n):
        x0, y0 = float(polygon[i, 0]), float(polygon[i, 1])
        x1, y1 = float(polygon[(i + 1) % n, 0]), float(polygon[(i + 1) % n, 1])
        ex, ey = x1 - x0, y1 - y0
        length2 = ex * ex + ey * ey
        t = 0.0 if length2 <= 0.0 else min(1.0, max(0.0, ((x - x0) * ex + (y - y0) * ey)
                                                   / length2))
        d = math.hypot(x - x0 - t * ex, y - y0 - t * ey)
        if d < best:
            best, bx, by = d, x0 + t * ex, y0 + t * ey
    return best, bx, by


def _keep_clear(px: float, py: float, vx: float, vy: float,
                robots: list[tuple[float, float]], velocities: list[tuple[float, float]],
                outlines: list[FloatArray]) -> tuple[float, float]:
    """Nobody walks into a robot: the speed at which a person and a robot close in stays one
    they can still stop from before touching it (feet brake at about 1.5 m/s² and people
    decide ten times a second: 1 m/s² and 0.2 m kept); a robot coming at them faster than
    that makes them step back. Closing in is measured toward the nearest point of the
    robot's outline (a robot's centre can be far from its corners: the IGV's is its front
    axle, with 0.75 m of body behind)."""
    for (rx, ry), (rvx, rvy), outline in zip(robots, velocities, outlines, strict=True):
        if math.hypot(px - rx, py - ry) >= 4.0:
            continue
        gap, qx, qy = _nearest_on_polygon(px, py, outline)
        if 1e-6 < gap < 3.0:
            ax, ay = (px - qx) / gap, (py - qy) / gap        # away from the robot, unit
            clearance = gap - PERSON_RADIUS
            coming = max(rvx * ax + rvy * ay, 0.0)
            allowed = math.sqrt(2.0 * 1.0 * max(clearance - 0.2, 0.0)) - coming
            toward = -(vx * ax + vy * ay)
            if toward > allowed:
                cut = toward - allowed
                vx, vy = vx + ax * cut, vy + ay * cut
    return vx, vy

@dataclass
class _Robot:
    description: RobotDescription
    body: pymunk.Body
    grounds: list[pymunk.Body]
    joints: list[pymunk.PivotJoint]
    traction: float
    lidar: Lidar | None
    imu: Imu | None
    topic_prefix: str
    tick_offset: NDArray[np.int64]
    wheel_target: FloatArray = field(default_factory=lambda: np.zeros(2))
    world_velocity: tuple[float, float] = (0.0, 0.0)
    accel: tuple[float, float] = (0.0, 0.0)
    yaw_accel: float = 0.0
    next_joint_state: float = 0.02  # 50 Hz, on the multiples of 20 ms
    controllers: list[Any] = field(default_factory=list)
    on_oil: list[bool] = field(default_factory=lambda: [False, False])
    limit: float = 0.0
    """[rad/s] the most a servo changes its wheel's speed in one step."""
    radius_factors: tuple[float, ...] = (1.0, 1.0)
    """(right, left) true rolling radius / nominal radius."""
    wheel_points: tuple[tuple[float, float], ...] = ((0.0, 0.0), (0.0, 0.0))
    """(right, left) wheels' contact points (x, y) in base_link [m]."""
    """(right, left) wheels' y in base_link [m]."""
    oil_force: float = 0.0
    """[N] a wheel's traction on oil."""
    oil_near: tuple[tuple[float, float, float, float], ...] = ()
    """The world's oil patches (x0, y0, x1, y1) [m] grown by the wheels' reach."""

    @property
    def topics(self) -> tuple[str, str, str]:
        return self._topics

    def __post_init__(self) -> None:
        self._topics = (self.topic_prefix + "/scan", self.topic_prefix + "/imu",
                        self.topic_prefix + "/joint_states")
        # the step's state as plain floats (numpy scalars cost ten times more to touch)
        self.speeds: list[float] = [0.0, 0.0]
        """(right, left) wheel speeds [rad/s] the servos turn the wheels at."""
        self.angles: list[float] = [0.0, 0.0]
        """(right, left) total wheel rotations [rad], what the encoders count."""
        self.targets: tuple[float, float] = (0.0, 0.0)
        self.x = self.y = self.yaw = self.yaw_rate = self.forward_speed = 0.0
        self.xy_yaw: tuple[float, float, float] = (0.0, 0.0, 0.0)
        """(x, y, yaw) [m, m, rad] as plain floats (a new tuple each step, never changed)."""
        self.cp_body: Any = self.body._body
        self.wheel_radius: float = self.description.wheel_radius
        self.ticks_per_rad: float = self.description.ticks_per_wheel_turn / (2 * math.pi)
        """encoder ticks per radian of wheel rotation (as :meth:`Simulation._joint_state`
        computes it)."""
        self.cp_grounds: tuple[Any, ...] = tuple(g._body for g in self.grounds)

    @property
    def pose(self) -> FloatArray:
        """(x, y, yaw) of base_link in the world [m, m, rad] (a new array)."""
        return np.array(self.xy_yaw)

    @property
    def velocity(self) -> FloatArray:
        """(v, ω) in base_link [m/s, rad/s] (a new array)."""
        return np.array((self.forward_speed, self.yaw_rate))

    @property
    def wheel_speed(self) -> FloatArray:
        """(right, left) wheel speeds [rad/s] (a copy)."""
        return np.array(self.speeds)

    @property
    def wheel_angle(self) -> FloatArray:
        """(right, left) total wheel rotations [rad] (a copy)."""
        return np.array(self.angles)


class _Crowd:
    """The people's walking states, one row per person, as arrays (the compiled rules of
    :mod:`sim._walk` update them in place); each :class:`_Person` is a view on its row."""

    def __init__(self, n: int) -> None:
        self.target = np.zeros(n, dtype=np.int64)
        self.direction = np.ones(n, dtype=np.int64)
        self.speed = np.zeros(n)
        self.blocked = np.zeros(n)
        self.alcove = np.full(n, -1, dtype=np.int64)
        self.stage = np.zeros(n, dtype=np.int64)


class _Row:
    """A :class:`_Person`'s attribute kept in the crowd's array of the same name."""

    def __init__(self, kind: type) -> None:
        self.kind = kind

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, person: Any, owner: type | None = None) -> Any:
        return self.kind(getattr(person.crowd, self.name)[person.index])

    def __set__(self, person: Any, value: Any) -> None:
        getattr(person.crowd, self.name)[person.index] = value


class _Person:
    """A pedestrian: their body, the kinematic ground body their feet push against, their
    route, and their walking state (a row of the simulation's :class:`_Crowd`)."""

    target = _Row(int)
    """The route point they walk to."""
    direction = _Row(int)
    """+1 or -1: along their route or back."""
    speed = _Row(float)
    """[m/s] their walking pace."""
    blocked = _Row(float)
    """Seconds this person has been held up by a robot in their way."""
    alcove = _Row(int)
    """The alcove this person is stepping into, waiting in or leaving (-1: none)."""
    stage = _Row(int)
    """1: to its front, 2: into it, 3: waiting, 4: back out to its front."""

    def __init__(self, crowd: _Crowd, index: int, body: pymunk.Body, ground: pymunk.Body,
                 route: FloatArray) -> None:
        self.crowd, self.index = crowd, index
        self.body, self.ground, self.route = body, ground, route
        self.cp_body, self.cp_ground = body._body, ground._body


def _at_most_walking_speed(vx: float, vy: float) -> tuple[float, float]:
    speed = math.hypot(vx, vy)
    return (vx * 1.5 / speed, vy * 1.5 / speed) if speed > 1.5 else (vx, vy)


def _in_doorway(px: float, py: float, fx: float, fy: float, bx: float, by: float) -> bool:
    """Whether a person at (px, py) is already in the doorway of the alcove from (fx, fy) to
    (bx, by): no farther from its back than its front is."""
    return math.hypot(bx - px, by - py) <= math.hypot(bx - fx, by - fy)


ALCOVE_REACH = 10.0
"""[m] how far a person held up by a robot walks to an alcove to let it by."""


def _give_way(p: _Person, held_up: bool, find_alcove: Callable[[], int] | None = None
              ) -> None:
    """Held up by a robot (going on at under a fifth of their pace with one within 1.5 m) for
    1 s, a person with an alcove on their side of it (``find_alcove()``, asked only then)
    steps into it; with none, after 4 s, they give way by turning back along their route."""
    if not held_up:
        p.blocked = 0.0
        return
    p.blocked += WALK_PERIOD
    alcove = find_alcove() if find_alcove is not None and p.blocked >= 1.0 else -1
    if alcove >= 0:
        p.alcove, p.stage, p.blocked = alcove, 1, 0.0
    elif p.blocked >= 4.0 and len(p.route) > 1:
        p.direction = -p.direction
        p.target = min(max(p.target + p.direction, 0), len(p.route) - 1)
        p.blocked = 0.0

class Simulation:
    """A world, one or more robots, their sensors and walking people, on a sim clock.

    Parameters
    ----------
    world : str or World
        ``"office"``, ``"aisle"``, ``"pillars"``, ``"square"``, a world file, a map_server
        ``.yaml``, or a :class:`World`.
    robot : str or RobotDescription or sequence of them
        The robot(s); several robots get topic prefixes ``/robot0``, ``/robot1``, ….
    seed : int
        Seeds every random draw (noise, people); the same seed gives the same streams.
    people : int
        Pedestrians, spread over the world's routes.
    start : (x, y, yaw) or a sequence of them
        Start poses; defaults to the world's spawn (robots after the first 1 m apart).
    lidar_rate, lidar_beams : optional
        Override the lidar's scan rate [Hz] and beams per scan (e.g. 10 Hz, 360 beams).
    wheel_controllers : callable, optional
        With ``physics.wheel_motor``: a factory called once per wheel, returning
        ``controller(setpoint [rad/s], wheel speed [rad/s]) -> voltage`` — a speed loop such as
        Lab 04's PI — run every physics step.
    sensors : bool
        False turns the lidar and IMU off (physics and encoders only).
    """

    compiled_walk = True
    """False walks the people by the readable Python rules (the compiled ones' reference)."""

    def __init__(self, world: str | World = "office",
                 robot: str | RobotDescription | Sequence[str | RobotDescription] = "uiabot",
                 seed: int = 0, people: int = 0, start: Any = None,
                 physics: Physics | None = None, lidar_rate: float | None = None,
                 lidar_beams: int | None = None, sensors: bool = True,
                 wheel_controllers: Any = None) -> None:
        self.world = world if isinstance(world, World) else load_world(world)
        robots = [robot] if isinstance(robot, (str, RobotDescription)) else list(robot)
        self.descriptions = [r if isinstance(r, RobotDescription) else load_robot(r)
                             for r in robots]
        self.physics = physics or Physics()
        self.n_people = int(people)
        if self.n_people and not self.world.routes:
            raise ValueError(f"world {self.world.name!r} has no routes for people to walk")
        self._start = start
        self._lidar_rate, self._lidar_beams = lidar_rate, lidar_beams
        self._sensors = sensors
        if (wheel_controllers is None) != (self.physics.wheel_motor is None):
            raise ValueError("wheel_controllers and physics.wheel_motor go together")
        self._controller_factory = wheel_controllers
        self.reset(seed)

    # ------------------------------------------------------------------ building
    def reset(self, seed: int | None = None) -> None:
        """Start again from the start poses with a fresh world; ``seed`` re-seeds the noise."""
        if seed is not None:
            self.seed = int(seed)
        self.rng = np.random.default_rng(self.seed)
        self.time = 0.0
        self.collisions: list[Collision] = []
        space = pymunk.Space()
        space.gravity = (0.0, 0.0)
        space.collision_slop = 0.001
        space.iterations = 10
        self.space = space
        static = space.static_body
        for seg in self.world.segments:
            shape = pymunk.Segment(static, (seg[0], seg[1]), (seg[2], seg[3]), 0.02)
            shape.collision_type = WALL
            shape.friction = 0.5
            space.add(shape)
        for cx, cy, radius in self.world.circles:
            pillar = pymunk.Circle(static, radius, (cx, cy))
            pillar.collision_type = WALL
            space.add(pillar)
        starts = self._start_poses()
        self.robots = [self._add_robot(d, pose, i) for i, (d, pose) in
                       enumerate(zip(self.descriptions, starts, strict=True))]
        self._crowd = _Crowd(self.n_people)
        self.people = [self._add_person(i) for i in range(self.n_people)]
        self._body_index = {r.body: i for i, r in enumerate(self.robots)}
        space.on_collision(ROBOT, WALL, begin=self._on_contact, data="wall")
        space.on_collision(ROBOT, PERSON, begin=self._on_contact, data="person")
        space.on_collision(ROBOT, ROBOT, begin=self._on_contact, data="robot")
        self._oil = len(self.world.oil) > 0
        self._people_bodies = tuple(p.body._body for p in self.people)
        self.bystanders: list[pymunk.Body] = []
        """the grounds (feet) of the people :meth:`add_bystander` placed."""
        # the people's routes stacked, for the compiled rules: (points, start, length)
        lengths = [len(p.route) for p in self.people]
        self._routes = (np.concatenate([p.route for p in self.people]).reshape(-1, 2)
                        if self.people else np.zeros((0, 2)),
                        np.cumsum([0, *lengths])[:-1].astype(np.int64),
                        np.array(lengths, dtype=np.int64))
        corners = [len(r.description.footprint) for r in self.robots]
        groups: dict[tuple[tuple[int, ...], bytes], list[int]] = {}
        for k, r in enumerate(self.robots):   # the robots of one footprint, for _walk
            footprint = np.ascontiguousarray(r.description.footprint, dtype=np.float64)
            groups.setdefault((footprint.shape, footprint.tobytes()), []).append(k)
        self._footprint_groups = [(self.robots[g[0]].description.footprint, g)
                                  for g in groups.values()]
        self._footprints = (
            np.array(corners, dtype=np.int64),
            np.array([float(np.ptp(r.description.footprint[:, 1])) for r in self.robots]),
            max(corners, default=0))
        for r in self.robots:
            self._read_state(r)

    def _start_poses(self) -> list[FloatArray]:
        n = len(self.descriptions)
        if self._start is None:
            spawn = np.asarray(self.world.spawn, float)
            c, s = math.cos(spawn[2]), math.sin(spawn[2])
            return [spawn + np.array([-s * i, c * i, 0.0]) for i in range(n)]
        given = np.asarray(self._start, float)
        poses = [given] if given.ndim == 1 else list(given)
        if len(poses) != n:
            raise ValueError(f"{n} robots need {n} start poses; got {len(poses)}")
        return [geometry.check_pose(p, "start") for p in poses]

    def _add_robot(self, d: RobotDescription, pose: FloatArray, index: int) -> _Robot:
        ph = self.physics
        footprint = [tuple(p) for p in d.footprint]
        body = pymunk.Body(d.mass, pymunk.moment_for_poly(d.mass, footprint))
        body.position = (float(pose[0]), float(pose[1]))
        body.angle = float(pose[2])
        shape = pymunk.Poly(body, footprint)
        shape.collision_type = ROBOT
        shape.friction = 0.5
        self.space.add(body, shape)
        traction = ph.friction * d.mass * ph.gravity * ph.weight_on_wheels / 2
        grounds, joints = [], []
        half = d.wheel_separation / 2.0
        ax, ay = float(d.axle[0]), float(d.axle[1])  # the wheels' midpoint in base_link
        for y in (-half, half):  # right, left
            ground = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            joint = pymunk.PivotJoint(body, ground, (ax, ay + y), (0.0, 0.0))
            joint.max_bias = 0.0
            joint.max_force = traction
            joint.collide_bodies = False
            self.space.add(ground, joint)
            grounds.append(ground)
            joints.append(joint)
        lidar = imu = None
        if self._sensors and "lidar" in d.sensors:
            mount = d.sensor_mount("lidar")  # composed from the URDF; (0, 0, 0) if absent
            lidar = Lidar(d.sensors["lidar"], mount, np.random.default_rng(self.rng.integers(
                2**63)), self._lidar_rate, self._lidar_beams)
        if self._sensors and "imu" in d.sensors:
            mount2 = d.sensor_mount("imu")[:2]
            imu = Imu(d.sensors["imu"], mount2, np.random.default_rng(self.rng.integers(2**63)))
        prefix = "" if len(self.descriptions) == 1 else f"/robot{index}"
        offset = self.rng.integers(0, 1 << min(d.counter_bits, 62), 2, dtype=np.int64)
        robot = _Robot(d, body, grounds, joints, traction, lidar, imu, prefix, offset)
        # the drive's constants, each computed as the step used to compute it
        robot.limit = ph.motor_acceleration / d.wheel_radius * ph.dt
        robot.radius_factors = tuple(1.0 + e for e in ph.wheel_radius_errors)
        robot.wheel_points = tuple((ax, ay + f * d.wheel_separation) for f in (-0.5, 0.5))
        robot.oil_force = ph.oil_friction / ph.friction * traction
        # the oil patches grown by how far a wheel is from the body's origin (and a
        # micrometre for rounding): a body outside all of them has no wheel on oil
        reach = max(math.hypot(x, y) for x, y in robot.wheel_points) + 1e-6
        robot.oil_near = tuple((x0 - reach, y0 - reach, x1 + reach, y1 + reach)
                               for x0, y0, x1, y1 in self.world._oil_rects)
        if self._controller_factory is not None:
            robot.controllers = [self._controller_factory(), self._controller_factory()]
        return robot

    def _add_person(self, index: int) -> _Person:
        route = self.world.routes[index % len(self.world.routes)]
        leg = int(self.rng.integers(0, max(1, len(route) - 1)))
        f = float(self.rng.uniform(0.0, 1.0))
        a, b = route[leg], route[min(leg + 1, len(route) - 1)]
        start = a + f * (b - a)
        body, ground = self._person_body(float(start[0]), float(start[1]))
        person = _Person(self._crowd, index, body, ground, route)
        person.target, person.direction = min(leg + 1, len(route) - 1), 1
        person.speed = float(self.rng.uniform(0.8, 1.4))
        return person

    def _person_body(self, x: float, y: float) -> tuple[pymunk.Body, pymunk.Body]:
        """A person's disc at (x, y) and the ground it walks on (their feet)."""
        body = pymunk.Body(70.0, float("inf"))
        body.position = (x, y)
        shape = pymunk.Circle(body, PERSON_RADIUS)
        shape.collision_type = PERSON
        shape.friction = 0.5
        ground = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        joint = pymunk.PivotJoint(body, ground, (0.0, 0.0), (0.0, 0.0))
        joint.max_bias = 0.0
        joint.max_force = 70.0 * 1.5  # feet push with about 1.5 m/s² on 70 kg
        self.space.add(body, shape, ground, joint)
        return body, ground

    def add_bystander(self, position: ArrayLike) -> int:
        """A person standing at ``position`` [m] who moves only when a scenario says so
        (:meth:`move_person`), never by the walking rules: someone who steps into a robot's
        way and waits there. Returns their index among :meth:`people_positions` (after the
        walking people)."""
        x, y = (float(v) for v in np.asarray(position, dtype=float).reshape(2))
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"a bystander needs a finite (x, y) position; got {position!r}")
        body, ground = self._person_body(x, y)
        self.bystanders.append(ground)
        self._people_bodies += (body._body,)
        return len(self.people) + len(self.bystanders) - 1

    def move_person(self, index: int, velocity: ArrayLike) -> None:
        """Set a bystander's walking velocity [m/s] (at most walking speed) until told
        otherwise."""
        k = index - len(self.people)
        if not 0 <= k < len(self.bystanders):
            raise ValueError(f"person {index} walks by the simulator's rules; only a "
                             f"bystander (add_bystander) is moved by a scenario")
        vx, vy = (float(v) for v in np.asarray(velocity, dtype=float).reshape(2))
        self.bystanders[k].velocity = _at_most_walking_speed(vx, vy)

    def _on_contact(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: Any) -> None:
        for shape in arbiter.shapes:
            if shape.body is None:
                continue
            index = self._body_index.get(shape.body)
            if index is not None:
                self.collisions.append(Collision(self.time, index, str(data)))
                break

    # ------------------------------------------------------------------ stepping
    def _discs(self) -> FloatArray:
        """(P, 3) the people as discs (x, y, radius) [m], where they are now."""
        if not self._people_bodies:
            return _NO_DISCS
        discs: list[float] = []
        for body in self._people_bodies:
            position = _body_position(body)
            discs += (position.x, position.y, PERSON_RADIUS)
        return np.array(discs).reshape(-1, 3)

    def _walk(self) -> None:
        """Every person decides where to walk for the next tenth of a second: the rules of
        :meth:`_walk_reference`, compiled (:mod:`sim._walk`; the same numbers to the bit)."""
        if not self.compiled_walk:
            self._walk_reference()
            return
        crowd, people, robots = self._crowd, self.people, self.robots
        where_they_are: list[float] = []
        how_they_move: list[float] = []
        for p in people:
            position, velocity = _body_position(p.cp_body), _body_velocity(p.cp_body)
            where_they_are += (position.x, position.y)
            how_they_move += (velocity.x, velocity.y)
        for body in self._people_bodies[len(people):]:   # the bystanders, passed like anyone
            position = _body_position(body)
            where_they_are += (position.x, position.y)
        positions = np.array(where_they_are).reshape(-1, 2)
        body_velocities = np.array(how_they_move).reshape(-1, 2)
        routes, start, length = self._routes
        new_speed = _walk_rules.arrive(positions[:len(people)], routes, start, length,
                                       crowd.alcove, crowd.target, crowd.direction)
        for i in new_speed.tolist():                # drawn in order, as the rules do
            crowd.speed[i] = float(self.rng.uniform(0.8, 1.4))
        corners, widths, most = self._footprints
        outlines = np.zeros((len(robots), most, 2))
        where = np.array([(r.x, r.y) for r in robots]).reshape(-1, 2)
        for footprint, group in self._footprint_groups:
            # kit.geometry.transform_points's arithmetic: numpy's product (which may fuse a
            # multiply and an add; stacked, each robot's is the product it would be alone),
            # then the position added
            rotations: list[tuple[tuple[float, float], tuple[float, float]]] = []
            for k in group:
                c, s = math.cos(robots[k].yaw), math.sin(robots[k].yaw)
                rotations.append(((c, -s), (s, c)))
            if len(group) == 1:
                k = group[0]
                np.add(footprint @ np.array(rotations[0]).T, (robots[k].x, robots[k].y),
                       out=outlines[k, :len(footprint)])
            else:
                turn = np.array(rotations).transpose(0, 2, 1)
                outlines[group, :len(footprint)] = footprint @ turn + where[group, None, :]
        moving = np.array([r.world_velocity for r in robots]).reshape(-1, 2)
        walking = _walk_rules.walk(positions, body_velocities, crowd.speed, routes, start,
                                   length, crowd.target, crowd.direction, crowd.blocked,
                                   crowd.alcove, crowd.stage, where, moving, outlines, corners,
                                   widths, self.world.segments, self.world.alcoves,
                                   len(people))
        for i, (vx, vy) in enumerate(walking.tolist()):
            _set_body_velocity(people[i].cp_ground, (vx, vy))

    def _walk_reference(self) -> None:
        """The people's rules in plain Python: the reference the compiled rules are tested
        against (``compiled_walk = False`` runs a simulation on it)."""
        robots = [(r.x, r.y) for r in self.robots]
        outlines = [geometry.transform_points(r.pose, r.description.footprint)
                    for r in self.robots]
        velocities = [r.world_velocity for r in self.robots]
        for p in self.people:
            px, py = p.body.position
            if p.alcove >= 0:
                self._walk_aside(p, px, py, robots, velocities, outlines)
                continue
            gx, gy = p.route[p.target]
            dist = math.hypot(gx - px, gy - py)
            if dist < 0.3:
                if len(p.route) > 1:
                    nxt = p.target + p.direction
                    if not 0 <= nxt < len(p.route):
                        p.direction = -p.direction
                        nxt = p.target + p.direction
                    p.target = nxt
                p.speed = float(self.rng.uniform(0.8, 1.4))
                gx, gy = p.route[p.target]
                dist = math.hypot(gx - px, gy - py)
            vx, vy = ((gx - px) / dist * p.speed, (gy - py) / dist * p.speed) if dist > 1e-9 \
                else (0.0, 0.0)
            ux, uy = (vx / p.speed, vy / p.speed) if dist > 1e-9 else (0.0, 0.0)
            if len(self.world.alcoves) and self._no_way_past(px, py, ux, uy):
                alcove = self._alcove_for(px, py, robots)
                if alcove >= 0:                       # step aside now, before meeting it
                    p.alcove, p.stage, p.blocked = alcove, 1, 0.0
                    self._walk_aside(p, px, py, robots, velocities, outlines)
                    continue
            vx, vy = self._step_round_walls(px, py, vx, vy, ux, uy, p.speed, dist)
            vx, vy = self._step_round_robots(px, py, vx, vy, ux, uy, p.speed, robots)
            vx, vy = self._pass_people(p, px, py, vx, vy, ux, uy)
            vx, vy = self._slide_along_walls(px, py, vx, vy)
            vx, vy = _keep_clear(px, py, vx, vy, robots, velocities, outlines)
            near = any(math.hypot(px - rx, py - ry) < 1.5 for rx, ry in robots)
            bvx, bvy = p.body.velocity                # commanded or really: a push is no way
            held = near and dist > 1e-9 and min(vx * ux + vy * uy, bvx * ux + bvy * uy) < \
                0.2 * p.speed
            _give_way(p, held, functools.partial(self._alcove_for, px, py, robots))
            p.ground.velocity = _at_most_walking_speed(vx, vy)

    def _walk_aside(self, p: _Person, px: float, py: float,
                    robots: list[tuple[float, float]], velocities: list[tuple[float, float]],
                    outlines: list[FloatArray]) -> None:
        vx, vy = self._step_aside(p, px, py, robots, velocities, outlines)
        vx, vy = self._pass_people(p, px, py, vx, vy, 0.0, 0.0)
        vx, vy = self._slide_along_walls(px, py, vx, vy)
        vx, vy = _keep_clear(px, py, vx, vy, robots, velocities, outlines)
        p.ground.velocity = _at_most_walking_speed(vx, vy)

    def _no_way_past(self, px: float, py: float, ux: float, uy: float) -> bool:
        """Whether a robot within 3.5 m ahead of a person walking along (ux, uy), and not
        going away from them, leaves too little room in the passage to pass it: the room
        across the passage (the narrower of where the person and the robot are), less the
        robot's width, under a body and 0.3 m."""
        for r in self.robots:
            rx, ry = r.x, r.y
            d = math.hypot(rx - px, ry - py)
            if d >= 3.5 or (rx - px) * ux + (ry - py) * uy <= 0.5 * d:
                continue
            rvx, rvy = r.world_velocity
            if (rvx * (px - rx) + rvy * (py - ry)) / d < -0.1:
                continue                              # going away: follow it
            across = min(self._room(x, y, -uy, ux, 3.0) + self._room(x, y, uy, -ux, 3.0)
                         for x, y in ((px, py), (rx, ry)))   # a door beside one is no way
            width = float(np.ptp(r.description.footprint[:, 1]))
            if across - width < 2 * PERSON_RADIUS + 0.3:
                return True
        return False

    def _alcove_for(self, px: float, py: float, robots: list[tuple[float, float]]) -> int:
        """The nearest free alcove (nobody else stepping into it or waiting there) within
        :data:`ALCOVE_REACH` that a person at (px, py) can walk straight to without going
        toward the nearest robot (-1: none)."""
        alcoves = self.world.alcoves
        if len(alcoves) == 0 or not robots:
            return -1
        rx, ry = min(robots, key=lambda r: math.hypot(px - r[0], py - r[1]))
        gap = math.hypot(px - rx, py - ry)
        ax, ay = ((px - rx) / gap, (py - ry) / gap) if gap > 1e-9 else (0.0, 0.0)
        taken = {q.alcove for q in self.people}
        best, chosen = ALCOVE_REACH, -1
        for i, (fx, fy, bx, by) in enumerate(alcoves):
            if i in taken:
                continue
            if _in_doorway(px, py, fx, fy, bx, by):
                fx, fy = bx, by                  # straight in
            d = math.hypot(fx - px, fy - py)
            if d < best and (fx - px) * ax + (fy - py) * ay > -0.3 and \
                    not self.world.crosses_wall((px, py), (float(fx), float(fy))):
                best, chosen = d, i
        return chosen

    def _step_aside(self, p: _Person, px: float, py: float,
                    robots: list[tuple[float, float]], velocities: list[tuple[float, float]],
                    outlines: list[FloatArray]) -> tuple[float, float]:
        """A person letting a robot by: to the alcove's front, into it, waiting there while a
        robot is within 2 m, coming toward it from within 8 m or standing within 6 m (held up
        by someone else, it has yet to go by), back out to its front, then on along their
        route as before."""
        fx, fy, bx, by = (float(v) for v in self.world.alcoves[p.alcove])
        if p.stage == 1 and _in_doorway(px, py, fx, fy, bx, by):
            p.stage = 2
        if p.stage == 3:
            for (rx, ry), (rvx, rvy), outline in zip(robots, velocities, outlines,
                                                    strict=True):
                d = math.hypot(fx - rx, fy - ry)
                closing = ((fx - rx) * rvx + (fy - ry) * rvy) / d if d > 1e-9 else 0.0
                if _nearest_on_polygon(px, py, outline)[0] < 2.0 or \
                        (d < 8.0 and closing > 0.05) or (d < 6.0 and closing > -0.05):
                    return 0.0, 0.0
            p.stage = 4
        gx, gy = (bx, by) if p.stage == 2 else (fx, fy)
        dist = math.hypot(gx - px, gy - py)
        if dist < (0.1 if p.stage == 2 else 0.2):
            if p.stage == 4:
                p.alcove, p.stage = -1, 0
            else:
                p.stage += 1
            return 0.0, 0.0
        pace = min(p.speed, 2.0 * dist)                # slowing down onto the spot
        return (gx - px) / dist * pace, (gy - py) / dist * pace

    def _step_round_robots(self, px: float, py: float, vx: float, vy: float, ux: float,
                           uy: float, pace: float, robots: list[tuple[float, float]]
                           ) -> tuple[float, float]:
        """People keep out of robots' way: a push away from any robot within 1.5 m, stronger
        the closer it is (a "social force"), and a step sideways round a robot ahead of them
        (without it a person walking straight at a robot stops against it, pushed back as
        hard as they push on)."""
        for rx, ry in robots:
            ax, ay = px - rx, py - ry
            gap = math.hypot(ax, ay)
            if 1e-6 < gap < 1.5:
                push = (1.5 - gap) / gap * (2.0 if gap < 0.9 else 1.0)   # harder when near
                vx, vy = vx + ax * push, vy + ay * push
                if -(ax * ux + ay * uy) > 0.5 * gap:      # the robot within ±60° ahead
                    # step away from the side the robot is on (right when dead ahead),
                    # unless a wall there leaves no room to pass: then the other way
                    away = -1.0 if ux * ay - uy * ax > 0.0 else 1.0   # +1: to the right
                    if self._room(px, py, uy * away, -ux * away) < 0.8 <= \
                            self._room(px, py, -uy * away, ux * away):
                        away = -away
                    side = pace * (1.5 - gap) / 1.5 * away
                    vx, vy = vx + uy * side, vy - ux * side
        return vx, vy

    def _step_round_walls(self, px: float, py: float, vx: float, vy: float, ux: float,
                          uy: float, pace: float, dist: float) -> tuple[float, float]:
        """Nor into walls and boxes: a wall or box within 0.8 m ahead of either side of a
        person's body (and before their next route point) makes them step sideways, away from
        the side it is on — to the side with more room when it is across their whole way —
        the nearer, the harder. Without it a person pushed off their line (passing someone,
        stepping round a robot) walks into the corner of a box and stays there."""
        reach = min(0.8, dist)
        if reach <= 0.0:
            return vx, vy
        edge = PERSON_RADIUS - 0.05                 # rays just inside the body's sides
        left, right, centre = (float(v) for v in free_distance(
            self.world.segments, np.array([px - uy * edge, px + uy * edge, px]),
            np.array([py + ux * edge, py - ux * edge, py]), ux, uy, reach))
        ahead = min(left, right, centre)
        if ahead >= reach:
            return vx, vy
        if (left < reach) == (right < reach):     # across the way: toward the more room
            away = 1.0 if self._room(px, py, uy, -ux) > self._room(px, py, -uy, ux) else -1.0
        else:                                     # +1: to the right
            away = 1.0 if left < right else -1.0
        side = pace * (1.0 - ahead / reach) * away
        return vx + uy * side, vy - ux * side

    def _slide_along_walls(self, px: float, py: float, vx: float, vy: float
                           ) -> tuple[float, float]:
        """The way a person against a wall really goes: along it (the part of their step
        into the wall is taken out), so that keeping clear of a robot judges the step they
        will take — pressed to a wall beside a robot, a person pushing into the wall slides
        along it into the robot's corner."""
        return along_walls(self.world.segments, px, py, vx, vy, PERSON_RADIUS + 0.03)

    def _pass_people(self, p: _Person, px: float, py: float, vx: float, vy: float, ux: float,
                     uy: float) -> tuple[float, float]:
        """Nor into each other: someone ahead within ±45° is passed on the right, and the
        stopping rule of :func:`_keep_clear` holds between two people (each brakes for their
        part)."""
        others: list[tuple[float, float]] = [q.body.position for q in self.people if q is not p]
        others += [(v.x, v.y) for v in map(_body_position, self._people_bodies[len(self.people):])]
        for qx, qy in others:                        # the bystanders too
            ax, ay = px - qx, py - qy
            gap = math.hypot(ax, ay)
            if 1e-6 < gap < 1.5:
                if -(ax * ux + ay * uy) > 0.7 * gap:
                    side = 0.5 * p.speed * (1.5 - gap) / 1.5
                    vx, vy = vx + uy * side, vy - ux * side
                allowed = math.sqrt(2.0 * 1.0 * max(gap - 2 * PERSON_RADIUS - 0.1, 0.0))
                toward = -(vx * ax + vy * ay) / gap
                if toward > allowed:
                    cut = toward - allowed
                    vx, vy = vx + ax / gap * cut, vy + ay / gap * cut
        return vx, vy

    def _room(self, x: float, y: float, dx: float, dy: float, reach: float = 1.5) -> float:
        """Free distance [m] from (x, y) along the unit direction (dx, dy) to the nearest wall
        (up to ``reach``): how far a person can step that way."""
        return float(free_distance(self.world.segments, x, y, dx, dy, reach)[0])

    def _set_command(self, r: _Robot, cmd: Command) -> None:
        d = r.description
        if cmd is None:
            return
        if isinstance(cmd, msgs.Twist):
            target = kinematics.twist_to_wheel_speeds(cmd.linear.x, cmd.angular.z,
                                                      d.wheel_radius, d.wheel_separation)
        else:
            target = np.asarray(cmd, dtype=float)
            if target.shape != (2,) or not np.all(np.isfinite(target)):
                raise ValueError(f"a wheel command is (right, left) in rad/s; got {cmd!r}")
        r.wheel_target = kinematics.saturate_wheel_speeds(target, d.max_wheel_speed)
        r.targets = (float(r.wheel_target[0]), float(r.wheel_target[1]))

    def _drive(self, r: _Robot, dt: float) -> None:
        """The wheel servos (or motors) one step on, and the traction joints' ground bodies
        moved at the wheels' rim speeds. The arithmetic, operation for operation, of the
        model in the module's docstring; pymunk is reached through its C functions (the
        property wrappers cost several times the physics)."""
        d = r.description
        ph = self.physics
        limit, wheel_radius = r.limit, d.wheel_radius
        cp_body = r.cp_body
        angle = _body_angle(cp_body)
        c, s = math.cos(angle), math.sin(angle)
        speeds, angles, targets = r.speeds, r.angles, r.targets
        # the ground bodies' positions do not matter: anchored at their centres and never
        # rotating, they only lend the joints their velocity
        motor = ph.wheel_motor
        for k in (0, 1):
            if motor is not None:
                volts = float(r.controllers[k](targets[k], speeds[k]))
                volts = min(max(volts, -motor.voltage), motor.voltage)
                speed = motor.quasi_static_step(speeds[k], volts, dt)
            else:
                change = targets[k] - speeds[k]
                speed = speeds[k] + (limit if change > limit else
                                     -limit if change < -limit else change)
            speeds[k] = speed
            angles[k] += speed * dt
            rim = speed * wheel_radius * r.radius_factors[k]
            if ph.slip_variance:
                # the wheel turns a little more or less than it rolls over the floor: an
                # error of variance k |Δs| in what the encoder counts over this step
                slip = math.sqrt(ph.slip_variance * abs(rim) * dt) * \
                    float(self.rng.standard_normal())
                angles[k] += slip / wheel_radius
            _set_body_velocity(r.cp_grounds[k], (rim * c, rim * s))
        if self._oil:
            position = _body_position(cp_body)
            px, py = position.x, position.y
            for k in (0, 1):
                x, y = r.wheel_points[k]
                slippery = self.world.in_oil(px + c * x - s * y, py + s * x + c * y)
                if slippery != r.on_oil[k]:  # pymunk's setters are dear: only on a change
                    r.on_oil[k] = slippery
                    r.joints[k].max_force = r.oil_force if slippery else r.traction

    def _drive_servos(self, robots: list[_Robot], dt: float) -> None:
        """:meth:`_drive` for every robot when the wheels are ideal servos on a floor without
        micro-slip (no ``wheel_motor``, no ``slip_variance``): the same arithmetic, operation
        for operation, in one loop with both wheels written out (this runs for every robot
        at every step)."""
        rects = self.world._oil_rects if self._oil else ()
        for r in robots:
            cp_body = r.cp_body
            angle = _body_angle(cp_body)
            c, s = math.cos(angle), math.sin(angle)
            speeds, angles, (target_r, target_l) = r.speeds, r.angles, r.targets
            limit, wheel_radius = r.limit, r.wheel_radius
            factor_r, factor_l = r.radius_factors
            ground_r, ground_l = r.cp_grounds
            speed = speeds[0]
            change = target_r - speed
            speed = speed + (limit if change > limit else -limit if change < -limit else change)
            speeds[0] = speed
            angles[0] += speed * dt
            rim = speed * wheel_radius * factor_r
            _set_body_velocity(ground_r, (rim * c, rim * s))
            speed = speeds[1]
            change = target_l - speed
            speed = speed + (limit if change > limit else -limit if change < -limit else change)
            speeds[1] = speed
            angles[1] += speed * dt
            rim = speed * wheel_radius * factor_l
            _set_body_velocity(ground_l, (rim * c, rim * s))
            if rects:
                position = _body_position(cp_body)
                px, py = position.x, position.y
                on_oil = r.on_oil
                if not (on_oil[0] or on_oil[1]):
                    # off the oil, and no wheel can be on it (the body's origin is outside
                    # every patch grown by the wheels' reach, r.oil_near): nothing changes
                    for x0, y0, x1, y1 in r.oil_near:
                        if x0 <= px <= x1 and y0 <= py <= y1:
                            break
                    else:
                        continue
                for k in (0, 1):
                    x, y = r.wheel_points[k]
                    wx, wy = px + c * x - s * y, py + s * x + c * y
                    # World.in_oil, written out
                    slippery = False
                    for x0, y0, x1, y1 in rects:
                        if x0 <= wx <= x1 and y0 <= wy <= y1:
                            slippery = True
                            break
                    if slippery != on_oil[k]:  # pymunk's setters are dear: only on a change
                        on_oil[k] = slippery
                        r.joints[k].max_force = r.oil_force if slippery else r.traction

    def _read_state(self, r: _Robot, dt: float | None = None) -> None:
        cp_body = r.cp_body
        angle = _body_angle(cp_body)
        # geometry.wrap_angle's arithmetic on a float
        yaw = (angle + _PI) % _TWO_PI - _PI
        if yaw >= _PI:
            yaw = yaw - _TWO_PI
        velocity = _body_velocity(cp_body)
        vx, vy = velocity.x, velocity.y
        c, s = _cos(angle), _sin(angle)
        v_forward = c * vx + s * vy
        w = _body_angular_velocity(cp_body)
        if dt:
            # acceleration in base_link: the change of the world velocity, rotated in
            wvx, wvy = r.world_velocity
            ax_w = (vx - wvx) / dt
            ay_w = (vy - wvy) / dt
            r.accel = (c * ax_w + s * ay_w, -s * ax_w + c * ay_w)
            r.yaw_accel = (w - r.yaw_rate) / dt
        r.world_velocity = (vx, vy)
        position = _body_position(cp_body)
        x, y = position.x, position.y
        r.x, r.y, r.yaw, r.yaw_rate, r.forward_speed = x, y, yaw, w, v_forward
        r.xy_yaw = (x, y, yaw)

    def step(self, cmd: Command | Mapping[int, Command] = None) -> list[tuple[str, Any]]:
        """Advance by one physics step (``physics.dt``).

        ``cmd`` is a ``Twist`` (``linear.x`` [m/s], ``angular.z`` [rad/s]), wheel speeds
        ``(right, left)`` [rad/s], ``None`` (keep the last command), or a mapping from robot
        index to any of these. Returns the sensor messages produced in this step as
        ``(topic, message)`` pairs, stamped with the sim clock.
        """
        if cmd is not None:
            commands = cmd if isinstance(cmd, Mapping) else {0: cmd}
            for index, c in commands.items():
                self._set_command(self.robots[index], c)
        ph = self.physics
        dt = ph.dt
        t0 = self.time
        t1 = round((t0 + dt) * 1e9) * 1e-9
        if self.people and round(t1 / dt) % 10 == 0:
            self._walk()  # people decide where to go ten times a second
        robots = self.robots
        before = [r.xy_yaw for r in robots]  # _read_state replaces it with a new tuple
        if ph.wheel_motor is None and not ph.slip_variance:
            self._drive_servos(robots, dt)
        else:
            for r in robots:
                self._drive(r, dt)
        self._step_space(dt / ph.substeps, ph.substeps)
        self.time = t1
        out: list[tuple[str, Any]] = []
        discs = self._discs() if self._people_bodies else _NO_DISCS
        segments, circles = self.world.lidar_segments, self.world.circles
        # this step's headers, one per frame: every robot's messages share them (immutable)
        headers: dict[str, msgs.Header] = {}
        if len(robots) == 1:   # one robot: its messages made as they come
            r = robots[0]
            self._read_state(r, dt)
            if r.lidar is not None:
                scan = r.lidar.collect(t0, t1, before[0], r.xy_yaw, discs, segments, circles)
                if scan is not None:
                    out.append((r._topics[0], scan))
            imu = r.imu
            if imu is not None and t1 + 1e-12 >= imu.next_time:
                header = self._header(headers, imu.frame_id)
                out.append((r._topics[1], imu.measure(t1, r.yaw, r.yaw_rate, r.yaw_accel,
                                                     r.accel, header)))
            if t1 + 1e-12 >= r.next_joint_state:
                r.next_joint_state += 0.02
                header = headers.get("") or self._header(headers, "")
                out.append((r._topics[2], self._joint_state(r, header)))
            return out
        # several: the scans and joint states due now made together after the loop, into
        # their places in out (the scans in one compiled call when they can)
        due: list[tuple[int, Lidar]] = []
        joints_due: list[tuple[int, _Robot]] = []
        for i, r in enumerate(robots):
            self._read_state(r, dt)
            lidar = r.lidar
            if lidar is not None and lidar.record(t0, t1, before[i], r.xy_yaw, discs):
                due.append((len(out), lidar))
                out.append((r._topics[0], None))
            imu = r.imu
            if imu is not None and t1 + 1e-12 >= imu.next_time:
                header = headers.get(imu.frame_id) or self._header(headers, imu.frame_id)
                out.append((r._topics[1], imu.measure(t1, r.yaw, r.yaw_rate, r.yaw_accel,
                                                     r.accel, header)))
            if t1 + 1e-12 >= r.next_joint_state:
                r.next_joint_state += 0.02
                joints_due.append((len(out), r))
                out.append((r._topics[2], None))
        if due:
            scans = finish_scans([lidar for _, lidar in due], segments, circles)
            for (k, _), scan in zip(due, scans, strict=True):
                out[k] = (out[k][0], scan)
        if joints_due:
            header = headers.get("") or self._header(headers, "")
            for (k, _), state in zip(joints_due, self._joint_states(
                    [r for _, r in joints_due], header), strict=True):
                out[k] = (out[k][0], state)
        return out

    def _header(self, headers: dict[str, msgs.Header], frame_id: str) -> msgs.Header:
        """The header of this step's messages in ``frame_id``, made once (into ``headers``)."""
        stamp = next(iter(headers.values())).stamp if headers else stamp_of(self.time)
        header = headers[frame_id] = _header(stamp, frame_id)
        return header

    def _step_space(self, dt: float, substeps: int) -> None:
        """``pymunk.Space.step`` ``substeps`` times: straight into Chipmunk when there is none
        of the bookkeeping the wrapper does around it to do (bodies to check, objects added or
        removed from callbacks, post-step callbacks; the simulator uses none of them)."""
        space = self.space
        if space._bodies_to_check or space._add_later or space._remove_later or \
                space._post_step_callbacks:
            for _ in range(substeps):
                space.step(dt)
            return
        cp_space = space._space
        space._locked = True
        try:
            for _ in range(substeps):
                _space_step(cp_space, dt)
        finally:
            space._locked = False

    def run(self, seconds: float, cmd: Command | Mapping[int, Command] = None
            ) -> list[tuple[str, Any]]:
        """Step for ``seconds`` with one command; all messages produced, in order."""
        out = self.step(cmd)
        for _ in range(round(seconds / self.physics.dt) - 1):
            out.extend(self.step())
        return out

    # ------------------------------------------------------------------ reading
    def description(self, robot: int = 0) -> RobotDescription:
        """The description (URDF and parameters) of robot ``robot`` as simulated."""
        if not 0 <= robot < len(self.descriptions):
            raise ValueError(f"robot index {robot} is out of range: this simulation has "
                             f"{len(self.descriptions)} robot(s)")
        return self.descriptions[robot]

    def clock(self) -> msgs.Time:
        return msgs.Time.from_sec(self.time)

    def preset_encoders(self, right: int, left: int, robot: int = 0) -> None:
        """Make the encoder counters read (right, left) now (e.g. just below a roll-over)."""
        r = self.robots[robot]
        current = np.array(self.encoder_ticks(robot), dtype=np.int64) - r.tick_offset
        r.tick_offset = (np.array([right, left], dtype=np.int64) - current) % \
            (1 << r.description.counter_bits)

    def encoder_ticks(self, robot: int = 0) -> tuple[int, int]:
        """Raw (right, left) encoder counter readings, as the motor controller reports them."""
        r = self.robots[robot]
        d = r.description
        return encoder_counts(r.wheel_angle, d.ticks_per_wheel_turn, r.tick_offset,
                              d.counter_bits)

    def joint_state(self, robot: int = 0) -> msgs.JointState:
        """Wheel positions [rad] from the encoders (quantised) and the servos' speeds."""
        return self._joint_state(self.robots[robot], _header(stamp_of(self.time), ""))

    @staticmethod
    def _joint_states(robots: list[_Robot], header: msgs.Header) -> list[msgs.JointState]:
        """:meth:`_joint_state` of several robots, the same numbers, their arrays rows of
        one array each (two numpy calls instead of two per robot)."""
        floor = math.floor
        wheels: list[float] = []
        speeds: list[float] = []
        for r in robots:
            per_rad = r.ticks_per_rad
            right, left = r.angles
            wheels += (floor(right * per_rad) / per_rad, floor(left * per_rad) / per_rad)
            speeds += r.speeds
        positions = np.array(wheels).reshape(-1, 2)
        velocities = np.array(speeds).reshape(-1, 2)
        positions.flags.writeable = velocities.flags.writeable = False  # handed over
        # each message's arrays are rows of these (read-only float64, two wheels each)
        return [_joint_state(header, _WHEEL_JOINTS, position, velocity, _NO_EFFORT)
                for position, velocity in zip(positions, velocities, strict=True)]

    @staticmethod
    def _joint_state(r: _Robot, header: msgs.Header) -> msgs.JointState:
        per_rad = r.ticks_per_rad
        right, left = r.angles
        position = np.array((math.floor(right * per_rad) / per_rad,
                             math.floor(left * per_rad) / per_rad))
        velocity = np.array(r.speeds)
        position.flags.writeable = velocity.flags.writeable = False  # handed over, not copied
        # fresh read-only float64 arrays and a tuple of names: nothing for __init__ to check
        return _joint_state(header, _WHEEL_JOINTS, position, velocity, _NO_EFFORT)

    def ground_truth(self, robot: int = 0) -> GroundTruth:
        r = self.robots[robot]
        v_forward, w = r.forward_speed, r.yaw_rate
        rim = r.wheel_speed * r.description.wheel_radius * \
            (1.0 + np.asarray(self.physics.wheel_radius_errors))
        half = 0.5 * r.description.wheel_separation
        v_axle = v_forward - w * float(r.description.axle[1])  # forward speed at the axle
        ground_speed = np.array([v_axle + w * half, v_axle - w * half])
        return GroundTruth(self.time, r.pose, r.velocity, rim - ground_speed,
                           self.world.in_oil(r.x, r.y))

    def people_positions(self) -> FloatArray:
        """(P, 2) positions of the pedestrians [m] (ground truth)."""
        return self._discs()[:, :2]

    def static_transforms(self, robot: int = 0) -> msgs.TFMessage:
        """``/tf_static``: the robot's URDF joints at the sim clock."""
        return msgs.TFMessage(self.robots[robot].description.static_transforms(self.clock()))
