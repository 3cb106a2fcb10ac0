"""Grading throughput, as ``grader grade --jobs 2`` grades a class.

Two figures, each in the strongest sandbox layer this machine offers, each from a fresh
gradebook (and a fresh grading server: its start-up is counted):

* **Lab 01, a class of 100** cycling through honest work (the release with the solution's
  exercise cells), untouched releases and honest work with swapped wheels — the issue's goal:
  ≤ 30 s on 2 cores, quiet machine;
* **Lab 11, one submission** (an honest controller: four seeded office episodes, each run in
  the grader's process and asking the controller across the boundary step by step) — the goal:
  ≤ 10 s.

Printed: wall time, the grader's own CPU time and the submissions' (each sandboxed
process's CPU time, as the grading server reports it when the submission ends: the
sandboxes are not the grader's own children, so ``getrusage`` cannot see them), and the load
average before and after, for each repeat. Run:
``python benchmarks/bench_grader.py [--count 100] [--repeats 3] [--lab11 1]``
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import resource
import shutil
import statistics
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from grader import server
from grader.grade import close_servers
from grader.gradebook import grade_class
from grader.sandbox import detect_layer
from grader.spec import load_lab

ROOT = Path(__file__).resolve().parents[1]


def _solved_release() -> Any:
    """tests/conftest.py's honest submission builder (loaded by path: the tests folder is
    not put on sys.path, where its kit/ and grader/ folders would shadow the packages)."""
    spec = importlib.util.spec_from_file_location("kit_tests_conftest",
                                                  ROOT / "tests" / "conftest.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.solved_release


solved_release = _solved_release()

SWAP = ("return np.asarray(wheel_speeds, dtype=float) @ J.T",
        "return np.asarray(wheel_speeds, dtype=float)[..., ::-1] @ J.T")


def make_class(folder: Path, count: int) -> None:
    honest = solved_release("lab01", folder.parent / "honest.ipynb")
    buggy = solved_release("lab01", folder.parent / "buggy.ipynb", *SWAP)
    untouched = ROOT / "labs" / "01-kinematics.ipynb"
    for i in range(count):
        shutil.copy((honest, untouched, buggy)[i % 3], folder / f"student{i:03d}.ipynb")


class _SubmissionsCpu:
    """The CPU seconds of every submission that ended, from the endings the grading server
    reports (:meth:`grader.server.Session.finish`), summed across the grading threads."""

    def __init__(self) -> None:
        self.total, self.lock = 0.0, threading.Lock()
        finish = server.Session.finish

        def counted(session: server.Session, *args: Any, **kwargs: Any) -> server.Ending:
            ending = finish(session, *args, **kwargs)
            with self.lock:
                self.total += ending.cpu
            return ending

        server.Session.finish = counted  # type: ignore[method-assign]


SUBMISSIONS = _SubmissionsCpu()


def _cpu() -> tuple[float, float]:
    me = resource.getrusage(resource.RUSAGE_SELF)
    return me.ru_utime + me.ru_stime, SUBMISSIONS.total


def run_once(lab: str, folder: Path, out: Path, jobs: int, layer: str) -> tuple[float, float,
                                                                               float]:
    spec = load_lab(lab)
    cpu_before = _cpu()
    start = time.perf_counter()
    results = grade_class(sorted(folder.glob("*.ipynb")), spec, out / "gb.csv", out / "gb.json",
                          jobs=jobs, secret="benchmark", layer=layer)
    close_servers()
    elapsed = time.perf_counter() - start
    cpu_after = _cpu()
    assert all(r.status == "ok" for r in results), {r.student: r.reason for r in results
                                                    if r.status != "ok"}
    if lab == "lab01":
        assert sum(r.total == spec.max_points for r in results) == (len(results) + 2) // 3
    else:
        assert all(r.total == spec.max_points for r in results), [r.exercises for r in results]
    return elapsed, cpu_after[0] - cpu_before[0], cpu_after[1] - cpu_before[1]


def report(label: str, figures: list[tuple[float, float, float]], loads: list[tuple[float,
                                                                                   float]]) -> None:
    for (wall, own, children), (before, after) in zip(figures, loads, strict=True):
        print(f"{label}: {wall:6.1f} s wall, CPU {own:5.1f} s in the grader + {children:5.1f} s "
              f"in the submissions (load average {before:.1f} before, {after:.1f} after)",
              flush=True)
    walls = [f[0] for f in figures]
    print(f"{label}: best {min(walls):.1f} s, median {statistics.median(walls):.1f} s "
          f"({len(walls)} runs)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=100, help="Lab 01 submissions (100)")
    parser.add_argument("--lab11", type=int, default=1, help="Lab 11 submissions (1)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    layer = detect_layer()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "lab01"
        folder.mkdir()
        make_class(folder, args.count)
        figures, loads = [], []
        for repeat in range(args.repeats):
            before = os.getloadavg()[0]
            figures.append(run_once("lab01", folder, Path(tmp) / f"out01-{repeat}", args.jobs,
                                    layer))
            loads.append((before, os.getloadavg()[0]))
        report(f"lab01, {args.count} submissions, --jobs {args.jobs}, {layer}", figures, loads)
        if args.lab11:
            folder = Path(tmp) / "lab11"
            folder.mkdir()
            for i in range(args.lab11):
                solved_release("lab11", folder / f"student{i}.ipynb")
            figures, loads = [], []
            for repeat in range(args.repeats):
                before = os.getloadavg()[0]
                figures.append(run_once("lab11", folder, Path(tmp) / f"out11-{repeat}",
                                        args.jobs, layer))
                loads.append((before, os.getloadavg()[0]))
            report(f"lab11, {args.lab11} submission(s), --jobs {args.jobs}, {layer}", figures,
                   loads)


if __name__ == "__main__":
    main()
