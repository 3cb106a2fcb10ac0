"""Grading throughput: submissions per minute with --jobs 1 and 2.

Grades copies of the Lab 01 solution and the untouched lab (half each), so every submission
runs its notebook in its own process, as a class would. Run: python benchmarks/bench_grader.py
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path

from grader.grade import grade_submissions
from grader.spec import load_lab

ROOT = Path(__file__).resolve().parents[1]


def main(count: int = 20) -> None:
    spec = load_lab("lab01")
    with tempfile.TemporaryDirectory() as tmp:
        paths = []
        for i in range(count):
            source = ROOT / ("solutions" if i % 2 == 0 else "labs") / "01-kinematics.ipynb"
            paths.append(Path(shutil.copy(source, Path(tmp) / f"student{i:03d}.ipynb")))
        for jobs in (1, 2):
            start = time.perf_counter()
            results = grade_submissions(paths, spec, jobs=jobs)
            elapsed = time.perf_counter() - start
            assert sum(r.total == spec.max_points for r in results) == (count + 1) // 2
            print(f"lab01, {count} submissions, --jobs {jobs}: {elapsed:5.1f} s = "
                  f"{60 * count / elapsed:5.0f} submissions/min")


if __name__ == "__main__":
    main()
