"""Robot descriptions: a URDF (or xacro) plus parameters, loaded into one frozen object.

Three ways to describe a robot, all through :func:`load`:

* a shipped robot by name — ``load("uiabot")`` reads ``hardware/robots/uiabot.toml`` and the
  URDF it names (package data);
* a kit parameter file — ``load("path/to/robot.toml")``: a TOML file whose ``urdf = "…"``
  names its URDF (or xacro file: ``[xacro] args`` and ``[xacro] packages`` give its arguments
  and package folders), and which gives what a URDF cannot say: gearing, encoders, limits,
  sensor models. Its wheel joints are the ones ``[wheels] right_joint`` and ``left_joint``
  name (by default ``right_wheel_joint`` and ``left_wheel_joint``);
* any robot's own description — ``load("turtlebot3_burger.urdf")``, a ``.urdf.xacro`` (with
  ``xacro_args``), or a bag that recorded ``/robot_description`` (a rosbag2 folder, ``.mcap``,
  ``.db3`` or ROS 1 ``.bag``). The wheels are found by structure
  (:mod:`kit.robot_structure`), the outline from the collision shapes, the lidar and IMU from
  the Gazebo sensors or the links' names (a bag's own ``LaserScan`` gives its lidar's model);
  what a URDF does not hold comes from an optional parameter file (``parameters=``, the same
  TOML keys) or a stated default (:data:`DEFAULTS`). ``description.found`` and
  ``description.assumed`` say which is which (``kit robot FILE`` prints them).

In every case the geometry comes from the URDF, composed from its root: the wheel radius from
the wheels' collision shapes, the separation from the wheel joints' composed origins.
"""

from __future__ import annotations

import importlib.util
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from kit import msgs
from kit.tf import RigidTransform, TransformError, TransformTree
from kit.urdf import Joint, Link, RobotDescriptionError, Shape

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

__all__ = ["DEFAULTS", "ROBOTS", "Joint", "Link", "RobotDescription", "RobotDescriptionError",
           "Shape", "load"]

ROBOTS = ("uiabot", "igv", "eddie")
"""The robots shipped with the kit."""

URDF_SUFFIXES = (".urdf", ".xacro")
BAG_SUFFIXES = (".bag", ".mcap", ".db3")

DEFAULTS: Mapping[str, Mapping[str, Any]] = MappingProxyType({
    "drive": MappingProxyType({
        # Nav2's stock parameters (nav2_bringup's nav2_params.yaml, controller_server
        # FollowPath, DWB): max_vel_x, max_vel_theta, acc_lim_x
        "max_linear_velocity": 0.26,
        "max_angular_velocity": 1.0,
        "max_linear_acceleration": 2.5,
        # encoder counts taken at the wheel, a 12-bit (4096-count) encoder, as on the
        # TurtleBot 3's Dynamixel XL430 servos; a 32-bit counter
        "gear_ratio": 1.0,
        "encoder_resolution": 4096,
        "counter_bits": 32,
    }),
    "odometry": MappingProxyType({"k_right": 1.0e-4, "k_left": 1.0e-4}),
    # the kit's RPLidar A1 (the TurtleBot 4's and the Uiabot's lidar), standard scan
    "lidar": MappingProxyType({
        "model": "rplidar_a1", "scan_rate": 5.5, "angle_min": -math.pi, "angle_max": math.pi,
        "angle_increment": 2 * math.pi / 360, "range_min": 0.15, "range_max": 12.0,
        "range_noise_std": 0.01}),
    # the kit's assumptions for the Uiabot's BNO055
    "imu": MappingProxyType({
        "model": "imu", "rate": 100.0, "yaw_noise_std": 0.0035, "gyro_noise_std": 0.002,
        "gyro_bias_std": 0.0005, "accel_noise_std": 0.05}),
    "mass": MappingProxyType({"mass": 5.0}),
})
"""What a bare URDF robot gets where neither its URDF nor a parameter file says (every use is
listed in ``RobotDescription.assumed``)."""


