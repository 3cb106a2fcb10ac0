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
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from kit import msgs
from kit.tf import RigidTransform, TransformError, TransformTree
from kit.urdf import Joint, Link, RobotDescriptionError, Shape, Urdf

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


class _Sourced:
    """Values taken from a parameter file, else the description, else a stated default;
    each use of a default is listed."""

    def __init__(self, params: dict[str, Any], where: str) -> None:
        self.params, self.where = params, where
        self.found: list[str] = []
        self.assumed: list[str] = []

    def number(self, section: str, key: str, found: float | None = None, how: str = "",
               default: float | None = None, why: str = "") -> float:
        table = self.params.get(section, {})
        if not isinstance(table, dict):
            raise RobotDescriptionError(f"{self.where}: [{section}] must be a table")
        if key in table:
            value = table[key]
            if not _is_positive(value):
                raise RobotDescriptionError(f"{self.where}: [{section}] {key} must be a "
                                            f"positive number; got {value!r}")
            return float(value)
        if found is not None:
            self.found.append(f"{key} {found:g} from {how}")
            return float(found)
        if default is None:
            raise RobotDescriptionError(f"{self.where}: missing [{section}] {key}")
        self.assumed.append(f"{key} {default:g}" + (f" ({why})" if why else ""))
        return float(default)


def _sensor(name: str, keys: dict[str, Any], params: dict[str, Any],
            sourced: _Sourced) -> dict[str, Any]:
    """One ``sensors`` entry: the parameter file's keys over the found ones over the
    defaults (listed as assumed)."""
    given = dict(params.get("sensors", {}).get(name, {}))
    out = dict(DEFAULTS[name])
    used_default = [k for k in out if k not in given and k not in keys]
    out.update(keys)
    out.update(given)
    if used_default:
        sourced.assumed.append(f"{name}: " + ", ".join(f"{k} {out[k]:g}" if isinstance(
            out[k], float) else f"{k} {out[k]}" for k in used_default) +
            f" (the kit's {'RPLidar A1' if name == 'lidar' else 'BNO055'} model)")
    return out


def _lidar(model: Urdf, base: str, params: dict[str, Any], scan: dict[str, Any],
           sourced: _Sourced) -> dict[str, Any]:
    from kit import robot_structure

    given = params.get("sensors", {}).get("lidar", {})
    frame, given_by = given.get("frame_id"), "the parameter file"
    if frame is None and scan and model.has_link(str(scan["frame_id"])):
        frame, given_by = scan["frame_id"], f"the bag's {scan['topic']}"
    mount = robot_structure.find_lidar(model, base, None if frame is None else str(frame),
                                       given_by)
    keys: dict[str, Any] = {}
    if mount is None:
        keys["frame_id"] = base
        sourced.assumed.append(f"lidar: the URDF has none; one at {base}'s origin")
    else:
        keys["frame_id"] = mount.frame
        x, y, yaw = mount.pose
        sourced.found.append(f"lidar {mount.frame} at ({x:+.3f}, {y:+.3f}) m, yaw "
                             f"{math.degrees(yaw):+.1f}°, by {mount.how}")
        tag = mount.sensor
        if scan and scan["frame_id"] == mount.frame:
            keys.update({k: v for k, v in scan.items() if k not in ("frame_id", "topic")})
            keys["model"] = "bag"
            beams = round((scan["angle_max"] - scan["angle_min"]) / scan["angle_increment"]) + 1
            sourced.found.append(
                f"lidar model from the bag's {scan['topic']}: {beams} beams, "
                f"{scan.get('scan_rate', 0):.2f} Hz, {scan['range_min']:g}-"
                f"{scan['range_max']:g} m")
        elif tag is not None and tag.values.get("samples", 0) >= 2 and \
                {"min_angle", "max_angle"} <= set(tag.values):
            v = tag.values
            keys.update(model=f"gazebo_{tag.type}", angle_min=v["min_angle"],
                        angle_max=v["max_angle"],
                        angle_increment=(v["max_angle"] - v["min_angle"]) / (v["samples"] - 1))
            for key, name in (("range_min", "range_min"), ("range_max", "range_max"),
                              ("range_noise_std", "noise_std")):
                if name in v:
                    keys[key] = v[name]
            if tag.rate > 0:
                keys["scan_rate"] = tag.rate
            sourced.found.append(f"lidar model from the Gazebo sensor {tag.name!r}: "
                                 f"{int(v['samples'])} beams, {tag.rate:g} Hz, "
                                 + ", ".join(f"{k} {keys[k]:g}" for k in
                                             ("range_min", "range_max", "range_noise_std")
                                             if k in keys))
    return _sensor("lidar", keys, params, sourced)


