"""What a URDF's structure says about a differential-drive robot: its wheels, their radius
and separation, its outline and where its lidar and IMU sit.

Nothing here goes by the names of joints (one robot calls its wheel joint
``right_wheel_joint``, the next ``wheel_right_joint``, a third ``drivewhl_r_joint``); it goes by
the composed kinematic tree (:class:`kit.urdf.Urdf`), in the base frame, REP-103: x forward,
y left, z up.

Drive wheels (:func:`find_wheels`) are joints that

* turn without end: ``continuous``, or ``revolute`` with at least one turn between its limits;
* turn about the base's y axis (within 15°), whatever the joint's own frame says: the
  TurtleBot 3's wheel axis is z in a frame rolled by −1.57 rad, which is y in ``base_link``;
* are driven: not ``mimic`` joints, and not under a joint that swivels about the vertical (a
  caster's wheel);
* stand one on either side, at y > 0 (left) and y < 0 (right), composed from the root: the
  TurtleBot 4's wheel joints hang under spring-loaded ``wheel_drop_*`` joints, at y = 0 in
  their own frames.

Several candidates on a side are settled by the Gazebo drive plugin's joint names, then by the
only mirror-image pair, then by the larger wheels; otherwise the message lists them.

The wheel radius is the depth of the wheel link's lowest point below the axle (its collision
shapes, else its visual ones): a cylinder's radius when it lies along the axle, a sphere's
radius, a box's half height, a mesh's lowest vertex. The separation is the distance along y
between the two wheel joints' composed origins.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from kit.urdf import Joint, RobotDescriptionError, SensorTag, Shape, Urdf

__all__ = ["LIDAR_TYPES", "MeshReader", "Mount", "Wheels", "base_frame", "find_imu",
           "find_lidar", "find_wheels", "footprint", "named_wheels"]

FloatArray = NDArray[np.float64]
MeshReader = Callable[[Shape], FloatArray]
"""Given a mesh shape, its (N, 3) vertices in the shape's frame [m] (scale applied), or a
:class:`~kit.urdf.RobotDescriptionError` saying what is missing to read it."""

LIDAR_TYPES = ("ray", "gpu_ray", "lidar", "gpu_lidar")
"""Gazebo sensor types of a scanning range finder."""

_ALONG = math.cos(math.radians(15.0))
_LIDAR_NAME = re.compile(r"lidar|laser|scan|lds|hokuyo|sick|urg|velodyne|ouster", re.I)
_NOT_LIDAR = re.compile(r"camera|depth|cliff|sonar|optical|rgb|ir_", re.I)
_IMU_NAME = re.compile(r"imu", re.I)


@dataclass(frozen=True, eq=False)
class Wheels:
    """The two drive wheels, in the base frame.

    ``right_position``/``left_position`` are the wheel joints' composed origins (3,) [m];
    ``axle`` the midpoint of the two in the plane (2,) [m]; ``radius`` and ``separation`` [m];
    ``notes`` say how each was found.
    """

    right: str
    left: str
    right_position: FloatArray
    left_position: FloatArray
    radius: float
    separation: float
    axle: FloatArray
    notes: tuple[str, ...]


@dataclass(frozen=True)
class Mount:
    """A sensor found in the URDF: its frame, planar pose in the base frame ``(x, y, yaw)``,
    the Gazebo sensor that models it (None if found by name) and how it was found."""

    frame: str
    pose: tuple[float, float, float]
    sensor: SensorTag | None
    how: str


def base_frame(urdf: Urdf) -> str:
    """The robot's body frame: ``base_link`` (also with a namespace prefix such as
    ``tb3_0/base_link``), else ``base_footprint``, else the root link."""
    names = [link.name for link in urdf.links]
    for wanted in ("base_link", "base_footprint"):
        if wanted in names:
            return wanted
        suffixed = [n for n in names if n.endswith(wanted)]
        if len(suffixed) == 1:
            return suffixed[0]
    roots = urdf.roots()
    if len(roots) != 1:
        raise RobotDescriptionError(f"{urdf.source}: {len(roots)} separate trees "
                                    f"(roots {roots}) and no base_link to choose one")
    return roots[0]


def _axis_in(urdf: Urdf, joint: Joint, base: str) -> FloatArray:
    R = urdf.transform(joint.child, base)[:3, :3]
    return np.asarray(R @ joint.axis, dtype=np.float64)


def _origin_in(urdf: Urdf, joint: Joint, base: str) -> FloatArray:
    return np.asarray(urdf.transform(joint.child, base)[:3, 3], dtype=np.float64)


def _turns_freely(joint: Joint) -> bool:
    return joint.type == "continuous" or (
        joint.type == "revolute" and joint.upper - joint.lower >= 2 * math.pi - 1e-6)


def _between(urdf: Urdf, base: str, link: str) -> list[Joint]:
    """The joints from the common ancestor of ``base`` and ``link`` down to ``link``."""
    above = {j.name for j in urdf.chain(base)}
    return [j for j in urdf.chain(link) if j.name not in above]


def _swivel(urdf: Urdf, base: str, joint: Joint) -> Joint | None:
    for j in _between(urdf, base, joint.child)[:-1]:
        if j.type in ("continuous", "revolute") and abs(_axis_in(urdf, j, base)[2]) > _ALONG:
            return j
    return None


def _describe(urdf: Urdf, joint: Joint, base: str) -> str:
    a, p = _axis_in(urdf, joint, base), _origin_in(urdf, joint, base)
    return (f"{joint.name!r} ({joint.type}, axis ({a[0]:+.2f}, {a[1]:+.2f}, {a[2]:+.2f}) at "
            f"({p[0]:+.3f}, {p[1]:+.3f}, {p[2]:+.3f}))")


def _shape_points(shape: Shape, T: FloatArray, reader: MeshReader | None,
                  n: int = 16) -> FloatArray:
    """Points (M, 3) in the base frame that bound the shape (T = T_base_shape): a box's
    corners, a cylinder's rims, a sphere's equator and poles, a mesh's vertices."""
    if shape.kind == "box":
        half = np.asarray(shape.dimensions) / 2.0
        local = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)],
                         dtype=float) * half
    elif shape.kind == "cylinder":
        r, length = shape.dimensions
        a = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
        rim = np.column_stack([r * np.cos(a), r * np.sin(a), np.zeros(n)])
        lid = np.array([0.0, 0.0, length / 2])
        local = np.vstack([rim + lid, rim - lid])
    elif shape.kind == "sphere":
        r = shape.dimensions[0]
        a = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
        local = np.vstack([np.column_stack([r * np.cos(a), r * np.sin(a), np.zeros(n)]),
                           [[0, 0, r], [0, 0, -r]]])
        return np.asarray(local + T[:3, 3], dtype=np.float64)  # a sphere turns into itself
    else:
        if reader is None:
            raise RobotDescriptionError(f"mesh {shape.filename!r}: no way to read meshes given")
        local = reader(shape)
    return np.asarray(local @ T[:3, :3].T + T[:3, 3], dtype=np.float64)


