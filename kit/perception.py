"""From a ``sensor_msgs/LaserScan`` to points: the geometry every think-half algorithm starts
from (localization, mapping, costmaps); filters in the manner of ROS's ``laser_filters``;
Eddie's Kinect depth image turned into a scan the way ``depthimage_to_laserscan`` does; and
what a glass wall does to a scan.

Conventions:

* Beam ``i`` points at ``angle_min + i * angle_increment`` [rad], counter-clockwise from the
  scanner's x axis, in the scan's ``header.frame_id`` (``laser_link`` on the kit's robots).
* REP-117: a range of ``+inf`` means nothing was hit within ``range_max`` (free space along
  the whole beam), ``-inf`` means an object closer than ``range_min``, ``NaN`` an invalid
  measurement. Finite ranges outside ``[range_min, range_max]`` are invalid too. Only valid
  returns become points; the masks below say which beams those are.
* Beam ``i`` is measured at ``header.stamp + i * time_increment`` (the stamp is the first
  beam's time, as ROS drivers publish it). A spinning lidar on a turning robot measures its
  beams from different poses; :func:`scan_to_points_tf` with a ``fixed_frame`` puts every
  beam where the scanner was at that beam's own time (de-skewing), as ``laser_geometry``'s
  high-fidelity projection does.
* Transforms are named ``T_target_source``: the pose of ``source`` in ``target``, mapping
  ``source`` coordinates into ``target`` (:mod:`kit.tf`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs
from kit.tf import TransformTree

__all__ = [
    "angular_bounds_filter",
    "angular_bounds_filter_in_place",
    "beam_angles",
    "beam_times",
    "beam_to_point",
    "box_filter",
    "depth_column_angle",
    "depth_image_to_scan",
    "depth_to_range",
    "deskew_beam",
    "max_range_beams",
    "range_filter",
    "returns_beyond",
    "reverse_beam_order",
    "scan_to_points",
    "scan_to_points_tf",
    "valid_returns",
]

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


# ---------------------------------------------------------------- one beam, through frames

def beam_to_point(r: float, angle: float, pose: ArrayLike | None = None) -> FloatArray:
    """One beam of range ``r`` [m] at ``angle`` [rad] as a point ``(x, y)`` [m].

    .. math:: p = T \\cdot (r\\cos α,\\; r\\sin α)

    ``pose`` is ``T_target_laser = (x, y, θ)``, the scanner's pose in the target frame
    (``None``: the scanner's own frame).

    >>> beam_to_point(2.0, np.pi / 2).round(6).tolist()
    [0.0, 2.0]
    >>> beam_to_point(2.0, np.pi / 2, pose=[0.1, 0.0, np.pi / 2]).round(6).tolist()
    [-1.9, 0.0]
    """
    if not (math.isfinite(r) and math.isfinite(angle)):
        raise ValueError(f"a beam to a point needs a finite range and angle; got r={r}, "
                         f"angle={angle}")
    local = np.array([r * math.cos(angle), r * math.sin(angle)])
    if pose is None:
        return local
    return geometry.transform_points(geometry.check_pose(pose), local[None, :])[0]


def beam_times(scan: msgs.LaserScan) -> FloatArray:
    """When each beam was measured [s]: ``header.stamp + i * time_increment``, shape (N,)."""
    return scan.header.stamp.to_sec() + scan.time_increment * np.arange(len(scan.ranges),
                                                                        dtype=np.float64)


def deskew_beam(r: float, angle: float, laser_at_beam: ArrayLike,
                laser_at_reference: ArrayLike) -> FloatArray:
    """Where one beam's point lies in the scanner's frame *at the reference time*.

    The beam was measured when the scanner stood at ``laser_at_beam`` = ``T_fixed_laser(tᵢ)``;
    seen from where the scanner stands at the reference time, ``T_fixed_laser(t_ref)``, the
    same point is

    .. math:: p_{ref} = T_{fixed,laser}(t_{ref})^{-1}\\; T_{fixed,laser}(t_i)\\;
              (r\\cos α, r\\sin α)

    Both poses are ``(x, y, θ)`` in one fixed frame (``odom``), e.g. from the odometry.

    >>> # the scanner turned by +0.1 rad between the reference time and the beam
    >>> deskew_beam(1.0, 0.0, [0.0, 0.0, 0.1], [0.0, 0.0, 0.0]).round(6).tolist()
    [0.995004, 0.099833]
    """
    point = beam_to_point(r, angle, laser_at_beam)
    return geometry.transform_points(geometry.inverse(geometry.check_pose(laser_at_reference)),
                                     point[None, :])[0]


def _matrices(tree: TransformTree, target: str, source: str,
              times: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Rotation matrices (K, 3, 3) and translations (K, 3) of ``T_target_source`` at times."""
    rotations = np.empty((len(times), 3, 3))
    translations = np.empty((len(times), 3))
    identity = np.eye(3)
    for k, t in enumerate(times):
        tr = tree.lookup_transform(target, source, float(t))
        rotations[k] = geometry.quaternion_rotate(tr.rotation[None, :], identity).T
        translations[k] = tr.translation
    return rotations, translations


DESKEW_STEP = 0.005
"""s: the spacing of the transform look-ups a scan is de-skewed with; each beam's pose is
interpolated between the two nearest look-ups (a point moves by at most ``r ω² Δt² / 8`` off
the true arc: 0.1 mm at 10 m and 2 rad/s)."""


def scan_to_points_tf(scan: msgs.LaserScan, tree: TransformTree, target_frame: str,
                      fixed_frame: str | None = None, reference_time: float | None = None,
                      all_beams: bool = False) -> FloatArray:
    """The valid returns of ``scan`` as points in ``target_frame``, shape (M, 2) [m]
    (``all_beams``: one row per beam, shape (N, 2), NaN for beams that are not valid
    returns).

    Without ``fixed_frame`` every beam goes through one transform, ``T_target_laser`` at the
    scan's stamp: right for a robot standing still. With ``fixed_frame`` (``"odom"``) each
    beam is first placed in the fixed frame where the scanner was at that beam's own time
    (:func:`beam_times`), then taken into ``target_frame`` as it was at ``reference_time``
    (default: the stamp) — tf2's "time travel" lookup, which de-skews a scan taken while
    moving. With ``target_frame == fixed_frame`` this is ``laser_geometry``'s high-fidelity
    projection.

    Parameters
    ----------
    scan
        The scan, in ``scan.header.frame_id``; its beams' z = 0 plane is taken through the
        full 3-D transforms (a scanner mounted upside down works), and z is dropped.
    tree
        Holds the transforms (static mountings and the odometry).
    target_frame, fixed_frame
        Frame names in ``tree``.
    reference_time
        Seconds; the time at which ``target_frame`` is taken.

    Raises
    ------
    kit.tf.TransformError
        A frame the tree does not know, or beam times outside its buffered odometry.
    """
    valid = valid_returns(scan)
    if all_beams:
        out = np.full((len(valid), 2), np.nan)
        out[valid] = scan_to_points_tf(scan, tree, target_frame, fixed_frame, reference_time)
        return out
    r = np.asarray(scan.ranges, dtype=np.float64)[valid]
    a = beam_angles(scan)[valid]
    local = np.column_stack([r * np.cos(a), r * np.sin(a), np.zeros_like(r)])
    stamp = scan.header.stamp.to_sec()
    t_ref = stamp if reference_time is None else float(reference_time)
    laser = scan.header.frame_id
    if fixed_frame is None or len(r) == 0 or scan.time_increment == 0.0:
        T = tree.lookup_transform(target_frame, laser, stamp if fixed_frame is None else t_ref)
        if fixed_frame is not None:  # no spread in time: still honour the reference time
            T = tree.lookup_transform(target_frame, fixed_frame, t_ref) @ \
                tree.lookup_transform(fixed_frame, laser, stamp)
        return T.apply(local)[:, :2]
    times = beam_times(scan)[valid]
    first, last = float(times[0]), float(times[-1])
    knots = np.linspace(first, last, max(2, math.ceil((last - first) / DESKEW_STEP) + 1),
                        dtype=np.float64)
    R, t = _matrices(tree, fixed_frame, laser, knots)
    k = np.clip(np.searchsorted(knots, times, side="right") - 1, 0, len(knots) - 2)
    f = ((times - knots[k]) / (knots[k + 1] - knots[k]))[:, None]
    # the point as each neighbouring look-up places it, blended by time
    p0 = np.einsum("nij,nj->ni", R[k], local) + t[k]
    p1 = np.einsum("nij,nj->ni", R[k + 1], local) + t[k + 1]
    in_fixed = (1.0 - f) * p0 + f * p1
    return tree.lookup_transform(target_frame, fixed_frame, t_ref).apply(in_fixed)[:, :2]


def reverse_beam_order(scan: msgs.LaserScan, *, stamped_at_end: bool = False) -> msgs.LaserScan:
    """The same scan with its beams listed in the opposite order, so that index order is the
    order in which they were measured.

    ``rplidar_ros`` (the RPLidar's ROS driver, on the TurtleBot 4 and the Uiabot) publishes
    the beams counter-clockwise, from ``angle_min`` to ``angle_max``, while the device spins
    clockwise: the last beam of its message was measured first. It also stamps the message
    when the driver hands the finished revolution over, not when the first beam was taken.
    De-skewing such a scan as published moves every beam the wrong way.

    The returned scan lists the beams from the old last to the old first, with ``angle_min``
    and ``angle_max`` swapped and a negative ``angle_increment``: every beam keeps its
    direction and range. With ``stamped_at_end`` the stamp moves back by
    ``(N - 1) * time_increment``, to the first measured beam, so that
    ``header.stamp + i * time_increment`` is when beam ``i`` was measured, as the message's
    convention says.
    """
    n = len(scan.ranges)
    reversed_: dict[str, object] = {
        "ranges": np.asarray(scan.ranges, dtype=np.float32)[::-1].copy()}
    if len(scan.intensities):
        reversed_["intensities"] = np.asarray(scan.intensities, dtype=np.float32)[::-1].copy()
    if stamped_at_end and n > 1:
        start = scan.header.stamp.to_nsec() - round(scan.time_increment * (n - 1) * 1e9)
        reversed_["header"] = dataclasses.replace(
            scan.header, stamp=msgs.Time(sec=start // 1_000_000_000,
                                         nanosec=start % 1_000_000_000))
    last = scan.angle_min + scan.angle_increment * (n - 1)
    return dataclasses.replace(scan, angle_min=float(last), angle_max=float(scan.angle_min),
                               angle_increment=-float(scan.angle_increment),
                               **reversed_)  # type: ignore[arg-type]


# ---------------------------------------------------------------- filters (laser_filters)

def _with_ranges(scan: msgs.LaserScan, ranges: ArrayLike, **changes: object) -> msgs.LaserScan:
    return dataclasses.replace(scan, ranges=np.asarray(ranges, dtype=np.float32),
                               **changes)  # type: ignore[arg-type]


def range_filter(scan: msgs.LaserScan, lower_threshold: float = 0.0,
                 upper_threshold: float = 100000.0, *,
                 lower_replacement: float = float("nan"),
                 upper_replacement: float = float("nan"),
                 use_message_range_limits: bool = False) -> msgs.LaserScan:
    """``laser_filters``' ``LaserScanRangeFilter``: a range ``<= lower_threshold`` becomes
    ``lower_replacement``, one ``>= upper_threshold`` becomes ``upper_replacement`` (both NaN
    by default, so ``+inf`` turns NaN too, as in ROS). ``use_message_range_limits`` takes the
    thresholds from the scan's ``range_min``/``range_max``.

    >>> s = msgs.LaserScan(angle_increment=0.1, range_max=10.0,
    ...                    ranges=np.array([0.05, 1.0, 20.0, np.inf]))
    >>> range_filter(s, 0.1, 8.0).ranges.tolist()
    [nan, 1.0, nan, nan]
    """
    if use_message_range_limits:
        lower_threshold, upper_threshold = scan.range_min, scan.range_max
    if not lower_threshold <= upper_threshold:
        raise ValueError(f"range_filter needs lower_threshold <= upper_threshold [m]; got "
                         f"{lower_threshold} > {upper_threshold}")
    r = np.array(scan.ranges, dtype=np.float32)
    with np.errstate(invalid="ignore"):
        low = r <= lower_threshold
        high = ~low & (r >= upper_threshold)
    r[low] = lower_replacement
    r[high] = upper_replacement
    return _with_ranges(scan, r)


def _check_bounds(lower_angle: float, upper_angle: float) -> None:
    if not (math.isfinite(lower_angle) and math.isfinite(upper_angle)
            and lower_angle <= upper_angle):
        raise ValueError(f"angular bounds are lower_angle <= upper_angle in radians; got "
                         f"{lower_angle}, {upper_angle}")


def angular_bounds_filter(scan: msgs.LaserScan, lower_angle: float,
                          upper_angle: float) -> msgs.LaserScan:
    """``laser_filters``' ``LaserScanAngularBoundsFilter``: keep only the beams with
    ``lower_angle <= angle <= upper_angle`` [rad]; the scan is cut, so ``angle_min``,
    ``angle_max`` and the stamp (moved by the dropped beams' time) change with it.

    >>> s = msgs.LaserScan(angle_min=-1.0, angle_increment=0.5, range_max=5.0,
    ...                    ranges=np.arange(5.0))
    >>> cut = angular_bounds_filter(s, -0.6, 0.6)
    >>> cut.ranges.tolist(), cut.angle_min, cut.angle_max
    ([1.0, 2.0, 3.0], -0.5, 0.5)
    """
    _check_bounds(lower_angle, upper_angle)
    a = beam_angles(scan)
    keep = np.flatnonzero((a >= lower_angle) & (a <= upper_angle))
    if len(keep) == 0:
        raise ValueError(f"no beam of the scan ({a[0]:.4f} .. {a[-1]:.4f} rad) lies within "
                         f"[{lower_angle}, {upper_angle}] rad")
    first, last = int(keep[0]), int(keep[-1])
    intensities = scan.intensities[first:last + 1] if len(scan.intensities) > last else \
        scan.intensities
    nanoseconds = scan.header.stamp.to_nsec() + round(first * scan.time_increment * 1e9)
    stamp = msgs.Time(nanoseconds // 1_000_000_000, nanoseconds % 1_000_000_000)
    return dataclasses.replace(
        scan, header=msgs.Header(stamp, scan.header.frame_id),
        angle_min=float(a[first]), angle_max=float(a[last]),
        ranges=scan.ranges[first:last + 1], intensities=intensities)


def angular_bounds_filter_in_place(scan: msgs.LaserScan, lower_angle: float,
                                   upper_angle: float) -> msgs.LaserScan:
    """``laser_filters``' ``LaserScanAngularBoundsFilterInPlace``: beams strictly *inside*
    ``(lower_angle, upper_angle)`` get ``range_max + 1`` (out of range, so ignored) and the
    scan keeps its length — e.g. to blank the robot's own mast.

    >>> s = msgs.LaserScan(angle_min=-1.0, angle_increment=0.5, range_max=5.0,
    ...                    ranges=np.ones(5))
    >>> angular_bounds_filter_in_place(s, -0.6, 0.6).ranges.tolist()
    [1.0, 6.0, 6.0, 6.0, 1.0]
    """
    _check_bounds(lower_angle, upper_angle)
    a = beam_angles(scan)
    r = np.array(scan.ranges, dtype=np.float32)
    r[(a > lower_angle) & (a < upper_angle)] = scan.range_max + 1.0
    return _with_ranges(scan, r)


def box_filter(scan: msgs.LaserScan, box: ArrayLike, T_box_laser: ArrayLike | None = None,
               invert: bool = False) -> msgs.LaserScan:
    """``laser_filters``' ``LaserScanBoxFilter`` in the plane: returns whose points fall
    inside ``box = (min_x, min_y, max_x, max_y)`` [m] of the box's frame become NaN
    (``invert``: those outside). ``T_box_laser`` is the scanner's pose ``(x, y, θ)`` in the
    box's frame (e.g. ``base_link``, to remove the robot's own footprint).

    >>> s = msgs.LaserScan(angle_min=0.0, angle_increment=np.pi / 2, range_max=5.0,
    ...                    ranges=np.array([0.1, 2.0, 0.15, 3.0]))
    >>> box_filter(s, (-0.2, -0.2, 0.2, 0.2)).ranges.tolist()
    [nan, 2.0, nan, 3.0]
    """
    b = np.asarray(box, dtype=np.float64)
    if b.shape != (4,) or not np.all(np.isfinite(b)) or b[0] > b[2] or b[1] > b[3]:
        raise ValueError(f"box must be (min_x, min_y, max_x, max_y) with min <= max [m]; "
                         f"got {box!r}")
    valid = valid_returns(scan)
    r = np.asarray(scan.ranges, dtype=np.float64)
    a = beam_angles(scan)
    points = np.column_stack([r * np.cos(a), r * np.sin(a)])
    if T_box_laser is not None:
        points = geometry.transform_points(geometry.check_pose(T_box_laser),
                                           np.where(valid[:, None], points, 0.0))
    with np.errstate(invalid="ignore"):
        inside = (points[:, 0] >= b[0]) & (points[:, 0] <= b[2]) & \
            (points[:, 1] >= b[1]) & (points[:, 1] <= b[3])
    remove = valid & (~inside if invert else inside)
    out = np.array(scan.ranges, dtype=np.float32)
    out[remove] = np.nan
    return _with_ranges(scan, out)


# ---------------------------------------------------------------- depth image → scan

def depth_column_angle(u: ArrayLike, fx: float, cx: float) -> FloatArray:
    """The bearing [rad] of image column ``u`` of a pinhole camera, counter-clockwise in the
    scan's frame: ``−atan((u − cx) / fx)`` (the image's u grows to the right, a scan's angle
    to the left).

    >>> float(depth_column_angle(0.0, 500.0, 320.0)) > 0   # the leftmost column looks left
    True
    """
    return -np.arctan2(np.asarray(u, dtype=np.float64) - cx, fx)


def depth_to_range(depth: ArrayLike, u: ArrayLike, fx: float, cx: float) -> FloatArray:
    """Range [m] along the floor plane to a pixel of column ``u`` at ``depth`` [m].

    A depth camera reports z (along the optical axis), not the distance along the ray: with
    the pinhole model the pixel lies at ``x = (u − cx) z / fx`` beside the axis, so
    ``r = hypot(x, z)``.

    >>> float(depth_to_range(2.0, 320.0, 500.0, 320.0))      # on the axis: r = z
    2.0
    >>> round(float(depth_to_range(2.0, 820.0, 500.0, 320.0)), 6)  # 45° off: r = z √2
    2.828427
    """
    z = np.asarray(depth, dtype=np.float64)
    return np.hypot((np.asarray(u, dtype=np.float64) - cx) * z / fx, z)


def _check_depth_image(depth: ArrayLike) -> NDArray[np.generic]:
    d = np.asarray(depth)
    if d.ndim != 2 or d.shape[0] < 1 or d.shape[1] < 2:
        raise ValueError(f"a depth image has shape (rows, columns) with at least 2 columns; "
                         f"got shape {d.shape}")
    if d.dtype not in (np.uint16, np.float32, np.float64):
        raise TypeError(f"depth images are uint16 (millimetres, 16UC1) or float (metres, "
                        f"32FC1); got dtype {d.dtype}")
    return d


def depth_image_to_scan(depth: ArrayLike, fx: float, cx: float, cy: float, *,
                        scan_height: int = 1, range_min: float = 0.45,
                        range_max: float = 10.0, scan_time: float = 1.0 / 30.0,
                        header: msgs.Header | None = None) -> msgs.LaserScan:
    """A band of a depth image's rows as a ``LaserScan``, by ``depthimage_to_laserscan``'s
    rule (pinhole model, no lens distortion).

    * The scan spans the image's columns: ``angle_max`` is the angle between the ray of
      column 0 and the optical axis, ``angle_min`` minus the one of the last column, and
      ``angle_increment = (angle_max − angle_min) / (width − 1)``; ``time_increment`` is 0
      (all columns are exposed at once).
    * The band is the ``scan_height`` rows from ``int(cy − scan_height // 2)``.
    * Each pixel's range is :func:`depth_to_range`; its beam index is
      ``int((−atan((u − cx)/fx) − angle_min) / angle_increment)``. Because the columns'
      angles are not evenly spaced (the atan), a few beams near the middle receive no column
      and stay NaN, and some near the edges receive two — exactly as in ROS.
    * Per beam the nearest finite range within ``[range_min, range_max]`` wins; with none,
      a ±inf reading wins over NaN; otherwise NaN.
    * ``uint16`` images are millimetres with 0 meaning "no reading"; float images are metres
      with NaN/inf meaning "no reading". The arithmetic follows the original's float32
      constants, so the indices agree with it pixel for pixel.

    Parameters
    ----------
    depth : array_like, shape (rows, columns)
        The depth image, uint16 [mm] or float [m].
    fx, cx, cy : float
        Focal length [pixels] and principal point [pixels] (``CameraInfo.K[0], K[2], K[5]``).
    scan_height : int
        Number of rows in the band.
    range_min, range_max : float
        [m] (the original's defaults 0.45 and 10).
    scan_time : float
        [s] between frames.
    header : msgs.Header, optional
        The scan's stamp and frame (the original copies the image's header).

    Raises
    ------
    ValueError
        A band taller than the image around ``cy``, a non-positive focal length, bad limits.
    TypeError
        An image that is neither uint16 nor float.
    """
    d = _check_depth_image(depth)
    rows, width = d.shape
    _check_depth_band(rows, fx, cx, cy, scan_height, range_min, range_max)
    millimetres = d.dtype == np.uint16
    unit = float(np.float32(0.001)) if millimetres else 1.0     # toMeters(1)
    cx32, constant_x = np.float32(cx), np.float32(unit / fx)
    angle_max = np.float32(math.atan2(float(cx32), fx))          # left ray vs the axis
    angle_min = np.float32(-math.atan2(width - 1 - float(cx32), fx))
    increment = np.float32((angle_max - angle_min) / np.float32(width - 1))
    du = np.arange(width, dtype=np.float32) - cx32               # float, as in the original
    theta = -np.arctan2(du.astype(np.float64) * float(constant_x), unit)
    index = np.clip(np.trunc((theta - float(angle_min)) / float(increment)).astype(np.int64),
                    0, width - 1)
    first_row = int(float(np.float32(cy)) - scan_height // 2)
    band = d[first_row:first_row + scan_height]
    if millimetres:
        z = band.astype(np.float32) * np.float32(0.001)
        r = np.hypot((du * band.astype(np.float32) * constant_x).astype(np.float64), z)
        r[band == 0] = 0.0                                       # passes through as 0
    else:
        z = band.astype(np.float64)
        with np.errstate(invalid="ignore"):
            x = (du * band.astype(np.float32) * constant_x).astype(np.float64)
            r = np.where(np.isfinite(z), np.hypot(x, z), z)      # NaN and ±inf pass through
    ranges = _nearest_per_beam(r.astype(np.float32).ravel(), np.tile(index, len(band)), width,
                               range_min, range_max)
    return msgs.LaserScan(
        header=header or msgs.Header(), angle_min=float(angle_min), angle_max=float(angle_max),
        angle_increment=float(increment), time_increment=0.0, scan_time=scan_time,
        range_min=range_min, range_max=range_max, ranges=ranges)


def _check_depth_band(rows: int, fx: float, cx: float, cy: float, scan_height: int,
                      range_min: float, range_max: float) -> None:
    """:func:`depth_image_to_scan`'s argument checks (ValueError naming what is wrong)."""
    if not (math.isfinite(fx) and fx > 0 and math.isfinite(cx) and math.isfinite(cy)):
        raise ValueError(f"the pinhole model needs fx > 0 and finite cx, cy [pixels]; got "
                         f"fx={fx}, cx={cx}, cy={cy}")
    if not 0.0 <= range_min < range_max:
        raise ValueError(f"need 0 <= range_min < range_max [m]; got {range_min}, {range_max}")
    if not (isinstance(scan_height, (int, np.integer)) and scan_height >= 1):
        raise ValueError(f"scan_height is a number of rows >= 1; got {scan_height!r}")
    if scan_height // 2 > cy or scan_height // 2 > rows - cy:
        raise ValueError(f"scan_height ({scan_height} rows) is too large for an image of "
                         f"{rows} rows around cy = {cy}")


def _nearest_per_beam(r32: NDArray[np.float32], beam: NDArray[np.int64], width: int,
                      range_min: float, range_max: float) -> NDArray[np.float32]:
    """Per beam the nearest range [m] within the limits; with none, the last ±inf in pixel
    order; otherwise NaN (``depthimage_to_laserscan``'s rule)."""
    ranges = np.full(width, np.inf, dtype=np.float32)
    with np.errstate(invalid="ignore"):
        usable = np.isfinite(r32) & (r32 >= np.float32(range_min)) & \
            (r32 <= np.float32(range_max))
    np.minimum.at(ranges, beam[usable], r32[usable])
    have = np.zeros(width, dtype=bool)
    have[beam[usable]] = True
    infinite = np.flatnonzero(np.isinf(r32))
    fallback = np.full(width, np.nan, dtype=np.float32)
    fallback[beam[infinite]] = r32[infinite]  # later pixels overwrite earlier ones
    return np.where(have, ranges, fallback)


# ---------------------------------------------------------------- glass

def returns_beyond(scan: msgs.LaserScan, expected_ranges: ArrayLike,
                   margin: float = 0.1) -> BoolArray:
    """``True`` for valid returns that lie more than ``margin`` [m] *beyond* the range a map
    predicts for the same beam (``expected_ranges``, shape (N,), ``inf`` where the map has
    nothing within reach).

    A lidar's light passes through glass: where the building's map has a glass wall, the
    scanner reports the furniture or the wall behind it. Those beams are the ones this
    returns: a localizer that trusts them sees the robot closer to the glass than it is, and
    a costmap that clears along them opens a wall a robot would drive into.

    >>> s = msgs.LaserScan(angle_increment=0.1, range_min=0.1, range_max=10.0,
    ...                    ranges=np.array([2.0, 4.5, np.inf]))
    >>> returns_beyond(s, [2.0, 3.0, 3.0]).tolist()
    [False, True, False]
    """
    expected = np.asarray(expected_ranges, dtype=np.float64)
    if expected.shape != (len(scan.ranges),):
        raise ValueError(f"expected_ranges must have one range per beam, shape "
                         f"({len(scan.ranges)},); got shape {expected.shape}")
    if not margin >= 0:
        raise ValueError(f"margin must be a non-negative distance [m]; got {margin}")
    r = np.asarray(scan.ranges, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return valid_returns(scan) & (r > expected + margin)
