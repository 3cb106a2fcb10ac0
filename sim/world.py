"""Static worlds: walls, glass, boxes, pillars, oil on the floor, and the people's routes.

A world file is TOML (``sim/worlds/*.toml`` are the built-in ones)::

    name = "square"
    spawn = [2.0, 2.0, 0.0]                       # x, y, yaw of the first robot
    [[walls]]                                     # a polyline of wall segments
    material = "wall"                             # or "glass": solid, invisible to lidar
    points = [[0, 0], [10, 0], [10, 10]]
    [[boxes]]                                     # solid rectangles
    center = [3, 2]
    size = [1.6, 0.8]
    [[circles]]                                   # solid discs (pillars)
    center = [3, 3.6]
    radius = 0.25
    [[oil]]                                       # slippery floor, [xmin, ymin, xmax, ymax]
    rect = [4, 1, 6, 3]
    [[routes]]                                    # a pedestrian walks these points to and fro
    points = [[8, 8], [8, 5]]
    [[alcoves]]                                   # a doorway or niche off a narrow passage:
    front = [5, 0.75]                             # people held up by a robot step from the
    back = [5, -0.4]                              # passage (front) into it (back) to let it by

A route's legs and an alcove's front-to-back step may not cross a wall or box: a person would
push against it for ever (the file is refused, naming the leg).

A ROS map_server map (``.yaml``) is a world too: its occupied cells become boxes (runs of
cells merged into rectangles), and its spawn is the map's first free cell near the origin.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import sys
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from kit import maps, msgs

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["BUILTIN_WORLDS", "World", "WorldError", "along_walls", "free_distance",
           "load_world", "world_from_grid"]

BUILTIN_WORLDS = ("aisle", "office", "pillars", "square")
WORLD_DIR = Path(__file__).resolve().parent / "worlds"
MATERIALS = ("wall", "glass")

FloatArray = NDArray[np.float64]


class WorldError(ValueError):
    """A world file that is missing or malformed; the message names the file."""


@dataclass(frozen=True, eq=False)
class World:
    """Static geometry in the world frame (metres). Arrays are read-only."""

    name: str
    description: str
    segments: FloatArray
    """(M, 4) wall segments [x1, y1, x2, y2], boxes' edges included."""
    segment_glass: NDArray[np.bool_]
    """(M,) True for glass: solid to bodies, invisible to the lidar."""
    boxes: FloatArray
    """(B, 4) solid rectangles [xmin, ymin, xmax, ymax] (their edges are in ``segments``)."""
    circles: FloatArray
    """(K, 3) solid discs [cx, cy, radius]."""
    oil: FloatArray
    """(P, 4) slippery rectangles [xmin, ymin, xmax, ymax]."""
    spawn: FloatArray
    routes: tuple[FloatArray, ...]
    alcoves: FloatArray = dataclasses.field(
        default_factory=lambda: _frozen([], float, (4,)))
    """(A, 4) places to step aside [front x, front y, back x, back y]: the front on the
    passage, the back out of it."""

    def crosses_wall(self, a: tuple[float, float], b: tuple[float, float]) -> bool:
        """Whether the straight walk from ``a`` to ``b`` crosses a wall, box or glass."""
        return _crosses(self.segments, a, b)

    @cached_property
    def lidar_segments(self) -> FloatArray:
        """The segments a lidar sees (glass left out)."""
        visible = self.segments[~self.segment_glass]
        visible.flags.writeable = False
        return visible

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        pts = [self.segments[:, :2], self.segments[:, 2:]]
        if len(self.circles):
            pts.append(self.circles[:, :2] - self.circles[:, 2:3])
            pts.append(self.circles[:, :2] + self.circles[:, 2:3])
        allpts = np.vstack(pts)
        return (float(np.min(allpts[:, 0])), float(np.min(allpts[:, 1])),
                float(np.max(allpts[:, 0])), float(np.max(allpts[:, 1])))

    def occupancy_grid(self, resolution: float = 0.05, *, layer: str = "all",
                       margin: float = 0.5) -> msgs.OccupancyGrid:
        """The world drawn as a map_server map: cells a wall, box or disc touches are 100, the
        rest 0, origin ``margin`` metres beyond the world's lower-left corner.

        ``layer`` picks what is drawn: ``"all"`` (what bumps the robot), ``"lidar"`` (what a
        lidar, and so a SLAM map, sees: no glass) or ``"glass"`` (only the glass: a keep-out
        mask for Nav2's filter). Segments are sampled every quarter cell.
        """
        if not (math.isfinite(resolution) and resolution > 0):
            raise ValueError(f"resolution is metres per cell > 0; got {resolution!r}")
        if layer not in ("all", "lidar", "glass"):
            raise ValueError(f"layer is 'all', 'lidar' or 'glass'; got {layer!r}")
        resolution = float(np.float32(resolution))  # as the message stores it
        x0, y0, x1, y1 = self.bounds
        ox, oy = x0 - margin, y0 - margin
        width = math.ceil((x1 + margin - ox) / resolution)
        height = math.ceil((y1 + margin - oy) / resolution)
        hit = np.zeros((height, width), dtype=bool)
        chosen = {"all": np.ones(len(self.segments), bool), "lidar": ~self.segment_glass,
                  "glass": self.segment_glass}[layer]
        for ax, ay, bx, by in self.segments[chosen]:
            n = int(math.hypot(bx - ax, by - ay) / (resolution / 4)) + 2
            t = np.linspace(0.0, 1.0, n)
            col = np.floor((ax + t * (bx - ax) - ox) / resolution).astype(np.int64)
            row = np.floor((ay + t * (by - ay) - oy) / resolution).astype(np.int64)
            hit[row.clip(0, height - 1), col.clip(0, width - 1)] = True
        if layer != "glass" and len(self.circles):
            rows, cols = np.indices(hit.shape)
            cx, cy = ox + (cols + 0.5) * resolution, oy + (rows + 0.5) * resolution
            half = resolution / 2
            for x, y, r in self.circles:              # the disc touches the cell's square
                hit |= np.hypot(np.maximum(np.abs(cx - x) - half, 0.0),
                                np.maximum(np.abs(cy - y) - half, 0.0)) <= r
        info = msgs.MapMetaData(resolution=resolution, width=width, height=height,
                                origin=msgs.Pose(msgs.Point(ox, oy, 0.0)))
        return msgs.OccupancyGrid(msgs.Header(frame_id="map"), info,
                                  np.where(hit, 100, 0).astype(np.int8).ravel())

    @cached_property
    def _oil_rects(self) -> tuple[tuple[float, float, float, float], ...]:
        return tuple((float(a), float(b), float(c), float(d)) for a, b, c, d in self.oil)

    def in_oil(self, x: float, y: float) -> bool:
        for x0, y0, x1, y1 in self._oil_rects:  # plain floats: called per wheel per step
            if x0 <= x <= x1 and y0 <= y <= y1:
                return True
        return False


