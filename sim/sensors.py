"""Sensor models: wheel encoders, IMU and 2-D lidars, each seeded and at its device's rate.

Sensors see only what a real one would: the encoders count the *wheels'* rotation (slip
included), the IMU measures the body with noise and drifting biases, the lidar measures ranges
to walls and people (not glass) with noise and dropouts. Ground truth is never in their output.
"""

from __future__ import annotations

import itertools
import math
import operator
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from kit import msgs
from sim.raycast import _beam_geometry, _cast_scan, segments_near

__all__ = ["Imu", "Lidar", "encoder_counts", "finish_scans", "stamp_of"]

FloatArray = NDArray[np.float64]
GRAVITY = 9.80665
_time = msgs.Time.trusted_builder()
_header = msgs.Header.trusted_builder()
_vector3 = msgs.Vector3.trusted_builder()
_quaternion = msgs.Quaternion.trusted_builder()
_imu = msgs.Imu.trusted_builder()
_ZERO_VECTOR = msgs.Vector3(0.0, 0.0, 0.0)
_laser_scan = msgs.LaserScan.trusted_builder()
_NO_PEOPLE = np.zeros((1, 0, 3))
_NO_DRAWS = np.zeros(0)


def stamp_of(seconds: float) -> msgs.Time:
    """``msgs.Time.from_sec(seconds)`` for the simulator's own (finite) clock, unchecked."""
    nanoseconds = round(seconds * 1e9)
    return _time(nanoseconds // 1_000_000_000, nanoseconds % 1_000_000_000)


@njit(cache=True)
def _measure(ranges: FloatArray, noise: FloatArray, drops: FloatArray, dropout: float,
             range_min: float, range_max: float
             ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:  # pragma: no cover
    """A scan's true ranges [m] as the lidar reports them: plus ``noise`` (none when empty),
    a beam dropped (``inf``) where ``drops < dropout`` (none when empty), ``inf`` beyond
    ``range_max``, ``-inf`` under ``range_min`` (REP-117: too close to measure), in float32;
    and the intensities (47 for a return, 0 for none)."""
    n = ranges.shape[0]
    out = np.empty(n, dtype=np.float32)
    intensities = np.empty(n, dtype=np.float32)
    for i in range(n):
        r = ranges[i] + noise[i] if noise.shape[0] else ranges[i]
        if drops.shape[0] and drops[i] < dropout:
            r = np.inf
        if r > range_max:
            r = np.inf
        if r < range_min:
            r = -np.inf
        out[i] = np.float32(r)
        intensities[i] = np.float32(47.0) if np.isfinite(out[i]) else np.float32(0.0)
    return out, intensities


def encoder_counts(wheel_angle: FloatArray, ticks_per_wheel_turn: float, offset: NDArray[Any],
                   counter_bits: int) -> tuple[int, int]:
    """Raw (right, left) counter readings for total wheel rotations [rad]: quantised to whole
    ticks, started at ``offset``, wrapped to the counter's width."""
    counts = np.floor(np.asarray(wheel_angle) * (ticks_per_wheel_turn / (2 * math.pi)))
    wrapped = (counts.astype(np.int64) + offset) % (1 << counter_bits)
    return int(wrapped[0]), int(wrapped[1])


class Imu:
    """An IMU in ``imu_link``: yaw (absolute, as the BNO055's fusion or a compass gives it),
    yaw rate and linear acceleration (gravity included, REP-145), each with white noise; the
    yaw and the gyro carry biases that drift as random walks.

    Parameters come from the robot's ``[sensors.imu]``; ``gyro_noise_std = 0`` means the device
    reports no rates (the OS5000), which the message marks with covariance −1.
    """

    YAW_DRIFT = 2e-4      # rad/sqrt(s), random walk of the fused yaw's bias (assumed)
    GYRO_DRIFT = 5e-5     # rad/s/sqrt(s), random walk of the gyro bias (assumed)

    def __init__(self, params: Mapping[str, Any], mount: tuple[float, float],
                 rng: np.random.Generator) -> None:
        self.rate = float(params.get("rate", 100.0))
        self.frame_id = str(params.get("frame_id", "imu_link"))
        self.yaw_std = float(params.get("yaw_noise_std", 0.0))
        self.gyro_std = float(params.get("gyro_noise_std", 0.0))
        self.accel_std = float(params.get("accel_noise_std", 0.0))
        self.mount = mount
        self.rng = rng
        self.yaw_bias = 0.0
        self.gyro_bias = float(rng.normal(0.0, float(params.get("gyro_bias_std", 0.0))))
        self.period = 1.0 / self.rate
        # each bias's random-walk step per reading, as YAW_DRIFT * sqrt(period) * draw
        self._yaw_drift_step = self.YAW_DRIFT * math.sqrt(self.period)
        self._gyro_drift_step = self.GYRO_DRIFT * math.sqrt(self.period)
        self.next_time = 0.0
        self._rows: Iterator[list[float]] = iter(())
        self.cov_orientation = self._cov(self.yaw_std ** 2 or 1e-6, 1e-6)
        self.cov_gyro = self._cov(self.gyro_std ** 2, 1e-6) if self.gyro_std else \
            self._unavailable()
        self.cov_accel = self._cov(self.accel_std ** 2, self.accel_std ** 2) if \
            self.accel_std else self._unavailable()

    @staticmethod
    def _cov(z: float, other: float) -> FloatArray:
        c = np.diag([other, other, z]).ravel().copy()
        c.flags.writeable = False
        return c

    @staticmethod
    def _unavailable() -> FloatArray:
        """ROS's mark for "not provided": −1 as the covariance's first element."""
        c = np.zeros(9)
        c[0] = -1.0
        c.flags.writeable = False
        return c

    def due(self, time: float) -> bool:
        return time + 1e-12 >= self.next_time

    def _draws(self) -> list[float]:
        """Seven standard normal draws, taken from a block drawn ahead (fewer rng calls): the
        block's rows of seven, in the order drawn."""
        draws = next(self._rows, None)
        if draws is None:
            self._rows = iter(self.rng.standard_normal(7 * 256).reshape(256, 7).tolist())
            draws = next(self._rows)
        return draws

    def measure(self, time: float, yaw: float, yaw_rate: float, yaw_accel: float,
                accel_body: tuple[float, float], header: msgs.Header | None = None
                ) -> msgs.Imu:
        """One reading at ``time`` of the body's true yaw, rates and base_link acceleration
        (``header``: the message's, when the caller has it: stamped ``time``, in
        ``frame_id``)."""
        self.next_time += self.period
        n_yaw_bias, n_gyro_bias, n_yaw, n_rate, n_ax, n_ay, n_az = self._draws()
        self.yaw_bias += self._yaw_drift_step * n_yaw_bias
        self.gyro_bias += self._gyro_drift_step * n_gyro_bias
        measured_yaw = yaw + self.yaw_bias + self.yaw_std * n_yaw
        rate = yaw_rate + self.gyro_bias + self.gyro_std * n_rate if self.gyro_std else 0.0
        # acceleration at the mounting point: a + alpha x r + omega x (omega x r)
        mx, my = self.mount
        ax = accel_body[0] - yaw_accel * my - yaw_rate * yaw_rate * mx
        ay = accel_body[1] + yaw_accel * mx - yaw_rate * yaw_rate * my
        # built with Message.trusted's builders: every value here is already a float or a
        # read-only array of the right shape, and this runs at the IMU's rate for every robot
        if self.accel_std:
            sd = self.accel_std
            accel = _vector3(ax + sd * n_ax, ay + sd * n_ay, GRAVITY + sd * n_az)
        else:
            accel = _ZERO_VECTOR   # messages are immutable: one zero vector serves them all
        half = 0.5 * measured_yaw
        if header is None:
            header = _header(stamp_of(time), self.frame_id)
        return _imu(header, _quaternion(0.0, 0.0, math.sin(half), math.cos(half)),
                    self.cov_orientation, _vector3(0.0, 0.0, float(rate)), self.cov_gyro,
                    accel, self.cov_accel)


class Lidar:
    """A planar lidar in ``laser_link`` whose beams are taken one after another.

    Beam ``i`` of a scan is measured at ``stamp + i * time_increment`` from where the sensor
    is at that instant, so a scan taken while the robot turns is bent, as a slow-spinning
    RPLidar's is. ``time_increment = 0`` (a depth camera) takes all beams at once.

    The simulator calls :meth:`collect` every physics step with the sensor's pose at the start
    and the end of the step and the people's discs; the beams that fall in the step are
    queued, and when a scan is complete all its beams are cast at once (vectorised).
    """

    def __init__(self, params: Mapping[str, Any], mount: tuple[float, float, float],
                 rng: np.random.Generator, rate: float | None = None,
                 beams: int | None = None) -> None:
        model = str(params.get("model", "rplidar_a1"))
        self.frame_id = str(params.get("frame_id", "laser_link"))
        self.rate = float(rate if rate is not None else params.get("scan_rate", 5.5))
        self.angle_min = float(params.get("angle_min", -math.pi))
        span = float(params.get("angle_max", math.pi)) - self.angle_min
        full_circle = abs(span - 2 * math.pi) < 1e-9
        if beams is None:
            if "angle_increment" in params:
                beams = round(span / float(params["angle_increment"])) + \
                    (0 if full_circle else 1)
            else:
                beams = 360
        self.beams = int(beams)
        self.increment = span / self.beams if full_circle else span / (self.beams - 1)
        self.range_min = float(params.get("range_min", 0.1))
        self.range_max = float(params.get("range_max", 12.0))
        self.noise_std = float(params.get("range_noise_std", 0.0))
        self.dropout = float(params.get("dropout", 0.01 if model == "rplidar_a1" else 0.0))
        if model == "kinect_depth_row":
            self.time_increment = 0.0
        elif model == "lms291":
            self.time_increment = 1.0 / 75.0 / (2 * math.pi / self.increment)
        else:
            self.time_increment = 1.0 / (self.rate * self.beams)
        self.mount = mount
        self.rng = rng
        self.scan_start = 0.0
        self._times: list[float] = []
        self._poses: list[Sequence[float]] = []
        self._people: list[FloatArray] = []
        self.last_ranges: FloatArray = np.full(self.beams, np.inf)
        """float64 ranges of the last scan, before noise (for tests against geometry)."""
        self._near: tuple[FloatArray, float, float, FloatArray] | None = None
        self._circles_cache: tuple[FloatArray, FloatArray] | None = None
        self._mount_x, self._mount_y = float(mount[0]), float(mount[1])
        self._angle0 = float(mount[2]) + float(self.angle_min)   # as beam_geometry adds them
        # the scan's float32 fields, rounded once (LaserScan stores them as float32)
        self._fields32 = tuple(float(np.float32(v)) for v in (
            self.angle_min, self.angle_min + self.increment * (self.beams - 1), self.increment,
            self.time_increment, 1.0 / self.rate, self.range_min, self.range_max))

    def beam_times(self) -> FloatArray:
        return np.asarray(self.scan_start + self.time_increment * np.arange(self.beams),
                          dtype=np.float64)

    def collect(self, t0: float, t1: float, pose0: Sequence[float], pose1: Sequence[float],
                people: FloatArray, segments: FloatArray, circles: FloatArray,
                ) -> msgs.LaserScan | None:
        """Record one physics step (sensor-carrier poses at ``t0`` and ``t1``, the people's
        discs during it); return a scan once its last beam's time has passed."""
        if not self.record(t0, t1, pose0, pose1, people):
            return None
        return self._finish(segments, circles)

    def record(self, t0: float, t1: float, pose0: Sequence[float], pose1: Sequence[float],
               people: FloatArray) -> bool:
        """:meth:`collect`'s recording alone: whether a scan is now due (:func:`finish_scans`
        makes it, with the other lidars' due in the same step)."""
        times = self._times
        if not times:
            times.append(t0)
            self._poses.append(pose0)
        times.append(t1)
        self._poses.append(pose1)
        self._people.append(people)
        return t1 + 1e-12 >= self.scan_start + self.time_increment * (self.beams - 1)

    def _finish(self, segments: FloatArray, circles: FloatArray) -> msgs.LaserScan:
        # beam_geometry and cast_scan without their wrappers' conversions: every argument
        # here already has its type, and this runs for every scan of every robot
        ox, oy, angles, step = _beam_geometry(
            np.array(self._times), np.array(self._poses), self.scan_start,
            self.time_increment, self.beams, self._mount_x, self._mount_y, self._angle0,
            self.increment)
        near = self._segments_near(segments, float(ox[0]), float(oy[0]))
        # each beam sees the people where they were during its physics step
        people = np.array(self._people) if self._people[0].size else _NO_PEOPLE
        ranges = _cast_scan(ox, oy, angles, near, self._circles(circles), people, step,
                            self.range_max)
        # keep the last step: the next scan's first beams may fall inside it
        self._times, self._poses = self._times[-2:], self._poses[-2:]
        self._people = self._people[-1:]
        self.last_ranges = ranges
        noise = self.rng.normal(0.0, self.noise_std, self.beams) if self.noise_std else \
            _NO_DRAWS
        drops = self.rng.random(self.beams) if self.dropout else _NO_DRAWS
        ranges32, intensities = _measure(ranges, noise, drops, self.dropout, self.range_min,
                                         self.range_max)
        ranges32.flags.writeable = intensities.flags.writeable = False  # handed over
        return self._message(ranges32, intensities)

    def _message(self, ranges32: NDArray[np.float32], intensities: NDArray[np.float32],
                 header: msgs.Header | None = None) -> msgs.LaserScan:
        """The scan's message (read-only float32 ``ranges32`` and ``intensities``; ``header``
        when the caller has it: stamped ``scan_start``, in ``frame_id``), and the next
        scan's start."""
        if header is None:
            header = _header(stamp_of(self.scan_start), self.frame_id)
        # every field is already normal (float32-rounded numbers, read-only float32 arrays)
        scan = _laser_scan(header, *self._fields32, ranges32, intensities)
        self.scan_start += 1.0 / self.rate
        return scan

    def _circles(self, circles: FloatArray) -> FloatArray:
        """The world's discs as the caster takes them (contiguous (K, 3)), converted once."""
        cached = self._circles_cache
        if cached is None or cached[0] is not circles:
            self._circles_cache = cached = (circles, np.ascontiguousarray(
                circles, dtype=np.float64).reshape(-1, 3))
        return cached[1]

    def _segments_near(self, segments: FloatArray, x: float, y: float) -> FloatArray:
        """The walls within reach of the sensor at (x, y), culled again only when it has moved
        more than a metre from where they were last culled (the cull keeps a metre to spare,
        so the beams meet the same walls)."""
        cached = self._near
        if cached is None or cached[0] is not segments or \
                abs(x - cached[1]) > 1.0 or abs(y - cached[2]) > 1.0:
            near = np.ascontiguousarray(
                segments_near(segments, np.array((x, y)), self.range_max + 2.0),
                dtype=np.float64).reshape(-1, 4)
            self._near = cached = (segments, x, y, near)
        return cached[3]


_same = operator.is_
_chain = itertools.chain.from_iterable
_scan_parameters = operator.attrgetter(
    "time_increment", "beams", "_mount_x", "_mount_y", "_angle0", "increment", "range_min",
    "range_max", "dropout", "noise_std")


def finish_scans(lidars: Sequence[Lidar], segments: FloatArray, circles: FloatArray
                 ) -> list[msgs.LaserScan]:
    """The scans of ``lidars`` (each :meth:`Lidar.record` said it was due in this step), in
    order: what :meth:`Lidar.collect` would have returned for each.

    Lidars that recorded the same steps (the same times and the same people's discs: robots
    of one simulation whose scans started together) are made in two compiled calls — every
    scan's beam geometry, then, with each lidar's walls within reach from its own cache,
    every scan's casting, noise, dropouts and float32 ranges — with the same arithmetic as
    each lidar's own; any other set, one by one."""
    first = lidars[0]
    times, people = first._times, first._people
    if len(lidars) == 1 or not all(
            lidar._times == times and len(lidar._people) == len(people) and
            all(map(_same, lidar._people, people)) for lidar in lidars[1:]):
        return [lidar._finish(segments, circles) for lidar in lidars]
    # each lidar's draws from its own generator, in the order _finish takes them, straight
    # into one array: its noise as standard normals (rng.normal(0, sd) is 0.0 + sd * those,
    # which _cast_many computes), then its dropout draws; none where it has none
    parameters = [_scan_parameters(lidar) for lidar in lidars]
    beams_at = [0]
    draws_at = [0]
    for lidar, p in zip(lidars, parameters, strict=True):
        beams_at.append(beams_at[-1] + lidar.beams)
        draws_at.append(draws_at[-1] + (lidar.beams if p[9] else 0) +
                        (lidar.beams if p[8] else 0))
    draws = np.empty(draws_at[-1])
    for k, (lidar, p) in enumerate(zip(lidars, parameters, strict=True)):
        a = draws_at[k]
        if p[9]:
            lidar.rng.standard_normal(out=draws[a:a + lidar.beams])
            a += lidar.beams
        if p[8]:
            lidar.rng.random(out=draws[a:a + lidar.beams])
    rows, at = np.array(parameters, dtype=np.float64), np.array(beams_at)
    ox, oy, angles, step = _geometry_many(
        np.array(times), np.fromiter(_chain(_chain(lidar._poses for lidar in lidars)),
                                     np.float64, 3 * len(lidars) * len(times)
                                     ).reshape(len(lidars), len(times), 3),
        np.array([lidar.scan_start for lidar in lidars]), rows, at)
    # each lidar's walls within reach, from its own cache, as _finish takes them
    near = [lidar._segments_near(segments, float(ox[a]), float(oy[a]))
            for lidar, a in zip(lidars, beams_at, strict=False)]
    near_at = np.cumsum([0] + [len(walls) for walls in near])
    ranges, ranges32, intensities = _cast_many(
        ox, oy, angles, step, rows, at, np.concatenate(near), near_at,
        first._circles(circles), np.array(people) if people[0].size else _NO_PEOPLE, draws,
        np.array(draws_at))
    ranges.flags.writeable = ranges32.flags.writeable = intensities.flags.writeable = False
    scans = []
    headers: dict[tuple[float, str], msgs.Header] = {}   # shared (messages are immutable)
    for k, lidar in enumerate(lidars):
        a, b = beams_at[k], beams_at[k + 1]
        # keep the last step: the next scan's first beams may fall inside it
        lidar._times, lidar._poses = lidar._times[-2:], lidar._poses[-2:]
        lidar._people = lidar._people[-1:]
        lidar.last_ranges = ranges[a:b]
        key = (lidar.scan_start, lidar.frame_id)
        header = headers.get(key)
        if header is None:
            header = headers[key] = _header(stamp_of(lidar.scan_start), lidar.frame_id)
        scans.append(lidar._message(ranges32[a:b], intensities[a:b], header))
    return scans


@njit(cache=True)
def _geometry_many(times: FloatArray, poses: FloatArray, starts: FloatArray,
                   parameters: FloatArray, beams_at: NDArray[np.int64]
                   ) -> tuple[FloatArray, FloatArray, FloatArray,
                              NDArray[np.int64]]:  # pragma: no cover - compiled by numba
    """Every lidar's beams (:func:`sim.raycast.beam_geometry`) from the steps they all
    recorded: ``poses`` (L, S + 1, 3), one row of :data:`_scan_parameters` and one start time
    per lidar; their origins, angles and steps one lidar after the other (``beams_at``)."""
    total = beams_at[-1]
    ox, oy, angles = np.empty(total), np.empty(total), np.empty(total)
    step = np.empty(total, dtype=np.int64)
    for k in range(poses.shape[0]):
        p = parameters[k]
        a, n = beams_at[k], int(p[1])
        ox[a:a + n], oy[a:a + n], angles[a:a + n], step[a:a + n] = _beam_geometry(
            times, poses[k], starts[k], p[0], n, p[2], p[3], p[4], p[5])
    return ox, oy, angles, step


@njit(cache=True)
def _cast_many(ox: FloatArray, oy: FloatArray, angles: FloatArray, step: NDArray[np.int64],
               parameters: FloatArray, beams_at: NDArray[np.int64], near: FloatArray,
               near_at: NDArray[np.int64], circles: FloatArray, people: FloatArray,
               draws: FloatArray, draws_at: NDArray[np.int64]
               ) -> tuple[FloatArray, NDArray[np.float32],
                          NDArray[np.float32]]:  # pragma: no cover - compiled by numba
    """Every lidar's beams cast against its walls (``near[near_at[k]:near_at[k + 1]]``), the
    world's discs and the people, then measured with its draws (from ``draws_at[k]``: its
    noise's standard normals, then its dropout draws; none for what it lacks): the float64
    ranges, the float32 ranges and the intensities of all scans one after the other."""
    total = beams_at[-1]
    out = np.empty(total)
    out32 = np.empty(total, dtype=np.float32)
    intensities = np.empty(total, dtype=np.float32)
    for k in range(beams_at.shape[0] - 1):
        p = parameters[k]
        a, n, range_max, noise_std, dropout = beams_at[k], int(p[1]), p[7], p[9], p[8]
        b = a + n
        ranges = _cast_scan(ox[a:b], oy[a:b], angles[a:b], near[near_at[k]:near_at[k + 1]],
                            circles, people, step[a:b], range_max)
        d = draws_at[k]
        noise = np.empty(n if noise_std else 0)
        for i in range(noise.shape[0]):
            noise[i] = 0.0 + noise_std * draws[d + i]   # as rng.normal(0.0, noise_std)
        d += noise.shape[0]
        r32, i32 = _measure(ranges, noise, draws[d:d + (n if dropout else 0)], dropout, p[6],
                            range_max)
        out[a:b] = ranges
        out32[a:b] = r32
        intensities[a:b] = i32
    return out, out32, intensities
