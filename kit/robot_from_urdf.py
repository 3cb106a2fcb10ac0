"""A robot built from its own URDF: what the description holds, then a parameter file, then
the stated defaults (:data:`kit.robots.DEFAULTS`), each use of which is listed.

:func:`build` is what :func:`kit.robots.load` runs for a ``.urdf``/``.xacro`` file or a bag;
the structure (wheels, outline, sensors) comes from :mod:`kit.robot_structure`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from kit import robot_structure, urdf
from kit.robots import (
    DEFAULTS,
    RobotDescription,
    _cruise_velocity,
    _footprint,
    _is_positive,
    _mesh_reader,
    _require,
)
from kit.urdf import RobotDescriptionError, Urdf

__all__ = ["build"]


class _Sourced:
    """Values taken from a parameter file, else the description, else a stated default;
    each use of a default is listed."""

    def __init__(self, params: dict[str, Any], where: str) -> None:
        self.params, self.where = params, where
        self.found: list[str] = []
        self.assumed: list[str] = []

    def number(self, section: str, key: str, found: float | None = None, how: str = "",
               default: float | None = None, why: str = "") -> float:
        table = self.params.get(section, {}) if section else self.params
        if not isinstance(table, dict):
            raise RobotDescriptionError(f"{self.where}: [{section}] must be a table")
        if key in table:
            value = table[key]
            if not _is_positive(value):
                where = f"[{section}] " if section else ""
                raise RobotDescriptionError(f"{self.where}: {where}{key} must be a positive "
                                            f"number; got {value!r}")
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


def _wheels(model: Urdf, base: str, params: dict[str, Any], where: str,
            reader: Any) -> robot_structure.Wheels:
    """The drive wheels: named in ``[wheels]``, else found by structure."""
    wheel_keys = params.get("wheels", {})
    radius = wheel_keys.get("radius")
    if radius is not None and not _is_positive(radius):
        raise RobotDescriptionError(f"{where}: [wheels] radius must be a positive number; "
                                    f"got {radius!r}")
    if "right_joint" in wheel_keys or "left_joint" in wheel_keys:
        return robot_structure.named_wheels(
            model, base, str(_require(params, "wheels", "right_joint", Path(where))),
            str(_require(params, "wheels", "left_joint", Path(where))), reader, radius)
    return robot_structure.find_wheels(model, base, reader, radius)


def _plugin_notes(model: Urdf, wheels: robot_structure.Wheels) -> list[str]:
    """Where a Gazebo drive plugin's own figures disagree with the geometry."""
    notes = []
    for key, mine in (("wheel_separation", wheels.separation),
                      ("wheel_diameter", 2 * wheels.radius)):
        try:
            theirs = float(model.drive_plugin[key])
        except (KeyError, ValueError):
            continue
        if abs(theirs - mine) > 1e-3:
            notes.append(f"note: the Gazebo drive plugin says {key} {theirs:g} m; the joints "
                         f"and wheel shapes say {mine:g} m (the kit takes the geometry)")
    return notes


def _drive(model: Urdf, wheels: robot_structure.Wheels, params: dict[str, Any],
           s: _Sourced) -> dict[str, float]:
    """Speed and acceleration limits, encoder and counter: the parameter file, the wheel
    joints' velocity limits, the defaults — never faster than the wheels allow."""
    nav2 = "Nav2's stock controller parameters"
    drive = DEFAULTS["drive"]
    out = {"max_linear_velocity": s.number("drive", "max_linear_velocity",
                                           default=drive["max_linear_velocity"],
                                           why=nav2 + ", DWB max_vel_x"),
           "max_angular_velocity": s.number("drive", "max_angular_velocity",
                                            default=drive["max_angular_velocity"],
                                            why=nav2 + ", DWB max_vel_theta"),
           "max_linear_acceleration": s.number("drive", "max_linear_acceleration",
                                               default=drive["max_linear_acceleration"],
                                               why=nav2 + ", DWB acc_lim_x")}
    limits = [model.joint(n).velocity for n in (wheels.right, wheels.left)]
    out["max_wheel_speed"] = speed = s.number(
        "drive", "max_wheel_speed",
        found=min(limits) if all(math.isfinite(v) for v in limits) else None,
        how="the wheel joints' <limit velocity>",
        default=round((out["max_linear_velocity"] + out["max_angular_velocity"] *
                       wheels.separation / 2) / wheels.radius, 9),
        why="enough for the top linear and angular speeds together")
    tops = {"max_linear_velocity": round(speed * wheels.radius, 9),
            "max_angular_velocity": round(2 * speed * wheels.radius / wheels.separation, 9)}
    for key, top in tops.items():
        if key not in params.get("drive", {}) and out[key] > top:
            out[key] = top
            s.assumed = [a for a in s.assumed if not a.startswith(key + " ")]
            s.assumed.append(f"{key} {top:g}: the wheels' top speed ({speed:g} rad/s) allows "
                             f"no more than the default")
    out["gear_ratio"] = s.number("drive", "gear_ratio", default=drive["gear_ratio"],
                                 why="encoder counts taken at the wheel")
    out["encoder_resolution"] = s.number("drive", "encoder_resolution",
                                         default=drive["encoder_resolution"],
                                         why="a 12-bit encoder on the wheel")
    out["counter_bits"] = s.number("drive", "counter_bits", default=drive["counter_bits"])
    return out


