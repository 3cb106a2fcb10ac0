"""``grader grade``: run each submission in its own process and score its outputs here.

For every submitted notebook: read it (a malformed notebook still gets a row), start
``python -m grader.worker`` in a scratch directory with time and memory limits, hand it the
code cells and the cases' inputs (public cases and the student's seeded hidden cases), and
judge the outputs it sends back against the ``kit`` references, in this process. A crash, a
hang or a submission that exits early still yields a row with its reason.

Scoring: an exercise earns its points when every case (public and hidden) passes; each case's
outcome and message is kept in the JSON results.
"""

from __future__ import annotations

import csv
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
from collections.abc import Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import nbformat

from grader import serialize
from grader.checker import explain
from grader.spec import Case, Exercise, LabSpec, course_seed

__all__ = ["ExerciseResult", "SubmissionResult", "find_submissions", "grade_notebook",
           "grade_submissions", "write_gradebook", "write_results"]

DEFAULT_TIMEOUT = 120.0
DEFAULT_MEMORY_MB = 2048
RESULT_LIMIT = 64 * 1024 * 1024


@dataclass
class CaseOutcome:
    case: str
    public: bool
    passed: bool
    message: str = ""


@dataclass
class ExerciseResult:
    id: str
    points: float
    max_points: float
    status: str
    """passed, wrong, not implemented, missing function, error, timeout, not graded."""
    reason: str
    cases: list[CaseOutcome] = field(default_factory=list)


@dataclass
class SubmissionResult:
    student: str
    path: str
    status: str
    """ok, timeout, crashed, malformed notebook."""
    reason: str
    exercises: dict[str, ExerciseResult] = field(default_factory=dict)
    cell_errors: list[dict[str, Any]] = field(default_factory=list)

    @property
    def total(self) -> float:
        return float(sum(e.points for e in self.exercises.values()))


def student_id(path: Path, lab: str) -> str:
    """``alice.ipynb`` → alice; ``alice/01-kinematics.ipynb`` → alice."""
    stem = path.stem
    if stem[:2].isdigit() and stem[:2] == lab[-2:]:
        return path.parent.name or stem
    return stem


def find_submissions(paths: Sequence[Path], lab: str) -> list[Path]:
    """Notebooks named by ``paths``: files as given, folders searched for ``*.ipynb``."""
    found: list[Path] = []
    for p in paths:
        if p.is_dir():
            found.extend(sorted(q for q in p.rglob("*.ipynb")
                                if ".ipynb_checkpoints" not in q.parts))
        elif p.exists():
            found.append(p)
        else:
            raise FileNotFoundError(f"{p}: no such submission")
    return found


def _limits(memory_mb: int, cpu_seconds: int) -> Any:
    def apply() -> None:
        memory = memory_mb * 1024 * 1024
        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
        resource.setrlimit(resource.RLIMIT_CPU, (cpu_seconds, cpu_seconds + 5))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    return apply


def _not_graded(spec: LabSpec, status: str, reason: str) -> dict[str, ExerciseResult]:
    return {ex.id: ExerciseResult(ex.id, 0.0, ex.points, status, reason)
            for ex in spec.exercises}


def _cases(ex: Exercise, student: str, secret: str | None) -> list[tuple[Case, bool]]:
    hidden = ex.hidden_cases(course_seed(ex.id, student, secret))
    return [(c, True) for c in ex.public] + [(c, False) for c in hidden]


