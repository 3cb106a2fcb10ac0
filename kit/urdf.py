"""URDF robot descriptions: parsed, checked, and their frames composed from the root.

:func:`parse` reads URDF XML (already expanded from xacro, see :mod:`kit.description_files`)
into a :class:`Urdf`: its links with their collision and visual shapes, its joints, the
Gazebo sensors and drive plugin it declares. The geometry is parsed and the kinematic tree is
composed by pytransform3d's URDF reader (``pytransform3d.urdf``, imported when a URDF is
parsed); the checks before it give every malformed element a message that names the file, the
link or joint and what was expected.

Frames and conventions (REP-103): ``T_a_b`` maps points in frame ``b`` into frame ``a``; a
joint's ``origin`` is ``T_parent_child`` at zero joint position; its ``axis`` is given in the
child's frame. :meth:`Urdf.transform` composes the chain (``T_base_link`` for any two links of
one tree), so a wheel that hangs under a suspension joint is placed where it really is.

>>> text = '''<robot name="r"><link name="base_link"/><link name="wheel"/>
...   <joint name="j" type="continuous"><parent link="base_link"/><child link="wheel"/>
...   <origin xyz="0 0.1 0" rpy="-1.5708 0 0"/><axis xyz="0 0 1"/></joint></robot>'''
>>> urdf = parse(text, "example.urdf")
>>> urdf.transform("wheel", "base_link")[:3, 3].round(3).tolist()
[0.0, 0.1, 0.0]
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from kit import geometry
from kit.tf import RigidTransform

__all__ = ["JOINT_TYPES", "Joint", "Link", "RobotDescriptionError", "SensorTag", "Shape",
           "Urdf", "parse"]

FloatArray = NDArray[np.float64]

JOINT_TYPES = ("fixed", "continuous", "revolute", "prismatic", "floating", "planar")
"""The joint types URDF defines."""

XACRO_NAMESPACES = ("http://ros.org/wiki/xacro", "http://www.ros.org/wiki/xacro")
"""The namespace URIs xacro files declare (``xmlns:xacro``)."""


class RobotDescriptionError(ValueError):
    """A robot description that is missing or malformed; the message names the file."""


@dataclass(frozen=True, eq=False)
class Shape:
    """One collision or visual geometry of a link.

    ``kind`` is ``"box"`` (``dimensions`` = the three side lengths [m]), ``"cylinder"``
    (radius, length [m]; its axis is the shape frame's z), ``"sphere"`` (radius [m]) or
    ``"mesh"`` (``dimensions`` = the scale along x, y, z; ``filename`` the URI as written).
    ``origin`` is ``T_link_shape`` (4, 4).
    """

    kind: str
    dimensions: tuple[float, ...]
    origin: FloatArray
    filename: str = ""


@dataclass(frozen=True)
class Link:
    """A URDF link: its name, mass [kg] (0 when the URDF gives none) and shapes."""

    name: str
    mass: float
    collision: tuple[Shape, ...] = ()
    visual: tuple[Shape, ...] = ()


@dataclass(frozen=True, eq=False)
class Joint:
    """A URDF joint: ``T_parent_child`` at zero joint position is ``(xyz, rpy)``.

    ``axis`` is the unit axis in the child's frame; ``lower``/``upper`` [rad or m] and
    ``velocity`` [rad/s or m/s] are the ``<limit>`` (infinite when not given); ``mimic`` is
    the joint this one follows ("" if none).
    """

    name: str
    type: str
    parent: str
    child: str
    xyz: FloatArray
    rpy: FloatArray
    axis: FloatArray
    lower: float = -math.inf
    upper: float = math.inf
    velocity: float = math.inf
    mimic: str = ""

    def transform(self) -> RigidTransform:
        return RigidTransform(self.xyz.copy(), geometry.rpy_to_quaternion(*self.rpy))


@dataclass(frozen=True)
class SensorTag:
    """A ``<sensor>`` of a ``<gazebo reference="link">`` block: Gazebo's model of it.

    ``type`` as written (``ray``, ``gpu_ray``, ``lidar``, ``gpu_lidar``, ``imu`` …),
    ``rate`` its ``update_rate`` [Hz] (0 if not given), ``pose`` ``T_link_sensor`` (4, 4)
    and ``values`` the numbers read from it (lidar: ``samples``, ``min_angle``,
    ``max_angle``, ``range_min``, ``range_max``, ``noise_std``; IMU: ``gyro_noise_std``,
    ``accel_noise_std``).
    """

    name: str
    type: str
    link: str
    rate: float
    pose: FloatArray = field(default_factory=lambda: np.eye(4))
    values: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))


class Urdf:
    """A parsed URDF: links, joints, Gazebo sensors, and the composed kinematic tree.

    Build it with :func:`parse`. ``drive_plugin`` holds what a Gazebo differential-drive
    plugin declares (keys ``left_joint``, ``right_joint``, ``wheel_separation``,
    ``wheel_diameter``, as strings), empty if there is none; ``notes`` what the parser left
    out and why.
    """

    def __init__(self, name: str, source: str, links: tuple[Link, ...],
                 joints: tuple[Joint, ...], sensors: tuple[SensorTag, ...],
                 drive_plugin: Mapping[str, str], notes: tuple[str, ...],
                 manager: Any) -> None:
        self.name = name
        self.source = source
        self.links = links
        self.joints = joints
        self.sensors = sensors
        self.drive_plugin = MappingProxyType(dict(drive_plugin))
        self.notes = notes
        self._tm = manager
        self._links = {link.name: link for link in links}
        self._joints = {j.name: j for j in joints}
        self._parent_joint = {j.child: j for j in joints}

    def link(self, name: str) -> Link:
        return self._links[name]

    def joint(self, name: str) -> Joint:
        return self._joints[name]

    def has_link(self, name: str) -> bool:
        return name in self._links

    def parent_joint(self, link: str) -> Joint | None:
        """The joint whose child is ``link`` (None for a root)."""
        return self._parent_joint.get(link)

    def roots(self) -> list[str]:
        """The links that are no joint's child, in file order."""
        return [link.name for link in self.links if link.name not in self._parent_joint]

    def chain(self, link: str) -> list[Joint]:
        """The joints from ``link``'s root down to ``link``, root first."""
        out: list[Joint] = []
        j = self._parent_joint.get(link)
        while j is not None:
            out.append(j)
            j = self._parent_joint.get(j.parent)
        return out[::-1]

    def root_of(self, link: str) -> str:
        chain = self.chain(link)
        return chain[0].parent if chain else link

    def transform(self, frame: str, base: str) -> FloatArray:
        """``T_base_frame`` (4, 4) at zero joint positions, composed along the tree.

        ``frame`` and ``base`` are link names (or a shape's frame, ``"collision:link/i"``).
        """
        for name in (frame, base):
            if name not in self._links and not name.startswith(("collision:", "visual:")):
                raise KeyError(f"{self.source}: no link named {name!r}")
        if frame in self._links and base in self._links and \
                self.root_of(frame) != self.root_of(base):
            raise RobotDescriptionError(
                f"{self.source}: no joints join {frame!r} to {base!r}: they hang from "
                f"different roots ({self.root_of(frame)!r}, {self.root_of(base)!r}); a robot's "
                f"links form one tree")
        return np.asarray(self._tm.get_transform(frame, base), dtype=np.float64)

    def pose2d(self, frame: str, base: str) -> FloatArray:
        """Planar ``(x, y, yaw)`` of ``frame`` in ``base`` (z, roll and pitch dropped)."""
        T = self.transform(frame, base)
        return np.array([T[0, 3], T[1, 3], math.atan2(T[1, 0], T[0, 0])])


# ---------------------------------------------------------------------------- parsing

def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1] if tag.startswith("{") else tag


