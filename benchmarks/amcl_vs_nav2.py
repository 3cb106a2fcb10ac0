"""The kit's AMCL beside Nav2's (the ``amcl`` package on PyPI) on the same maps, scans and
odometry: position and heading error per scan, CPU time per update (issue 29).

    .venv/bin/python benchmarks/amcl_vs_nav2.py [--scenes olin,office] [--particles 2000 10000]
        [--seeds 0 1 2 3 4 5] [--scans 20] [--nav2-src DIR]

The set-up of the issue: a seeded track (0.1 m steps, turns of 0.4 rad), scans of 360 beams
over the full circle cast in the map with N(0, 0.02 m) noise, odometry equal to the truth,
both filters started at the true pose with Nav2's default initial covariance (0.5², 0.5²,
(π/12)²) and updated at every scan, with the same particle count (``min_particles =
max_particles``, so neither filter's KLD-sampling changes it), Nav2's alphas (0.2), z_hit 0.5,
z_rand 0.5, σ_hit 0.2 and 60 beams. The scanner sits 0.1 m ahead of the base, turned +90°
(as a TurtleBot 4's), so that both filters' mountings are exercised.

Scenes:

* ``olin`` — the real Olin MAC first-floor map (map_server's own reading of its YAML); the
  scans are cast in the map (the first occupied cell along each beam, found by marching the
  raster in steps of an eighth of a cell and then intersecting that cell's square exactly);
  tracks stay in the building's mapped free space (the PGM's white, not the grey), 0.4 m
  clear of walls; ``--map YAML`` runs any other map_server map the same way;
* ``office`` — the simulator's office rasterised at 5 cm (the lidar's layer: no glass) as the
  map; the scans are cast on the world's wall segments themselves (``sim.raycast``), so the
  map is an approximation of what the scanner sees, as a real map is.

Filters:

* ``nav2`` — the ``amcl`` package: Nav2's AMCL code (``pf.c``, its motion model, its laser
  models) behind a small C++ class. That class builds Nav2's **beam model** (``BeamModel``,
  ray casting) in its constructor and ``set_map``, whatever one asks for: the package cannot
  run the likelihood field. It updates at every call (no ``update_min_d``/``update_min_a``),
  resamples at every update, keeps ``pf.c``'s own KLD constants (``pop_err`` 0.01, ``pop_z``
  3, not Nav2's ``pf_err``/``pf_z``), and returns the whole set's mean. Its map lookup rounds
  (Nav2's ``MAP_GXWX``), which places every cell half a cell lower-left of map_server's
  geometry: the package is given the map's origin moved by half a cell, so that it sees the
  walls where they are (without it its estimates carry that half cell, 0.021 m on the Olin
  map). Its random numbers come from libc's one ``drand48`` generator: each Nav2 filter
  here gets a stream of its own (:class:`Drand48`, seeded as ``srand48(seed)``) swapped in
  around its updates, so that filters run side by side do not draw from each other's
  stream. Only the initial cloud escapes the seed: ``pf_pdf_gaussian_alloc`` reseeds the
  generator with a counter that only grows within a process, so it depends on how many
  filters the process started before (the same for the same command line);
* ``kit-beam`` — the kit with ``laser_model_type: beam``, the model the package runs: the
  filters set alike (the expected ranges measured as AMCL's ``map_calc_range`` does, between
  cell centres: the kit's ``beam_lookup: cells``, its default);
* ``kit-beam-exact`` — the same with ``beam_lookup: exact`` (each range from the scanner to
  where the ray enters the blocked cell), the kit's lookup before issue 29's last round;
* ``kit-lf`` — the kit with Nav2's default model (``likelihood_field``, ``1 + Σ p³``);
* ``kit-prob`` — the kit with ``likelihood_field_prob`` (the product of the beams'
  likelihoods);
* with ``--nav2-src DIR`` (a checkout of github.com/damanikjosh/amcl_python, the package's
  source, GPL-3.0): ``nav2-lf`` and ``nav2-prob`` — the same Nav2 sources compiled here with
  ``benchmarks/nav2_amcl_capi.cpp``, which drives ``pf.c`` exactly as the package's class does
  but builds the laser model one asks for. Before anything else the run checks that, with
  the beam model, the build reproduces the package bit for bit on a track (both are then the
  first filter of their library, so their initial clouds are drawn alike): ``nav2-lf`` is
  then Nav2's likelihood field on the very loop of the package.

The kit runs first-party code only; the ``amcl`` package is a development reference (the
``dev`` extra). Every filter sees the same scans; the kit gets ``inf`` for a beam without a
return (REP 117), the package ``range_max`` (the kit's beam model reads a missing return as a
max-range reading; Nav2 would give an ``inf`` beam no weight at all).
"""

