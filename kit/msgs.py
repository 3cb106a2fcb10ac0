"""ROS 2 messages as frozen dataclasses.

Class names, field names, field order and nesting mirror the ROS 2 (Humble) definitions
exactly, so code written against the kit reads like ``rclpy`` code and converts to real ROS
messages field by field (see :mod:`kit.rosconv`; a test round-trips every class through the
``rosbags`` type store and its CDR serialiser).

Differences from ``rclpy`` messages, all deliberate:

* messages are immutable (``frozen=True``), and so are their arrays (read-only numpy arrays
  with the ROS element type: ``LaserScan.ranges`` is float32, ``OccupancyGrid.data`` int8);
* sequences of messages are tuples; ``Time`` carries helpers to and from float seconds.

Equality compares arrays element-wise (NaN equals NaN), so two scans read from the same bag
compare equal.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "MESSAGE_TYPES",
    "Clock",
    "Header",
    "Imu",
    "JointState",
    "LaserScan",
    "MapMetaData",
    "Message",
    "OccupancyGrid",
    "Odometry",
    "Path",
    "Point",
    "Pose",
    "PoseArray",
    "PoseStamped",
    "PoseWithCovariance",
    "PoseWithCovarianceStamped",
    "Quaternion",
    "String",
    "TFMessage",
    "Time",
    "Transform",
    "TransformStamped",
    "Twist",
    "TwistWithCovariance",
    "Vector3",
]


def _frozen_array(value: ArrayLike, dtype: Any, shape: tuple[int, ...] | None,
                  name: str) -> NDArray[Any]:
    if (isinstance(value, np.ndarray) and not value.flags.writeable and value.dtype == dtype
            and value.base is None and (value.shape == shape or (shape is None and
                                                                 value.ndim == 1))):
        return value  # already a read-only array of its own: sharing it is safe
    a = np.array(value, dtype=dtype, copy=True)
    if a.ndim == 0:
        raise ValueError(f"{name} must be a sequence, got the scalar {value!r}")
    if shape is not None and a.shape != shape:
        raise ValueError(f"{name} must have shape {shape}; got shape {a.shape}")
    if shape is None and a.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional; got shape {a.shape}")
    a.flags.writeable = False
    return a


_M = TypeVar("_M", bound="Message")
_TRUSTED: dict[type, Any] = {}


def _trusted_builder(cls: type) -> Any:
    """A function taking the fields of ``cls`` in order and filling a new instance's
    ``__dict__`` directly (generated once per class, as dataclasses generate ``__init__``)."""
    names = [f.name for f in dataclasses.fields(cls)]
    args = ", ".join(f"v{i}" for i in range(len(names)))
    body = "; ".join(f"d[{name!r}] = v{i}" for i, name in enumerate(names))
    source = f"def build({args}):\n    m = new(cls)\n    d = m.__dict__\n    {body}\n    return m\n"
    namespace: dict[str, Any] = {"new": object.__new__, "cls": cls}
    exec(source, namespace)  # code built from the dataclass's own field names only
    return namespace["build"]


class Message:
    """Base of all kit messages: ROS type name, array-aware equality."""

    ROS_TYPE: ClassVar[str] = ""
    # field name -> (numpy dtype, fixed shape or None for a variable-length sequence)
    ARRAYS: ClassVar[dict[str, tuple[Any, tuple[int, ...] | None]]] = {}
    # scalar fields that ROS stores as float32: rounded to float32 precision on construction,
    # so that a message equals itself after a trip through a bag
    FLOAT32: ClassVar[tuple[str, ...]] = ()

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            a, b = getattr(self, f.name), getattr(other, f.name)
            if isinstance(a, np.ndarray):
                if a.dtype != b.dtype or not np.array_equal(a, b, equal_nan=a.dtype.kind == "f"):
                    return False
            elif a != b:
                return False
        return True

    __hash__ = None  # type: ignore[assignment]

    @classmethod
    def trusted_builder(cls: type[_M]) -> Callable[..., _M]:
        """The function behind :meth:`trusted` (for a loop building thousands of messages):
        it takes exactly the fields' values, in order, and checks nothing."""
        try:
            return _TRUSTED[cls]
        except KeyError:
            build = _TRUSTED[cls] = _trusted_builder(cls)
            return build

    @classmethod
    def trusted(cls: type[_M], *values: Any) -> _M:
        """Build a message from field values in declaration order, skipping the checks and
        normalisation of ``__init__``.

        Only for producers that already hold normal values — read-only arrays of the right
        dtype and shape, float32-rounded floats, nanoseconds in range — at sensor rates (the
        simulator). Anything else must use the constructor.
        """
        try:
            return cls.trusted_builder()(*values)
        except TypeError:
            n = len(dataclasses.fields(cls))  # type: ignore[arg-type]
            raise TypeError(f"{cls.__name__}.trusted takes {n} values; got {len(values)}") \
                from None


