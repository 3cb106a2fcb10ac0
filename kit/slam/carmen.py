"""CARMEN log files and the Kümmerle et al. (2009) relation files of the SLAM benchmark.

A CARMEN log is text, one message per line, the message type first. The readers here take:

* ``FLASER n r_1 … r_n x y θ odom_x odom_y odom_θ ipc_timestamp ipc_hostname logger_timestamp``
  (old front laser: ``x y θ`` is the laser's pose, ``odom_*`` the robot's odometry);
* ``ROBOTLASER1 laser_type start_angle fov resolution max_range accuracy remission_mode n
  r_1 … r_n m [remissions] laser_x laser_y laser_θ robot_x robot_y robot_θ tv rv
  forward_safety side_safety turn_axis ipc_timestamp ipc_hostname logger_timestamp``;
* ``ODOM x y θ tv rv accel ipc_timestamp ipc_hostname logger_timestamp``.

Other message types (``PARAM``, ``NEFF``, ``VERTEX2`` …) are counted and skipped. The
``ipc_timestamp`` is the one the benchmark's relations refer to.

FLASER carries no beam geometry: it is CARMEN's default for the SICK LMS, a front half-circle
centred on the x axis with 1° between beams for 180 or 181 readings and 0.5° for 360 or 361
(``π / (n − 1)`` otherwise). A range of 81.91 m or more is the SICK's "no return"; it is kept
and, being above the scan's ``range_max`` of 81.9 m, counts as a max-range beam (REP-117).

A relation line is ``t1 t2 x y z roll pitch yaw``: the robot's pose at ``t2`` seen from its pose
at ``t1``, ``δ = x(t1)⁻¹ ⊕ x(t2)`` (metres, radians); lines starting with ``#`` are comments.
"""

from __future__ import annotations

import gzip
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from kit import msgs

__all__ = [
    "CarmenError",
    "CarmenLog",
    "LaserRecord",
    "OdometryRecord",
    "Relations",
    "laser_to_scan",
    "read_carmen",
    "read_relations",
]

FloatArray = NDArray[np.float64]
FLASER_RANGE_MAX = 81.9
"""range_max given to FLASER scans [m]: the SICK's "no return" reads 81.91 or more."""


class CarmenError(ValueError):
    """A log or relations file that cannot be read; the message names the file and line."""


@dataclass(frozen=True, eq=False)
class LaserRecord:
    """One laser message: ranges [m] with their beam geometry, poses, and times [s]."""

    timestamp: float
    """The IPC timestamp (the one relations use)."""
    ranges: FloatArray
    angle_min: float
    angle_increment: float
    range_max: float
    laser_pose: FloatArray
    """(x, y, θ) of the laser as the log has it (raw odometry, or corrected poses)."""
    robot_pose: FloatArray
    """(x, y, θ) of the robot (FLASER: its odometry fields)."""
    logger_timestamp: float
    kind: str


@dataclass(frozen=True, eq=False)
class OdometryRecord:
    timestamp: float
    pose: FloatArray
    velocity: tuple[float, float]
    """(tv [m/s], rv [rad/s])."""


@dataclass
class CarmenLog:
    """The messages of a log, in file order."""

    lasers: list[LaserRecord] = field(default_factory=list)
    odometry: list[OdometryRecord] = field(default_factory=list)
    skipped: dict[str, int] = field(default_factory=dict)
    """How many lines of each other message type were skipped."""

    @property
    def laser_timestamps(self) -> FloatArray:
        return np.array([r.timestamp for r in self.lasers])


def _lines(path: str | Path) -> list[str]:
    p = Path(path)
    try:
        with (gzip.open(p, "rt", encoding="utf-8") if p.suffix == ".gz" else
              p.open(encoding="utf-8")) as f:
            return f.read().splitlines()
    except FileNotFoundError:
        raise CarmenError(f"{p}: no such file") from None
    except (OSError, UnicodeDecodeError, EOFError) as exc:
        raise CarmenError(f"{p}: unreadable ({exc})") from None


def flaser_geometry(n: int) -> tuple[float, float]:
    """``(angle_min, angle_increment)`` [rad] CARMEN assumes for a FLASER of ``n`` beams.

    >>> [round(v, 6) for v in flaser_geometry(361)]
    [-1.570796, 0.008727]
    """
    if n in (180, 181):
        inc = math.pi / 180.0
    elif n in (360, 361):
        inc = math.pi / 360.0
    else:
        inc = math.pi / max(n - 1, 1)
    return -0.5 * inc * (n - 1), inc


def _floats(values: list[str], where: str) -> list[float]:
    try:
        return [float(v) for v in values]
    except ValueError:
        raise CarmenError(f"{where}: not a number among {' '.join(values)[:80]!r}") from None