def _score(ex: Exercise, cases: list[tuple[Case, bool]], outcome: dict[str, Any]) -> ExerciseResult:
    if "missing" in outcome:
        return ExerciseResult(ex.id, 0.0, ex.points, "missing function", str(outcome["missing"]))
    raw = outcome.get("cases", [])
    if len(raw) != len(cases):
        return ExerciseResult(ex.id, 0.0, ex.points, "error", "the worker's answer was incomplete")
    results: list[CaseOutcome] = []
    statuses: list[str] = []
    for (case, public), got in zip(cases, raw, strict=True):
        status = got.get("status")
        label = case.name if public else f"hidden case {len(results) - len(ex.public) + 1}"
        if status != "returned":
            statuses.append(str(status))
            results.append(CaseOutcome(label, public, False, str(got.get("message", ""))))
            continue
        try:
            value = serialize.decode(got["value"])
        except serialize.DecodeError as exc:
            statuses.append("error")
            results.append(CaseOutcome(label, public, False, f"unreadable output: {exc}"))
            continue
        verdict = explain(ex, case, value)
        if verdict is None:
            statuses.append("passed")
            results.append(CaseOutcome(label, public, True))
            continue
        statuses.append("wrong")
        problem, hint = verdict
        # a hidden case's message names neither its inputs nor its expected output
        message = problem if public else "wrong output"
        results.append(CaseOutcome(label, public, False, message + (f"; {hint}" if hint else "")))
    failed = [r for r in results if not r.passed]
    if not failed:
        return ExerciseResult(ex.id, ex.points, ex.points, "passed",
                              f"all {len(results)} cases pass", results)
    for status in ("not implemented", "timeout", "error", "wrong"):
        if status in statuses:
            first = next(r for r, s in zip(results, statuses, strict=True) if s == status)
            reason = (f"{len(failed)} of {len(results)} cases fail; "
                      f"{first.case}: {first.message}") if status != "not implemented" \
                else "not implemented yet"
            return ExerciseResult(ex.id, 0.0, ex.points, status, reason, results)
    return ExerciseResult(ex.id, 0.0, ex.points, "error", "unknown outcome", results)


