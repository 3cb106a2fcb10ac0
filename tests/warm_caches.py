"""Compile the kit's and the simulator's numba functions once, before the test suite runs.

numba keeps what it compiles (``cache=True``) beside each module, keyed on the source file;
a fresh checkout has none of it. Without this step both pytest workers, every subprocess a
test starts and every grading sandbox (which gets a private copy of the caches as they are
when the grader starts) compile the same functions again, a few seconds of CPU each time:
about 15 s of CPU for the functions below, once per consumer. ``make test`` runs this beside
ruff and mypy, on the core they leave free; with the caches already there it only loads them.

What runs: one AMCL episode of the office tour (the simulator with its people, the lidar,
AMCL's likelihood field, the costmaps, the planner, Regulated Pure Pursuit), one SLAM
episode with DWB (the SLAM front end's matchers and mapping, DWB's footprint checks), and
AMCL's beam model's ray casting (the user's own commands, so nothing here names a private
function), half a second of two robots, whose scans are cast together, and the imports of a
grading server, so that their bytecode is written (``make test`` lets Python write it).

``python tests/warm_caches.py`` (a checkout's ``.venv``); it prints one line.
"""

from __future__ import annotations

import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path


def warm() -> None:
    import numpy as np

    from kit.localization.likelihood_field import LikelihoodField, expected_ranges
    from sim.__main__ import main
    from sim.world import load_world

    with tempfile.TemporaryDirectory(prefix="kit-warm-") as tmp:
        for k, options in enumerate((["--localization", "amcl"],
                                     ["--localization", "slam", "--controller", "dwb"])):
            argv = ["navigate", "--episodes", "1", "--quiet", *options, "--out",
                    str(Path(tmp) / f"run{k}")]
            with contextlib.redirect_stdout(io.StringIO()):
                if main(argv) != 0:
                    raise SystemExit(f"warm_caches: python -m sim {' '.join(argv)} failed")
    field = LikelihoodField.from_grid(load_world("office").occupancy_grid(0.05, layer="lidar"))
    expected_ranges(field, np.array([4.0, 6.0, 0.0]), np.linspace(-3.0, 3.0, 60), 12.0)
    # what a grading server imports before it forks (its submissions cannot write bytecode:
    # whatever has none yet is compiled again by every server)
    import importlib

    from grader.server import preload_modules
    from grader.spec import load_lab

    for name in preload_modules(load_lab("lab01")):
        importlib.import_module(name)
    # several robots: their scans of a frame are cast together
    from sim.simulation import Simulation

    sim = Simulation("square", ["uiabot", "uiabot"], seed=1, people=2,
                     start=[[1.0, 1.0, 0.0], [3.0, 1.0, 0.0]])
    for _ in range(round(0.5 / sim.physics.dt)):
        sim.step()


if __name__ == "__main__":
    start = time.process_time()
    warm()
    print(f"numba's caches ready ({time.process_time() - start:.0f} s of CPU)", file=sys.stderr)