def _frozen(a: Any, dtype: Any, shape_tail: tuple[int, ...]) -> NDArray[Any]:
    arr = np.array(a, dtype=dtype).reshape((-1, *shape_tail)) if shape_tail else \
        np.array(a, dtype=dtype)
    arr.flags.writeable = False
    return arr


def _box_segments(box: tuple[float, float, float, float]) -> list[list[float]]:
    x0, y0, x1, y1 = box
    return [[x0, y0, x1, y0], [x1, y0, x1, y1], [x1, y1, x0, y1], [x0, y1, x0, y0]]


def free_distance(segments: FloatArray, xs: ArrayLike, ys: ArrayLike, dx: float, dy: float,
                  reach: float) -> FloatArray:
    """Free distance [m] from each point (xs, ys) along the unit direction (dx, dy) to the
    nearest of the (M, 4) ``segments``, up to ``reach`` (compiled: people ask ten times a
    second, each several times)."""
    px, py = np.atleast_1d(np.asarray(xs, float)), np.atleast_1d(np.asarray(ys, float))
    return _free_distance(np.ascontiguousarray(segments, dtype=np.float64), px, py,
                          float(dx), float(dy), float(reach))


@njit(cache=True)
def _free_distance(segments: FloatArray, px: FloatArray, py: FloatArray, dx: float, dy: float,
                   reach: float) -> FloatArray:  # pragma: no cover - compiled by numba
    out = np.empty(px.shape[0])
    for i in range(px.shape[0]):
        out[i] = _free_distance_one(segments, px[i], py[i], dx, dy, reach)
    return out


@njit(cache=True)
def _free_distance_one(segments: FloatArray, px: float, py: float, dx: float, dy: float,
                       reach: float) -> float:  # pragma: no cover - compiled by numba
    best = np.inf
    for j in range(segments.shape[0]):
        ex, ey = segments[j, 2] - segments[j, 0], segments[j, 3] - segments[j, 1]
        denom = dx * ey - dy * ex
        if not abs(denom) > 1e-12:
            continue
        wx, wy = segments[j, 0] - px, segments[j, 1] - py
        t = (wx * ey - wy * ex) / denom              # along the ray
        u = (wx * dy - wy * dx) / denom              # along the segment
        if t >= 0.0 and u >= 0.0 and u <= 1.0 and t < best:
            best = t
    return min(best, reach)


