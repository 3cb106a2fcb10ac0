"""From a ``sensor_msgs/LaserScan`` to points: the geometry every think-half algorithm starts
from (localization, mapping, costmaps).

Conventions:

* Beam ``i`` points at ``angle_min + i * angle_increment`` [rad], counter-clockwise from the
  scanner's x axis, in the scan's ``header.frame_id`` (``laser_link`` on the kit's robots).
* REP-117: a range of ``+inf`` means nothing was hit within ``range_max`` (free space along
  the whole beam), ``-inf`` means an object closer than ``range_min``, ``NaN`` an invalid
  measurement. Finite ranges outside ``[range_min, range_max]`` are invalid too. Only valid
  returns become points; the masks below say which beams those are.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs

__all__ = ["beam_angles", "max_range_beams", "scan_to_points", "valid_returns"]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


def beam_angles(scan: msgs.LaserScan) -> FloatArray:
    """The angle of every beam [rad] in the scan's frame, shape ``(N,)``."""
    return scan.angles()


def valid_returns(scan: msgs.LaserScan) -> BoolArray:
    """``True`` for beams that hit something: finite and within ``[range_min, range_max]``.

    >>> s = msgs.LaserScan(angle_increment=0.1, range_min=0.2, range_max=5.0,
    ...                    ranges=np.array([1.0, np.inf, -np.inf, np.nan, 0.1, 6.0]))
    >>> valid_returns(s).tolist()
    [True, False, False, False, False, False]
    """
    r = np.asarray(scan.ranges, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return np.isfinite(r) & (r >= scan.range_min) & (r <= scan.range_max)


def max_range_beams(scan: msgs.LaserScan) -> BoolArray:
    """``True`` for beams that saw nothing up to ``range_max`` (REP-117 ``+inf``, or a finite
    reading beyond ``range_max`` as older drivers report it): free space, no obstacle.

    >>> s = msgs.LaserScan(angle_increment=0.1, range_min=0.2, range_max=5.0,
    ...                    ranges=np.array([1.0, np.inf, -np.inf, np.nan, 6.0]))
    >>> max_range_beams(s).tolist()
    [False, True, False, False, True]
    """
    r = np.asarray(scan.ranges, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return np.isposinf(r) | (np.isfinite(r) & (r > scan.range_max))


def scan_to_points(scan: msgs.LaserScan, pose: ArrayLike | None = None) -> FloatArray:
    """The valid returns of ``scan`` as points, shape ``(M, 2)`` [m].

    Parameters
    ----------
    scan
        The scan; only :func:`valid_returns` become points, in beam order.
    pose
        ``(x, y, theta)`` of the scanner's frame in a target frame (for instance
        ``T_base_laser`` from the robot's URDF, or ``T_map_laser``). ``None`` keeps the points
        in the scan's own frame.

    >>> s = msgs.LaserScan(angle_min=0.0, angle_increment=np.pi / 2, range_min=0.1,
    ...                    range_max=10.0, ranges=np.array([1.0, 2.0, np.inf]))
    >>> scan_to_points(s).round(6).tolist()  # angle_increment is float32, as in ROS
    [[1.0, 0.0], [-0.0, 2.0]]
    >>> scan_to_points(s, pose=[1.0, 0.0, np.pi]).round(6).tolist()
    [[0.0, 0.0], [1.0, -2.0]]
    """
    valid = valid_returns(scan)
    r = np.asarray(scan.ranges, dtype=np.float64)[valid]
    a = beam_angles(scan)[valid]
    points = np.column_stack([r * np.cos(a), r * np.sin(a)])
    if pose is None:
        return points
    return geometry.transform_points(geometry.check_pose(pose), points)