def _numbers(text: str | None, n: int, where: str, default: str | None = None) -> FloatArray:
    if text is None:
        if default is None:
            raise RobotDescriptionError(f"{where}: missing (expected {n} numbers)")
        text = default
    try:
        values = np.array([float(v) for v in text.split()], dtype=np.float64)
    except ValueError:
        raise RobotDescriptionError(f"{where}: expected {n} numbers, got {text!r}") from None
    if values.shape != (n,) or not np.all(np.isfinite(values)):
        raise RobotDescriptionError(f"{where}: expected {n} finite numbers, got {text!r}")
    return values


def _number(element: ET.Element, attribute: str, where: str,
            default: float | None = None, positive: bool = False) -> float:
    text = element.get(attribute)
    if text is None:
        if default is None:
            raise RobotDescriptionError(f"{where}: needs a {attribute}=\"…\"")
        return default
    try:
        value = float(text)
    except ValueError:
        raise RobotDescriptionError(f"{where}: {attribute} must be a number; got "
                                    f"{text!r}") from None
    if math.isnan(value) or (positive and not value > 0):
        raise RobotDescriptionError(f"{where}: {attribute} must be a positive number; got "
                                    f"{text!r}")
    return value


def _origin_matrix(element: ET.Element, where: str) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(xyz, rpy, T) of an element's ``<origin>`` (identity when it has none)."""
    origin = element.find("origin")
    xyz = _numbers(origin.get("xyz") if origin is not None else None, 3, f"{where} origin xyz",
                   "0 0 0")
    rpy = _numbers(origin.get("rpy") if origin is not None else None, 3, f"{where} origin rpy",
                   "0 0 0")
    T = np.eye(4)
    q = geometry.rpy_to_quaternion(*rpy)
    T[:3, :3] = _rotation(q)
    T[:3, 3] = xyz
    return xyz, rpy, T


