"""``grader grade``: run each submission in a sandbox and score its outputs here.

For every submitted notebook: read it (a malformed notebook still gets a row), start
``python -m grader.worker`` in a scratch directory inside the strongest sandbox this machine
offers (:mod:`grader.sandbox`), hand it the code cells and the cases' inputs (public cases and
the student's own seeded hidden cases), and judge the outputs it leaves in its result file
against the ``kit`` references, in this process. A crash, a hang, a memory bomb or a
submission that exits early still yields a row with its reason.

Scoring: each exercise earns ``points × passed cases / all cases`` (public and hidden).

Grading a class is resumable and idempotent: after every submission the gradebook and the
JSON results are rewritten atomically, and a re-run reuses every finished result whose
notebook (SHA-256 of its bytes) and grading set-up (the lab's specification, the course
secret, the limits) are unchanged — so an interrupted run continues where it stopped and a
re-run grades only what changed.
"""

from __future__ import annotations

import csv
import hashlib
import inspect
import io
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import nbformat

from grader import serialize
from grader.checker import explain
from grader.sandbox import Limits, Sandbox, detect_layer
from grader.spec import Case, Exercise, LabSpec, course_seed, load_lab

__all__ = ["ExerciseResult", "Limits", "SubmissionResult", "find_submissions", "grade_class",
           "grade_notebook", "grade_submissions", "write_gradebook", "write_results"]

DEFAULT_TIMEOUT = 120.0
DEFAULT_MEMORY_MB = 2048
RESULT_LIMIT = 64 * 1024 * 1024
STATUSES = ("ok", "timeout", "memory", "crashed", "output limit", "malformed notebook")


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
    """passed, partly passed, wrong, not implemented, missing function, error, timeout,
    memory, not graded."""
    reason: str
    cases: list[CaseOutcome] = field(default_factory=list)


@dataclass
class SubmissionResult:
    student: str
    path: str
    status: str
    """one of STATUSES."""
    reason: str
    exercises: dict[str, ExerciseResult] = field(default_factory=dict)
    cell_errors: list[dict[str, Any]] = field(default_factory=list)
    sandbox: str = ""
    sha256: str = ""

    @property
    def total(self) -> float:
        return round(float(sum(e.points for e in self.exercises.values())), 2)

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["total"] = self.total
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SubmissionResult:
        exercises = {k: ExerciseResult(**{**v, "cases": [CaseOutcome(**c) for c in v["cases"]]})
                     for k, v in data["exercises"].items()}
        return cls(data["student"], data["path"], data["status"], data["reason"], exercises,
                   list(data.get("cell_errors", [])), data.get("sandbox", ""),
                   data.get("sha256", ""))


def student_id(path: Path, lab: str) -> str:
    """``alice.ipynb`` → alice; ``alice/01-kinematics.ipynb`` → alice. (A notebook whose
    metadata has ``{"kit": {"student": "..."}}`` is graded under that id instead.)"""
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


def _not_graded(spec: LabSpec, status: str, reason: str) -> dict[str, ExerciseResult]:
    return {ex.id: ExerciseResult(ex.id, 0.0, ex.points, status, reason)
            for ex in spec.exercises}


def _cases(ex: Exercise, student: str, secret: str | None) -> list[tuple[Case, bool]]:
    hidden = ex.hidden_cases(course_seed(ex.id, student, secret))
    return [(c, True) for c in ex.public] + [(c, False) for c in hidden]