def _imu(model: Urdf, base: str, params: dict[str, Any],
         sourced: _Sourced) -> dict[str, Any] | None:
    from kit import robot_structure

    given = params.get("sensors", {}).get("imu")
    mount = robot_structure.find_imu(model, base)
    if given is None and mount is None:
        return None
    keys: dict[str, Any] = {}
    if mount is not None:
        keys["frame_id"] = mount.frame
        sourced.found.append(f"IMU {mount.frame} by {mount.how}")
        if mount.sensor is not None:
            if mount.sensor.rate > 0:
                keys["rate"] = mount.sensor.rate
            keys.update(dict(mount.sensor.values))
    return _sensor("imu", keys, params, sourced)


def _from_urdf(text: str, label: str, source: Path, params: dict[str, Any], where: str,
               found: list[str], scan: dict[str, Any],
               package_paths: Mapping[str, str | Path]) -> RobotDescription:
    """A robot from its own URDF: structure, then the parameter file, then defaults."""
    from kit import robot_structure, urdf

    model = urdf.parse(text, label)
    base = str(params.get("base_frame") or robot_structure.base_frame(model))
    if not model.has_link(base):
        raise RobotDescriptionError(f"{where}: base_frame {base!r} is no link of {label}")
    reader = _mesh_reader(source if source.is_file() else None, package_paths)
    wheel_keys = params.get("wheels", {})
    radius = wheel_keys.get("radius")
    if radius is not None and not _is_positive(radius):
        raise RobotDescriptionError(f"{where}: [wheels] radius must be a positive number; "
                                    f"got {radius!r}")
    if "right_joint" in wheel_keys or "left_joint" in wheel_keys:
        wheels = robot_structure.named_wheels(
            model, base, str(_require(params, "wheels", "right_joint", Path(where))),
            str(_require(params, "wheels", "left_joint", Path(where))), reader, radius)
    else:
        wheels = robot_structure.find_wheels(model, base, reader, radius)
    found = [*found, *model.notes, f"base frame {base}",
             f"drive wheels {wheels.right!r} (right) and {wheels.left!r} (left)",
             *wheels.notes]
    plugin = model.drive_plugin
    for key, mine in (("wheel_separation", wheels.separation),
                      ("wheel_diameter", 2 * wheels.radius)):
        try:
            theirs = float(plugin[key])
        except (KeyError, ValueError):
            continue
        if abs(theirs - mine) > 1e-3:
            found.append(f"note: the Gazebo drive plugin says {key} {theirs:g} m; the joints "
                         f"and wheel shapes say {mine:g} m (the kit takes the geometry)")
    s = _Sourced(params, where)
    s.found.extend(found)
    nav2 = "Nav2's stock controller parameters"
    v_max = s.number("drive", "max_linear_velocity", default=DEFAULTS["drive"][
        "max_linear_velocity"], why=nav2 + ", DWB max_vel_x")
    w_max = s.number("drive", "max_angular_velocity", default=DEFAULTS["drive"][
        "max_angular_velocity"], why=nav2 + ", DWB max_vel_theta")
    a_max = s.number("drive", "max_linear_acceleration", default=DEFAULTS["drive"][
        "max_linear_acceleration"], why=nav2 + ", DWB acc_lim_x")
    limits = [model.joint(n).velocity for n in (wheels.right, wheels.left)]
    wheel_speed = s.number(
        "drive", "max_wheel_speed",
        found=min(limits) if all(math.isfinite(v) for v in limits) else None,
        how="the wheel joints' <limit velocity>",
        default=round((v_max + w_max * wheels.separation / 2) / wheels.radius, 9),
        why="enough for the top linear and angular speeds together")
    drive_given = params.get("drive", {})
    top_v = round(wheel_speed * wheels.radius, 9)
    top_w = round(2 * wheel_speed * wheels.radius / wheels.separation, 9)
    if "max_linear_velocity" not in drive_given and v_max > top_v:
        v_max = top_v
        s.assumed = [a for a in s.assumed if not a.startswith("max_linear_velocity ")]
        s.assumed.append(f"max_linear_velocity {v_max:g}: the wheels' top speed "
                         f"({wheel_speed:g} rad/s) allows no more than the default")
    if "max_angular_velocity" not in drive_given and w_max > top_w:
        w_max = top_w
        s.assumed = [a for a in s.assumed if not a.startswith("max_angular_velocity ")]
        s.assumed.append(f"max_angular_velocity {w_max:g}: the wheels' top speed "
                         f"({wheel_speed:g} rad/s) allows no more than the default")
    gear = s.number("drive", "gear_ratio", default=DEFAULTS["drive"]["gear_ratio"],
                    why="encoder counts taken at the wheel")
    resolution = s.number("drive", "encoder_resolution", default=DEFAULTS["drive"][
        "encoder_resolution"], why="a 12-bit encoder on the wheel")
    bits = s.number("drive", "counter_bits", default=DEFAULTS["drive"]["counter_bits"])
    links_mass = float(sum(link.mass for link in model.links))
    mass = s.number("mass", "mass", found=links_mass if links_mass > 0 else None,
                    how="the links' <inertial> masses", default=DEFAULTS["mass"]["mass"],
                    why="the URDF gives no masses") if "mass" in params else (
        links_mass if links_mass > 0 else s.number("mass", "mass", default=DEFAULTS["mass"][
            "mass"], why="the URDF gives no masses"))
    k_right = s.number("odometry", "k_right", default=DEFAULTS["odometry"]["k_right"],
                       why="rubber wheels on an indoor floor, as the Uiabot's")
    k_left = s.number("odometry", "k_left", default=DEFAULTS["odometry"]["k_left"])
    if "footprint" in params:
        outline = _footprint(params, where)
    else:
        outline, how = robot_structure.footprint(model, base, wheels, reader)
        (s.assumed if how.startswith("assumed") else s.found).append(
            f"footprint {np.ptp(outline[:, 0]):.3f} x {np.ptp(outline[:, 1]):.3f} m from "
            f"{how}" if not how.startswith("assumed") else f"footprint: {how[9:]}")
    sensors: dict[str, Any] = {name: dict(value) for name, value in
                               params.get("sensors", {}).items() if isinstance(value, dict)}
    sensors["lidar"] = _lidar(model, base, params, scan, s)
    imu = _imu(model, base, params, s)
    if imu is not None:
        sensors["imu"] = imu
    name = str(params.get("name") or model.name or source.stem)
    return RobotDescription(
        name=name,
        description=str(params.get("description", f"robot {model.name!r} from {label}")),
        source=source,
        links=model.links,
        joints=model.joints,
        wheel_radius=wheels.radius,
        wheel_separation=wheels.separation,
        gear_ratio=gear,
        encoder_resolution=int(resolution),
        counter_bits=int(bits),
        max_wheel_speed=wheel_speed,
        max_linear_velocity=v_max,
        max_angular_velocity=w_max,
        max_linear_acceleration=a_max,
        cruise_velocity=_cruise_velocity(params, where, v_max),
        mass=mass,
        footprint=outline,
        odometry_k=(k_right, k_left),
        sensors=MappingProxyType({k: MappingProxyType(v) for k, v in sensors.items()}),
        parameters=MappingProxyType(params),
        base_frame=base,
        wheel_joints=(wheels.right, wheels.left),
        axle=wheels.axle,
        found=tuple(s.found),
        assumed=tuple(s.assumed),
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
    from kit import description_files

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
        return _from_urdf(text, str(path), path, params, where, list(notes), {}, packages)
    if args:
        raise RobotDescriptionError(f"{path}: a bag's URDF is already expanded; it takes no "
                                    f"xacro arguments")
    text, scan = description_files.read_bag_description(path, topic)
    return _from_urdf(text, f"{path} {topic}", path, params, where,
                      [f"URDF from the bag's {topic}"], scan, packages)