def _rotation(q: FloatArray) -> FloatArray:
    return np.column_stack([geometry.quaternion_rotate(q, e) for e in np.eye(3)])


def _shapes(link: ET.Element, kind: str, name: str) -> tuple[Shape, ...]:
    out: list[Shape] = []
    for i, element in enumerate(link.findall(kind)):
        where = f"link {name!r} <{kind}> {i}"
        _, _, T = _origin_matrix(element, where)
        geom = element.find("geometry")
        if geom is None or len(geom) == 0:
            raise RobotDescriptionError(f"{where}: needs a <geometry> with a box, cylinder, "
                                        f"sphere or mesh")
        for g in geom:
            tag = _local(g.tag)
            if tag == "box":
                size = _numbers(g.get("size"), 3, f"{where} box size")
                if np.any(size < 0):
                    raise RobotDescriptionError(f"{where} box size: negative side {size}")
                out.append(Shape("box", tuple(map(float, size)), T))
            elif tag == "cylinder":
                out.append(Shape("cylinder", (
                    _number(g, "radius", f"{where} cylinder", positive=True),
                    _number(g, "length", f"{where} cylinder", positive=True)), T))
            elif tag == "sphere":
                out.append(Shape("sphere", (_number(g, "radius", f"{where} sphere",
                                                    positive=True),), T))
            elif tag == "mesh":
                filename = g.get("filename", "")
                if not filename:
                    raise RobotDescriptionError(f"{where} mesh: needs a filename")
                scale = _numbers(g.get("scale"), 3, f"{where} mesh scale", "1 1 1")
                out.append(Shape("mesh", tuple(map(float, scale)), T, filename))
            else:
                raise RobotDescriptionError(f"{where}: unknown geometry <{tag}> (expected box, "
                                            f"cylinder, sphere or mesh)")
    return tuple(out)


_XACRO_TEXT = re.compile(r"\$\{|\$\(")


