"""Robot descriptions: a URDF plus a parameter file, loaded into one frozen object.

``load("uiabot")`` reads ``hardware/robots/uiabot.urdf`` and ``uiabot.toml`` (package data);
``load("path/to/robot.toml")`` reads any robot described the same way. The URDF gives the
geometry — links, joints with their origins, the wheel radius (the wheels' collision
cylinders) and the wheel separation (the distance between the wheel joints) — and the
parameter file what a URDF cannot say: gearing, encoders, limits, sensor models.

Wheel joints must be named ``right_wheel_joint`` and ``left_wheel_joint``.
"""

from __future__ import annotations

import importlib.util
import math
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from kit import geometry, msgs
from kit.tf import RigidTransform, TransformTree

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

__all__ = ["ROBOTS", "Joint", "Link", "RobotDescription", "RobotDescriptionError", "load"]

ROBOTS = ("uiabot", "igv", "eddie")
"""The robots shipped with the kit."""


class RobotDescriptionError(ValueError):
    """A robot description file that is missing or malformed; the message names the file."""


@dataclass(frozen=True)
class Link:
    """A URDF link: its name, mass [kg] (0 when the URDF gives none) and collision shapes."""

    name: str
    mass: float
    collision: tuple[tuple[str, tuple[float, ...]], ...] = ()


@dataclass(frozen=True, eq=False)
class Joint:
    """A URDF joint: ``T_parent_child`` at zero joint position is ``(xyz, rpy)``."""

    name: str
    type: str
    parent: str
    child: str
    xyz: NDArray[np.float64]
    rpy: NDArray[np.float64]
    axis: NDArray[np.float64]

    def transform(self) -> RigidTransform:
        return RigidTransform(self.xyz.copy(), geometry.rpy_to_quaternion(*self.rpy))


@dataclass(frozen=True, eq=False)
class RobotDescription:
    """Everything the kit knows about one robot. SI units, REP-103/105 frames."""

    name: str
    description: str
    source: Path
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    wheel_radius: float
    """m, from the wheels' collision cylinders."""
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


def _floats(text: str | None, n: int, where: str) -> NDArray[np.float64]:
    if text is None:
        return np.zeros(n)
    try:
        values = np.array([float(v) for v in text.split()])
    except ValueError:
        raise ValueError(f"{where}: expected {n} numbers, got {text!r}") from None
    if values.shape != (n,):
        raise ValueError(f"{where}: expected {n} numbers, got {text!r}")
    return values


def _parse_urdf(path: Path) -> tuple[str, tuple[Link, ...], tuple[Joint, ...]]:
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise RobotDescriptionError(f"{path}: not well-formed XML ({exc})") from None
    if root.tag != "robot":
        raise RobotDescriptionError(f"{path}: the root element is <{root.tag}>, not <robot>")
    links: list[Link] = []
    for el in root.findall("link"):
        name = el.get("name")
        if not name:
            raise RobotDescriptionError(f"{path}: a <link> has no name")
        mass_el = el.find("inertial/mass")
        shapes: list[tuple[str, tuple[float, ...]]] = []
        for geom in el.findall("collision/geometry/*"):
            if geom.tag == "cylinder":
                shapes.append(("cylinder", (float(geom.get("radius", "nan")),
                                            float(geom.get("length", "nan")))))
            elif geom.tag == "sphere":
                shapes.append(("sphere", (float(geom.get("radius", "nan")),)))
            elif geom.tag == "box":
                shapes.append(("box", tuple(_floats(geom.get("size"), 3, f"{path}: {name} box"))))
        links.append(Link(name, float(mass_el.get("value", "0")) if mass_el is not None else 0.0,
                          tuple(shapes)))
    link_names = {link.name for link in links}
    joints: list[Joint] = []
    for el in root.findall("joint"):
        name, jtype = el.get("name"), el.get("type")
        parent_el, child_el = el.find("parent"), el.find("child")
        if not name or not jtype or parent_el is None or child_el is None:
            raise RobotDescriptionError(
                f"{path}: joint {name!r} needs a name, a type, a <parent> and a <child>")
        parent, child = parent_el.get("link", ""), child_el.get("link", "")
        for ref in (parent, child):
            if ref not in link_names:
                raise RobotDescriptionError(
                    f"{path}: joint {name!r} names the link {ref!r}, which is not defined")
        origin = el.find("origin")
        axis = el.find("axis")
        try:
            xyz = _floats(origin.get("xyz") if origin is not None else None, 3, f"joint {name} xyz")
            rpy = _floats(origin.get("rpy") if origin is not None else None, 3, f"joint {name} rpy")
            ax = _floats(axis.get("xyz") if axis is not None else "1 0 0", 3, f"joint {name} axis")
        except ValueError as exc:
            raise RobotDescriptionError(f"{path}: {exc}") from None
        for a in (xyz, rpy, ax):
            a.flags.writeable = False
        joints.append(Joint(name, jtype, parent, child, xyz, rpy, ax))
    children = [j.child for j in joints]
    twice = {c for c in children if children.count(c) > 1}
    if twice:
        raise RobotDescriptionError(f"{path}: links with two parents: {sorted(twice)}")
    return root.get("name", ""), tuple(links), tuple(joints)


def robots_dir() -> Path:
    """The folder of the shipped robot descriptions, ``hardware/robots``.

    Found with ``importlib.util.find_spec``, which locates the ``hardware`` package without
    running any of its code: the kit reads these data files and imports nothing of hardware.
    """
    spec = importlib.util.find_spec("hardware")
    if spec is None or not spec.submodule_search_locations:
        raise RobotDescriptionError("the hardware package (robot descriptions) is not installed")
    return Path(next(iter(spec.submodule_search_locations))) / "robots"


