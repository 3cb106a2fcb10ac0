"""Grading throughput: a class of Lab 01 submissions graded as ``grader grade --jobs 2`` does.

The class cycles through the solution, the untouched lab and the solution with swapped wheels,
so every submission runs its whole notebook (the solution's simulation cells included) in its
own sandbox in the strongest layer this machine offers. Each repeat grades into a fresh
gradebook; the figures are submissions per minute, best and spread over the repeats, with the
machine's load average. Run: python benchmarks/bench_grader.py [--count 100] [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import nbformat

from grader.gradebook import grade_class
from grader.sandbox import detect_layer
from grader.spec import load_lab

ROOT = Path(__file__).resolve().parents[1]
SWAP = ("return np.asarray(wheel_speeds, dtype=float) @ J.T",
        "return np.asarray(wheel_speeds, dtype=float)[..., ::-1] @ J.T")


def make_class(folder: Path, count: int) -> None:
    solution = ROOT / "solutions" / "01-kinematics.ipynb"
    buggy = nbformat.read(solution, as_version=4)
    for cell in buggy.cells:
        if cell.cell_type == "code" and SWAP[0] in cell.source:
            cell.source = cell.source.replace(*SWAP)
    for i in range(count):
        path = folder / f"student{i:03d}.ipynb"
        kind = i % 3
        if kind == 2:
            nbformat.write(buggy, path)
        else:
            shutil.copy(solution if kind == 0 else ROOT / "labs" / "01-kinematics.ipynb", path)


def run_once(folder: Path, out: Path, jobs: int, layer: str) -> float:
    spec = load_lab("lab01")
    start = time.perf_counter()
    results = grade_class(sorted(folder.glob("*.ipynb")), spec, out / "gb.csv", out / "gb.json",
                          jobs=jobs, secret="benchmark", layer=layer)
    elapsed = time.perf_counter() - start
    assert all(r.status == "ok" for r in results), {r.student: r.reason for r in results
                                                    if r.status != "ok"}
    assert sum(r.total == spec.max_points for r in results) == (len(results) + 2) // 3
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    layer = detect_layer()
    rates = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "class"
        folder.mkdir()
        make_class(folder, args.count)
        for repeat in range(args.repeats):
            out = Path(tmp) / f"run{repeat}"
            load = os.getloadavg()[0]
            elapsed = run_once(folder, out, args.jobs, layer)
            rates.append(60 * args.count / elapsed)
            print(f"lab01, {args.count} submissions, --jobs {args.jobs}, {layer}: "
                  f"{elapsed:6.1f} s = {rates[-1]:5.0f} submissions/min "
                  f"(load average {load:.1f} before, {os.getloadavg()[0]:.1f} after)",
                  flush=True)
    print(f"best {max(rates):.0f} submissions/min, median {statistics.median(rates):.0f}, "
          f"worst {min(rates):.0f} ({len(rates)} runs; bar: 60)")


if __name__ == "__main__":
    main()