class _Normalised(Message):
    """A message with arrays or float32 fields, normalised on construction. (Messages without
    them skip ``__post_init__`` altogether: they are built at sensor rates.)"""

    def __post_init__(self) -> None:
        for name in self.FLOAT32:
            object.__setattr__(self, name, float(np.float32(getattr(self, name))))
        for name, (dtype, shape) in self.ARRAYS.items():
            object.__setattr__(
                self, name, _frozen_array(getattr(self, name), dtype, shape,
                                          f"{type(self).__name__}.{name}"))


# ---------------------------------------------------------------- builtin_interfaces, std_msgs

@dataclass(frozen=True, eq=False)
class Time(Message):
    """builtin_interfaces/Time: seconds and nanoseconds since the epoch (or sim start)."""

    ROS_TYPE: ClassVar[str] = "builtin_interfaces/msg/Time"
    sec: int = 0
    nanosec: int = 0

    def __post_init__(self) -> None:
        if not 0 <= int(self.nanosec) < 1_000_000_000:
            raise ValueError(f"Time.nanosec must be in [0, 1e9); got {self.nanosec}")
        object.__setattr__(self, "sec", int(self.sec))
        object.__setattr__(self, "nanosec", int(self.nanosec))

    @classmethod
    def from_sec(cls, seconds: float) -> Time:
        """Time from float seconds, rounded to the nearest nanosecond."""
        if not math.isfinite(seconds):
            raise ValueError(f"Time.from_sec needs a finite number of seconds; got {seconds}")
        total = round(seconds * 1e9)
        return cls(sec=total // 1_000_000_000, nanosec=total % 1_000_000_000)

    def to_sec(self) -> float:
        return self.sec + self.nanosec * 1e-9

    def to_nsec(self) -> int:
        return self.sec * 1_000_000_000 + self.nanosec


@dataclass(frozen=True, eq=False)
class Header(Message):
    """std_msgs/Header."""

    ROS_TYPE: ClassVar[str] = "std_msgs/msg/Header"
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass(frozen=True, eq=False)
class String(Message):
    """std_msgs/String: one text (``/robot_description``'s URDF)."""

    ROS_TYPE: ClassVar[str] = "std_msgs/msg/String"
    data: str = ""


@dataclass(frozen=True, eq=False)
class Clock(Message):
    """rosgraph_msgs/Clock: the simulation's time on ``/clock`` (nodes with ``use_sim_time``
    follow it instead of the wall clock)."""

    ROS_TYPE: ClassVar[str] = "rosgraph_msgs/msg/Clock"
    clock: Time = field(default_factory=Time)


# ---------------------------------------------------------------- geometry_msgs

@dataclass(frozen=True, eq=False)
class Vector3(Message):
    ROS_TYPE: ClassVar[str] = "geometry_msgs/msg/Vector3"
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


@dataclass(frozen=True, eq=False)
class Point(Message):
    ROS_TYPE: ClassVar[str] = "geometry_msgs/msg/Point"
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


@dataclass(frozen=True, eq=False)
class Quaternion(Message):
    """geometry_msgs/Quaternion in ROS order (x, y, z, w); the default is the identity."""

    ROS_TYPE: ClassVar[str] = "geometry_msgs/msg/Quaternion"
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0


@dataclass(frozen=True, eq=False)
class Pose(Message):
    ROS_TYPE: ClassVar[str] = "geometry_msgs/msg/Pose"
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass(frozen=True, eq=False)
class PoseWithCovariance(_Normalised):
    """Pose with a row-major 6×6 covariance over (x, y, z, rot x, rot y, rot z)."""

    ROS_TYPE: ClassVar[str] = "geometry_msgs/msg/PoseWithCovariance"
    ARRAYS: ClassVar[dict[str, tuple[Any, tuple[int, ...] | None]]] = {
        "covariance": (np.float64, (36,))}
    pose: Pose = field(default_factory=Pose)
    covariance: NDArray[np.float64] = field(default_factory=lambda: np.zeros(36))


@dataclass(frozen=True, eq=False)
class PoseWithCovarianceStamped(Message):
    """A pose estimate with its covariance in ``header.frame_id`` (AMCL's ``/amcl_pose``)."""

    ROS_TYPE: ClassVar[str] = "geometry_msgs/msg/PoseWithCovarianceStamped"
    header: Header = field(default_factory=Header)
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)