def along_walls(segments: FloatArray, x: float, y: float, vx: float, vy: float,
                within: float) -> tuple[float, float]:
    """The velocity (vx, vy) of a body at (x, y) with the part of it into every segment
    closer than ``within`` taken out, in the segments' order: where a body pressed to a
    wall really goes (along it)."""
    out = _along_walls(np.ascontiguousarray(segments, dtype=np.float64), float(x), float(y),
                       float(vx), float(vy), float(within))
    return float(out[0]), float(out[1])


@njit(cache=True)
def _along_walls(segments: FloatArray, x: float, y: float, vx: float, vy: float,
                 within: float) -> FloatArray:  # pragma: no cover - compiled by numba
    for j in range(segments.shape[0]):
        ax, ay = segments[j, 0], segments[j, 1]
        ex, ey = segments[j, 2] - ax, segments[j, 3] - ay
        length2 = max(ex * ex + ey * ey, 1e-12)
        t = min(max(((x - ax) * ex + (y - ay) * ey) / length2, 0.0), 1.0)
        nx, ny = x - (ax + t * ex), y - (ay + t * ey)     # from the wall to the body
        d = math.hypot(nx, ny)
        if d < within and d > 1e-9:
            ux, uy = nx / d, ny / d
            into = vx * ux + vy * uy
            if into < 0.0:
                vx, vy = vx - into * ux, vy - into * uy
    out = np.empty(2)
    out[0], out[1] = vx, vy
    return out


def _crosses(segments: FloatArray, a: tuple[float, float], b: tuple[float, float]) -> bool:
    length = math.hypot(b[0] - a[0], b[1] - a[1])
    if length == 0.0:
        return False
    dx, dy = (b[0] - a[0]) / length, (b[1] - a[1]) / length
    return bool(free_distance(segments, a[0], a[1], dx, dy, length)[0] < length)


