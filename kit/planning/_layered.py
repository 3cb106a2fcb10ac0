"""The kit's costmap: Nav2's ``costmap_2d`` layered costmap, configured with Nav2's parameters.
The planner plans on it and the navigator's global and local costmaps are two of it.

``load_costmap_params("nav2_params.yaml", "local_costmap")`` reads a costmap's node of a Nav2
parameter file as it is (see :mod:`kit.nav2params`); :class:`LayeredCostmap` combines the
layers in their ``plugins`` order into one grid each :meth:`~LayeredCostmap.update`:

1. start from unknown (``track_unknown_space``) or free;
2. the static layer writes the map's costs (everything, unknown too; ``use_maximum``: keeps
   the larger); in a rolling window only where the map reaches;
3. an obstacle layer (a voxel layer too, read as a 2-D obstacle layer) combines its marks and
   clearings (``combination_method`` 0 overwrite, 1 maximum, 2 maximum without overwriting
   unknown);
4. the inflation layer inflates what is there;
5. then the filters: the keep-out mask raises costs (not inflated, as in Nav2). A keep-out
   filter listed among the ``plugins`` instead acts at its place there — before the inflation
   layer, its zone is inflated like a wall (the kit's navigator keeps the glass out so).

The footprint is ``footprint`` when given, else a 16-point circle of ``robot_radius``, padded
by ``footprint_padding``; its inscribed radius feeds the inflation. A ``rolling_window``
costmap (Nav2's local costmap) is ``width`` × ``height`` metres centred on the robot, its
cells aligned with the map's; what leaves it is forgotten.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from kit import geometry, msgs, robots
from kit.nav2params import Nav2File, ParameterReport, Section
from kit.planning._costmap import (
    FREE_SPACE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap,
    apply_keepout_costs,
    footprint_from_radius,
    footprint_radii,
    inflate,
    inflation_cost,
    keepout_costs,
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
    footprint_clearing_enabled: bool = False


@dataclass(frozen=True)
class ObstacleLayerParams:
    """An obstacle layer (or a voxel layer, read in 2-D), with Nav2's names, and three of the
    kit's, each off (Nav2's behaviour) unless set: ``clip_rays`` and ``range_in_cells`` (see
    :class:`~kit.planning.ObstacleLayer`) and ``moving_margin`` [m] — returns farther than
    0.15 m from the static map's obstacles (people, most likely) marked as discs of this
    radius, where a walking person can be by the next scan."""

    name: str = "obstacle_layer"
    enabled: bool = True
    footprint_clearing_enabled: bool = True
    combination_method: int = 1
    observation_sources: tuple[ObservationSource, ...] = ()
    clip_rays: bool = True
    range_in_cells: bool = True
    moving_margin: float = 0.0

    def __post_init__(self) -> None:
        if self.combination_method not in (0, 1, 2):
            raise ValueError(f"{self.name}.combination_method must be 0 (overwrite), 1 (max) or "
                             f"2 (max without unknown overwrite); got {self.combination_method}")
        if not (math.isfinite(self.moving_margin) and self.moving_margin >= 0):
            raise ValueError(f"{self.name}.moving_margin must be a non-negative number of "
                             f"metres; got {self.moving_margin!r}")


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


Layer = StaticLayerParams | ObstacleLayerParams | InflationLayerParams | KeepoutFilterParams

MAX_CELLS = 100_000_000
"""The most cells a costmap may have (10 km × 10 km at 1 m, 500 m × 500 m at 5 cm)."""

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
    inscribed_obstacle_cost_value: int = 99
    """Lyrical's: a map value read as the inscribed cost 253 (Jazzy has no such value)."""
    trinary_costmap: bool = True
    use_maximum: bool = False
    rolling_window: bool = False
    update_frequency: float = 5.0
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

    def same_as(self, other: CostmapParams) -> bool:
        """Whether two parameter sets configure the same costmap (``ignored`` and ``raw``
        aside)."""
        fields = [f.name for f in dataclasses.fields(self) if f.name not in ("ignored", "raw")]
        for name in fields:
            a, b = getattr(self, name), getattr(other, name)
            if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
                if a is None or b is None or not np.array_equal(a, b):
                    return False
            elif a != b:
                return False
        return True