from __future__ import annotations

import argparse
import ctypes
import importlib.util
import json
import math
import os
import subprocess
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image
from scipy.ndimage import distance_transform_edt

from kit import geometry, maps, msgs
from kit.localization import Amcl, AmclParameters
from kit.tf import RigidTransform

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
OLIN = DATA / "maps/olin-mac-first-floor-real/mac_1st_floor_final.yaml"
BEAMS = 360
RANGE_MAX = 12.0
RANGE_NOISE = 0.02
STEP = 0.1
TURN = 0.4
CLEARANCE = 0.4
MOUNT = (0.1, 0.0, math.pi / 2)
"""Scanner in base (x [m], y [m], yaw [rad])."""
INITIAL_COVARIANCE = (0.25, 0.25, (math.pi / 12) ** 2)
"""Nav2's default initial covariance: variances of x [m²], y [m²], yaw [rad²]."""
ALPHAS = (0.2, 0.2, 0.2, 0.2)
KIT_MODELS = {"kit-beam": "beam", "kit-beam-exact": "beam", "kit-lf": "likelihood_field",
              "kit-prob": "likelihood_field_prob"}
NAV2_MODELS = {"nav2-beam": 0, "nav2-lf": 1, "nav2-prob": 2}

FloatArray = np.ndarray


# ------------------------------------------------------------------ scenes, tracks, scans

@dataclass(frozen=True)
class Scene:
    """A map, where a track may go, and how the world answers a beam."""

    name: str
    grid: msgs.OccupancyGrid
    roam: np.ndarray
    """(height, width) bool: cells a track may enter."""
    cast: Callable[[FloatArray, FloatArray], FloatArray]
    """(origin (2,) in map, angles (B,) in map) → ranges (B,) [m], inf without a return."""


def _cell(grid: msgs.OccupancyGrid, xy: FloatArray) -> tuple[int, int]:
    o = grid.info.origin.position
    r = grid.info.resolution
    return math.floor((xy[1] - o.y) / r), math.floor((xy[0] - o.x) / r)