@dataclass(frozen=True, eq=False)
class RobotDescription:
    """Everything the kit knows about one robot. SI units, REP-103/105 frames."""

    name: str
    description: str
    source: Path
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    wheel_radius: float
    """m, from the wheels' collision geometry."""
    wheel_separation: float
    """m, distance between the wheel contact points (twice the half-track b)."""
    gear_ratio: float
    """motor turns per wheel turn."""
    encoder_resolution: int
    """encoder counts per motor turn."""
    counter_bits: int
    """width of the encoder counter; it rolls over modulo 2**counter_bits."""
    max_wheel_speed: float
    """rad/s at the wheel."""
    max_linear_velocity: float
    max_angular_velocity: float
    max_linear_acceleration: float
    cruise_velocity: float
    """m/s the navigation stack drives at (Nav2's ``desired_linear_vel``): the ``[navigation]``
    section's ``cruise_velocity``, else ``max_linear_velocity``."""
    mass: float
    """kg, all links."""
    footprint: NDArray[np.float64]
    """(N, 2) polygon in base_link."""
    odometry_k: tuple[float, float]
    """(k_right, k_left): wheel-travel variance per metre travelled [m²/m]."""
    sensors: MappingProxyType[str, MappingProxyType[str, Any]]
    parameters: MappingProxyType[str, Any] = field(repr=False)
    """the whole parameter file, for robot-specific numbers (drive addresses, PID gains…)."""
    base_frame: str = "base_link"
    """the body frame the wheels, footprint and sensors are given in."""
    wheel_joints: tuple[str, str] = ("right_wheel_joint", "left_wheel_joint")
    """(right, left) drive wheel joints."""
    axle: NDArray[np.float64] = field(default_factory=lambda: np.zeros(2))
    """(x, y) [m] of the midpoint of the wheels in the base frame: the point the
    differential-drive kinematics move (the origin for the shipped robots)."""
    found: tuple[str, ...] = ()
    """what was read from the robot's description, and how (for ``kit robot``)."""
    assumed: tuple[str, ...] = ()
    """the stated defaults used where neither the description nor a parameter file said."""

    @property
    def ticks_per_wheel_turn(self) -> float:
        return self.encoder_resolution * self.gear_ratio

    @property
    def metres_per_tick(self) -> float:
        """Wheel travel per encoder count: pi * D / (n * C_e)."""
        return math.pi * 2.0 * self.wheel_radius / self.ticks_per_wheel_turn

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(f"{self.name} has no joint {name!r}; joints: "
                       f"{[j.name for j in self.joints]}")

    def static_transforms(self,
                          stamp: msgs.Time | None = None) -> tuple[msgs.TransformStamped, ...]:
        """The URDF's joints at zero position as ``TransformStamped`` (for ``/tf_static``)."""
        header_stamp = stamp if stamp is not None else msgs.Time()
        return tuple(
            msgs.TransformStamped(msgs.Header(header_stamp, j.parent), j.child,
                                  j.transform().to_msg())
            for j in self.joints)

    def transform_tree(self, T_map_odom: RigidTransform | None = None,
                       cache_time: float = 10.0) -> TransformTree:
        """The REP-105 tree: ``map → odom`` (static identity unless given; localization
        replaces it), the URDF's static children of ``base_link``. Add ``odom → base_link``
        samples from odometry with ``tree.set_transform("odom", "base_link", t, ...)``."""
        tree = TransformTree(cache_time=cache_time)
        for j in self.joints:
            tree.set_static(j.parent, j.child, j.transform())
        if T_map_odom is not None:
            tree.set_transform("map", "odom", 0.0, T_map_odom)
        else:
            tree.set_static("map", "odom", RigidTransform.identity())
        return tree

    def frame_pose(self, frame: str) -> NDArray[np.float64]:
        """Planar pose ``(x, y, yaw)`` of ``frame`` in the base frame, composed along the
        URDF's joints (at zero position).

        Raises
        ------
        KeyError
            ``frame`` is no link of the URDF.
        """
        tree = TransformTree()
        for j in self.joints:
            tree.set_static(j.parent, j.child, j.transform())
        if frame == self.base_frame:
            return np.zeros(3)
        try:
            return tree.lookup_transform(self.base_frame, frame).to_pose2d()
        except TransformError:
            raise KeyError(f"{self.name}: no frame {frame!r} joined to {self.base_frame}") \
                from None

    def sensor_mount(self, sensor: str) -> tuple[float, float, float]:
        """Planar pose ``(x, y, yaw)`` in the base frame of ``sensors[sensor]["frame_id"]``,
        composed from the URDF; ``(0, 0, 0)`` when the URDF has no such frame."""
        frame = str(self.sensors[sensor].get("frame_id", "")) if sensor in self.sensors else ""
        try:
            x, y, yaw = self.frame_pose(frame)
        except KeyError:
            return (0.0, 0.0, 0.0)
        return (float(x), float(y), float(yaw))


