"""Compile the kit's and the simulator's numba functions once, before the test suite runs.

numba keeps what it compiles (``cache=True``) beside each module, keyed on the source file;
a fresh checkout has none of it. Without this step both pytest workers, every subprocess a
test starts and every grading sandbox (which gets a private copy of the caches as they are
when the grader starts) compile the same functions again, a few seconds of CPU each time:
about 15 s of CPU for the functions below, once per consumer. ``make test`` runs this beside
ruff and mypy, on the core they leave free; with the caches already there it only loads them.

What runs: one AMCL episode (the simulator with its people, the lidar, AMCL's likelihood
field, the costmaps, the planner, Regulated Pure Pursuit) and one SLAM episode with DWB (the
SLAM front end's matchers, loop closure and mapping, DWB's footprint checks), each on the
office's one-goal glass route: it compiles what the five-goal tour does but one function
(the footprint's overlap with cells it already touches, needed by a robot pressed against
something: 0.6 s to compile where a test needs it), in 25 s of CPU instead of 32 from a
fresh checkout and 9 s instead of 16 with the caches there; and
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
        for k, options in enumerate((["--localization", "amcl", "--route", "glass"],
                                     ["--localization", "slam", "--controller", "dwb",
                                      "--route", "glass"])):
            argv = ["navigate", "--episodes", "1", "--quiet", *options, "--out",
                    str(Path(tmp) / f"run{k}")]
            with contextlib.redirect_stdout(io.StringIO()):
                if main(argv) != 0:
                    raise SystemExit(f"warm_caches: python -m sim {' '.join(argv)} failed")
    field = LikelihoodField.from_grid(load_world("office").occupancy_grid(0.05, layer="lidar"))
    for lookup in ("exact", "cells"):
        expected_ranges(field, np.array([4.0, 6.0, 0.0]), np.linspace(-3.0, 3.0, 60), 12.0,
                        lookup=lookup)
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