def robot_footprint(robot: str | robots.RobotDescription) -> FloatArray:
    """A kit robot's footprint polygon (from ``hardware/robots``), shape ``(N, 2)`` [m]."""
    description = robots.load(robot) if isinstance(robot, str) else robot
    return np.array(description.footprint, dtype=np.float64)


# ------------------------------------------------------------------ reading Nav2 YAML

NO_EFFECT = "no effect in the kit (ROS plumbing: topics, frames, timing, publishing)"
"""The reason given for the keys that only concern ROS's plumbing."""

_COSTMAP_PLUMBING = ("use_sim_time", "publish_frequency", "robot_base_frame",
                     "transform_tolerance", "always_send_full_costmap", "map_topic",
                     "map_vis_z", "initial_transform_timeout", "subscribe_to_updates",
                     "footprint_topic", "introspection_mode", "service_introspection_mode")
_STATIC_PLUMBING = ("map_subscribe_transient_local", "map_topic", "subscribe_to_updates",
                    "transform_tolerance")
_SOURCE_PLUMBING = ("topic", "sensor_frame", "expected_update_rate")
_TWO_D = "no effect: the kit's obstacle layers are 2-D"
_VOXEL_ONLY = ("publish_voxel_map", "origin_z", "z_resolution", "z_voxels", "mark_threshold",
               "unknown_threshold")
_DEFAULT_PLUGINS = {"static_layer": "nav2_costmap_2d::StaticLayer",
                    "obstacle_layer": "nav2_costmap_2d::ObstacleLayer",
                    "inflation_layer": "nav2_costmap_2d::InflationLayer"}
_KINDS = {"StaticLayer": "static", "ObstacleLayer": "obstacle", "VoxelLayer": "voxel",
          "InflationLayer": "inflation", "LegacyInflationLayer": "inflation",
          "KeepoutFilter": "keepout"}


def _footprint(value: Any, key: str) -> FloatArray | None:
    """Nav2's ``footprint``: ``"[]"`` (use the radius) or ``"[[x, y], ...]"`` (or a list)."""
    if isinstance(value, str):
        if value.strip() in ("", "[]"):
            return None
        try:
            value = json.loads(value)
        except json.JSONDecodeError:
            raise ValueError(f"{key} must be '[[x, y], [x, y], ...]' with three or more "
                             f"points [m]; got {value!r}") from None
    try:
        points = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{key} must have three or more [x, y] points [m]; got "
                         f"{value!r}") from None
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 3 or \
            not np.isfinite(points).all():
        raise ValueError(f"{key} must have three or more [x, y] points [m]; got {value!r}")
    return points


def _sources(s: Section, layer: str) -> tuple[ObservationSource, ...]:
    names = s.get_list("observation_sources", [])
    out = []
    d = ObservationSource()
    for name in names:
        src = s.sub(name)
        data_type = src.get("data_type", d.data_type)
        if data_type != "LaserScan":
            s.report.errors.append(f"{src.key('data_type').replace(':', '.')}: the kit's "
                                   f"obstacle layer reads LaserScan only; got {data_type!r}")
            data_type = d.data_type
        values = {key: src.get(key, getattr(d, key)) for key in (
            "marking", "clearing", "obstacle_max_range", "obstacle_min_range",
            "raytrace_max_range", "raytrace_min_range", "inf_is_valid")}
        for key in ("obstacle_max_range", "obstacle_min_range", "raytrace_max_range",
                    "raytrace_min_range"):
            if not (math.isfinite(values[key]) and values[key] >= 0):
                s.report.errors.append(f"{src.key(key).replace(':', '.')} must be a "
                                       f"non-negative number of metres; got {values[key]!r}")
                values[key] = getattr(d, key)
        topic = src.get("topic", name)
        for key in _SOURCE_PLUMBING:               # kept in the parameters, no effect
            src.report.unuse(src.key(key), NO_EFFECT)
        src.ignore_all(_TWO_D, ("min_obstacle_height", "max_obstacle_height"))
        persistence = src.get("observation_persistence", 0.0, "0 s: only the newest scan")
        if persistence != 0.0:
            src.report.unuse(src.key("observation_persistence"), "not supported: the kit's "
                             "obstacle layer keeps only the newest scan (0 s)")
        src.ignore_all(f"not a parameter of an observation source the kit knows "
                       f"(in {layer})")
        out.append(ObservationSource(name=name, topic=topic, data_type=data_type, **values))
    return tuple(out)