def robots_dir() -> Path:
    """The folder of the shipped robot descriptions, ``hardware/robots``.

    Found with ``importlib.util.find_spec``, which locates the ``hardware`` package without
    running any of its code: the kit reads these data files and imports nothing of hardware.
    """
    spec = importlib.util.find_spec("hardware")
    if spec is None or not spec.submodule_search_locations:
        raise RobotDescriptionError("the hardware package (robot descriptions) is not installed")
    return Path(next(iter(spec.submodule_search_locations))) / "robots"


def _kind(name_or_path: str | Path) -> tuple[str, Path]:
    """("toml" | "urdf" | "bag", path) of what :func:`load` was given."""
    text = str(name_or_path)
    if text in ROBOTS:
        return "toml", robots_dir() / f"{text}.toml"
    path = Path(text)
    lower = path.name.lower()
    if lower.endswith(".toml"):
        return "toml", path
    if lower.endswith(URDF_SUFFIXES):
        return "urdf", path
    if lower.endswith(BAG_SUFFIXES) or (path.is_dir() and (path / "metadata.yaml").is_file()):
        return "bag", path
    raise RobotDescriptionError(
        f"{text!r} is neither a shipped robot {ROBOTS} nor a robot file: a .toml parameter "
        f"file, a .urdf or .xacro description, or a bag that recorded /robot_description")


def _require(params: dict[str, Any], section: str, key: str, path: Path) -> Any:
    try:
        return params[section][key] if section else params[key]
    except KeyError:
        where = f"[{section}] " if section else ""
        raise RobotDescriptionError(f"{path}: missing {where}{key}") from None


def _read_parameters(path: Path) -> dict[str, Any]:
    """The parameter file's TOML as a dict."""
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise RobotDescriptionError(f"{path}: no such robot parameter file") from None
    except tomllib.TOMLDecodeError as exc:
        raise RobotDescriptionError(f"{path}: not valid TOML ({exc})") from None


