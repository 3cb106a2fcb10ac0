"""A layered costmap as Nav2's ``costmap_2d`` builds it, configured with Nav2's parameters.

``load_costmap_params("nav2_params.yaml")`` reads the ``global_costmap`` (or any named)
section of a Nav2 parameter file as it is; :class:`LayeredCostmap` combines the layers in
their ``plugins`` order into one grid each :meth:`~LayeredCostmap.update`:

1. start from unknown (``track_unknown_space``) or free;
2. the static layer overwrites everything with the map's costs (``use_maximum``: keeps the
   larger);
3. an obstacle layer combines its marks and clearings (``combination_method`` 0 overwrite,
   1 maximum, 2 maximum without overwriting unknown);
4. the inflation layer inflates what is there;
5. then the filters: the keep-out mask raises costs (not inflated, as in Nav2).

The footprint is ``footprint`` when given, else a 16-point circle of ``robot_radius``, padded
by ``footprint_padding``; its inscribed radius feeds the inflation. Plugins the kit does not
model (a voxel layer, the speed filter, ...) are listed in ``CostmapParams.ignored``.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs, robots
from kit.planning._costmap import (
    FREE_SPACE,
    NO_INFORMATION,
    Costmap,
    apply_keepout,
    footprint_from_radius,
    footprint_radii,
    inflate,
    pad_footprint,
    static_layer,
)
from kit.planning._obstacle import ObservationSource, ObstacleLayer, cells_in_polygon

__all__ = [
    "CostmapParams",
    "InflationLayerParams",
    "KeepoutFilterParams",
    "LayeredCostmap",
    "ObstacleLayerParams",
    "StaticLayerParams",
    "costmap_from_map",
    "load_costmap_params",
    "robot_footprint",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class StaticLayerParams:
    name: str = "static_layer"
    enabled: bool = True


@dataclass(frozen=True)
class ObstacleLayerParams:
    name: str = "obstacle_layer"
    enabled: bool = True
    footprint_clearing_enabled: bool = True
    combination_method: int = 1
    observation_sources: tuple[ObservationSource, ...] = ()

    def __post_init__(self) -> None:
        if self.combination_method not in (0, 1, 2):
            raise ValueError(f"{self.name}.combination_method must be 0 (overwrite), 1 (max) or "
                             f"2 (max without unknown overwrite); got {self.combination_method}")


@dataclass(frozen=True)
class InflationLayerParams:
    name: str = "inflation_layer"
    enabled: bool = True
    inflation_radius: float = 0.55
    cost_scaling_factor: float = 10.0
    inflate_unknown: bool = False
    inflate_around_unknown: bool = False


@dataclass(frozen=True)
class KeepoutFilterParams:
    name: str = "keepout_filter"
    enabled: bool = True


Layer = StaticLayerParams | ObstacleLayerParams | InflationLayerParams

DEFAULT_PADDING = float(np.float32(0.01))
"""Nav2 declares ``footprint_padding`` as the float ``0.01f``: 0.009999999776 m."""


@dataclass(frozen=True, eq=False)
class CostmapParams:
    """A costmap's parameters: Nav2's names, Nav2's defaults."""

    resolution: float = 0.1
    width: float = 5.0
    height: float = 5.0
    origin_x: float = 0.0
    origin_y: float = 0.0
    global_frame: str = "map"
    robot_radius: float = 0.1
    footprint: FloatArray | None = None
    footprint_padding: float = DEFAULT_PADDING
    track_unknown_space: bool = False
    lethal_cost_threshold: int = 100
    unknown_cost_value: int = 255
    trinary_costmap: bool = True
    use_maximum: bool = False
    layers: tuple[Layer, ...] = (StaticLayerParams(),   # the kit's default: one scan source
                                 ObstacleLayerParams(observation_sources=(
                                     ObservationSource(clearing=True),)),
                                 InflationLayerParams())
    filters: tuple[KeepoutFilterParams, ...] = ()
    ignored: tuple[str, ...] = ()
    """``"name (type)"`` of the plugins and filters the kit does not model."""
    raw: Mapping[str, Any] = field(default_factory=dict, repr=False)

    def robot_footprint(self) -> FloatArray:
        """The padded footprint, shape ``(N, 2)`` [m] in ``base_link``."""
        points = (self.footprint if self.footprint is not None
                  else footprint_from_radius(self.robot_radius))
        return pad_footprint(points, self.footprint_padding)


def robot_footprint(robot: str | robots.RobotDescription) -> FloatArray:
    """A kit robot's footprint polygon (from ``hardware/robots``), shape ``(N, 2)`` [m]."""
    description = robots.load(robot) if isinstance(robot, str) else robot
    return np.array(description.footprint, dtype=np.float64)