def _reference_signature(ex: Exercise) -> str:
    """The reference's parameters as a student would write them (no annotations)."""
    try:
        params = inspect.signature(ex.reference).parameters.values()
    except (TypeError, ValueError):
        return "(?)"
    shown = [p.name if p.default is inspect.Parameter.empty else f"{p.name}={p.default!r}"
             for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return f"({', '.join(shown)})"


def _score(ex: Exercise, cases: list[tuple[Case, bool]], outcome: dict[str, Any]
           ) -> ExerciseResult:
    if "missing" in outcome:
        return ExerciseResult(ex.id, 0.0, ex.points, "missing function", str(outcome["missing"]))
    raw = outcome.get("cases", [])
    if not isinstance(raw, list) or len(raw) != len(cases):
        return ExerciseResult(ex.id, 0.0, ex.points, "error", "the worker's answer was incomplete")
    results: list[CaseOutcome] = []
    statuses: list[str] = []
    hidden_index = 0
    for (case, public), got in zip(cases, raw, strict=True):
        if not public:
            hidden_index += 1
        label = case.name if public else f"hidden case {hidden_index}"
        status = str(got.get("status")) if isinstance(got, dict) else "error"
        if status != "returned":
            message = str(got.get("message", ""))[:500] if isinstance(got, dict) else ""
            if "TypeError" in message and "argument" in message:
                message += (f"; the exercise calls it as {ex.function}"
                            f"{_reference_signature(ex)}, the notebook defines "
                            f"{ex.function}{outcome.get('signature', '(?)')}")
            statuses.append(status)
            results.append(CaseOutcome(label, public, False, message))
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
    passed = sum(r.passed for r in results)
    points = round(ex.points * passed / len(results), 2)
    if passed == len(results):
        return ExerciseResult(ex.id, points, ex.points, "passed",
                              f"all {len(results)} cases pass", results)
    for status in ("not implemented", "timeout", "memory", "error", "wrong"):
        if status in statuses:
            first = next(r for r, s in zip(results, statuses, strict=True) if s == status)
            if status == "not implemented":
                reason = "not implemented yet"
            else:
                reason = (f"{len(results) - passed} of {len(results)} cases fail; "
                          f"{first.case}: {first.message}")
            label = "partly passed" if passed and status == "wrong" else status
            return ExerciseResult(ex.id, points, ex.points, label, reason, results)
    return ExerciseResult(ex.id, points, ex.points, "error", "unknown outcome", results)


def _read_cells(path: Path) -> tuple[list[str], str, str | None]:
    try:
        raw = path.read_bytes()
        nb = nbformat.reads(raw.decode("utf-8"), as_version=4)
    except UnicodeDecodeError as exc:
        raise ValueError(f"not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except OSError:
        raise
    except Exception as exc:  # nbformat raises several types for bad JSON and bad schema
        raise ValueError(f"{type(exc).__name__}: {str(exc)[:200]}") from None
    named = nb.metadata.get("kit", {}).get("student") if isinstance(
        nb.metadata.get("kit"), dict) else None
    return ([c.source for c in nb.cells if c.cell_type == "code"],
            hashlib.sha256(raw).hexdigest(), str(named) if named else None)


def _tail(path: Path, limit: int = 4096) -> str:
    try:
        with open(path, "rb") as fh:
            fh.seek(max(0, path.stat().st_size - limit))
            return fh.read().decode("utf-8", "replace")
    except OSError:
        return ""


def grade_notebook(path: Path, spec: LabSpec, student: str | None = None,
                   timeout: float = DEFAULT_TIMEOUT, memory_mb: int = DEFAULT_MEMORY_MB,
                   secret: str | None = None, hide: Sequence[Path] = ()) -> SubmissionResult:
    """Grade one notebook; never raises for anything the submission does."""
    who = student or student_id(path, spec.name)
    try:
        cells, digest, named = _read_cells(path)
        who = student or named or who
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
    limits = Limits(memory_mb=memory_mb, cpu_seconds=int(timeout) + 1)
    env = {k: v for k, v in os.environ.items() if not k.startswith("KIT_COURSE")}
    env.update(KIT_GRADING="1", KIT_FAST="1", MPLBACKEND="Agg", PYTHONDONTWRITEBYTECODE="1",
               OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    with tempfile.TemporaryDirectory(prefix="grade-") as tmp:
        scratch = Path(tmp)
        (scratch / "request.json").write_text(json.dumps(request))
        (scratch / "result.json").write_bytes(b"")
        stdout_path, stderr_path = scratch / "stdout.txt", scratch / "stderr.txt"
        box = Sandbox.create(scratch, [path.parent, *hide], limits)
        env["HOME"] = env["TMPDIR"] = str(box.scratch)
        with open(stdout_path, "wb") as out, open(stderr_path, "wb") as err, \
                open(scratch / "request.json", "rb") as request_in:
            box.prepare()
            proc = subprocess.Popen(box.command(), cwd=box.scratch, env=env, stdin=request_in,
                                    stdout=out, stderr=err, start_new_session=True,
                                    preexec_fn=box.preexec())
            try:
                proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                _kill(proc)
                reason = f"did not finish within {timeout:g} s (an endless loop?)"
                return SubmissionResult(who, str(path), "timeout", reason,
                                        _not_graded(spec, "timeout", reason), [],
                                        box.layer, digest)
            finally:
                _kill(proc)  # anything the submission left running
        output_limited = max(stdout_path.stat().st_size,
                             stderr_path.stat().st_size) >= limits.file_mb * 1024 * 1024
        err_tail = _tail(stderr_path)
        result_size = (scratch / "result.json").stat().st_size
        raw = (scratch / "result.json").read_bytes() if 0 < result_size <= RESULT_LIMIT else b""
    if proc.returncode != 0 or not raw:
        status, reason = "crashed", ""
        code = proc.returncode
        if box.layer != "rlimits" and 128 < code < 128 + 65:
            code = -(code - 128)  # the sandbox reports its child's signal as 128 + n
        if code < 0:
            name = signal.Signals(-code).name
            reason = f"the process was killed by {name}"
            if name == "SIGXCPU":
                status, reason = "timeout", f"used more than {limits.cpu_seconds} s of CPU"
        elif proc.returncode != 0:
            reason = f"the process exited with code {proc.returncode} before reporting"
        elif result_size > RESULT_LIMIT:
            status, reason = "output limit", "its results were larger than the grader reads"
        else:
            reason = "the process ended without reporting results"
        last = err_tail.strip().splitlines()[-1:] if err_tail.strip() else []
        if last and "MemoryError" in last[0]:
            status, reason = "memory", f"ran out of memory (limit {memory_mb} MB)"
        elif last:
            reason += f": {last[0][:200]}"
        return SubmissionResult(who, str(path), status, reason,
                                _not_graded(spec, status, reason), [], box.layer, digest)
    try:
        answer = json.loads(raw)
        outcomes, cell_errors = answer["outcomes"], list(answer["cell_errors"])
        if not isinstance(outcomes, dict):
            raise TypeError("outcomes is not a mapping")
    except (ValueError, KeyError, TypeError) as exc:
        reason = f"the submission's process left an unreadable result ({exc})"
        return SubmissionResult(who, str(path), "crashed", reason,
                                _not_graded(spec, "crashed", reason), [], box.layer, digest)
    exercises = {ex.id: _score(ex, plan[ex.id], outcomes.get(ex.id, {"missing": "no answer"}))
                 for ex in spec.exercises}
    status, reason = "ok", "graded"
    memory_hit = any("MemoryError" in str(e.get("error", "")) for e in cell_errors) or \
        any(e.status == "memory" for e in exercises.values())
    if memory_hit:
        status, reason = "memory", f"ran out of memory (limit {memory_mb} MB); graded as far " \
                                   f"as it ran"
    elif output_limited:
        status, reason = "output limit", (f"printed more than {limits.file_mb} MB; the rest "
                                          f"was dropped; graded as far as it ran")
    return SubmissionResult(who, str(path), status, reason, exercises, cell_errors, box.layer,
                            digest)


def _kill(proc: subprocess.Popen[bytes]) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    proc.wait()


def grade_submissions(paths: Iterable[Path], spec: LabSpec, jobs: int = 1,
                      timeout: float = DEFAULT_TIMEOUT, memory_mb: int = DEFAULT_MEMORY_MB,
                      secret: str | None = None) -> list[SubmissionResult]:
    """Grade many notebooks, ``jobs`` at a time (each in its own sandboxed process)."""
    items = list(paths)
    hide = sorted({p.parent for p in items})
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        return list(pool.map(lambda p: grade_notebook(p, spec, None, timeout, memory_mb,
                                                      secret, hide), items))


# ------------------------------------------------------------------ a class, resumably

def fingerprint(spec: LabSpec, secret: str | None, timeout: float, memory_mb: int) -> str:
    """What a finished result depends on besides the notebook itself."""
    module = sys.modules[f"grader.labs.{spec.name}"]
    source = inspect.getsource(module)
    key = secret if secret is not None else os.environ.get("KIT_COURSE_SECRET", "kit-default")
    text = "\0".join([spec.name, source, hashlib.sha256(key.encode()).hexdigest(),
                      f"{timeout:g}", str(memory_mb)])
    return hashlib.sha256(text.encode()).hexdigest()


def _load_previous(path: Path, spec: LabSpec, stamp: str) -> dict[str, SubmissionResult]:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    if data.get("lab") != spec.name or data.get("fingerprint") != stamp:
        return {}
    previous = {}
    for item in data.get("submissions", []):
        try:
            result = SubmissionResult.from_dict(item)
        except (KeyError, TypeError):
            continue
        if result.sha256:
            previous[f"{result.path}\0{result.sha256}"] = result
    return previous


def _digest(path: Path) -> str:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return ""


def grade_class(paths: Sequence[Path], spec: LabSpec, gradebook: Path, results: Path,
                jobs: int = 1, timeout: float = DEFAULT_TIMEOUT,
                memory_mb: int = DEFAULT_MEMORY_MB, secret: str | None = None,
                dask_address: str | None = None,
                progress: Callable[[SubmissionResult, bool], None] | None = None
                ) -> list[SubmissionResult]:
    """Grade ``paths`` into ``gradebook`` (CSV) and ``results`` (JSON), resumably.

    ``progress(result, reused)`` is called as each submission finishes.
    """
    stamp = fingerprint(spec, secret, timeout, memory_mb)
    previous = _load_previous(results, spec, stamp)
    done: dict[Path, SubmissionResult] = {}
    todo: list[Path] = []
    for p in paths:
        old = previous.get(f"{p}\0{_digest(p)}")
        if old is not None:
            done[p] = old
            if progress:
                progress(old, True)
        else:
            todo.append(p)
    lock = threading.Lock()
    hide = sorted({p.parent for p in paths})

    def finished(p: Path, result: SubmissionResult) -> None:
        with lock:
            done[p] = result
            ordered = [done[q] for q in paths if q in done]
            # the results first: they are what a re-run resumes from, never behind the CSV
            write_results(results, ordered, spec, stamp)
            write_gradebook(gradebook, ordered, spec)
            if progress:
                progress(result, False)

    if dask_address:
        from distributed import Client
        from distributed import as_completed as dask_completed

        with Client(dask_address) as client:
            futures = {client.submit(_grade_remote, str(p), spec.name, timeout, memory_mb,
                                     secret, [str(h) for h in hide], pure=False): p
                       for p in todo}
            for future in dask_completed(futures):
                finished(futures[future], SubmissionResult.from_dict(future.result()))
    else:
        with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
            pending = {pool.submit(grade_notebook, p, spec, None, timeout, memory_mb, secret,
                                   hide): p for p in todo}
            for future in as_completed(pending):
                finished(pending[future], future.result())
    ordered = [done[p] for p in paths]
    write_gradebook(gradebook, ordered, spec)
    write_results(results, ordered, spec, stamp)
    return ordered


def _grade_remote(path: str, lab: str, timeout: float, memory_mb: int, secret: str | None,
                  hide: list[str]) -> dict[str, Any]:
    """One submission on a Dask worker (plain data in and out)."""
    result = grade_notebook(Path(path), load_lab(lab), None, timeout, memory_mb, secret,
                            [Path(h) for h in hide])
    return result.to_dict()


# ------------------------------------------------------------------ writing

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
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_gradebook(path: Path, results: Sequence[SubmissionResult], spec: LabSpec) -> None:
    """The CSV gradebook, written atomically (a reader never sees half a file)."""
    rows = gradebook_rows(results, spec)
    columns = ["student", *[ex.id for ex in spec.exercises], "total", "max", "percent",
               "status", "reason"]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    _atomic_write(path, buffer.getvalue())


def write_results(path: Path, results: Sequence[SubmissionResult], spec: LabSpec,
                  stamp: str = "") -> None:
    """Per-exercise and per-case outcomes and reasons, as JSON (atomically)."""
    data = {
        "lab": spec.name,
        "max": spec.max_points,
        "fingerprint": stamp,
        "sandbox": detect_layer(),
        "tolerances": {ex.id: {"rtol": ex.rtol, "atol": ex.atol} for ex in spec.exercises},
        "submissions": [r.to_dict() for r in results],
    }
    _atomic_write(path, json.dumps(data, indent=1, ensure_ascii=False))