def _outline(model: Urdf, base: str, wheels: robot_structure.Wheels, params: dict[str, Any],
             where: str, reader: Any, s: _Sourced) -> Any:
    if "footprint" in params:
        return _footprint(params, where)
    outline, how = robot_structure.footprint(model, base, wheels, reader)
    if how.startswith("assumed"):
        s.assumed.append(f"footprint: {how[len('assumed: '):]}")
    else:
        s.found.append(f"footprint {np.ptp(outline[:, 0]):.3f} x {np.ptp(outline[:, 1]):.3f} m "
                       f"from {how}")
    return outline


def build(text: str, label: str, source: Path, params: dict[str, Any], where: str,
          found: list[str], scan: dict[str, Any],
          package_paths: Mapping[str, str | Path]) -> RobotDescription:
    """A robot from its own URDF ``text`` (from ``label``): structure, then the parameter
    file ``params`` (from ``where``), then defaults; ``scan`` is a bag's lidar model."""
    model = urdf.parse(text, label)
    base = str(params.get("base_frame") or robot_structure.base_frame(model))
    if not model.has_link(base):
        raise RobotDescriptionError(f"{where}: base_frame {base!r} is no link of {label}")
    reader = _mesh_reader(source if source.is_file() else None, package_paths)
    wheels = _wheels(model, base, params, where, reader)
    s = _Sourced(params, where)
    s.found.extend([*found, *model.notes, f"base frame {base}",
                    f"drive wheels {wheels.right!r} (right) and {wheels.left!r} (left)",
                    *wheels.notes, *_plugin_notes(model, wheels)])
    drive = _drive(model, wheels, params, s)
    links_mass = float(sum(link.mass for link in model.links))
    mass = s.number("", "mass", found=links_mass if links_mass > 0 else None,
                    how="the links' <inertial> masses", default=DEFAULTS["mass"]["mass"],
                    why="the URDF gives no masses")
    odometry_k = (s.number("odometry", "k_right", default=DEFAULTS["odometry"]["k_right"],
                           why="rubber wheels on an indoor floor, as the Uiabot's"),
                  s.number("odometry", "k_left", default=DEFAULTS["odometry"]["k_left"]))
    outline = _outline(model, base, wheels, params, where, reader, s)
    sensors: dict[str, Any] = {name: dict(value) for name, value in
                               params.get("sensors", {}).items() if isinstance(value, dict)}
    sensors["lidar"] = _lidar(model, base, params, scan, s)
    imu = _imu(model, base, params, s)
    if imu is not None:
        sensors["imu"] = imu
    return RobotDescription(
        name=str(params.get("name") or model.name or source.stem),
        description=str(params.get("description", f"robot {model.name!r} from {label}")),
        source=source, links=model.links, joints=model.joints,
        wheel_radius=wheels.radius, wheel_separation=wheels.separation,
        gear_ratio=drive["gear_ratio"], encoder_resolution=int(drive["encoder_resolution"]),
        counter_bits=int(drive["counter_bits"]), max_wheel_speed=drive["max_wheel_speed"],
        max_linear_velocity=drive["max_linear_velocity"],
        max_angular_velocity=drive["max_angular_velocity"],
        max_linear_acceleration=drive["max_linear_acceleration"],
        cruise_velocity=_cruise_velocity(params, where, drive["max_linear_velocity"]),
        mass=mass, footprint=outline, odometry_k=odometry_k,
        sensors=MappingProxyType({k: MappingProxyType(v) for k, v in sensors.items()}),
        parameters=MappingProxyType(params), base_frame=base,
        wheel_joints=(wheels.right, wheels.left), axle=wheels.axle,
        found=tuple(s.found), assumed=tuple(s.assumed))