def _depth(shape: Shape, T: FloatArray, reader: MeshReader | None) -> float:
    """How far the shape reaches below its frame's origin along the base's −z [m], exactly
    for the primitives."""
    R, down = T[:3, :3], np.array([0.0, 0.0, -1.0])
    if shape.kind == "sphere":
        reach = shape.dimensions[0]
    elif shape.kind == "cylinder":
        r, length = shape.dimensions
        c = abs(float(R[:, 2] @ down))
        reach = r * math.sqrt(max(0.0, 1.0 - c * c)) + length / 2 * c
    elif shape.kind == "box":
        reach = float(sum(h / 2 * abs(float(R[:, i] @ down))
                          for i, h in enumerate(shape.dimensions)))
    else:
        points = _shape_points(shape, T, reader)
        return float(T[2, 3] - np.min(points[:, 2]))
    return reach


def _wheel_radius(urdf: Urdf, joint: Joint, base: str,
                  reader: MeshReader | None) -> tuple[float, str]:
    """The wheel's rolling radius: over the shapes of its link and the links fixed to it (a
    tyre may be a link of its own), the farthest reach below the axle."""
    link = urdf.link(joint.child)
    rigid = [urdf.link(name) for name in _rigid_links(urdf, link.name)]
    axle = _origin_in(urdf, joint, base)
    axis = _axis_in(urdf, joint, base)
    for kind in ("collision", "visual"):
        shapes = [(part.name, shape) for part in rigid
                  for shape in (part.collision if kind == "collision" else part.visual)]
        if not shapes:
            continue
        radii: list[float] = []
        words: list[str] = []
        problems: list[str] = []
        for i, (owner, shape) in enumerate(shapes):
            T = urdf.transform(owner, base) @ shape.origin
            offset = T[:3, 3] - axle
            off_axle = float(np.linalg.norm(offset - (offset @ axis) * axis))
            label = f"{owner}'s {kind} {shape.kind}" + (f" {i}" if len(shapes) > 1 else "")
            if shape.kind == "cylinder" and abs(float(T[:3, 2] @ axis)) >= _ALONG:
                radii.append(shape.dimensions[0] + off_axle)
            elif shape.kind == "sphere":
                radii.append(shape.dimensions[0] + off_axle)
            else:
                try:
                    radii.append(float(axle[2] - (T[2, 3] - _depth(shape, T, reader))))
                except RobotDescriptionError as exc:
                    problems.append(str(exc))
                    continue
                if shape.kind == "cylinder":
                    label += (f" lying across the axle (radius {shape.dimensions[0]:g}, length "
                              f"{shape.dimensions[1]:g}): its depth below the axle")
                else:
                    label += "'s depth below the axle"
            words.append(label)
        if radii:
            radius = max(radii)
            if radius <= 0:
                raise RobotDescriptionError(
                    f"{urdf.source}: the {kind} geometry of wheel link {link.name!r} does not "
                    f"reach below its axle (joint {joint.name!r}); expected a wheel around it")
            return radius, ", ".join(words)
        raise RobotDescriptionError(
            f"{urdf.source}: wheel link {link.name!r} (joint {joint.name!r}) has only meshes "
            f"as {kind} geometry, and they cannot be read: {'; '.join(problems)}; or give the "
            f"radius as [wheels] radius in a parameter file")
    raise RobotDescriptionError(
        f"{urdf.source}: wheel link {link.name!r} (joint {joint.name!r}) has no collision or "
        f"visual geometry to take the wheel radius from; expected a cylinder (or give the "
        f"radius as [wheels] radius in a parameter file)")