def _layer(s: Section, name: str, kind: str) -> Layer:
    """The kit's parameters of one plugin of a kind the kit models, read from ``s``."""
    enabled = s.get("enabled", True)
    if kind == "static":
        layer: Layer = StaticLayerParams(name, enabled, s.get("footprint_clearing_enabled",
                                                              False))
        s.ignore_all(NO_EFFECT, _STATIC_PLUMBING)
    elif kind in ("obstacle", "voxel"):
        d = ObstacleLayerParams()
        method = s.get("combination_method", d.combination_method)
        if method not in (0, 1, 2):
            s.report.errors.append(f"{s.key('combination_method').replace(':', '.')} must be "
                                   f"0 (overwrite), 1 (max) or 2 (max, unknown kept); got "
                                   f"{method!r}")
            method = d.combination_method
        layer = ObstacleLayerParams(
            name, enabled, s.get("footprint_clearing_enabled", d.footprint_clearing_enabled),
            method, _sources(s, name), s.get("clip_rays", d.clip_rays),
            s.get("range_in_cells", d.range_in_cells), s.get("moving_margin", d.moving_margin))
        s.ignore_all(_TWO_D, ("min_obstacle_height", "max_obstacle_height"))
        if kind == "voxel":
            s.ignore_all("no effect: the voxel layer is read as a 2-D obstacle layer",
                         _VOXEL_ONLY)
    elif kind == "inflation":
        d2 = InflationLayerParams()
        layer = InflationLayerParams(name, enabled, *(
            s.get(key, getattr(d2, key)) for key in (
                "inflation_radius", "cost_scaling_factor", "inflate_unknown",
                "inflate_around_unknown")))
    else:
        layer = KeepoutFilterParams(name, enabled)
        s.ignore_all("no effect: the kit takes the keep-out mask from the scenario, not "
                     "from a topic", ("filter_info_topic",))
        s.ignore_all(NO_EFFECT, ("transform_tolerance",))
    s.use("plugin")
    return layer


def read_costmap(s: Section) -> CostmapParams:
    """A costmap's parameters from its node's :class:`~kit.nav2params.Section`, each key
    accounted for in the section's report (unknown plugins, the keys of layers the kit does
    not model and ROS's plumbing reported as not used; errors collected)."""
    d = CostmapParams()
    scalars: dict[str, Any] = {}
    for key in ("resolution", "width", "height", "origin_x", "origin_y", "global_frame",
                "robot_radius", "footprint_padding", "track_unknown_space",
                "lethal_cost_threshold", "unknown_cost_value", "inscribed_obstacle_cost_value",
                "trinary_costmap", "use_maximum", "rolling_window", "update_frequency"):
        scalars[key] = s.get(key, getattr(d, key))
    if not (math.isfinite(scalars["resolution"]) and scalars["resolution"] > 0):
        s.report.errors.append(f"{s.key('resolution').replace(':', '.')} must be a positive "
                               f"number of metres per cell; got {scalars['resolution']!r}")
        scalars["resolution"] = d.resolution
    footprint = None
    if s.has("footprint"):
        try:
            footprint = _footprint(s.raw("footprint"), s.key("footprint").replace(":", "."))
        except ValueError as exc:
            s.report.errors.append(str(exc))
        if footprint is not None:
            s.use("footprint", f"{len(footprint)} points")
            s.report.unuse(s.key("robot_radius"), "not used: the footprint polygon is given")
        else:
            s.use("footprint", "[] (the robot_radius circle)")
    plugins = s.get_list("plugins", list(_DEFAULT_PLUGINS))
    filters = s.get_list("filters", [])
    layers: list[Layer] = []
    kept_filters: list[KeepoutFilterParams] = []
    ignored: list[str] = []
    listed = set(plugins) | set(filters)
    for names, is_filter in ((plugins, False), (filters, True)):
        for plugin_name in names:
            p = s.sub(plugin_name)
            default = _DEFAULT_PLUGINS.get(plugin_name, "") if not is_filter else ""
            plugin_type = p.get("plugin", default) if p.has("plugin") else default
            kind = _KINDS.get(plugin_type.replace("/", "::").split("::")[-1])
            if kind is None or (is_filter and kind != "keepout"):
                what = plugin_type or "no plugin type given"
                ignored.append(f"{plugin_name} ({what})")
                p.report.unuse(p.key("plugin"), "")
                p.ignore_all(f"not supported: {plugin_name} is a {what}, which the kit does "
                             f"not model")
                if not p.has("plugin"):
                    s.report.note(f"{s.node}: {plugin_name} is listed in "
                                  f"{'filters' if is_filter else 'plugins'} with no plugin "
                                  f"type: not used")
                continue
            layer = _layer(p, plugin_name, kind)
            if kind == "voxel":
                s.report.note("a VoxelLayer is read as a 2-D obstacle layer (marking and "
                              "clearing with its observation sources); its z parameters have "
                              "no effect")
            if is_filter:
                assert isinstance(layer, KeepoutFilterParams)
                kept_filters.append(layer)
            else:
                layers.append(layer)
            p.ignore_all(f"not a parameter of a {plugin_type.split('::')[-1]} the kit knows")
    s.ignore_all(NO_EFFECT, _COSTMAP_PLUMBING)
    s.ignore_all("no effect: Nav2 reads observation_sources in each obstacle layer",
                 ("observation_sources",))
    for name in s.names():
        head = name.split(".")[0]
        if head not in listed and "." in name:
            s.ignore(name, f"not used: {head} is not in plugins or filters")
    s.ignore_all("not a costmap parameter the kit knows")
    return CostmapParams(**scalars, footprint=footprint, layers=tuple(layers),
                         filters=tuple(kept_filters), ignored=tuple(ignored),
                         raw=dict(s.params))