def _leftover_xacro(root: ET.Element) -> str | None:
    """Where the XML still holds xacro (an element in its namespace, a ``${…}``/``$(…)``)."""
    for element in root.iter():
        if element.tag.startswith("{") and element.tag[1:].split("}")[0] in XACRO_NAMESPACES:
            return f"<xacro:{_local(element.tag)}>"
        for key, value in element.attrib.items():
            if _XACRO_TEXT.search(value):
                owner = element.get("name", "")
                return f"{value!r} in <{_local(element.tag)}{' ' + owner if owner else ''}> " \
                       f"{key}"
    return None


def _joints(root: ET.Element, link_names: set[str], source: str) -> list[Joint]:
    joints: list[Joint] = []
    for el in root.findall("joint"):
        name, jtype = el.get("name"), el.get("type")
        if not name:
            raise RobotDescriptionError(f"{source}: a <joint> has no name")
        if jtype not in JOINT_TYPES:
            raise RobotDescriptionError(f"{source}: joint {name!r} has type {jtype!r}; "
                                        f"expected one of {', '.join(JOINT_TYPES)}")
        parent_el, child_el = el.find("parent"), el.find("child")
        if parent_el is None or child_el is None:
            raise RobotDescriptionError(
                f"{source}: joint {name!r} needs a name, a type, a <parent> and a <child>")
        parent, child = parent_el.get("link", ""), child_el.get("link", "")
        for ref in (parent, child):
            if ref not in link_names:
                raise RobotDescriptionError(
                    f"{source}: joint {name!r} names the link {ref!r}, which is not defined")
        if parent == child:
            raise RobotDescriptionError(f"{source}: joint {name!r} joins the link {parent!r} "
                                        f"to itself")
        try:
            xyz, rpy, _ = _origin_matrix(el, f"joint {name!r}")
            axis_el = el.find("axis")
            axis = _numbers(axis_el.get("xyz") if axis_el is not None else None, 3,
                            f"joint {name!r} axis", "1 0 0")
        except RobotDescriptionError as exc:
            raise RobotDescriptionError(f"{source}: {exc}") from None
        norm = float(np.linalg.norm(axis))
        if jtype in ("continuous", "revolute", "prismatic") and norm < 1e-9:
            raise RobotDescriptionError(f"{source}: joint {name!r} has axis {axis.tolist()}, "
                                        f"which is no direction")
        axis = axis / norm if norm > 0 else axis
        lower, upper, velocity = -math.inf, math.inf, math.inf
        limit = el.find("limit")
        if limit is not None:
            where = f"{source}: joint {name!r} <limit>"
            velocity = _number(limit, "velocity", where, math.inf)
            if jtype != "continuous":
                lower = _number(limit, "lower", where, 0.0 if jtype != "floating" else -math.inf)
                upper = _number(limit, "upper", where, 0.0 if jtype != "floating" else math.inf)
        mimic_el = el.find("mimic")
        mimic = mimic_el.get("joint", "") if mimic_el is not None else ""
        for a in (xyz, rpy, axis):
            a.flags.writeable = False
        joints.append(Joint(name, jtype, parent, child, xyz, rpy, axis, lower, upper,
                            velocity if velocity > 0 else math.inf, mimic))
    return joints


def _check_tree(joints: list[Joint], link_names: list[str], source: str) -> None:
    names = [j.name for j in joints]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise RobotDescriptionError(f"{source}: joints defined twice: {twice}")
    children = [j.child for j in joints]
    twice = sorted({c for c in children if children.count(c) > 1})
    if twice:
        raise RobotDescriptionError(f"{source}: links with two parents: {twice}")
    known = set(names)
    for j in joints:
        if j.mimic and j.mimic not in known:
            raise RobotDescriptionError(f"{source}: joint {j.name!r} mimics {j.mimic!r}, "
                                        f"which is not defined")
    parent_of = {j.child: j.parent for j in joints}
    for link in link_names:
        seen = {link}
        up = parent_of.get(link)
        while up is not None:
            if up in seen:
                raise RobotDescriptionError(f"{source}: the joints form a loop through the "
                                            f"link {link!r}; a URDF is a tree")
            seen.add(up)
            up = parent_of.get(up)