def _build(name: str, description: str, walls: list[tuple[list[list[float]], str]],
           boxes: list[tuple[float, float, float, float]], circles: list[list[float]],
           oil: list[list[float]], spawn: list[float], routes: list[list[list[float]]],
           where: str, alcoves: list[list[float]] | None = None) -> World:
    segments: list[list[float]] = []
    glass: list[bool] = []
    for points, material in walls:
        if material not in MATERIALS:
            raise WorldError(f"{where}: material must be one of {MATERIALS}; got {material!r}")
        pts = np.asarray(points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 2:
            raise WorldError(f"{where}: walls need 2 or more [x, y] points; got {points!r}")
        for a, b in itertools.pairwise(pts):
            segments.append([*a, *b])
            glass.append(material == "glass")
    for box in boxes:
        for seg in _box_segments(box):
            segments.append(seg)
            glass.append(False)
    if not segments and not circles:
        raise WorldError(f"{where}: a world needs at least one wall, box or circle")
    all_values = np.array([v for s in segments for v in s] + [v for c in circles for v in c] +
                          list(spawn), dtype=float)
    if not np.all(np.isfinite(all_values)):
        raise WorldError(f"{where}: coordinates must be finite numbers")
    if len(spawn) != 3:
        raise WorldError(f"{where}: spawn is [x, y, yaw]; got {spawn!r}")
    seg_array = np.array(segments, float).reshape(-1, 4)
    for i, route in enumerate(routes):
        pts = np.asarray(route, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 1 or \
                not np.all(np.isfinite(pts)):
            raise WorldError(f"{where}: route {i + 1} needs finite [x, y] points; got "
                             f"{route!r}")
        for a, b in itertools.pairwise(pts):
            if _crosses(seg_array, tuple(a), tuple(b)):
                raise WorldError(f"{where}: route {i + 1} walks through a wall from "
                                 f"{a.tolist()} to {b.tolist()}")
    alcoves = [] if alcoves is None else alcoves
    for i, alcove in enumerate(alcoves):
        if len(alcove) != 4 or not np.all(np.isfinite(alcove)):
            raise WorldError(f"{where}: alcove {i + 1} needs a finite front and back [x, y]")
        if _crosses(seg_array, (alcove[0], alcove[1]), (alcove[2], alcove[3])):
            raise WorldError(f"{where}: alcove {i + 1}'s step from "
                             f"{[float(v) for v in alcove[:2]]} to "
                             f"{[float(v) for v in alcove[2:]]} crosses a wall")
    return World(
        name=name, description=description,
        segments=_frozen(segments, float, (4,)),
        segment_glass=_frozen(glass, bool, ()),
        boxes=_frozen(boxes, float, (4,)),
        circles=_frozen(circles, float, (3,)),
        oil=_frozen(oil, float, (4,)),
        spawn=_frozen(spawn, float, ()),
        routes=tuple(_frozen(r, float, (2,)) for r in routes),
        alcoves=_frozen([list(map(float, a)) for a in alcoves], float, (4,)),
    )


def _world_file(path: Path) -> World:
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise WorldError(f"{path}: no such world file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise WorldError(f"{path}: not valid TOML ({exc})") from None
    try:
        walls = [(w["points"], str(w.get("material", "wall"))) for w in data.get("walls", [])]
        boxes = []
        for b in data.get("boxes", []):
            (cx, cy), (w, h) = b["center"], b["size"]
            if b.get("material", "wall") != "wall":
                raise WorldError(f"{path}: boxes are solid walls; use walls for glass")
            boxes.append((cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2))
        circles = [[*c["center"], c["radius"]] for c in data.get("circles", [])]
        oil = [list(o["rect"]) for o in data.get("oil", [])]
        routes = [r["points"] for r in data.get("routes", [])]
        alcoves = [[*a["front"], *a["back"]] for a in data.get("alcoves", [])]
        spawn = list(data.get("spawn", [0.0, 0.0, 0.0]))
    except (KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, WorldError):
            raise
        raise WorldError(f"{path}: malformed entry ({type(exc).__name__}: {exc})") from None
    return _build(str(data.get("name", path.stem)), str(data.get("description", "")), walls,
                  boxes, circles, oil, spawn, routes, str(path), alcoves)


def world_from_grid(grid: msgs.OccupancyGrid, name: str = "map") -> World:
    """A world whose boxes are the grid's occupied cells (value ≥ 65), runs merged.

    Horizontal runs of occupied cells become rectangles, and identical runs in consecutive
    rows merge into one taller rectangle, which keeps a building's walls to a few hundred
    boxes. The map's origin yaw is honoured.
    """
    info = grid.info
    res = float(info.resolution)
    cells = grid.data.reshape(info.height, info.width) >= 65
    open_runs: dict[tuple[int, int], int] = {}  # (start, end) -> first row
    rects: list[tuple[int, int, int, int]] = []  # col0, row0, col1, row1 (exclusive)
    for row in range(info.height + 1):
        runs: set[tuple[int, int]] = set()
        if row < info.height:
            line = np.concatenate([[False], cells[row], [False]])
            edges = np.flatnonzero(line[1:] != line[:-1])
            runs = {(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)}
        for run in list(open_runs):
            if run not in runs:
                rects.append((run[0], open_runs.pop(run), run[1], row))
        for run in runs:
            open_runs.setdefault(run, row)
    o = info.origin
    yaw = math.atan2(2 * (o.orientation.w * o.orientation.z), 1 - 2 * o.orientation.z ** 2)
    c, s = math.cos(yaw), math.sin(yaw)
    walls: list[tuple[list[list[float]], str]] = []
    boxes: list[tuple[float, float, float, float]] = []
    for c0, r0, c1, r1 in sorted(rects):
        corners = np.array([[c0, r0], [c1, r0], [c1, r1], [c0, r1], [c0, r0]], float) * res
        if yaw == 0.0:
            x0, y0 = corners[0] + (o.position.x, o.position.y)
            x1, y1 = corners[2] + (o.position.x, o.position.y)
            boxes.append((float(x0), float(y0), float(x1), float(y1)))
        else:  # a rotated map: keep the rectangles as closed polylines
            rotated = corners @ np.array([[c, s], [-s, c]]) + (o.position.x, o.position.y)
            walls.append((rotated.tolist(), "wall"))
    from scipy.ndimage import distance_transform_edt

    free = grid.data.reshape(info.height, info.width) == 0
    if not free.any():
        raise WorldError(f"{name}: the map has no free cell to start in")
    # start where the most room is: the free cell farthest from any non-free cell
    clearance = distance_transform_edt(free)
    best_row, best_col = np.unravel_index(int(np.argmax(clearance)), clearance.shape)
    local = np.array([(int(best_col) + 0.5) * res, (int(best_row) + 0.5) * res])
    spawn = [float(o.position.x + c * local[0] - s * local[1]),
             float(o.position.y + s * local[0] + c * local[1]), 0.0]
    return _build(name, f"map_server map, {info.width} x {info.height} cells at {res:g} m",
                  walls, boxes, [], [], spawn, [], name)


def load_world(name_or_path: str | Path) -> World:
    """A built-in world (``"office"``, ``"aisle"``, ``"pillars"``, ``"square"``), a world file
    (``.toml``) or a map_server map (``.yaml``)."""
    text = str(name_or_path)
    if text in BUILTIN_WORLDS:
        return _world_file(WORLD_DIR / f"{text}.toml")
    path = Path(text)
    if path.suffix in (".yaml", ".yml"):
        try:
            grid = maps.read_map(path)
        except maps.MapError as exc:
            raise WorldError(str(exc)) from None
        return world_from_grid(grid, path.stem)
    if path.suffix == ".toml":
        return _world_file(path)
    raise WorldError(f"{text!r} is neither a built-in world {BUILTIN_WORLDS}, a world file "
                     f"(.toml) nor a map_server map (.yaml)")