def _pair(urdf: Urdf, base: str, right: Joint, left: Joint, reader: MeshReader | None,
          notes: list[str], radius: float | None) -> Wheels:
    pr, pl = _origin_in(urdf, right, base), _origin_in(urdf, left, base)
    if radius is None:
        (rr, how_r), (rl, how_l) = (_wheel_radius(urdf, right, base, reader),
                                    _wheel_radius(urdf, left, base, reader))
        if abs(rr - rl) > 1e-3:
            notes.append(f"the wheels' radii differ ({rr:.4f} m right, {rl:.4f} m left): their "
                         f"mean taken")
        radius = round((rr + rl) / 2, 9)
        notes.append(f"radius {radius:g} m from {how_l}" + (
            "" if how_l.split("'s ", 1)[-1] == how_r.split("'s ", 1)[-1] else f"; {how_r}"))
    else:
        notes.append(f"radius {radius:g} m from the parameter file")
    if abs(pr[0] - pl[0]) > 1e-3:
        notes.append(f"the wheels are not abreast: x = {pr[0]:+.3f} m right, {pl[0]:+.3f} m "
                     f"left; the separation is taken along y")
    separation = round(float(pl[1] - pr[1]), 9)
    axle = np.array([(pr[0] + pl[0]) / 2, (pr[1] + pl[1]) / 2])
    notes.append(f"separation {separation:g} m between the composed origins of {right.name!r} "
                 f"(y = {pr[1]:+.4f}) and {left.name!r} (y = {pl[1]:+.4f})")
    if np.hypot(*axle) > 1e-3:
        notes.append(f"{base} is not on the axle: the wheels' midpoint is at "
                     f"({axle[0]:+.3f}, {axle[1]:+.3f}) m")
    for a in (pr, pl, axle):
        a.flags.writeable = False
    return Wheels(right.name, left.name, pr, pl, radius, separation, axle, tuple(notes))