def _flaser(f: list[str], where: str) -> LaserRecord:
    n = int(_floats(f[1:2], where)[0]) if len(f) > 1 else -1
    if n < 1 or len(f) < 2 + n + 9:
        raise CarmenError(f"{where}: FLASER needs n, n ranges, 6 pose values and 3 time "
                          f"fields; got {len(f) - 1} fields")
    v = _floats(f[2:2 + n + 7], where)
    angle_min, inc = flaser_geometry(n)
    return LaserRecord(
        timestamp=v[n + 6], ranges=np.array(v[:n]), angle_min=angle_min, angle_increment=inc,
        range_max=FLASER_RANGE_MAX, laser_pose=np.array(v[n:n + 3]),
        robot_pose=np.array(v[n + 3:n + 6]), logger_timestamp=_floats(f[2 + n + 8:2 + n + 9],
                                                                       where)[0],
        kind="FLASER")


def _robotlaser(f: list[str], where: str) -> LaserRecord:
    head = _floats(f[1:9], where) if len(f) > 9 else []
    n = int(head[7]) if head else -1
    if n < 1 or len(f) < 10 + n:
        raise CarmenError(f"{where}: ROBOTLASER1 is shorter than its header says")
    ranges = _floats(f[9:9 + n], where)
    m = int(_floats(f[9 + n:10 + n], where)[0])
    rest = f[10 + n + m:]
    if len(rest) < 14:
        raise CarmenError(f"{where}: ROBOTLASER1 ends before its poses and timestamps")
    tail = _floats(rest[:12], where)
    start, _fov, resolution, max_range = head[1], head[2], head[3], head[4]
    return LaserRecord(
        timestamp=tail[11], ranges=np.array(ranges), angle_min=start,
        angle_increment=resolution, range_max=max_range, laser_pose=np.array(tail[0:3]),
        robot_pose=np.array(tail[3:6]), logger_timestamp=_floats(rest[13:14], where)[0],
        kind="ROBOTLASER1")


def read_carmen(path: str | Path) -> CarmenLog:
    """Read the laser and odometry messages of a CARMEN log (``.gz`` too).

    Raises
    ------
    CarmenError
        A malformed FLASER, ROBOTLASER1 or ODOM line (named by file and line), or a log
        without any laser message.
    """
    log = CarmenLog()
    for k, line in enumerate(_lines(path), start=1):
        f = line.split()
        if not f or f[0].startswith("#"):
            continue
        where = f"{path}:{k}"
        if f[0] == "FLASER":
            log.lasers.append(_flaser(f, where))
        elif f[0] == "ROBOTLASER1":
            log.lasers.append(_robotlaser(f, where))
        elif f[0] == "ODOM":
            if len(f) < 10:
                raise CarmenError(f"{where}: ODOM needs x y θ tv rv accel and 3 time fields")
            v = _floats(f[1:8], where)
            log.odometry.append(OdometryRecord(v[6], np.array(v[:3]), (v[3], v[4])))
        else:
            log.skipped[f[0]] = log.skipped.get(f[0], 0) + 1
    if not log.lasers:
        raise CarmenError(f"{path}: no FLASER or ROBOTLASER1 messages")
    return log


def laser_to_scan(record: LaserRecord, frame_id: str = "laser_link") -> msgs.LaserScan:
    """The record as a ``LaserScan`` stamped with its IPC timestamp.

    >>> r = LaserRecord(5.0, np.array([1.0, 81.91]), -0.1, 0.2, 81.9, np.zeros(3),
    ...                 np.zeros(3), 5.0, "FLASER")
    >>> s = laser_to_scan(r)
    >>> s.header.stamp.to_sec(), s.ranges.tolist()
    (5.0, [1.0, 81.91000366210938])
    """
    n = len(record.ranges)
    return msgs.LaserScan(
        header=msgs.Header(msgs.Time.from_sec(record.timestamp), frame_id),
        angle_min=record.angle_min,
        angle_max=record.angle_min + record.angle_increment * (n - 1),
        angle_increment=record.angle_increment, range_min=0.0, range_max=record.range_max,
        ranges=record.ranges.astype(np.float32))


@dataclass(frozen=True, eq=False)
class Relations:
    """Ground-truth relations: ``delta[k]`` is the pose at ``t2[k]`` seen from ``t1[k]``."""

    t1: FloatArray
    t2: FloatArray
    delta: FloatArray
    """(R, 3) as (x [m], y [m], θ [rad])."""

    def __len__(self) -> int:
        return len(self.t1)


def read_relations(path: str | Path) -> Relations:
    """Read a Kümmerle et al. relations file (``t1 t2 x y z roll pitch yaw`` per line)."""
    rows = []
    for k, line in enumerate(_lines(path), start=1):
        f = line.split()
        if not f or f[0].startswith("#"):
            continue
        if len(f) != 8:
            raise CarmenError(f"{path}:{k}: a relation has 8 fields (t1 t2 x y z roll pitch "
                              f"yaw); got {len(f)}")
        v = _floats(f, f"{path}:{k}")
        if not all(map(math.isfinite, v)):
            raise CarmenError(f"{path}:{k}: a relation must hold finite numbers")
        rows.append((v[0], v[1], v[2], v[3], v[7]))
    if not rows:
        raise CarmenError(f"{path}: no relations")
    a = np.array(rows)
    return Relations(a[:, 0], a[:, 1], a[:, 2:5])
