"""Likelihood-field updates: particle-beams per second on one core (issue 12's bar: 2000
particles × 60 beams at ≥ 80 updates/s, i.e. ≥ 10 M particle-beams/s).

    .venv/bin/python benchmarks/bench_localization.py [--repeat 5]

The map is the simulated office at 5 cm (what the lidar sees); the beams are endpoints of a
real simulated scan, 60 of them as AMCL's ``max_beams``; the particles are spread over the free
space. The compiled loop, the numpy version and the plain per-particle loop are timed on the
same inputs; their results are compared first.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from kit.localization.likelihood_field import (
    LikelihoodField,
    LikelihoodFieldModel,
    likelihood_field_weight,
    likelihood_field_weights,
)
from kit.localization.particles import uniform_free_poses
from sim.world import load_world


def best_of(fn, repeat: int) -> tuple[float, float]:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times), max(times)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    field = LikelihoodField.from_grid(load_world("office").occupancy_grid(0.05, layer="lidar"))
    rng = np.random.default_rng(1)
    poses = uniform_free_poses(field, 2000, rng)
    angles = np.linspace(-np.pi, np.pi, 60, endpoint=False)
    ranges = rng.uniform(0.5, 8.0, 60)
    endpoints = np.column_stack([ranges * np.cos(angles), ranges * np.sin(angles)])
    model = LikelihoodFieldModel(0.5, 0.5, 0.2, "amcl")
    compiled = likelihood_field_weights(poses, endpoints, field, model, 12.0)
    vectorised = likelihood_field_weights(poses, endpoints, field, model, 12.0, method="numpy")
    plain = [likelihood_field_weight(p, endpoints, field, model, 12.0) for p in poses[:200]]
    assert np.allclose(compiled, vectorised, rtol=1e-12)
    assert np.allclose(compiled[:200], plain, rtol=1e-12)
    work = len(poses) * len(endpoints)
    for name, fn in (("numba", lambda: likelihood_field_weights(poses, endpoints, field, model,
                                                                12.0)),
                     ("numpy", lambda: likelihood_field_weights(poses, endpoints, field, model,
                                                                12.0, method="numpy"))):
        best, worst = best_of(fn, args.repeat)
        print(f"{name:6s} 2000 particles x 60 beams: best {1e3 * best:.2f} ms "
              f"(worst {1e3 * worst:.2f}) = {1 / best:.0f} updates/s, "
              f"{work / best / 1e6:.1f} M particle-beams/s")
    best, _ = best_of(lambda: [likelihood_field_weight(p, endpoints, field, model, 12.0)
                               for p in poses[:200]], 1)
    print(f"plain  200 particles x 60 beams: {1e3 * best:.1f} ms = "
          f"{200 * 60 / best / 1e6:.2f} M particle-beams/s")
    print(f"load average {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