def load_costmap_params(source: str | Path | Mapping[str, Any],
                        name: str = "global_costmap", *,
                        report: ParameterReport | None = None,
                        namespace: str | None = None) -> CostmapParams:
    """Read a costmap's parameters from a Nav2 parameter file (or its parsed mapping).

    ``name`` selects the costmap (``global_costmap``, ``local_costmap``: the node
    ``name/name`` of the file, in any namespace, with the file's ``/**`` parameters); a
    mapping that holds the parameters directly (``{"resolution": 0.05, "inflation_layer":
    {...}}``) is taken as it is. ``report`` (:class:`~kit.nav2params.ParameterReport`) gets
    what became of each key of the costmap.

    Raises
    ------
    ValueError
        No such section, a parameter of the wrong type, a malformed footprint (every bad
        value named in one message).
    """
    if isinstance(source, Mapping) and not _has_nodes(source):
        from kit.nav2params import flatten

        params = flatten({str(k): v for k, v in source.items()})
        node, origin = name, None
        file_origin = "parameters"
    else:
        nav2 = Nav2File(source, namespace)
        problem = nav2.misnested_costmap(name)
        if problem:
            raise ValueError(problem)
        node, params, origin = nav2.node(f"{name}/{name}")
        file_origin = nav2.origin
        if not params:
            names = sorted({e.name for e in nav2.entries})
            raise ValueError(f"{file_origin}: no '{name}' section with ros__parameters; the "
                             f"file's nodes: {', '.join(names)}")
    rep = report if report is not None else ParameterReport(file_origin)
    costmap = read_costmap(Section(rep, node, params, origin=origin))
    rep.raise_errors()
    return costmap