def named_wheels(urdf: Urdf, base: str, right: str, left: str,
                 reader: MeshReader | None = None, radius: float | None = None) -> Wheels:
    """The wheels named ``right`` and ``left``, checked: they turn about the base's y axis,
    the right one at y < 0 and the left at y > 0 (REP-103: y points left)."""
    joints = {j.name: j for j in urdf.joints}
    for needed in (right, left):
        if needed not in joints:
            raise RobotDescriptionError(f"{urdf.source}: no joint named {needed!r}")
    jr, jl = joints[right], joints[left]
    pr, pl = _origin_in(urdf, jr, base), _origin_in(urdf, jl, base)
    if not pr[1] < 0 < pl[1]:
        raise RobotDescriptionError(
            f"{urdf.source}: the right wheel must be at negative y and the left at positive y "
            f"(REP-103: y points left); in {base}, composed from the root, the right wheel "
            f"{right!r} is at y={pr[1]:.6g} and the left wheel {left!r} at y={pl[1]:.6g}")
    for j in (jr, jl):
        if abs(_axis_in(urdf, j, base)[1]) < _ALONG:
            raise RobotDescriptionError(
                f"{urdf.source}: wheel joint {_describe(urdf, j, base)} does not turn about "
                f"{base}'s y axis; a wheel of a REP-103 base (x forward, y left) does")
    return _pair(urdf, base, jr, jl, reader, [f"wheels named {right!r} and {left!r}"], radius)


def _rep103_diagnosis(urdf: Urdf, base: str, turning: list[Joint]) -> str:
    """A sentence for wheels that exist but are not where REP-103 puts them."""
    along_x = [j for j in turning if abs(_axis_in(urdf, j, base)[0]) > _ALONG]
    xs = [_origin_in(urdf, j, base)[0] for j in along_x]
    if along_x and min(xs) < -1e-3 < 1e-3 < max(xs):
        return (f"; {', '.join(repr(j.name) for j in along_x)} turn about {base}'s x axis and "
                f"stand at x = {min(xs):+.3f} and {max(xs):+.3f}: this base drives along y, but "
                f"REP-103 has x forward and y left — turn {base} by 90° about z")
    along_z = [j for j in turning if abs(_axis_in(urdf, j, base)[2]) > _ALONG]
    if along_z and len(along_z) == len(turning):
        return (f"; every such joint turns about {base}'s z axis: is the base frame z up "
                f"(REP-103)?")
    return ""


def _candidates(urdf: Urdf, base: str, turning: list[Joint], notes: list[str]) -> list[Joint]:
    """The joints that could be drive wheels; why each other one is not goes into notes."""
    out: list[Joint] = []
    for j in turning:
        if abs(_axis_in(urdf, j, base)[1]) < _ALONG:
            continue
        if j.mimic:
            notes.append(f"{j.name!r} mimics {j.mimic!r}: not a drive wheel")
            continue
        swivel = _swivel(urdf, base, j)
        if swivel is not None:
            notes.append(f"{j.name!r} hangs under {swivel.name!r}, which swivels about the "
                         f"vertical: a caster, not a drive wheel")
            continue
        if abs(_origin_in(urdf, j, base)[1]) < 1e-3:
            notes.append(f"{j.name!r} is on the centre line (y = 0): not a drive wheel")
            continue
        out.append(j)
    return out


