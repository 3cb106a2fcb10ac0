"""The kit's AMCL beside Nav2's own (the ``amcl`` package: Nav2's AMCL sources behind Python
bindings) on the same maps, scans and odometry, with the set-up of issue 29: seeded tracks of
0.1 m steps and 0.4 rad turns, 360-beam scans with N(0, 0.02 m) noise, odometry equal to the
truth, Nav2's alphas, z_hit, z_rand, σ_hit and 60 beams, an update at every scan, both started
at the truth with Nav2's default initial covariance.

The package always runs Nav2's beam model, so the kit runs its beam model too
(``laser_model_type: beam``): the filters set alike. The harness (tracks, scans, both filters)
is ``benchmarks/amcl_vs_nav2.py``, which also runs the kit's likelihood-field models. Nav2's
filter draws from libc's ``drand48``, whose seeding in ``pf_init`` depends on how many filters
the process made before; so the package runs in a fresh process of its own, and its figures
do not depend on which tests ran first.
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from kit import msgs
from kit.localization import Amcl, AmclParameters
from kit.localization.particles import ParticleFilter
from kit.tf import RigidTransform

ROOT = Path(__file__).resolve().parents[3]
HARNESS = ROOT / "benchmarks" / "amcl_vs_nav2.py"
SEEDS = {2000: list(range(8)), 10000: list(range(4))}
MORE_SEEDS = {"turtlebot3-world-nav2": list(range(16))}
"""A small map's runs are cheap: more seeds, for a steadier mean."""
RATIO = 1.2


def harness() -> ModuleType:
    spec = importlib.util.spec_from_file_location("amcl_vs_nav2", HARNESS)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("amcl_vs_nav2", module)
    spec.loader.exec_module(module)
    return module


MAPS = {"turtlebot3-world-nav2": "maps/turtlebot3-world-nav2/map.yaml"}
"""Scenes that are a map file of ``../shared/data`` (run with the harness's ``--map``)."""


def package_errors(scene: str, particles: int, seeds: list[int], tmp_path: Path,
                   map_file: Path | None = None) -> dict[str, np.ndarray]:
    """The ``amcl`` package's per-scan errors (scans, 3) per seed, from a fresh process."""
    out = tmp_path / f"nav2-{scene}-{particles}.json"
    where = ["--scenes", "", "--map", str(map_file)] if map_file else ["--scenes", scene]
    subprocess.run([sys.executable, str(HARNESS), *where, "--particles",
                    str(particles), "--seeds", *map(str, seeds), "--filters", "nav2",
                    "--json", str(out)], check=True, capture_output=True, cwd=ROOT)
    table = json.loads(out.read_text(encoding="utf-8"))[f"{scene} {particles}"]
    return {seed: np.array(runs["nav2"]) for seed, runs in table.items()}


@pytest.mark.slow
@pytest.mark.parametrize("scene, particles", [
    pytest.param("olin", 2000, marks=pytest.mark.dataset),
    pytest.param("olin", 10000, marks=pytest.mark.dataset),
    ("office", 2000),
    pytest.param("turtlebot3-world-nav2", 2000, marks=pytest.mark.dataset)])