# ------------------------------------------------------------------ reading Nav2 YAML

def _value(section: Mapping[str, Any], key: str, default: Any, where: str) -> Any:
    """``section[key]`` of the type of ``default`` (ints accepted for floats), or
    ``default``; a clear error otherwise."""
    if key not in section:
        return default
    value = section[key]
    kind = type(default)
    if kind is bool:
        if not isinstance(value, bool):
            raise ValueError(f"{where}{key} must be true or false; got {value!r}"
                             + (" (a launch-file substitution left in the file?)"
                                if isinstance(value, str) else ""))
        return value
    if kind in (int, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or (
                kind is int and not isinstance(value, int)):
            raise ValueError(f"{where}{key} must be {'an integer' if kind is int else 'a number'}"
                             f"; got {value!r}")
        return kind(value)
    if not isinstance(value, str):
        raise ValueError(f"{where}{key} must be a string; got {value!r}")
    return value


def _footprint(value: Any) -> FloatArray | None:
    """Nav2's ``footprint``: ``"[]"`` (use the radius) or ``"[[x, y], ...]"`` (or a list)."""
    if isinstance(value, str):
        if value.strip() in ("", "[]"):
            return None
        try:
            value = json.loads(value)
        except json.JSONDecodeError:
            raise ValueError(f"footprint must be '[[x, y], [x, y], ...]' with three or more "
                             f"points [m]; got {value!r}") from None
    points = np.asarray(value, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 3:
        raise ValueError(f"footprint must have three or more [x, y] points [m]; got {value!r}")
    return points


def _sources(section: Mapping[str, Any], layer: str) -> tuple[ObservationSource, ...]:
    names = _value(section, "observation_sources", "", f"{layer}.").split()
    sources = []
    defaults = ObservationSource()
    for name in names:
        sub = section.get(name, {})
        if not isinstance(sub, Mapping):
            raise ValueError(f"{layer}.{name} must be a mapping of the source's parameters")
        where = f"{layer}.{name}."
        sources.append(ObservationSource(name=name, **{
            key: _value(sub, key, getattr(defaults, key) if key != "topic" else name, where)
            for key in ("topic", "data_type", "marking", "clearing", "obstacle_max_range",
                        "obstacle_min_range", "raytrace_max_range", "raytrace_min_range",
                        "inf_is_valid")}))
    return tuple(sources)


_DEFAULT_PLUGINS = {"static_layer": "nav2_costmap_2d::StaticLayer",
                    "obstacle_layer": "nav2_costmap_2d::ObstacleLayer",
                    "inflation_layer": "nav2_costmap_2d::InflationLayer"}


def _plugin(name: str, section: Mapping[str, Any]) -> Layer | KeepoutFilterParams | None:
    """The kit's parameters of one plugin, or ``None`` when the kit does not model it."""
    kind = str(section.get("plugin", _DEFAULT_PLUGINS.get(name, ""))).replace("/", "::")
    kind = kind.split("::")[-1]
    where = f"{name}."
    enabled = _value(section, "enabled", True, where)
    if kind == "StaticLayer":
        return StaticLayerParams(name, enabled)
    if kind == "ObstacleLayer":
        return ObstacleLayerParams(
            name, enabled, _value(section, "footprint_clearing_enabled", True, where),
            _value(section, "combination_method", 1, where), _sources(section, name))
    if kind in ("InflationLayer", "LegacyInflationLayer"):
        d = InflationLayerParams()
        return InflationLayerParams(name, enabled, *(
            _value(section, key, getattr(d, key), where)
            for key in ("inflation_radius", "cost_scaling_factor", "inflate_unknown",
                        "inflate_around_unknown")))
    if kind == "KeepoutFilter":
        return KeepoutFilterParams(name, enabled)
    return None


def _ros_parameters(data: Any, name: str, origin: str) -> Mapping[str, Any]:
    """The ``ros__parameters`` of ``name`` in a Nav2 file (``name: name: ros__parameters``,
    ``name: ros__parameters``), or ``data`` itself when it already is the parameters."""
    if not isinstance(data, Mapping):
        raise ValueError(f"{origin}: a Nav2 parameter file is a mapping")
    node = data
    for key in (name, name, "ros__parameters"):
        if isinstance(node, Mapping) and key in node:
            node = node[key]
    if node is data and ("plugins" in data or "resolution" in data):
        return data
    if node is data or not isinstance(node, Mapping) or "ros__parameters" in node:
        raise ValueError(f"{origin}: no '{name}' section with ros__parameters; top-level keys: "
                         f"{sorted(map(str, data))}")
    return node


def load_costmap_params(source: str | Path | Mapping[str, Any],
                        name: str = "global_costmap") -> CostmapParams:
    """Read a costmap's parameters from a Nav2 parameter file (or its parsed mapping).

    ``name`` selects the costmap (``global_costmap``, ``local_costmap``); a mapping that holds
    the parameters directly is taken as it is.

    Raises
    ------
    ValueError
        No such section, a parameter of the wrong type, a malformed footprint.
    """
    if isinstance(source, Mapping):
        data: Any = source
        origin = "parameters"
    else:
        from ruamel.yaml import YAML
        from ruamel.yaml.error import YAMLError

        origin = str(source)
        try:
            data = YAML(typ="safe", pure=True).load(Path(source).read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise ValueError(f"{source}: no such parameter file") from None
        except YAMLError as exc:
            raise ValueError(f"{source}: not valid YAML ({exc})") from None
    raw = _ros_parameters(data, name, origin)
    d = CostmapParams()
    scalars = {key: _value(raw, key, getattr(d, key), "")
               for key in ("resolution", "width", "height", "origin_x", "origin_y",
                           "global_frame", "robot_radius", "footprint_padding",
                           "track_unknown_space", "lethal_cost_threshold", "unknown_cost_value",
                           "trinary_costmap", "use_maximum")}
    footprint = _footprint(raw.get("footprint", "[]"))
    plugins = raw.get("plugins", list(_DEFAULT_PLUGINS))
    filters = raw.get("filters", [])
    layers: list[Layer] = []
    kept_filters: list[KeepoutFilterParams] = []
    ignored: list[str] = []
    for names, is_filter in ((plugins, False), (filters, True)):
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            raise ValueError(f"{origin}: {'filters' if is_filter else 'plugins'} must be a list "
                             f"of names; got {names!r}")
        for plugin_name in names:
            section = raw.get(plugin_name, {})
            if not isinstance(section, Mapping):
                raise ValueError(f"{origin}: {plugin_name} must be a mapping of parameters")
            params = _plugin(plugin_name, section)
            if isinstance(params, KeepoutFilterParams) and is_filter:
                kept_filters.append(params)
            elif params is not None and not isinstance(params, KeepoutFilterParams) \
                    and not is_filter:
                layers.append(params)
            else:
                ignored.append(f"{plugin_name} ({section.get('plugin', '?')})")
    return CostmapParams(**scalars, footprint=footprint, layers=tuple(layers),
                         filters=tuple(kept_filters), ignored=tuple(ignored), raw=dict(raw))


# ------------------------------------------------------------------ combining the layers

def _combine(master: NDArray[np.uint8], layer: NDArray[np.uint8], method: int) -> None:
    """Nav2's ``CostmapLayer`` update rules, in place: 0 overwrite with the layer's known
    cells, 1 maximum (unknown master cells always take the layer's), 2 maximum leaving unknown
    master cells unknown."""
    known = layer != NO_INFORMATION
    if method == 0:
        take = known
    elif method == 1:
        take = known & ((master == NO_INFORMATION) | (master < layer))
    else:
        take = known & (master != NO_INFORMATION) & (master < layer)
    master[take] = layer[take]


class LayeredCostmap:
    """Nav2's layered costmap: a static map, obstacles from scans, inflation, keep-out.

    Parameters
    ----------
    params
        The costmap's parameters (:func:`load_costmap_params`, or ``CostmapParams(...)``).
    grid
        The static map (``nav_msgs/OccupancyGrid``, e.g. from :func:`kit.maps.read_map`); it
        sets the costmap's size, resolution and origin. Without one, ``params``' ``width``,
        ``height``, ``resolution`` and ``origin_x/y`` do.
    footprint
        The robot's footprint ((N, 2) [m]), e.g. ``robot_footprint("uiabot")``; overrides
        ``params.footprint`` and ``robot_radius``.
    """

    def __init__(self, params: CostmapParams | None = None,
                 grid: msgs.OccupancyGrid | None = None, *,
                 footprint: ArrayLike | None = None) -> None:
        self.params = params if params is not None else CostmapParams()
        base = (np.asarray(footprint, dtype=np.float64) if footprint is not None
                else self.params.footprint if self.params.footprint is not None
                else footprint_from_radius(self.params.robot_radius))
        self.footprint = pad_footprint(base, self.params.footprint_padding)
        self.inscribed_radius, self.circumscribed_radius = footprint_radii(self.footprint)
        self.keepout_mask: msgs.OccupancyGrid | None = None
        self.static: NDArray[np.uint8] | None = None
        if grid is not None:
            self.set_map(grid)
        else:
            p = self.params
            shape = (round(p.height / p.resolution), round(p.width / p.resolution))
            self._resize(shape, p.resolution, (p.origin_x, p.origin_y))

    def _resize(self, shape: tuple[int, int], resolution: float,
                origin: tuple[float, float]) -> None:
        if shape[0] <= 0 or shape[1] <= 0:
            raise ValueError(f"a costmap needs at least one cell; got {shape}")
        self.shape, self.resolution, self.origin = shape, float(resolution), origin
        self.obstacles = {
            layer.name: ObstacleLayer(shape, resolution, origin, self.params.track_unknown_space)
            for layer in self.params.layers if isinstance(layer, ObstacleLayerParams)}

    def set_map(self, grid: msgs.OccupancyGrid) -> None:
        """Take a new static map; the costmap takes its geometry (obstacles are forgotten)."""
        p = self.params
        info = grid.info
        self._resize((info.height, info.width), info.resolution,
                     (info.origin.position.x, info.origin.position.y))
        self.static = static_layer(grid, track_unknown_space=p.track_unknown_space,
                                   lethal_cost_threshold=p.lethal_cost_threshold,
                                   unknown_cost_value=p.unknown_cost_value,
                                   trinary_costmap=p.trinary_costmap)

    def set_keepout_mask(self, mask: msgs.OccupancyGrid | None) -> None:
        """The keep-out filter's mask (0 free … 100 keep out, −1 no change), or ``None``."""
        self.keepout_mask = mask

    def update_scan(self, scan: msgs.LaserScan, sensor_pose: ArrayLike) -> tuple[int, int]:
        """Feed one scan, taken at ``sensor_pose`` (the scanner's ``(x, y, θ)`` in the
        costmap's frame), to every obstacle layer's sources; returns ``(rays traced, cells
        marked)``."""
        traced = marked = 0
        for layer in self.params.layers:
            if isinstance(layer, ObstacleLayerParams) and layer.enabled:
                t, m = self.obstacles[layer.name].update(scan, sensor_pose,
                                                         layer.observation_sources)
                traced, marked = traced + t, marked + m
        return traced, marked

    def update(self, robot_pose: ArrayLike | None = None) -> Costmap:
        """Combine the layers into a :class:`Costmap`. With ``robot_pose`` (``(x, y, θ)`` of
        ``base_link``), obstacle layers with ``footprint_clearing_enabled`` first clear the
        cells under the footprint (cell centres inside it)."""
        p = self.params
        master = np.full(self.shape, NO_INFORMATION if p.track_unknown_space else FREE_SPACE,
                         dtype=np.uint8)
        for layer in p.layers:
            if not layer.enabled:
                continue
            if isinstance(layer, StaticLayerParams) and self.static is not None:
                if p.use_maximum:
                    _combine(master, self.static, 1)
                else:
                    master[:] = self.static          # Nav2's "true overwrite", unknown too
            elif isinstance(layer, ObstacleLayerParams):
                grid = self.obstacles[layer.name]
                if robot_pose is not None and layer.footprint_clearing_enabled:
                    pose = geometry.check_pose(robot_pose, "robot_pose")
                    polygon = geometry.transform_points(pose, self.footprint)
                    grid.costs[cells_in_polygon(polygon, self.shape, self.resolution,
                                                self.origin)] = FREE_SPACE
                _combine(master, grid.costs, layer.combination_method)
            elif isinstance(layer, InflationLayerParams):
                master = inflate(master, self.resolution, inscribed_radius=self.inscribed_radius,
                                 inflation_radius=layer.inflation_radius,
                                 cost_scaling_factor=layer.cost_scaling_factor,
                                 inflate_unknown=layer.inflate_unknown,
                                 inflate_around_unknown=layer.inflate_around_unknown)
        for filt in p.filters:
            if filt.enabled and self.keepout_mask is not None:
                master = apply_keepout(master, self.keepout_mask, self.resolution, self.origin)
        return Costmap(master, self.resolution, self.origin, p.global_frame)


def costmap_from_map(grid: msgs.OccupancyGrid, params: CostmapParams | None = None, *,
                     footprint: ArrayLike | None = None,
                     keepout_mask: msgs.OccupancyGrid | None = None) -> Costmap:
    """The costmap of a static map in one call: static layer, inflation (and keep-out), with
    ``params`` (Nav2's defaults when ``None``) and the robot's ``footprint``."""
    layered = LayeredCostmap(params, grid, footprint=footprint)
    layered.set_keepout_mask(keepout_mask)
    if keepout_mask is not None and not layered.params.filters:
        layered.params = _with_keepout(layered.params)
    return layered.update()


def _with_keepout(params: CostmapParams) -> CostmapParams:
    return dataclasses.replace(params, filters=(KeepoutFilterParams(),))