def _resolve(name_or_path: str | Path) -> Path:
    text = str(name_or_path)
    if text in ROBOTS:
        return robots_dir() / f"{text}.toml"
    path = Path(text)
    if path.suffix != ".toml":
        raise RobotDescriptionError(
            f"{text!r} is neither a shipped robot {ROBOTS} nor a .toml parameter file")
    return path


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


def _wheel_geometry(urdf_path: Path, links: tuple[Link, ...],
                    joints: tuple[Joint, ...]) -> tuple[float, float]:
    """(wheel radius, wheel separation) [m] from the URDF's wheel joints and link."""
    by_name = {j.name: j for j in joints}
    for needed in ("right_wheel_joint", "left_wheel_joint"):
        if needed not in by_name:
            raise RobotDescriptionError(f"{urdf_path}: no joint named {needed!r}")
    right, left = by_name["right_wheel_joint"], by_name["left_wheel_joint"]
    if not right.xyz[1] < 0 < left.xyz[1]:
        raise RobotDescriptionError(
            f"{urdf_path}: the right wheel must be at negative y and the left at positive y "
            f"(REP-103: y points left); got right y={right.xyz[1]}, left y={left.xyz[1]}")
    wheel_link = next(link for link in links if link.name == right.child)
    radii = [dims[0] for kind, dims in wheel_link.collision if kind == "cylinder"]
    if not radii:
        raise RobotDescriptionError(
            f"{urdf_path}: wheel link {wheel_link.name!r} has no collision cylinder to take "
            f"the wheel radius from")
    return float(radii[0]), round(float(np.linalg.norm(left.xyz[:2] - right.xyz[:2])), 9)


def _drive_parameters(params: dict[str, Any], path: Path) -> dict[str, Any]:
    """The ``[drive]`` section, every number in it checked positive."""
    for key in ("gear_ratio", "encoder_resolution", "counter_bits", "max_wheel_speed",
                "max_linear_velocity", "max_angular_velocity", "max_linear_acceleration"):
        value = _require(params, "drive", key, path)
        if not isinstance(value, (int, float)) or value <= 0:
            raise RobotDescriptionError(f"{path}: [drive] {key} must be a positive number; "
                                        f"got {value!r}")
    return dict(params["drive"])


def _cruise_velocity(params: dict[str, Any], path: Path, top: float) -> float:
    """``[navigation] cruise_velocity`` [m/s]: positive and at most the drive's top speed;
    the top speed when not given."""
    value = params.get("navigation", {}).get("cruise_velocity", top)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value <= top:
        raise RobotDescriptionError(f"{path}: [navigation] cruise_velocity must be a number in "
                                    f"(0, max_linear_velocity = {top}]; got {value!r}")
    return float(value)


def _footprint(params: dict[str, Any], path: Path) -> NDArray[np.float64]:
    """The ``[footprint]`` polygon (N, 2) in base_link [m]: given points, or a 16-gon of the
    given radius."""
    fp = params.get("footprint", {})
    if "points" in fp:
        footprint = np.array(fp["points"], dtype=float)
        if footprint.ndim != 2 or footprint.shape[1] != 2 or len(footprint) < 3:
            raise RobotDescriptionError(f"{path}: [footprint] points must be 3 or more [x, y]")
    elif "radius" in fp:
        angles = np.linspace(0, 2 * np.pi, 16, endpoint=False)
        footprint = float(fp["radius"]) * np.column_stack([np.cos(angles), np.sin(angles)])
    else:
        raise RobotDescriptionError(f"{path}: [footprint] needs points or radius")
    footprint.flags.writeable = False
    return footprint


def load(name_or_path: str | Path) -> RobotDescription:
    """Load a robot by name (``"uiabot"``, ``"igv"``, ``"eddie"``) or parameter-file path.

    Raises
    ------
    RobotDescriptionError
        The file is missing or malformed; the message names the file and the problem.

    >>> robot = load("uiabot")
    >>> robot.wheel_radius, robot.wheel_separation
    (0.05, 0.361)
    """
    path = _resolve(name_or_path)
    params = _read_parameters(path)
    urdf_path = path.parent / str(_require(params, "", "urdf", path))
    if not urdf_path.is_file():
        raise RobotDescriptionError(f"{path}: its URDF {urdf_path} does not exist")
    robot_name, links, joints = _parse_urdf(urdf_path)
    wheel_radius, wheel_separation = _wheel_geometry(urdf_path, links, joints)
    drive = _drive_parameters(params, path)
    odo = params.get("odometry", {})
    sensors = MappingProxyType({k: MappingProxyType(dict(v))
                                for k, v in params.get("sensors", {}).items()})
    return RobotDescription(
        name=str(params.get("name", robot_name)),
        description=str(params.get("description", "")),
        source=path,
        links=links,
        joints=joints,
        wheel_radius=wheel_radius,
        wheel_separation=wheel_separation,
        gear_ratio=float(drive["gear_ratio"]),
        encoder_resolution=int(drive["encoder_resolution"]),
        counter_bits=int(drive["counter_bits"]),
        max_wheel_speed=float(drive["max_wheel_speed"]),
        max_linear_velocity=float(drive["max_linear_velocity"]),
        max_angular_velocity=float(drive["max_angular_velocity"]),
        max_linear_acceleration=float(drive["max_linear_acceleration"]),
        cruise_velocity=_cruise_velocity(params, path, float(drive["max_linear_velocity"])),
        mass=float(sum(link.mass for link in links)),
        footprint=_footprint(params, path),
        odometry_k=(float(odo.get("k_right", 0.0)), float(odo.get("k_left", 0.0))),
        sensors=sensors,
        parameters=MappingProxyType(params),
    )