def _has_nodes(data: Mapping[str, Any]) -> bool:
    """Whether a mapping is a parameter file's (nodes down to ``ros__parameters``)."""
    def walk(node: Any) -> bool:
        return isinstance(node, Mapping) and any(
            k == "ros__parameters" or walk(v) for k, v in node.items())
    return walk(data)


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
    """Nav2's layered costmap: a static map, obstacles from scans, inflation, keep-out; the
    whole map, or a window rolling with the robot.

    Parameters
    ----------
    params
        The costmap's parameters (:func:`load_costmap_params`, or ``CostmapParams(...)``).
    grid
        The static map (``nav_msgs/OccupancyGrid``, e.g. from :func:`kit.maps.read_map`); it
        sets the costmap's size, resolution and origin — but a rolling window's size is its
        ``width`` × ``height`` at its ``resolution`` (the map's float when the two agree to
        1 ppm), and it looks the map up cell by cell. Without one,
        ``params``' ``width``, ``height``, ``resolution`` and ``origin_x/y`` do (a rolling
        window then starts where the robot is first seen).
    footprint
        The robot's footprint ((N, 2) [m]), e.g. ``robot_footprint("uiabot")``; overrides
        ``params.footprint`` and ``robot_radius``.

    Examples
    --------
    >>> from kit.planning import CostmapParams, LayeredCostmap
    >>> local = LayeredCostmap(CostmapParams(rolling_window=True, width=3.0, height=3.0,
    ...                                      resolution=0.05))
    >>> local.update_points([[1.0, 0.5]], (0.0, 0.0), robot_xy=(0.0, 0.0))
    (1, 1)
    >>> costmap = local.update((0.0, 0.0, 0.0))
    >>> costmap.costs.shape, int(costmap.costs[costmap.world_to_cell(1.0, 0.5)])
    ((60, 60), 254)
    """

    def __init__(self, params: CostmapParams | None = None,
                 grid: msgs.OccupancyGrid | None = None, *,
                 footprint: ArrayLike | None = None) -> None:
        self.params = params if params is not None else CostmapParams()
        p = self.params
        base = (np.asarray(footprint, dtype=np.float64) if footprint is not None
                else p.footprint if p.footprint is not None
                else footprint_from_radius(p.robot_radius))
        self.footprint = pad_footprint(base, p.footprint_padding)
        self.inscribed_radius, self.circumscribed_radius = footprint_radii(self.footprint)
        self.rolling = bool(p.rolling_window)
        self.keepout_mask: msgs.OccupancyGrid | None = None
        self._keepout_key: tuple[Any, ...] | None = None
        self._keepout: NDArray[np.int16] | None = None
        self.static: NDArray[np.uint8] | None = None
        self.static_origin = (0.0, 0.0)
        self.static_resolution = 0.0
        self._static_distance: FloatArray | None = None
        self.obstacles: dict[str, ObstacleLayer] = {}
        if self.rolling:
            resolution = float(p.resolution)
            if grid is not None and math.isclose(grid.info.resolution, resolution,
                                                 rel_tol=1e-6):
                resolution = float(grid.info.resolution)   # the map's float32, exactly
            shape = (round(p.height / resolution), round(p.width / resolution))
            if min(shape) < 3:
                raise ValueError(f"a rolling window needs at least 3 × 3 cells; got {shape}")
            self._resize(shape, resolution, (math.nan, math.nan))
            if grid is not None:
                self.set_map(grid)
        elif grid is not None:
            self.set_map(grid)
        else:
            shape = (round(p.height / p.resolution), round(p.width / p.resolution))
            self._resize(shape, p.resolution, (p.origin_x, p.origin_y))

    def _resize(self, shape: tuple[int, int], resolution: float,
                origin: tuple[float, float]) -> None:
        if shape[0] <= 0 or shape[1] <= 0:
            raise ValueError(f"a costmap needs at least one cell; got {shape}")
        if shape[0] * shape[1] > MAX_CELLS:
            raise ValueError(f"a costmap of {shape[0]} × {shape[1]} cells is more than the kit "
                             f"holds ({MAX_CELLS:,}): check its size and resolution "
                             f"({resolution} m)")
        self.shape, self.resolution, self.origin = shape, float(resolution), origin
        self.obstacles = {
            layer.name: ObstacleLayer(shape, resolution, origin, self.params.track_unknown_space,
                                      clip_rays=layer.clip_rays,
                                      range_in_cells=layer.range_in_cells)
            for layer in self.params.layers if isinstance(layer, ObstacleLayerParams)}

    # ------------------------------------------------------------------ the static map
    def set_map(self, grid: msgs.OccupancyGrid) -> None:
        """Take a new static map, as Nav2's static layer takes each ``/map`` (SLAM's, every few
        seconds). A costmap that is not rolling takes the map's geometry; its obstacle layers
        keep what they have seen when the geometry stays (SLAM drawn on a fixed canvas) and
        start afresh otherwise. A rolling window keeps its grid and what it has seen."""
        p = self.params
        info = grid.info
        resolution = float(info.resolution)
        origin = (float(info.origin.position.x), float(info.origin.position.y))
        if self.rolling:
            pass                                   # the window keeps its own grid
        elif (self.static is None or (info.height, info.width) != self.shape or
              not math.isclose(resolution, self.resolution) or
              not (math.isclose(origin[0], self.origin[0], abs_tol=1e-9) and
                   math.isclose(origin[1], self.origin[1], abs_tol=1e-9))):
            self._resize((info.height, info.width), resolution, origin)
        self.static = static_layer(grid, track_unknown_space=p.track_unknown_space,
                                   lethal_cost_threshold=p.lethal_cost_threshold,
                                   unknown_cost_value=p.unknown_cost_value,
                                   trinary_costmap=p.trinary_costmap,
                                   inscribed_obstacle_cost_value=p.inscribed_obstacle_cost_value)
        self.static_origin = origin
        self.static_resolution = resolution
        self._static_distance = None
        if any(isinstance(layer, ObstacleLayerParams) and layer.moving_margin > 0
               for layer in p.layers):
            self._static_distance = ndimage.distance_transform_edt(
                self.static != LETHAL_OBSTACLE) * resolution

    def set_keepout_mask(self, mask: msgs.OccupancyGrid | None) -> None:
        """The keep-out filter's mask (0 free … 100 keep out, −1 no change), or ``None``."""
        self.keepout_mask = mask
        self._keepout_key = None

    def _static_window(self) -> tuple[NDArray[np.uint8], NDArray[np.bool_]] | None:
        """A rolling window's static costs and where the map reaches (each cell's centre
        looked up in the map; a map of the window's resolution, aligned, by slicing)."""
        if self.static is None:
            return None
        h, w = self.shape
        sh, sw = self.static.shape
        out = np.full((h, w), NO_INFORMATION, dtype=np.uint8)
        on = np.zeros((h, w), dtype=bool)
        if math.isclose(self.static_resolution, self.resolution, rel_tol=1e-6):
            r0 = round((self.origin[1] - self.static_origin[1]) / self.resolution)
            c0 = round((self.origin[0] - self.static_origin[0]) / self.resolution)
            rs, re = max(r0, 0), min(r0 + h, sh)
            cs, ce = max(c0, 0), min(c0 + w, sw)
            if rs < re and cs < ce:
                out[rs - r0:re - r0, cs - c0:ce - c0] = self.static[rs:re, cs:ce]
                on[rs - r0:re - r0, cs - c0:ce - c0] = True
            return out, on
        rows, cols = np.indices((h, w))
        mx = np.floor((self.origin[0] + (cols + 0.5) * self.resolution - self.static_origin[0])
                      / self.static_resolution).astype(np.int64)
        my = np.floor((self.origin[1] + (rows + 0.5) * self.resolution - self.static_origin[1])
                      / self.static_resolution).astype(np.int64)
        on = (mx >= 0) & (my >= 0) & (mx < sw) & (my < sh)
        out[on] = self.static[my[on], mx[on]]
        return out, on

    # ------------------------------------------------------------------ the window
    def _roll(self, x: float, y: float) -> None:
        """Move a rolling window's centre to ``(x, y)``, its cells on a grid from the map's
        origin (aligned with the map's cells when the resolutions are the same)."""
        h, w = self.shape
        res = self.resolution
        ax, ay = self.static_origin
        ox = ax + math.floor((x - w * res / 2 - ax) / res) * res
        oy = ay + math.floor((y - h * res / 2 - ay) / res) * res
        if math.isnan(self.origin[0]):
            self.origin = (ox, oy)
            for layer in self.obstacles.values():
                layer.origin = (ox, oy)
            return
        dc = round((ox - self.origin[0]) / res)
        dr = round((oy - self.origin[1]) / res)
        if dc == 0 and dr == 0:
            return
        self.origin = (ox, oy)
        for layer in self.obstacles.values():
            layer.move((ox, oy))

    def _positioned(self) -> None:
        if self.rolling and math.isnan(self.origin[0]):
            raise ValueError("a rolling window has no position before its first update")

    # ------------------------------------------------------------------ observations
    def _obstacle_layers(self) -> list[ObstacleLayerParams]:
        return [layer for layer in self.params.layers
                if isinstance(layer, ObstacleLayerParams) and layer.enabled]

    def update_scan(self, scan: msgs.LaserScan, sensor_pose: ArrayLike,
                    robot_xy: ArrayLike | None = None) -> tuple[int, int]:
        """Feed one scan, taken at ``sensor_pose`` (the scanner's ``(x, y, θ)`` in the
        costmap's frame), to every obstacle layer's sources; a rolling window first moves to
        ``robot_xy`` (default: the scanner). Returns ``(rays traced, cells marked)``."""
        pose = geometry.check_pose(sensor_pose, "sensor_pose")
        if self.rolling:
            centre = pose[:2] if robot_xy is None else np.asarray(robot_xy, dtype=float)
            self._roll(float(centre[0]), float(centre[1]))
        traced = marked = 0
        for layer in self._obstacle_layers():
            t, m = self.obstacles[layer.name].update(scan, pose, layer.observation_sources)
            traced, marked = traced + t, marked + m
        return traced, marked

    def update_points(self, points: ArrayLike, sensor: tuple[float, float],
                      robot_xy: ArrayLike | None = None) -> tuple[int, int]:
        """Feed a scan's returns already in the costmap's frame ((N, 2) [m], e.g. de-skewed
        beam by beam), seen from ``sensor`` ``(x, y)``, to every obstacle layer's sources; a
        rolling window first moves to ``robot_xy``. Returns ``(rays traced, cells
        marked)``."""
        if self.rolling and robot_xy is not None:
            xy = np.asarray(robot_xy, dtype=float)
            self._roll(float(xy[0]), float(xy[1]))
        self._positioned()
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        s = (float(sensor[0]), float(sensor[1]))
        traced = marked = 0
        for layer in self._obstacle_layers():
            grid = self.obstacles[layer.name]
            t, m = grid.update_points(pts, s, layer.observation_sources)
            if layer.moving_margin > 0:
                for source in layer.observation_sources:
                    if source.marking:
                        m += grid.mark_points(self._moving_discs(
                            _within(pts, s, source), layer.moving_margin))
            traced, marked = traced + t, marked + m
        return traced, marked

    def add_points(self, points: ArrayLike, sensor: tuple[float, float]) -> tuple[int, int]:
        """:meth:`update_points` without moving a rolling window."""
        return self.update_points(points, sensor)

    def _moving_discs(self, points: FloatArray, radius: float) -> FloatArray:
        """Points filling a disc of ``radius`` round each return that the static map does not
        explain (farther than 0.15 m from its obstacles; all of them without a map)."""
        if self._static_distance is not None:
            d = self._static_distance
            cols = np.floor((points[:, 0] - self.static_origin[0]) / self.static_resolution)
            rows = np.floor((points[:, 1] - self.static_origin[1]) / self.static_resolution)
            ok = (rows >= 0) & (rows < d.shape[0]) & (cols >= 0) & (cols < d.shape[1])
            away = np.ones(len(points), dtype=bool)
            away[ok] = d[rows[ok].astype(int), cols[ok].astype(int)] > 0.15
            points = points[away]
        if len(points) == 0:
            return np.zeros((0, 2))
        g = np.arange(-radius, radius + 1e-9, self.resolution)
        gx, gy = np.meshgrid(g, g)
        disc = np.column_stack([gx.ravel(), gy.ravel()])
        disc = disc[np.hypot(disc[:, 0], disc[:, 1]) <= radius]
        return (points[:, None, :] + disc[None, :, :]).reshape(-1, 2)

    def clear(self) -> None:
        """Forget every observation (Nav2's ``ClearEntireCostmap``)."""
        for layer in self.obstacles.values():
            layer.reset()

    # ------------------------------------------------------------------ the costmap
    @property
    def inflation(self) -> InflationLayerParams | None:
        """The first enabled inflation layer, if any."""
        for layer in self.params.layers:
            if isinstance(layer, InflationLayerParams) and layer.enabled:
                return layer
        return None

    @property
    def circumscribed_cost(self) -> int:
        """The cost at a centre one cell beyond the circumscribed radius from the nearest
        lethal cell: a pose whose centre costs less cannot touch an obstacle. 0 (every pose's
        outline must be checked) when the inflation does not reach that far."""
        layer = self.inflation
        reach = self.circumscribed_radius + self.resolution
        if layer is None or math.ceil(layer.inflation_radius / self.resolution) * \
                self.resolution < reach:
            return 0
        return int(inflation_cost(reach, self.inscribed_radius, layer.cost_scaling_factor))

    def _keepout_costs(self) -> NDArray[np.int16] | None:
        if self.keepout_mask is None:
            return None
        key = (id(self.keepout_mask), self.shape, self.resolution, self.origin)
        if key != self._keepout_key:
            self._keepout = keepout_costs(self.keepout_mask, self.shape, self.resolution,
                                          self.origin)
            self._keepout_key = key
        return self._keepout

    def update(self, robot_pose: ArrayLike | None = None) -> Costmap:
        """Combine the layers into a :class:`Costmap`. With ``robot_pose`` (``(x, y, θ)`` of
        ``base_link``) a rolling window first moves there, and the layers with
        ``footprint_clearing_enabled`` clear the cells under the footprint (cell centres inside
        it)."""
        p = self.params
        polygon = None
        if robot_pose is not None:
            pose = geometry.check_pose(robot_pose, "robot_pose")
            if self.rolling:
                self._roll(float(pose[0]), float(pose[1]))
            polygon = cells_in_polygon(geometry.transform_points(pose, self.footprint),
                                       self.shape, self.resolution, self.origin)
        self._positioned()
        master: NDArray[np.uint8] = np.full(
            self.shape, NO_INFORMATION if p.track_unknown_space else FREE_SPACE, dtype=np.uint8)
        for layer in p.layers:
            if not layer.enabled:
                continue
            if isinstance(layer, StaticLayerParams):
                if self.static is None:
                    continue
                if self.rolling:                 # only where the map reaches
                    window = self._static_window()
                    assert window is not None
                    static, on = window
                    master[on] = np.maximum(master[on], static[on]) if p.use_maximum \
                        else static[on]
                elif p.use_maximum:
                    _combine(master, self.static, 1)
                else:
                    master[:] = self.static      # Nav2's "true overwrite", unknown too
                if polygon is not None and layer.footprint_clearing_enabled:
                    master[polygon] = FREE_SPACE
            elif isinstance(layer, ObstacleLayerParams):
                grid = self.obstacles[layer.name]
                if polygon is not None and layer.footprint_clearing_enabled:
                    grid.costs[polygon] = FREE_SPACE
                _combine(master, grid.costs, layer.combination_method)
            elif isinstance(layer, InflationLayerParams):
                master = inflate(master, self.resolution, inscribed_radius=self.inscribed_radius,
                                 inflation_radius=layer.inflation_radius,
                                 cost_scaling_factor=layer.cost_scaling_factor,
                                 inflate_unknown=layer.inflate_unknown,
                                 inflate_around_unknown=layer.inflate_around_unknown)
            else:
                mask = self._keepout_costs()
                if mask is not None:
                    master = apply_keepout_costs(master, mask)
        for filt in p.filters:
            mask = self._keepout_costs()
            if filt.enabled and mask is not None:
                master = apply_keepout_costs(master, mask)
        return Costmap(master, self.resolution, self.origin, p.global_frame)

    def costmap(self, robot_pose: ArrayLike | None = None) -> Costmap:
        """:meth:`update` (the name the navigator's costmaps had)."""
        return self.update(robot_pose)


def _within(points: FloatArray, sensor: tuple[float, float],
            source: ObservationSource) -> FloatArray:
    """The points within the source's marking ranges of the sensor [m]."""
    d = np.hypot(points[:, 0] - sensor[0], points[:, 1] - sensor[1])
    return points[(d <= source.obstacle_max_range) & (d >= source.obstacle_min_range)]


def costmap_from_map(grid: msgs.OccupancyGrid, params: CostmapParams | None = None, *,
                     footprint: ArrayLike | None = None,
                     keepout_mask: msgs.OccupancyGrid | None = None) -> Costmap:
    """The costmap of a static map in one call: static layer, inflation (and keep-out), with
    ``params`` (Nav2's defaults when ``None``) and the robot's ``footprint``."""
    layered = LayeredCostmap(params, grid, footprint=footprint)
    layered.set_keepout_mask(keepout_mask)
    if keepout_mask is not None and not any(isinstance(layer, KeepoutFilterParams)
                                            for layer in (*layered.params.layers,
                                                          *layered.params.filters)):
        layered.params = dataclasses.replace(layered.params, filters=(KeepoutFilterParams(),))
    return layered.update()