def test_kit_amcl_tracks_within_1_2x_of_nav2s_amcl_set_alike(scene, particles, tmp_path,
                                                              request):
    """Mean position and heading error over every scan of every seeded track: the kit's at
    most 1.2× the package's; and the package itself tracks (a broken set-up of the
    reference must not let the kit pass). The issue's bar is on the Olin map at 2,000 and
    10,000 particles; the office and Nav2's TurtleBot3 world at 2,000 are two more maps
    (``benchmarks/amcl_vs_nav2.py`` runs any map at any count)."""
    pytest.importorskip("amcl")
    map_file = None
    if scene != "office":
        data = request.getfixturevalue("shared_data")
        map_file = data / MAPS[scene] if scene in MAPS else None
    bench = harness()
    seeds = MORE_SEEDS.get(scene, SEEDS[particles])
    nav2 = package_errors(scene, particles, seeds, tmp_path, map_file)
    world = bench.map_scene(map_file) if map_file else bench.SCENES[scene]()
    kit = {str(seed): bench.run(world, seed, particles, ["kit-beam"])["kit-beam"]
           for seed in seeds}
    nav2_position = np.mean([e[:, 0].mean() for e in nav2.values()])
    kit_position = np.mean([e[:, 0].mean() for e in kit.values()])
    nav2_heading = np.mean([e[:, 1].mean() for e in nav2.values()])
    kit_heading = np.mean([e[:, 1].mean() for e in kit.values()])
    per_seed = {s: (round(float(kit[s][:, 0].mean()), 4), round(float(nav2[s][:, 0].mean()), 4))
                for s in kit}
    assert nav2_position < 0.1, f"the reference does not track: {nav2_position:.3f} m"
    assert kit_position <= RATIO * nav2_position, \
        f"kit {kit_position:.4f} m against nav2 {nav2_position:.4f} m; per seed {per_seed}"
    assert kit_heading <= RATIO * nav2_heading, \
        f"kit {np.degrees(kit_heading):.3f}° against nav2 {np.degrees(nav2_heading):.3f}°"


def _scan(ranges: np.ndarray, angle_min: float, increment: float) -> msgs.LaserScan:
    return msgs.LaserScan(angle_min=angle_min, angle_max=angle_min + increment * (len(ranges) - 1),
                          angle_increment=increment, range_min=0.05, range_max=12.0,
                          ranges=ranges.astype(np.float32))


@pytest.mark.parametrize("model", ["likelihood_field", "likelihood_field_prob", "beam"])
def test_a_scan_weighs_particles_alike_however_its_beams_and_mounting_are_written(model):
    """The same beams written four ways — counter-clockwise from −2 rad; clockwise from the
    last beam (the ranges reversed); from a scanner turned +1 rad whose angles start 1 rad
    earlier; from a scanner mounted upside down (roll π), whose angles mirror — give every
    particle the same weight (REP 103: angles counter-clockwise about the scanner's z, the
    mounting through tf). The angles are multiples of 1/32 rad, exact in the message's
    float32 fields, so the four ways agree to rounding."""
    rng = np.random.default_rng(3)
    occupied = np.zeros((80, 100), dtype=bool)
    occupied[[0, -1], :] = True
    occupied[:, [0, -1]] = True
    occupied[30:34, 20:60] = True
    info = msgs.MapMetaData(resolution=0.1, width=100, height=80,
                            origin=msgs.Pose(msgs.Point(-2.0, -1.0, 0.0)))
    grid = msgs.OccupancyGrid(msgs.Header(frame_id="map"), info,
                              np.where(occupied, 100, 0).astype(np.int8).ravel())
    n, inc, first = 120, 1.0 / 32.0, -2.0
    last = first + (n - 1) * inc
    ranges = rng.uniform(0.5, 6.0, n)
    ranges[::17] = np.inf
    poses = np.column_stack([rng.uniform(1, 6, 300), rng.uniform(1, 5, 300),
                             rng.uniform(-np.pi, np.pi, 300)])
    params = AmclParameters(max_beams=n, laser_model_type=model, laser_max_range=12.0)
    level = RigidTransform.from_pose2d([0.2, 0.1, 0.0])
    turned = RigidTransform.from_pose2d([0.2, 0.1, 1.0])
    upside_down = RigidTransform(np.array([0.2, 0.1, 0.3]), np.array([1.0, 0.0, 0.0, 0.0]))
    ways = [(_scan(ranges, first, inc), level),
            (_scan(ranges[::-1], last, -inc), level),
            (_scan(ranges, first - 1.0, inc), turned),
            (_scan(ranges, -first, -inc), upside_down)]
    weights = []
    for scan, mount in ways:
        node = Amcl(grid, params, seed=0)
        node.filter = ParticleFilter.from_poses(poses, node.rng)
        log_likelihoods, _ = node._log_likelihoods(scan, node._laser(scan, mount), None)
        weights.append(log_likelihoods)
    assert np.ptp(weights[0]) > 1.0  # the particles are told apart at all
    for other in weights[1:]:
        np.testing.assert_allclose(other, weights[0], rtol=1e-9, atol=1e-9)