def _float_text(element: ET.Element | None, path: str) -> float | None:
    if element is None:
        return None
    found = element.find(path)
    if found is None or found.text is None:
        return None
    try:
        return float(found.text.strip())
    except ValueError:
        return None


def _sensors(root: ET.Element, link_names: set[str], notes: list[str]) -> list[SensorTag]:
    out: list[SensorTag] = []
    for block in root.findall("gazebo"):
        reference = block.get("reference", "")
        for sensor in block.findall("sensor"):
            stype = sensor.get("type", "")
            name = sensor.get("name", stype)
            if reference not in link_names:
                notes.append(f"Gazebo sensor {name!r} refers to {reference!r}, which is no "
                             f"link: left out")
                continue
            rate = _float_text(sensor, "update_rate") or 0.0
            pose_T = np.eye(4)
            pose = sensor.find("pose")
            if pose is not None and pose.text and pose.text.strip():
                try:
                    p = [float(v) for v in pose.text.split()]
                    if len(p) == 6:
                        pose_T[:3, :3] = _rotation(geometry.rpy_to_quaternion(*p[3:]))
                        pose_T[:3, 3] = p[:3]
                except ValueError:
                    notes.append(f"Gazebo sensor {name!r}: <pose> {pose.text!r} is not six "
                                 f"numbers: taken as zero")
            values: dict[str, float] = {}
            scan = sensor.find("ray") if sensor.find("ray") is not None else sensor.find("lidar")
            if scan is not None:
                for key, path in (("samples", "scan/horizontal/samples"),
                                  ("min_angle", "scan/horizontal/min_angle"),
                                  ("max_angle", "scan/horizontal/max_angle"),
                                  ("range_min", "range/min"), ("range_max", "range/max"),
                                  ("noise_std", "noise/stddev")):
                    v = _float_text(scan, path)
                    if v is not None:
                        values[key] = v
            imu = sensor.find("imu")
            if imu is not None:
                for key, path in (("gyro_noise_std", "angular_velocity/z/noise/stddev"),
                                  ("accel_noise_std", "linear_acceleration/x/noise/stddev")):
                    v = _float_text(imu, path)
                    if v is not None:
                        values[key] = v
            out.append(SensorTag(name, stype, reference, rate, pose_T,
                                 MappingProxyType(values)))
    return out


_PLUGIN_KEYS = {"leftjoint": "left_joint", "rightjoint": "right_joint",
                "wheelseparation": "wheel_separation", "wheeldiameter": "wheel_diameter"}


def _drive_plugin(root: ET.Element) -> dict[str, str]:
    """What a Gazebo differential-drive plugin (ROS 1 or ROS 2 spelling) declares."""
    for block in root.findall("gazebo"):
        for plugin in block.findall("plugin"):
            if "diff_drive" not in plugin.get("filename", "") and \
                    "diff_drive" not in plugin.get("name", ""):
                continue
            out: dict[str, str] = {}
            for child in plugin:
                key = _PLUGIN_KEYS.get(_local(child.tag).replace("_", "").lower())
                if key and child.text and key not in out:
                    out[key] = child.text.strip()
            return out
    return {}


def _strip_namespaces(root: ET.Element) -> None:
    for element in root.iter():
        if element.tag.startswith("{"):
            namespace, local = element.tag[1:].split("}", 1)
            if namespace not in XACRO_NAMESPACES:
                element.tag = local