@dataclass(frozen=True, eq=False)
class PoseArray(Message):
    """Poses in ``header.frame_id`` without weights (a particle cloud, as ROS 1's ``amcl``
    publishes it on ``/particlecloud``)."""

    ROS_TYPE: ClassVar[str] = "geometry_msgs/msg/PoseArray"
    header: Header = field(default_factory=Header)
    poses: tuple[Pose, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "poses", tuple(self.poses))


@dataclass(frozen=True, eq=False)
class PoseStamped(Message):
    ROS_TYPE: ClassVar[str] = "geometry_msgs/msg/PoseStamped"
    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)


@dataclass(frozen=True, eq=False)
class Twist(Message):
    """Velocity in free space: ``linear`` [m/s] and ``angular`` [rad/s], in the child frame."""

    ROS_TYPE: ClassVar[str] = "geometry_msgs/msg/Twist"
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass(frozen=True, eq=False)
class TwistWithCovariance(_Normalised):
    ROS_TYPE: ClassVar[str] = "geometry_msgs/msg/TwistWithCovariance"
    ARRAYS: ClassVar[dict[str, tuple[Any, tuple[int, ...] | None]]] = {
        "covariance": (np.float64, (36,))}
    twist: Twist = field(default_factory=Twist)
    covariance: NDArray[np.float64] = field(default_factory=lambda: np.zeros(36))


@dataclass(frozen=True, eq=False)
class Transform(Message):
    ROS_TYPE: ClassVar[str] = "geometry_msgs/msg/Transform"
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass(frozen=True, eq=False)
class TransformStamped(Message):
    """The transform from ``header.frame_id`` (parent) to ``child_frame_id``."""

    ROS_TYPE: ClassVar[str] = "geometry_msgs/msg/TransformStamped"
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


# ---------------------------------------------------------------- nav_msgs

@dataclass(frozen=True, eq=False)
class Odometry(Message):
    """Pose in ``header.frame_id`` (``odom``), twist in ``child_frame_id`` (``base_link``)."""

    ROS_TYPE: ClassVar[str] = "nav_msgs/msg/Odometry"
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@dataclass(frozen=True, eq=False)
class Path(Message):
    ROS_TYPE: ClassVar[str] = "nav_msgs/msg/Path"
    header: Header = field(default_factory=Header)
    poses: tuple[PoseStamped, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "poses", tuple(self.poses))


@dataclass(frozen=True, eq=False)
class MapMetaData(_Normalised):
    """Resolution [m/cell] and size of a grid whose cell (0, 0) corner sits at ``origin``."""

    ROS_TYPE: ClassVar[str] = "nav_msgs/msg/MapMetaData"
    FLOAT32: ClassVar[tuple[str, ...]] = ("resolution",)
    map_load_time: Time = field(default_factory=Time)
    resolution: float = 0.0
    width: int = 0
    height: int = 0
    origin: Pose = field(default_factory=Pose)


@dataclass(frozen=True, eq=False)
class OccupancyGrid(_Normalised):
    """Row-major occupancy in percent (0 free … 100 occupied, −1 unknown), row 0 at the origin."""

    ROS_TYPE: ClassVar[str] = "nav_msgs/msg/OccupancyGrid"
    ARRAYS: ClassVar[dict[str, tuple[Any, tuple[int, ...] | None]]] = {"data": (np.int8, None)}
    header: Header = field(default_factory=Header)
    info: MapMetaData = field(default_factory=MapMetaData)
    data: NDArray[np.int8] = field(default_factory=lambda: np.zeros(0, np.int8))

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.data.size != self.info.width * self.info.height:
            raise ValueError(
                f"OccupancyGrid.data has {self.data.size} cells but info says "
                f"{self.info.width} x {self.info.height} = {self.info.width * self.info.height}")