def _read_cells(path: Path) -> list[str]:
    try:
        nb = nbformat.read(path, as_version=4)
    except UnicodeDecodeError as exc:
        raise ValueError(f"not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except Exception as exc:  # nbformat raises several types for bad JSON and bad schema
        raise ValueError(f"{type(exc).__name__}: {str(exc)[:200]}") from None
    return [c.source for c in nb.cells if c.cell_type == "code"]


def grade_notebook(path: Path, spec: LabSpec, student: str | None = None,
                   timeout: float = DEFAULT_TIMEOUT, memory_mb: int = DEFAULT_MEMORY_MB,
                   secret: str | None = None) -> SubmissionResult:
    """Grade one notebook; never raises for anything the submission does."""
    who = student or student_id(path, spec.name)
    try:
        cells = _read_cells(path)
    except (OSError, ValueError) as exc:
        return SubmissionResult(who, str(path), "malformed notebook", str(exc),
                                _not_graded(spec, "not graded", "malformed notebook"))
    plan = {ex.id: _cases(ex, who, secret) for ex in spec.exercises}
    request = {
        "cells": cells,
        # each exercise may lose at most one case to an endless loop: half the budget in all
        "case_time_limit": min(10.0, timeout / (2 * len(spec.exercises))),
        "blocked": sorted({name for ex in spec.exercises for name in ex.blocked}),
        "exercises": [{"id": ex.id, "function": ex.function,
                       "cases": [{"args": serialize.encode(c.args),
                                  "kwargs": serialize.encode(c.kwargs)}
                                 for c, _ in plan[ex.id]]}
                      for ex in spec.exercises],
    }
    env = {k: v for k, v in os.environ.items() if not k.startswith("KIT_COURSE")}
    env.update(KIT_GRADING="1", KIT_FAST="1", MPLBACKEND="Agg", PYTHONDONTWRITEBYTECODE="1",
               OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    with tempfile.TemporaryDirectory(prefix="grade-") as scratch:
        env["HOME"] = scratch
        proc = subprocess.Popen(
            [sys.executable, "-m", "grader.worker"], cwd=scratch, env=env,
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            start_new_session=True,
            preexec_fn=_limits(memory_mb, int(timeout) + 1))
        try:
            out, err = proc.communicate(json.dumps(request).encode(), timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            reason = f"did not finish within {timeout:g} s (an endless loop?)"
            return SubmissionResult(who, str(path), "timeout", reason,
                                    _not_graded(spec, "timeout", reason))
        finally:
            try:
                os.killpg(proc.pid, signal.SIGKILL)  # anything the submission left running
            except ProcessLookupError:
                pass
    if proc.returncode != 0 or not out:
        if proc.returncode < 0:
            name = signal.Signals(-proc.returncode).name
            reason = f"the process was killed by {name}"
            if name == "SIGXCPU":
                reason += " (CPU time limit)"
        else:
            reason = f"the process exited with code {proc.returncode} before reporting"
        tail = err.decode("utf-8", "replace").strip().splitlines()[-1:] if err else []
        if tail and "MemoryError" in tail[0]:
            reason = f"ran out of memory (limit {memory_mb} MB)"
        elif tail:
            reason += f": {tail[0][:200]}"
        return SubmissionResult(who, str(path), "crashed", reason,
                                _not_graded(spec, "crashed", reason))
    try:
        if len(out) > RESULT_LIMIT:
            raise ValueError("result too large")
        answer = json.loads(out)
        outcomes, cell_errors = answer["outcomes"], answer["cell_errors"]
    except (ValueError, KeyError, TypeError) as exc:
        reason = f"the submission's process sent an unreadable answer ({exc})"
        return SubmissionResult(who, str(path), "crashed", reason,
                                _not_graded(spec, "crashed", reason))
    exercises = {ex.id: _score(ex, plan[ex.id], outcomes.get(ex.id, {"missing": "no answer"}))
                 for ex in spec.exercises}
    return SubmissionResult(who, str(path), "ok", "graded", exercises, list(cell_errors))


def grade_submissions(paths: Iterable[Path], spec: LabSpec, jobs: int = 1,
                      timeout: float = DEFAULT_TIMEOUT, memory_mb: int = DEFAULT_MEMORY_MB,
                      secret: str | None = None) -> list[SubmissionResult]:
    """Grade many notebooks, ``jobs`` at a time (each in its own process)."""
    items = list(paths)
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        return list(pool.map(lambda p: grade_notebook(p, spec, None, timeout, memory_mb, secret),
                             items))


def gradebook_rows(results: Sequence[SubmissionResult], spec: LabSpec) -> list[dict[str, Any]]:
    rows = []
    for r in results:
        row: dict[str, Any] = {"student": r.student}
        for ex in spec.exercises:
            row[ex.id] = f"{r.exercises[ex.id].points:g}" if ex.id in r.exercises else "0"
        row["total"] = f"{r.total:g}"
        row["max"] = f"{spec.max_points:g}"
        row["percent"] = f"{100.0 * r.total / spec.max_points:.1f}" if spec.max_points else "0"
        row["status"] = r.status
        row["reason"] = r.reason
        rows.append(row)
    return rows


def _atomic_write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_gradebook(path: Path, results: Sequence[SubmissionResult], spec: LabSpec) -> None:
    """The CSV gradebook, written atomically (a reader never sees half a file)."""
    import io

    rows = gradebook_rows(results, spec)
    columns = ["student", *[ex.id for ex in spec.exercises], "total", "max", "percent",
               "status", "reason"]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    _atomic_write(path, buffer.getvalue())


def write_results(path: Path, results: Sequence[SubmissionResult], spec: LabSpec) -> None:
    """Per-exercise and per-case outcomes and reasons, as JSON."""
    data = {
        "lab": spec.name,
        "max": spec.max_points,
        "submissions": [
            {**{k: v for k, v in asdict(r).items() if k != "exercises"},
             "total": r.total,
             "exercises": {k: asdict(v) for k, v in r.exercises.items()}}
            for r in results],
    }
    _atomic_write(path, json.dumps(data, indent=1, ensure_ascii=False))