def _manager(root: ET.Element, source: str) -> Any:
    """pytransform3d's transform manager of the tree (materials, floating and planar joints
    left out: the kit needs neither colours nor a robot's place in a world)."""
    from pytransform3d.urdf import UrdfException, UrdfTransformManager, parse_urdf

    copy = ET.fromstring(ET.tostring(root, encoding="unicode"))
    for parent in list(copy.iter()):
        for child in list(parent):
            if _local(child.tag) == "material":
                parent.remove(child)
    for joint in copy.findall("joint"):
        if joint.get("type") in ("floating", "planar"):
            copy.remove(joint)
    copy.set("name", copy.get("name") or "robot")
    try:
        _, links, joints = parse_urdf(ET.tostring(copy, encoding="unicode"))
    except (UrdfException, KeyError, ValueError) as exc:
        raise RobotDescriptionError(f"{source}: {exc}") from None
    tm = UrdfTransformManager(strict_check=False, check=False)
    for link in links:
        for frame, link_name, T in link.transforms:
            tm.add_transform(frame, link_name, T)
    kinds = {"continuous": "revolute", "revolute": "revolute", "prismatic": "prismatic",
             "fixed": "fixed"}
    for j in joints:
        limits = (0.0, 0.0) if j.joint_type == "fixed" else j.limits
        tm.add_joint(str(j.joint_name), str(j.child), str(j.parent), j.child2parent,
                     np.asarray(j.joint_axis, dtype=float), limits, kinds[str(j.joint_type)])
    return tm


def parse(text: str, source: str) -> Urdf:
    """Parse URDF XML into a :class:`Urdf`.

    Parameters
    ----------
    text : str
        The URDF, xacro already expanded.
    source : str
        Where it came from (a file, a bag's topic), for the error messages.

    Raises
    ------
    RobotDescriptionError
        Not well-formed XML, not a ``<robot>``, xacro left in it, a joint naming a link that
        is not defined, a link with two parents, numbers that are not numbers; the message
        names ``source`` and the link or joint.
    """
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise RobotDescriptionError(f"{source}: not well-formed XML ({exc})") from None
    _strip_namespaces(root)
    if root.tag != "robot":
        hint = " (an SDF model, not a URDF)" if root.tag == "sdf" else ""
        raise RobotDescriptionError(f"{source}: the root element is <{root.tag}>, not "
                                    f"<robot>{hint}")
    leftover = _leftover_xacro(root)
    if leftover is not None:
        raise RobotDescriptionError(
            f"{source}: still holds xacro ({leftover}); expand it first (kit.robots.load and "
            f"kit.description_files.read_urdf do when the file uses xacro)")
    link_elements = root.findall("link")
    if not link_elements:
        raise RobotDescriptionError(f"{source}: no <link> elements: this file describes no "
                                    f"robot (is it one that other files include?)")
    links: list[Link] = []
    for el in link_elements:
        name = el.get("name")
        if not name:
            raise RobotDescriptionError(f"{source}: a <link> has no name")
        try:
            mass_el = el.find("inertial/mass")
            mass = _number(mass_el, "value", f"link {name!r} mass", 0.0) \
                if mass_el is not None else 0.0
            links.append(Link(name, mass, _shapes(el, "collision", name),
                              _shapes(el, "visual", name)))
        except RobotDescriptionError as exc:
            raise RobotDescriptionError(f"{source}: {exc}") from None
    names = [link.name for link in links]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise RobotDescriptionError(f"{source}: links defined twice: {twice}")
    joints = _joints(root, set(names), source)
    _check_tree(joints, names, source)
    notes = [f"joint {j.name!r} is {j.type}: it places the robot in a world, and is left out"
             for j in joints if j.type in ("floating", "planar")]
    joints = [j for j in joints if j.type not in ("floating", "planar")]
    sensors = _sensors(root, set(names), notes)
    return Urdf(root.get("name", ""), source, tuple(links), tuple(joints), tuple(sensors),
                _drive_plugin(root), tuple(notes), _manager(root, source))
