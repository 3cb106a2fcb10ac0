"""The SLAM's outputs on the three real logs, bit for bit, as one SHA-256 per run: the check
that a speed-up changed nothing.

The runs are issue 29's (``tests/kit/slam/test_slam_logs.py``): ``offline.run_carmen`` on
the Intel Research Lab and Freiburg 079 logs as their poses are and with
:func:`kit.slam.evaluate.perturb_odometry` seeds 1–5, and on MIT CSAIL as it is (13 runs,
about 14 s of CPU each). Each digest covers:

- the trajectory (every scan's stamp and ``T_map_base``, by their bytes), every scan's record
  (anchor node, offset, odometry, how its pose was found, returns dropped as moving);
- the final graph: every node's pose and every edge (its nodes, measurement, information);
- every loop-closure attempt in order, accepted or not: its nodes, reason, response,
  supports, shift, reference, surprise, χ², group, measurement and covariance;
- the match edges the back end replaced.

Each line also prints the Kümmerle et al. (2009) mean translational error on the benchmark's
relations (what issue 29's bars hold) and the run's CPU time (``process_time``).

Run it on two versions of the code and compare (``--save FILE`` writes the lines,
``--check FILE`` compares with saved ones, by default with ``slam_fingerprint.json`` beside
this script, the rows of ``main`` at 4d0568a on the machine the kit is developed on; exits 1
on any difference). The digests hold for one machine: numpy's SIMD kernels differ in the last
bit between CPUs, and a whole-log run makes other decisions from that. The old
code need not have this script: put its checkout (its ``kit/``) first on the path and run
this file from another folder::

    mkdir /tmp/old && git archive main | tar -x -C /tmp/old
    cd /tmp && PYTHONPATH=/tmp/old python CHECKOUT/benchmarks/slam_fingerprint.py --save before.txt
    cd CHECKOUT && python benchmarks/slam_fingerprint.py --check /tmp/before.txt

``--runs intel:1 fr079:as-is …`` picks runs (default all 13). Needs ``../shared/data``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
from pathlib import Path

from bench_slam_logs import DATA, slam_run
from fingerprint import feed

from kit.slam import evaluate
from kit.slam.frontend import Slam

RUNS = {"intel": (1, 2, 3, 4, 5), "fr079": (1, 2, 3, 4, 5), "csail": ()}
"""Each log's noise seeds (besides the run as-is); the logs are ``bench_slam_logs``'s."""

EXPECTED = Path(__file__).with_suffix(".json")
"""The rows of ``main`` at 4d0568a (ICP's solve written out) on the 2-core machine the kit is
developed on (its ``rows``): what ``--check`` compares with by default."""


def digest(slam: Slam) -> str:
    """The SHA-256 of everything a SLAM run produced (see the module docstring)."""
    h = hashlib.sha256()
    stamps, poses = slam.trajectory()
    feed(h, (stamps, poses))
    for r in slam.records:
        feed(h, (r.stamp, r.anchor, r.offset, r.odometry, r.matched, r.moving))
    feed(h, (slam.graph.poses, *slam.graph.edges()))
    for c in slam.closures:
        feed(h, (c.node, c.candidate, c.accepted, c.reason, c.response, c.support,
                 c.recent_support, c.shift, c.reference, c.surprise, c.chi2, c.group,
                 c.measurement, c.covariance))
    feed(h, list(slam.replaced_matches))
    return h.hexdigest()


def run(name: str, seed: int | None) -> tuple[str, float]:
    """One run's row (``name:label digest mean=…``) and its CPU time [s]."""
    slam, relations, cpu = slam_run(name, seed)
    summary = evaluate.summarize(evaluate.relation_errors(*slam.trajectory(), relations))
    label = "as-is" if seed is None else str(seed)
    return (f"{name}:{label} {digest(slam)} mean={summary.translational_mean:.6f} "
            f"closures={sum(c.accepted for c in slam.closures)}/{len(slam.closures)}"), cpu


def all_runs() -> list[str]:
    return [f"{name}:{label}" for name, seeds in RUNS.items()
            for label in ["as-is", *map(str, seeds)]]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", nargs="+", metavar="LOG:SEED", default=all_runs(),
                        help="runs as log:seed or log:as-is (default all 13)")
    parser.add_argument("--save", type=Path, help="write the rows to this file")
    parser.add_argument("--check", type=Path, help="compare with the rows in this file "
                        "(default: with the digests in this script)")
    args = parser.parse_args(argv)
    unknown = [r for r in args.runs if r not in all_runs()]
    if unknown:
        print(f"unknown run {unknown[0]!r}; runs are {' '.join(all_runs())}", file=sys.stderr)
        return 2
    if not DATA.is_dir():
        print(f"{DATA} not found: nothing to fingerprint", file=sys.stderr)
        return 2
    try:
        if args.check is not None:
            lines = args.check.read_text().split("\n")
            expected = {line.split()[0]: line for line in lines if line.strip()}
        else:
            expected = json.loads(EXPECTED.read_text())["rows"]
    except OSError as e:
        print(f"cannot read {e.filename}: {e.strerror}", file=sys.stderr)
        return 2
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores", flush=True)
    rows, failed, total = [], 0, 0.0
    for key in args.runs:
        name, label = key.split(":")
        row, cpu = run(name, None if label == "as-is" else int(label))
        total += cpu
        verdict = ""
        if expected:
            same = expected.get(key) == row
            failed += not same
            verdict = "  identical" if same else \
                f"  DIFFERENT (expected {expected.get(key, 'no such run')})"
        print(f"{row}{verdict}   [{cpu:.1f} s CPU]", flush=True)
        rows.append(row)
    print(f"{total:.1f} s CPU in all")
    if args.save is not None:
        args.save.write_text("\n".join(rows) + "\n")
    if expected:
        print("all identical" if not failed else f"{failed} run(s) differ")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