# ---------------------------------------------------------------- sensor_msgs

@dataclass(frozen=True, eq=False)
class LaserScan(_Normalised):
    """One planar scan; beam ``i`` points at ``angle_min + i * angle_increment`` (CCW from x)."""

    ROS_TYPE: ClassVar[str] = "sensor_msgs/msg/LaserScan"
    ARRAYS: ClassVar[dict[str, tuple[Any, tuple[int, ...] | None]]] = {
        "ranges": (np.float32, None), "intensities": (np.float32, None)}
    FLOAT32: ClassVar[tuple[str, ...]] = (
        "angle_min", "angle_max", "angle_increment", "time_increment", "scan_time",
        "range_min", "range_max")
    header: Header = field(default_factory=Header)
    angle_min: float = 0.0
    angle_max: float = 0.0
    angle_increment: float = 0.0
    time_increment: float = 0.0
    scan_time: float = 0.0
    range_min: float = 0.0
    range_max: float = 0.0
    ranges: NDArray[np.float32] = field(default_factory=lambda: np.zeros(0, np.float32))
    intensities: NDArray[np.float32] = field(default_factory=lambda: np.zeros(0, np.float32))

    def angles(self) -> NDArray[np.float64]:
        """Beam angles ``angle_min + i * angle_increment`` [rad], one per range."""
        return np.asarray(self.angle_min + self.angle_increment * np.arange(len(self.ranges)),
                          dtype=np.float64)


@dataclass(frozen=True, eq=False)
class Imu(_Normalised):
    """Orientation, angular velocity [rad/s] and linear acceleration [m/s²] with 3×3 covariances.

    A covariance whose first element is −1 means "this quantity is not provided" (ROS rule).
    """

    ROS_TYPE: ClassVar[str] = "sensor_msgs/msg/Imu"
    ARRAYS: ClassVar[dict[str, tuple[Any, tuple[int, ...] | None]]] = {
        "orientation_covariance": (np.float64, (9,)),
        "angular_velocity_covariance": (np.float64, (9,)),
        "linear_acceleration_covariance": (np.float64, (9,)),
    }
    header: Header = field(default_factory=Header)
    orientation: Quaternion = field(default_factory=Quaternion)
    orientation_covariance: NDArray[np.float64] = field(default_factory=lambda: np.zeros(9))
    angular_velocity: Vector3 = field(default_factory=Vector3)
    angular_velocity_covariance: NDArray[np.float64] = field(default_factory=lambda: np.zeros(9))
    linear_acceleration: Vector3 = field(default_factory=Vector3)
    linear_acceleration_covariance: NDArray[np.float64] = field(
        default_factory=lambda: np.zeros(9))


@dataclass(frozen=True, eq=False)
class JointState(_Normalised):
    """Joint positions [rad], velocities [rad/s] and efforts [N·m], matched by ``name``."""

    ROS_TYPE: ClassVar[str] = "sensor_msgs/msg/JointState"
    ARRAYS: ClassVar[dict[str, tuple[Any, tuple[int, ...] | None]]] = {
        "position": (np.float64, None), "velocity": (np.float64, None),
        "effort": (np.float64, None)}
    header: Header = field(default_factory=Header)
    name: tuple[str, ...] = ()
    position: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    velocity: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    effort: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        object.__setattr__(self, "name", tuple(self.name))
        super().__post_init__()


# ---------------------------------------------------------------- tf2_msgs

@dataclass(frozen=True, eq=False)
class TFMessage(Message):
    """The ``/tf`` and ``/tf_static`` payload: a batch of transforms."""

    ROS_TYPE: ClassVar[str] = "tf2_msgs/msg/TFMessage"
    transforms: tuple[TransformStamped, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "transforms", tuple(self.transforms))


MESSAGE_TYPES: dict[str, type[Message]] = {
    cls.ROS_TYPE: cls
    for cls in (Time, Header, String, Clock, Vector3, Point, Quaternion, Pose,
                PoseWithCovariance, PoseWithCovarianceStamped, PoseArray, PoseStamped,
                Twist, TwistWithCovariance, Transform, TransformStamped, Odometry, Path,
                MapMetaData, OccupancyGrid, LaserScan, Imu, JointState, TFMessage)
}
"""ROS type name (``"nav_msgs/msg/Odometry"``) → kit message class."""