def find_wheels(urdf: Urdf, base: str, reader: MeshReader | None = None,
                radius: float | None = None) -> Wheels:
    """The two drive wheels, found by structure (see the module's text).

    Raises
    ------
    RobotDescriptionError
        No such pair, or several that nothing settles; the message names the file, the
        joints looked at and what was expected.
    """
    notes: list[str] = []
    turning = [j for j in urdf.joints if _turns_freely(j)]
    candidates = _candidates(urdf, base, turning, notes)
    lefts = [j for j in candidates if _origin_in(urdf, j, base)[1] > 0]
    rights = [j for j in candidates if _origin_in(urdf, j, base)[1] < 0]
    if not lefts or not rights:
        seen = "; ".join(_describe(urdf, j, base) for j in turning) or "none"
        raise RobotDescriptionError(
            f"{urdf.source}: no pair of drive wheels: expected two continuous joints (or "
            f"revolute ones with a full turn of range) turning about {base}'s y axis, one at "
            f"y > 0 (left) and one at y < 0 (right), neither a mimic nor a caster's; joints "
            f"that turn: {seen}" + (f"; left out: {'; '.join(notes)}" if notes else "")
            + _rep103_diagnosis(urdf, base, turning))
    for j in rights + lefts:
        side = "left" if j in lefts else "right"
        other = "right" if side == "left" else "left"
        if re.search(other, j.name, re.I) and not re.search(side, j.name, re.I):
            notes.append(f"{j.name!r} is at y = {_origin_in(urdf, j, base)[1]:+.3f} m: the "
                         f"{side} wheel in REP-103 (y left), though its name says {other}")
    if len(lefts) == 1 and len(rights) == 1:
        return _pair(urdf, base, rights[0], lefts[0], reader, notes, radius)
    plugin = urdf.drive_plugin
    named = [j for j in candidates if j.name in (plugin.get("left_joint"),
                                                    plugin.get("right_joint"))]
    chosen_l = [j for j in named if j in lefts]
    chosen_r = [j for j in named if j in rights]
    if len(chosen_l) == 1 and len(chosen_r) == 1:
        notes.append("the pair the Gazebo drive plugin names")
        return _pair(urdf, base, chosen_r[0], chosen_l[0], reader, notes, radius)
    pairs = []
    for jl in lefts:
        for jr in rights:
            pl, pr = _origin_in(urdf, jl, base), _origin_in(urdf, jr, base)
            tol = max(0.005, 0.05 * (pl[1] - pr[1]))
            if abs(pl[0] - pr[0]) <= tol and abs(pl[1] + pr[1]) <= tol:
                pairs.append((jr, jl))
    if len(pairs) == 1:
        notes.append("the only mirror-image pair")
        return _pair(urdf, base, pairs[0][0], pairs[0][1], reader, notes, radius)
    if len(pairs) > 1:
        sizes = []
        for _, jl in pairs:
            try:
                sizes.append(_wheel_radius(urdf, jl, base, reader)[0])
            except RobotDescriptionError:
                sizes.append(-1.0)
        order = np.argsort(sizes)[::-1]
        if sizes[order[0]] > sizes[order[1]] + 1e-3:
            jr, jl = pairs[order[0]]
            notes.append(f"the largest of {len(pairs)} mirror-image pairs of wheels")
            return _pair(urdf, base, jr, jl, reader, notes, radius)
    listing = ", ".join(_describe(urdf, j, base) for j in rights + lefts)
    raise RobotDescriptionError(
        f"{urdf.source}: cannot tell which wheels drive: {len(rights)} on the right and "
        f"{len(lefts)} on the left ({listing}); the kit models a two-wheel differential drive: "
        f"name the driven two in a parameter file ([wheels] right_joint and left_joint)")


def _rigid_links(urdf: Urdf, base: str) -> list[str]:
    """The links fixed to ``base`` (through fixed joints, up or down the tree)."""
    neighbours: dict[str, list[str]] = {}
    for j in urdf.joints:
        if j.type == "fixed":
            neighbours.setdefault(j.parent, []).append(j.child)
            neighbours.setdefault(j.child, []).append(j.parent)
    out, todo = [base], [base]
    while todo:
        for other in neighbours.get(todo.pop(), []):
            if other not in out:
                out.append(other)
                todo.append(other)
    return out