def raster_caster(grid: msgs.OccupancyGrid) -> Callable[[FloatArray, FloatArray], FloatArray]:
    """Beams cast in the raster: the first occupied cell (value >= 65) or the map's edge
    along each beam, found by marching in eighths of a cell, its square then intersected
    exactly (slab method). Independent of the kit's own ray casting."""
    info = grid.info
    res = float(info.resolution)
    ox, oy = info.origin.position.x, info.origin.position.y
    occupied = grid.data.reshape(info.height, info.width) >= 65
    t = np.arange(0.0, RANGE_MAX + res, res / 8)

    def cast(origin: FloatArray, angles: FloatArray) -> FloatArray:
        dx, dy = np.cos(angles)[:, None], np.sin(angles)[:, None]
        col = np.floor((origin[0] + dx * t - ox) / res).astype(np.int64)
        row = np.floor((origin[1] + dy * t - oy) / res).astype(np.int64)
        inside = (row >= 0) & (row < info.height) & (col >= 0) & (col < info.width)
        stop = ~inside
        stop[inside] = occupied[row[inside], col[inside]]
        first = np.argmax(stop, axis=1)
        hit = stop[np.arange(len(angles)), first]
        c, r = col[np.arange(len(angles)), first], row[np.arange(len(angles)), first]
        out = np.full(len(angles), np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            for k in np.flatnonzero(hit):
                entry = []
                for o, d, lo in ((origin[0], dx[k, 0], ox + c[k] * res),
                                 (origin[1], dy[k, 0], oy + r[k] * res)):
                    if d == 0.0:
                        continue
                    a, b = (lo - o) / d, (lo + res - o) / d
                    entry.append(min(a, b))
                out[k] = max(entry)
        out[out > RANGE_MAX] = np.inf
        return out

    return cast


def map_scene(path: Path, name: str | None = None) -> Scene:
    """A map_server map (YAML + image; the scene is named after its folder unless ``name``
    is given) as both filters read it (map_server's thresholds, as
    its YAML gives them); tracks only in its *mapped* free space — pixels free under Nav2's
    default ``free_thresh`` 0.196, so that map_saver's grey (unknown, 205) is not walked on
    even where the YAML's ``free_thresh: 0.25`` reads it as free (the Olin map, map8) —
    0.4 m clear of walls and of unmapped space; beams cast in the raster."""
    from ruamel.yaml import YAML

    path = Path(path)
    grid = maps.read_map(path)
    info = grid.info
    meta = YAML(typ="safe", pure=True).load(path.read_text(encoding="utf-8"))
    with Image.open(path.parent / str(meta["image"])) as image:
        pixels = np.flipud(np.asarray(image.convert("L"), dtype=np.float64))  # row 0 at origin
    darkness = pixels / 255.0 if int(meta.get("negate", 0)) else (255.0 - pixels) / 255.0
    mapped_free = darkness < 0.196
    occupied = grid.data.reshape(info.height, info.width) >= 65
    clear = distance_transform_edt(~occupied) * info.resolution
    inside = distance_transform_edt(mapped_free) * info.resolution
    roam = (clear > CLEARANCE) & (inside > CLEARANCE)
    if not roam.any():
        raise ValueError(f"{path}: no mapped free cell is {CLEARANCE} m clear of walls and "
                         f"unmapped space ({info.width} × {info.height} cells of "
                         f"{info.resolution:g} m): no room for a track")
    return Scene(name or path.parent.name, grid, roam, raster_caster(grid))


def olin_scene() -> Scene:
    """The real Olin MAC map."""
    return map_scene(OLIN, "olin")


def office_scene() -> Scene:
    """The simulator's office: the lidar layer at 5 cm as the map, the world's segments
    answering the beams."""
    from sim.raycast import cast_rays
    from sim.world import load_world

    world = load_world("office")
    grid = world.occupancy_grid(0.05, layer="lidar")
    info = grid.info
    occupied = grid.data.reshape(info.height, info.width) >= 65
    clear = distance_transform_edt(~occupied) * info.resolution
    x0, y0, x1, y1 = world.bounds
    rows, cols = np.indices(occupied.shape)
    cx = info.origin.position.x + (cols + 0.5) * info.resolution
    cy = info.origin.position.y + (rows + 0.5) * info.resolution
    within = (cx > x0 + CLEARANCE) & (cx < x1 - CLEARANCE) & (cy > y0 + CLEARANCE) & \
        (cy < y1 - CLEARANCE)
    segments, circles = world.lidar_segments, world.circles

    def cast(origin: FloatArray, angles: FloatArray) -> FloatArray:
        origins = np.repeat(np.asarray(origin, dtype=np.float64)[None, :2], len(angles), 0)
        return cast_rays(origins, angles, segments, circles, RANGE_MAX)

    return Scene("office", grid, (clear > CLEARANCE) & within, cast)


SCENES = {"olin": olin_scene, "office": office_scene}


def track(scene: Scene, seed: int, scans: int) -> FloatArray:
    """``scans`` true poses (scans, 3): a random start in the roaming space, then each step
    a turn of −0.4, 0 or +0.4 rad and 0.1 m ahead (the step is skipped where it would leave
    the roaming space; a step that would do nothing turns instead)."""
    rng = np.random.default_rng(seed)
    rows, cols = np.nonzero(scene.roam)
    k = int(rng.integers(len(rows)))
    centre = scene.grid.info.resolution * (np.array([cols[k], rows[k]]) + 0.5)
    o = scene.grid.info.origin.position
    pose = np.array([o.x + centre[0], o.y + centre[1], rng.uniform(-math.pi, math.pi)])
    poses = [pose]
    while len(poses) < scans:
        turn = float(rng.choice([-TURN, 0.0, TURN]))
        ahead = pose[:2] + STEP * np.array([math.cos(pose[2] + turn), math.sin(pose[2] + turn)])
        r, c = _cell(scene.grid, ahead)
        moves = 0 <= r < scene.roam.shape[0] and 0 <= c < scene.roam.shape[1] and \
            bool(scene.roam[r, c])
        if not moves and turn == 0.0:
            turn = TURN
        heading = float(geometry.wrap_angle(pose[2] + turn))
        pose = np.array([*(ahead if moves else pose[:2]), heading])
        poses.append(pose)
    return np.array(poses)


def beam_angles() -> FloatArray:
    """The scanner's beam angles in its own frame: −π … π − 2π/360, counter-clockwise."""
    return -math.pi + np.arange(BEAMS) * (2 * math.pi / BEAMS)


def scans_along(scene: Scene, poses: FloatArray, seed: int,
                mount: tuple[float, float, float] = MOUNT) -> FloatArray:
    """(len(poses), 360) ranges seen from each pose's scanner, with N(0, 0.02 m) noise;
    ``inf`` without a return within 12 m."""
    rng = np.random.default_rng(10_000 + seed)
    out = np.empty((len(poses), BEAMS))
    for k, pose in enumerate(poses):
        laser = geometry.compose(pose, np.asarray(mount, dtype=np.float64))
        r = scene.cast(laser[:2], laser[2] + beam_angles())
        out[k] = r + rng.normal(0.0, RANGE_NOISE, BEAMS)
    out[out >= RANGE_MAX] = np.inf
    return out


# ------------------------------------------------------------------ the filters

class Drand48:
    """A stream of libc's ``drand48`` of one's own: Nav2's ``pf.c`` draws every random number
    from that one process-wide generator, so filters run side by side would share (and
    perturb) each other's draws. Inside ``with``, the generator holds this stream's state;
    on leaving, the state is kept and the previous one restored. Starts where
    ``srand48(seed)`` would."""

    _libc = ctypes.CDLL(None)
    _libc.seed48.restype = ctypes.POINTER(ctypes.c_ushort)
    _libc.seed48.argtypes = (ctypes.POINTER(ctypes.c_ushort),)

    def __init__(self, seed: int) -> None:
        # srand48(s) sets the 48-bit state to s · 2^16 + 0x330E; seed48 takes it low word first
        self.state = (ctypes.c_ushort * 3)(0x330E, seed & 0xFFFF, (seed >> 16) & 0xFFFF)
        self._saved = (ctypes.c_ushort * 3)()

    def __enter__(self) -> Drand48:
        previous = self._libc.seed48(self.state)
        self._saved = (ctypes.c_ushort * 3)(*previous[:3])
        return self

    def __exit__(self, *exc: object) -> None:
        mine = self._libc.seed48(self._saved)
        self.state = (ctypes.c_ushort * 3)(*mine[:3])


def _package_grid(grid: msgs.OccupancyGrid) -> tuple[np.ndarray, float, float]:
    """The grid as Nav2's map_t takes it (0 free, 100 occupied, −1 unknown; row-major, row 0
    at the origin) and the origin moved half a cell, against Nav2's rounding lookup."""
    info = grid.info
    cells = grid.data.astype(np.int16)
    data = np.full(cells.shape, -1, dtype=np.int8)
    data[(cells >= 0) & (cells < 20)] = 0
    data[cells >= 65] = 100
    half = info.resolution / 2
    return data, info.origin.position.x + half, info.origin.position.y + half


class PackageFilter:
    """The ``amcl`` package, as the issue runs it."""

    name = "nav2"

    def __init__(self, scene: Scene, particles: int, seed: int, start: FloatArray,
                 mount: tuple[float, float, float] = MOUNT) -> None:
        import amcl

        self._amcl = amcl
        motion = amcl.MotionParameters(*ALPHAS, 0.2)
        laser = amcl.LaserParameters(0.5, 0.05, 0.05, 0.5, 0.2, 0.1, 0.05, 60)
        self.node = amcl.AMCL(particles, particles, 0.0, 0.0, motion, laser, "differential")
        info = scene.grid.info
        data, ox, oy = _package_grid(scene.grid)
        g = amcl.OccupancyGrid(info.width, info.height, float(info.resolution), ox, oy)
        g.data = data.tolist()
        self.node.set_map(g)
        self.node.set_laser_pose(amcl.Vector3D(*mount))
        self.node.set_initial_pose(amcl.Vector3D(*start),
                                   amcl.create_diagonal_covariance(*INITIAL_COVARIANCE))
        self.random = Drand48(seed)
        self.bearings = beam_angles()

    def update(self, ranges: FloatArray, odom: FloatArray) -> float:
        r = np.where(np.isfinite(ranges), ranges, RANGE_MAX)
        scan = self._amcl.create_laser_scan_from_list(
            np.column_stack([r, self.bearings]).tolist(), RANGE_MAX)
        pose = self._amcl.Vector3D(*map(float, odom))
        with self.random:
            start = time.process_time()
            self.node.update(scan, pose)
            return time.process_time() - start

    def estimate(self) -> FloatArray:
        m = self.node.get_pose_mean()
        return np.array([m.x, m.y, m.theta])


class KitFilter:
    """The kit's :class:`~kit.localization.Amcl` with one of its laser models."""

    def __init__(self, name: str, scene: Scene, particles: int, seed: int, start: FloatArray,
                 mount: tuple[float, float, float] = MOUNT) -> None:
        self.name = name
        params = AmclParameters(
            alpha1=ALPHAS[0], alpha2=ALPHAS[1], alpha3=ALPHAS[2], alpha4=ALPHAS[3],
            min_particles=particles, max_particles=particles, max_beams=60, z_hit=0.5,
            z_rand=0.5, sigma_hit=0.2, laser_model_type=KIT_MODELS[name],
            laser_max_range=RANGE_MAX, beam_lookup="exact" if name.endswith("-exact") else "cells")
        self.node = Amcl(scene.grid, params, seed=seed)
        self.node.initialize(start, np.diag(INITIAL_COVARIANCE))
        self.mount = RigidTransform.from_pose2d(mount)
        inc = 2 * math.pi / BEAMS
        self.template = dict(angle_min=-math.pi, angle_max=math.pi - inc, angle_increment=inc,
                             range_min=0.05, range_max=RANGE_MAX)

    def update(self, ranges: FloatArray, odom: FloatArray) -> float:
        scan = msgs.LaserScan(ranges=ranges.astype(np.float32), **self.template)
        self.node.force_update()  # an update at every scan, as the package does
        start = time.process_time()
        self.node.process(scan, odom, self.mount)
        return time.process_time() - start

    def estimate(self) -> FloatArray:
        assert self.node.estimate is not None
        return self.node.estimate[0]


class Nav2Build:
    """Nav2's AMCL sources (the package's checkout) compiled with
    ``benchmarks/nav2_amcl_capi.cpp``: the package's loop with any of Nav2's laser models."""

    def __init__(self, source: Path) -> None:
        self.lib = ctypes.CDLL(str(build_nav2(source)))
        d, i, p = ctypes.c_double, ctypes.c_int, ctypes.c_void_p
        self.lib.nav2_create.restype = p
        self.lib.nav2_create.argtypes = [i, i, d, d, d, d, i, d, d, d, d, d, d, d, i]
        self.lib.nav2_set_map.argtypes = [p, ctypes.c_char_p, i, i, d, d, d]
        self.lib.nav2_set_laser_pose.argtypes = [p, d, d, d]
        self.lib.nav2_set_initial_pose.argtypes = [p, d, d, d, d, d, d]
        self.lib.nav2_update.argtypes = [p, p, p, i, d, d, d, d]
        self.lib.nav2_mean.argtypes = [p, p]
        self.lib.nav2_free.argtypes = [p]


def build_nav2(source: Path) -> Path:
    """Compile the wrapper and Nav2's ``pf``, ``map``, motion and laser sources of the
    ``amcl`` package's checkout into a shared library (in a temporary directory)."""
    src = Path(source)
    files = ["src/map/map.c", "src/map/map_cspace.cpp", "src/map/map_range.c",
             "src/motion_model/differential_motion_model.cpp", "src/pf/eig3.c", "src/pf/pf.c",
             "src/pf/pf_kdtree.c", "src/pf/pf_pdf.c", "src/pf/pf_vector.c",
             "src/sensors/laser/beam_model.cpp", "src/sensors/laser/laser.cpp",
             "src/sensors/laser/likelihood_field_model.cpp",
             "src/sensors/laser/likelihood_field_model_prob.cpp"]
    missing = [f for f in files if not (src / f).is_file()]
    if missing:
        raise SystemExit(f"--nav2-src {src}: not a checkout of amcl_python (no {missing[0]})")
    out = Path(tempfile.mkdtemp(prefix="nav2amcl-"))
    objects = []
    for f in [str(Path(__file__).with_name("nav2_amcl_capi.cpp")), *(str(src / f) for f in files)]:
        obj = out / (Path(f).stem + ".o")
        compiler = ["gcc"] if f.endswith(".c") else ["g++", "-std=c++17"]
        subprocess.run([*compiler, "-O2", "-fPIC", "-DHAVE_DRAND48", f"-I{src / 'include'}",
                        "-c", f, "-o", str(obj)], check=True)
        objects.append(str(obj))
    lib = out / "libnav2amcl.so"
    subprocess.run(["g++", "-shared", "-o", str(lib), *objects], check=True)
    return lib


class BuiltFilter:
    """One filter of :class:`Nav2Build`."""

    def __init__(self, name: str, build: Nav2Build, scene: Scene, particles: int, seed: int,
                 start: FloatArray, mount: tuple[float, float, float] = MOUNT) -> None:
        self.name, self.lib = name, build.lib
        self.handle = self.lib.nav2_create(particles, particles, *ALPHAS, NAV2_MODELS[name],
                                           0.5, 0.05, 0.05, 0.5, 0.2, 0.1, 2.0, 60)
        info = scene.grid.info
        data, ox, oy = _package_grid(scene.grid)
        self._data = data.tobytes()
        self.lib.nav2_set_map(self.handle, self._data, info.width, info.height,
                              float(info.resolution), ox, oy)
        self.lib.nav2_set_laser_pose(self.handle, *mount)
        self.lib.nav2_set_initial_pose(self.handle, *map(float, start), *INITIAL_COVARIANCE)
        self.random = Drand48(seed)
        self.bearings = beam_angles()

    def update(self, ranges: FloatArray, odom: FloatArray) -> float:
        r = np.ascontiguousarray(np.where(np.isfinite(ranges), ranges, RANGE_MAX))
        b = np.ascontiguousarray(self.bearings)
        with self.random:
            start = time.process_time()
            self.lib.nav2_update(self.handle, r.ctypes.data, b.ctypes.data, len(r), RANGE_MAX,
                                 *map(float, odom))
            return time.process_time() - start

    def estimate(self) -> FloatArray:
        out = np.zeros(3)
        self.lib.nav2_mean(self.handle, out.ctypes.data)
        return out

    def __del__(self) -> None:
        self.lib.nav2_free(self.handle)


# ------------------------------------------------------------------ runs

def check_build(scene: Scene, build: Nav2Build, particles: int = 2000, scans: int = 10
                ) -> float:
    """The largest difference [m, rad] between the package's estimates and the build's
    with Nav2's beam model over one seeded track; 0.0 when the build runs the package's code.
    Meaningful only as the first filters of the process (see the module docstring)."""
    poses = track(scene, 0, scans)
    ranges = scans_along(scene, poses, 0)
    package = PackageFilter(scene, particles, 0, poses[0])
    built = BuiltFilter("nav2-beam", build, scene, particles, 0, poses[0])
    worst = 0.0
    for truth, r in zip(poses, ranges, strict=True):
        package.update(r, truth)
        built.update(r, truth)
        worst = max(worst, float(np.max(np.abs(package.estimate() - built.estimate()))))
    return worst


def run(scene: Scene, seed: int, particles: int, names: list[str], scans: int = 20,
        build: Nav2Build | None = None) -> dict[str, FloatArray]:
    """One seeded track through every filter named, interleaved scan by scan.

    Returns, per filter, an array (scans, 3): position error [m], heading error [rad] and
    CPU time of the update [s] after each scan.
    """
    poses = track(scene, seed, scans)
    ranges = scans_along(scene, poses, seed)
    filters: list[Any] = []
    for name in names:
        if name == "nav2":
            filters.append(PackageFilter(scene, particles, seed, poses[0]))
        elif name in KIT_MODELS:
            filters.append(KitFilter(name, scene, particles, seed, poses[0]))
        elif name in NAV2_MODELS:
            if build is None:
                raise ValueError(f"{name} needs --nav2-src")
            filters.append(BuiltFilter(name, build, scene, particles, seed, poses[0]))
        else:
            raise ValueError(f"unknown filter {name!r}")
    out = {f.name: np.zeros((scans, 3)) for f in filters}
    for k, (truth, r) in enumerate(zip(poses, ranges, strict=True)):
        for f in filters:
            cpu = f.update(r, truth)
            e = f.estimate()
            out[f.name][k] = (math.hypot(e[0] - truth[0], e[1] - truth[1]),
                              abs(float(geometry.wrap_angle(e[2] - truth[2]))), cpu)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="olin,office")
    parser.add_argument("--particles", type=int, nargs="+", default=[2000, 10000])
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(6)))
    parser.add_argument("--scans", type=int, default=20)
    parser.add_argument("--filters", default="nav2,kit-beam,kit-lf,kit-prob")
    parser.add_argument("--nav2-src", type=Path, default=None,
                        help="a checkout of amcl_python: adds nav2-beam, nav2-lf, nav2-prob")
    parser.add_argument("--map", type=Path, action="append", default=[],
                        help="a map_server YAML to run as one more scene (repeatable)")
    parser.add_argument("--json", type=Path, default=None,
                        help="also write every run's per-scan errors and CPU times here")
    args = parser.parse_args(argv)
    names = args.filters.split(",")
    if "nav2" in names and importlib.util.find_spec("amcl") is None:
        raise SystemExit("the nav2 column needs the amcl package (pip install 'amcl>=0.1.2,<0.2', "
                         "in the dev extra on Linux x86-64; --filters without nav2 to go on)")
    build = None
    if args.nav2_src is not None:
        build = Nav2Build(args.nav2_src)
        names += list(NAV2_MODELS)
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    if build is not None:
        worst = check_build(SCENES["olin"](), build)
        print(f"the build of Nav2's sources against the amcl package, beam model, 10 scans: "
              f"largest difference of the estimates {worst:.3g}")
    table: dict[str, dict[str, dict[str, list[list[float]]]]] = {}
    unknown = [name for name in args.scenes.split(",") if name and name not in SCENES]
    if unknown:
        parser.error(f"unknown scene {unknown[0]!r}: {', '.join(SCENES)} (--map for a map file)")
    try:  # every map read (and refused) before the first run
        scenes = [SCENES[name]() for name in args.scenes.split(",") if name]
        scenes += [map_scene(path) for path in args.map]
    except (OSError, ValueError) as exc:
        raise SystemExit(f"amcl_vs_nav2: {exc}") from None
    for scene in scenes:
        scene_name = scene.name
        for n in args.particles:
            results = []
            for seed in args.seeds:
                r = run(scene, seed, n, names, args.scans, build)
                results.append(r)
                table.setdefault(f"{scene_name} {n}", {})[str(seed)] = {
                    k: v.tolist() for k, v in r.items()}
                print(f"{scene_name} {n:5d} seed {seed}: " + "  ".join(
                    f"{k} {v[:, 0].mean():.3f} m @10 {v[9 if len(v) > 9 else -1, 0]:.3f} "
                    f"{math.degrees(v[:, 1].mean()):.2f}°" for k, v in r.items()), flush=True)
            print(f"{scene_name} {n:5d} mean over {len(results)} seeds:")
            base = np.mean([r["nav2"][:, 0].mean() for r in results]) if "nav2" in names \
                else math.nan
            for k in results[0]:
                pos = np.mean([r[k][:, 0].mean() for r in results])
                head = math.degrees(np.mean([r[k][:, 1].mean() for r in results]))
                cpu = 1e3 * np.mean([r[k][1:, 2].mean() for r in results])
                curve = np.mean([r[k][:, 0] for r in results], axis=0)
                print(f"  {k:10s} position {pos:.4f} m ({pos / base:.2f}× nav2)  heading "
                      f"{head:.2f}°  CPU {cpu:.2f} ms/update  per scan "
                      f"{' '.join(f'{e:.3f}' for e in curve[::2])}")
    print(f"load average {os.getloadavg()[0]:.2f}")
    if args.json is not None:
        args.json.write_text(json.dumps(table), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