def _is_positive(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and \
        math.isfinite(value) and value > 0


def _drive_parameters(params: dict[str, Any], path: Path) -> dict[str, Any]:
    """The ``[drive]`` section, every number in it checked positive."""
    for key in ("gear_ratio", "encoder_resolution", "counter_bits", "max_wheel_speed",
                "max_linear_velocity", "max_angular_velocity", "max_linear_acceleration"):
        value = _require(params, "drive", key, path)
        if not isinstance(value, (int, float)) or value <= 0:
            raise RobotDescriptionError(f"{path}: [drive] {key} must be a positive number; "
                                        f"got {value!r}")
    return dict(params["drive"])


def _cruise_velocity(params: dict[str, Any], path: Path | str, top: float) -> float:
    """``[navigation] cruise_velocity`` [m/s]: positive and at most the drive's top speed;
    the top speed when not given."""
    value = params.get("navigation", {}).get("cruise_velocity", top)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value <= top:
        raise RobotDescriptionError(f"{path}: [navigation] cruise_velocity must be a number in "
                                    f"(0, max_linear_velocity = {top}]; got {value!r}")
    return float(value)


def _footprint(params: dict[str, Any], path: Path | str) -> NDArray[np.float64]:
    """The ``[footprint]`` polygon (N, 2) in base_link [m]: given points, or a 16-gon of the
    given radius."""
    fp = params.get("footprint", {})
    if "points" in fp:
        try:
            footprint = np.array(fp["points"], dtype=float)
        except (TypeError, ValueError):
            raise RobotDescriptionError(f"{path}: [footprint] points must be 3 or more "
                                        f"[x, y]") from None
        if footprint.ndim != 2 or footprint.shape[1] != 2 or len(footprint) < 3:
            raise RobotDescriptionError(f"{path}: [footprint] points must be 3 or more [x, y]")
    elif "radius" in fp:
        if not _is_positive(fp["radius"]):
            raise RobotDescriptionError(f"{path}: [footprint] radius must be a positive "
                                        f"number; got {fp['radius']!r}")
        angles = np.linspace(0, 2 * np.pi, 16, endpoint=False)
        footprint = float(fp["radius"]) * np.column_stack([np.cos(angles), np.sin(angles)])
    else:
        raise RobotDescriptionError(f"{path}: [footprint] needs points or radius")
    footprint.flags.writeable = False
    return footprint


def _xacro_settings(params: dict[str, Any], path: Path,
                    xacro_args: Mapping[str, str] | None,
                    package_paths: Mapping[str, str | Path] | None
                    ) -> tuple[dict[str, str], dict[str, Path]]:
    """A parameter file's ``[xacro] args`` and ``[xacro] packages`` (folders relative to the
    file), with the caller's on top."""
    section = params.get("xacro", {})
    args, packages = section.get("args", {}), section.get("packages", {})
    if not isinstance(args, dict) or not isinstance(packages, dict):
        raise RobotDescriptionError(f"{path}: [xacro] args and [xacro] packages are tables "
                                    f"(name = \"value\")")
    merged_args = {str(k): str(v) for k, v in args.items()} | dict(xacro_args or {})
    merged_packages = {str(k): path.parent / Path(str(v)).expanduser()
                       for k, v in packages.items()}
    merged_packages.update({k: Path(v) for k, v in (package_paths or {}).items()})
    return merged_args, merged_packages


def _mesh_reader(source: Path | None,
                 package_paths: Mapping[str, str | Path]) -> Any:
    from kit import description_files

    def read(shape: Shape) -> NDArray[np.float64]:
        path = description_files.resolve_uri(shape.filename, source, package_paths)
        return description_files.mesh_vertices(path, shape.dimensions)
    return read


def _load_toml(path: Path, xacro_args: Mapping[str, str] | None,
               package_paths: Mapping[str, str | Path] | None) -> RobotDescription:
    """A kit parameter file and the URDF it names (its wheels by name)."""
    from kit import description_files, robot_structure, urdf

    params = _read_parameters(path)
    urdf_path = path.parent / str(_require(params, "", "urdf", path))
    if not urdf_path.is_file():
        raise RobotDescriptionError(f"{path}: its URDF {urdf_path} does not exist")
    args, packages = _xacro_settings(params, path, xacro_args, package_paths)
    text, notes = description_files.read_urdf(urdf_path, args, packages)
    model = urdf.parse(text, str(urdf_path))
    base = str(params.get("base_frame", "base_link"))
    if not model.has_link(base):
        raise RobotDescriptionError(f"{urdf_path}: no link {base!r} (the base frame)")
    names = params.get("wheels", {})
    right = str(names.get("right_joint", "right_wheel_joint"))
    left = str(names.get("left_joint", "left_wheel_joint"))
    wheels = robot_structure.named_wheels(model, base, right, left,
                                          _mesh_reader(urdf_path, packages))
    drive = _drive_parameters(params, path)
    odo = params.get("odometry", {})
    sensors = MappingProxyType({k: MappingProxyType(dict(v))
                                for k, v in params.get("sensors", {}).items()})
    return RobotDescription(
        name=str(params.get("name", model.name)),
        description=str(params.get("description", "")),
        source=path,
        links=model.links,
        joints=model.joints,
        wheel_radius=wheels.radius,
        wheel_separation=wheels.separation,
        gear_ratio=float(drive["gear_ratio"]),
        encoder_resolution=int(drive["encoder_resolution"]),
        counter_bits=int(drive["counter_bits"]),
        max_wheel_speed=float(drive["max_wheel_speed"]),
        max_linear_velocity=float(drive["max_linear_velocity"]),
        max_angular_velocity=float(drive["max_angular_velocity"]),
        max_linear_acceleration=float(drive["max_linear_acceleration"]),
        cruise_velocity=_cruise_velocity(params, path, float(drive["max_linear_velocity"])),
        mass=float(sum(link.mass for link in model.links)),
        footprint=_footprint(params, path),
        odometry_k=(float(odo.get("k_right", 0.0)), float(odo.get("k_left", 0.0))),
        sensors=sensors,
        parameters=MappingProxyType(params),
        base_frame=base,
        wheel_joints=(wheels.right, wheels.left),
        axle=wheels.axle,
        found=(*notes, *wheels.notes),
    )


def load(name_or_path: str | Path, *, parameters: str | Path | Mapping[str, Any] | None = None,
         xacro_args: Mapping[str, str] | None = None,
         package_paths: Mapping[str, str | Path] | None = None,
         topic: str = "/robot_description") -> RobotDescription:
    """Load a robot by name, parameter file, URDF or xacro file, or bag.

    Parameters
    ----------
    name_or_path : str or Path
        ``"uiabot"``, ``"igv"``, ``"eddie"``; a ``.toml`` parameter file; a ``.urdf``,
        ``.urdf.xacro`` or ``.xacro`` file; a bag (rosbag2 folder, ``.mcap``, ``.db3``,
        ROS 1 ``.bag``) that recorded ``topic``.
    parameters : path or mapping, optional
        For a URDF or bag: what the URDF does not hold, in the parameter file's TOML keys
        (``[drive]``, ``[odometry]``, ``[footprint]``, ``[navigation]``, ``[sensors.lidar]``,
        ``[wheels]``, ``base_frame``, ``name``); the rest is found or defaulted.
    xacro_args : mapping, optional
        xacro arguments, e.g. ``{"namespace": "tb3_0/"}``.
    package_paths : mapping, optional
        ``{"package": folder}`` for ``$(find package)`` and ``package://`` without ROS.
    topic : str
        The bag's URDF topic.

    Raises
    ------
    RobotDescriptionError
        The file is missing or malformed, xacro fails, no drive wheels can be found; the
        message names the file, the joint or link, and what was expected.

    >>> robot = load("uiabot")
    >>> robot.wheel_radius, robot.wheel_separation
    (0.05, 0.361)
    """
    from kit import description_files, robot_from_urdf

    kind, path = _kind(name_or_path)
    if kind == "toml":
        if parameters is not None:
            raise RobotDescriptionError(f"{path}: a .toml robot holds its own parameters; "
                                        f"parameters= goes with a URDF, xacro file or bag")
        return _load_toml(path, xacro_args, package_paths)
    if parameters is None:
        params: dict[str, Any] = {}
        where = str(path)
    elif isinstance(parameters, Mapping):
        params, where = dict(parameters), "parameters"
    else:
        params, where = _read_parameters(Path(parameters)), str(parameters)
    if "urdf" in params:
        raise RobotDescriptionError(f"{where}: names a URDF (urdf = …) and {path} was given "
                                    f"too; load the parameter file alone, or leave out urdf")
    args, packages = _xacro_settings(params, Path(where), xacro_args, package_paths)
    if kind == "urdf":
        text, notes = description_files.read_urdf(path, args, packages)
        return robot_from_urdf.build(text, str(path), path, params, where, list(notes), {},
                                     packages)
    if args:
        raise RobotDescriptionError(f"{path}: a bag's URDF is already expanded; it takes no "
                                    f"xacro arguments")
    text, scan = description_files.read_bag_description(path, topic)
    return robot_from_urdf.build(text, f"{path} {topic}", path, params, where,
                                 [f"URDF from the bag's {topic}"], scan, packages)


def load_from_options(name_or_path: str | Path, parameters: str | Path | None,
                      xacro_args: Sequence[str] = (), package_paths: Sequence[str] = (),
                      topic: str = "/robot_description",
                      names: tuple[str, str, str] = ("--params", "--xacro-arg",
                                                     "--package-path")) -> RobotDescription:
    """:func:`load` with a command line's options: ``xacro_args`` as ``NAME:=VALUE`` and
    ``package_paths`` as ``PKG=DIR`` strings. ``names`` are the three options as the command
    spells them, for the error a shipped robot given any of them raises (``ValueError``)."""
    from kit import description_files

    if str(name_or_path) in ROBOTS and (parameters or xacro_args or package_paths):
        raise ValueError(f"{', '.join(names[:2])} and {names[2]} go with a robot file, not "
                         f"the shipped {name_or_path}")
    return load(name_or_path, parameters=parameters,
                xacro_args=description_files.parse_xacro_args(xacro_args),
                package_paths=description_files.parse_package_paths(package_paths),
                topic=topic)