def footprint(urdf: Urdf, base: str, wheels: Wheels,
              reader: MeshReader | None = None) -> tuple[FloatArray, str]:
    """The robot's outline in the base frame (N, 2) [m], counter-clockwise, and how it was
    made: the convex hull of the ground-plane projection of the collision shapes of the links
    fixed to the base and of the two wheels (visual shapes where no link of the body has
    collision ones); with no shapes at all, a 16-gon of radius separation/2 + wheel radius."""
    from scipy.spatial import ConvexHull, QhullError

    body = _rigid_links(urdf, base)
    links = [*body, *_rigid_links(urdf, urdf.joint(wheels.right).child),
             *_rigid_links(urdf, urdf.joint(wheels.left).child)]
    kind = "collision" if any(urdf.link(n).collision for n in body) else "visual"
    points: list[FloatArray] = []
    skipped: list[str] = []
    for name in links:
        link = urdf.link(name)
        T_link = urdf.transform(name, base)
        for shape in link.collision if kind == "collision" else link.visual:
            try:
                points.append(_shape_points(shape, T_link @ shape.origin, reader)[:, :2])
            except RobotDescriptionError:
                skipped.append(f"{name} ({shape.filename})")
    how = f"the convex hull of the {kind} shapes of {len(body)} links fixed to {base} and the " \
          f"two wheels"
    if skipped:
        how += f"; meshes that could not be read left out: {', '.join(skipped)}"
    if points:
        cloud = np.vstack(points)
        try:
            hull = ConvexHull(cloud)
            polygon = cloud[hull.vertices]
            if hull.volume > 1e-6:
                polygon = np.round(polygon, 9)
                polygon.flags.writeable = False
                return polygon, how
        except QhullError:
            pass
    radius = wheels.separation / 2 + wheels.radius
    a = np.linspace(0.0, 2 * math.pi, 16, endpoint=False)
    polygon = radius * np.column_stack([np.cos(a), np.sin(a)]) + wheels.axle
    polygon.flags.writeable = False
    return polygon, (f"assumed: no {kind} shapes outline the body, so a 16-gon of radius "
                     f"{radius:.3f} m (half the separation plus a wheel radius) round the axle")


def _sensor_frame(urdf: Urdf, base: str, link: str, sensor: SensorTag | None) -> FloatArray:
    return urdf.transform(link, base) @ (sensor.pose if sensor is not None else np.eye(4))


def _level(urdf: Urdf, base: str, link: str, sensor: SensorTag | None = None) -> bool:
    """Whether the frame's x-y plane (a planar lidar's scan plane) is level in the base."""
    return abs(float(_sensor_frame(urdf, base, link, sensor)[2, 2])) > _ALONG


def _mount(urdf: Urdf, base: str, link: str, sensor: SensorTag | None, how: str) -> Mount:
    T = _sensor_frame(urdf, base, link, sensor)
    pose = (round(float(T[0, 3]), 9), round(float(T[1, 3]), 9),
            round(math.atan2(T[1, 0], T[0, 0]), 9))
    if T[2, 2] < 0:
        how += " (mounted upside down: the kit's planar lidar takes it as upright)"
    return Mount(link, pose, sensor, how)


def find_lidar(urdf: Urdf, base: str, frame: str | None = None,
               given_by: str = "the parameter file") -> Mount | None:
    """The planar lidar: the link named ``frame`` if given (by ``given_by``); else the Gazebo
    ray/lidar sensor with the most beams whose scan plane is level (20 beams or more, not a
    cliff, IR or sonar sensor: the Kobuki's cliff sensors are 50-beam rays pointing down); else
    the first level link whose name says lidar, laser or scan. None if there is none."""
    if frame is not None:
        if not urdf.has_link(frame):
            raise RobotDescriptionError(f"{urdf.source}: the lidar frame {frame!r} of "
                                        f"{given_by} is no link of the URDF")
        tags = [s for s in urdf.sensors if s.link == frame and s.type in LIDAR_TYPES]
        return _mount(urdf, base, frame, tags[0] if tags else None, f"{given_by}'s frame_id")
    scanners = [s for s in urdf.sensors if s.type in LIDAR_TYPES and
                s.values.get("samples", 0) >= 20 and not _NOT_LIDAR.search(s.name + s.link)
                and _level(urdf, base, s.link, s)]
    if scanners:
        best = max(scanners, key=lambda s: s.values.get("samples", 0))
        return _mount(urdf, base, best.link, best,
                      f"the Gazebo {best.type} sensor {best.name!r}")
    for link in urdf.links:
        if _LIDAR_NAME.search(link.name) and not _NOT_LIDAR.search(link.name) and \
                link.name != base and _level(urdf, base, link.name):
            return _mount(urdf, base, link.name, None, "its link's name")
    return None


def find_imu(urdf: Urdf, base: str) -> Mount | None:
    """The IMU: the Gazebo ``imu`` sensor's link, else the first link named ``*imu*``."""
    for s in urdf.sensors:
        if s.type == "imu":
            return _mount(urdf, base, s.link, s, f"the Gazebo imu sensor {s.name!r}")
    for link in urdf.links:
        if _IMU_NAME.search(link.name) and not _NOT_LIDAR.search(link.name):
            return _mount(urdf, base, link.name, None, "its link's name")
    return None
