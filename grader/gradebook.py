"""Grading a class into a gradebook that never loses or invents rows.

:func:`grade_class` grades submissions into a CSV gradebook and JSON results beside it,
resumably and idempotently: after every submission both files are rewritten atomically, and a
re-run reuses every finished result whose notebook (SHA-256 of its bytes) and grading set-up
(the lab's specification, the course secret, the limits: :func:`fingerprint`) are unchanged —
an interrupted run continues where it stopped, and a re-run grades only what changed.

The gradebook has one row per student. Grading some students into an existing gradebook
updates their rows and keeps the others; if the set-up changed, that would mix two set-ups
in one file, so it is refused unless the run grades every student the gradebook holds.
An interruption (SIGINT, SIGTERM: :func:`grader.sandbox.stop`) kills every sandbox, records
nothing for the submissions it cut short, and leaves both files as of the last finished one.
"""

from __future__ import annotations

import csv
import hashlib
import inspect
import io
import json
import os
import sys
import tempfile
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from grader import sandbox
from grader.grade import DEFAULT_MEMORY_MB, DEFAULT_TIMEOUT, grade_notebook, server_for
from grader.results import ExerciseResult, SubmissionResult, display_points, exact_points
from grader.sandbox import Limits
from grader.spec import PRACTICE_SECRET, LabSpec, load_lab
from grader.submissions import (
    Submission,
    clean_text,
    digest,
    find_submissions,
    one_row_per_student,
)

__all__ = ["GradebookError", "fingerprint", "grade_class", "gradebook_rows", "write_gradebook",
           "write_results"]

Progress = Callable[[SubmissionResult, bool], None]


class GradebookError(ValueError):
    """An existing gradebook this run cannot update without losing or mixing rows."""


def fingerprint(spec: LabSpec, secret: str | None, timeout: float, memory_mb: int) -> str:
    """What a finished result depends on besides the notebook itself."""
    module = sys.modules.get(f"grader.labs.{spec.name}")
    source = inspect.getsource(module) if module is not None else repr(spec)
    key = PRACTICE_SECRET if secret is None else secret
    text = "\0".join([spec.name, source, hashlib.sha256(key.encode()).hexdigest(),
                      f"{timeout:g}", str(memory_mb)])
    return hashlib.sha256(text.encode()).hexdigest()


def _load_previous(results: Path, gradebook: Path, spec: LabSpec, stamp: str,
                   students: set[str]) -> tuple[dict[str, SubmissionResult], bool]:
    """The rows already in ``results`` by student, and whether they may be reused."""
    if not results.exists():
        if gradebook.exists():
            raise GradebookError(f"{gradebook} exists but {results}, which a re-run resumes "
                                 f"from, does not: move {gradebook} away, or name the results "
                                 f"with --results")
        return {}, False
    try:
        data = json.loads(results.read_text(encoding="utf-8"))
        previous = {r.student: r for r in map(SubmissionResult.from_dict,
                                               data.get("submissions", []))}
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise GradebookError(f"{results} cannot be read ({exc}); move it away to start a new "
                             f"gradebook") from None
    if data.get("lab") != spec.name:
        raise GradebookError(f"{results} holds {data.get('lab')}'s grades, not {spec.name}'s: "
                             f"write to another --out")
    if data.get("fingerprint") == stamp:
        return previous, True
    left_out = sorted(set(previous) - students)
    if left_out:
        raise GradebookError(
            f"{results} was graded with another set-up (the lab's spec, the course secret or "
            f"the limits changed) and holds students this run does not grade "
            f"({', '.join(left_out[:5])}{', …' if len(left_out) > 5 else ''}): grading only "
            f"some would mix two set-ups in one gradebook. Grade them all again, or write to "
            f"another --out")
    return previous, False


def _as_submissions(items: Sequence[Path | Submission], lab: str) -> list[Submission]:
    out = []
    for item in items:
        if isinstance(item, Submission):
            out.append(item)
        else:
            out.extend(find_submissions([Path(item)], lab).submissions)
    return one_row_per_student(out, lab)  # given separately, still one row per student


def _refused_row(s: Submission, spec: LabSpec, practice: bool) -> SubmissionResult:
    """The row of a submission that is not graded at all: refused, duplicate, malformed."""
    return SubmissionResult(s.student, clean_text(str(s.path)), s.status, s.reason,
                            {ex.id: ExerciseResult(ex.id, 0.0, ex.points, "not graded",
                                                   s.status) for ex in spec.exercises},
                            practice=practice)


class _Book:
    """The rows of one gradebook while a run fills it (thread-safe, written after each)."""

    def __init__(self, spec: LabSpec, gradebook: Path, results: Path, stamp: str,
                 rows: dict[str, SubmissionResult], progress: Progress | None) -> None:
        self.spec, self.gradebook, self.results, self.stamp = spec, gradebook, results, stamp
        self.rows, self.progress = rows, progress
        self.lock = threading.Lock()

    def ordered(self) -> list[SubmissionResult]:
        return sorted(self.rows.values(), key=lambda r: (r.student.casefold(), r.student))

    def write(self) -> None:
        rows = self.ordered()
        # the results first: they are what a re-run resumes from, never behind the CSV
        write_results(self.results, rows, self.spec, self.stamp)
        write_gradebook(self.gradebook, rows, self.spec)

    def finished(self, result: SubmissionResult, reused: bool = False) -> None:
        with self.lock:
            self.rows[result.student] = result
            if not reused:
                self.write()
            if self.progress:
                self.progress(result, reused)


def _run_local(todo: list[Submission], book: _Book, jobs: int, options: dict[str, Any]) -> None:
    pool = ThreadPoolExecutor(max_workers=max(1, jobs))
    try:
        server = server_for(book.spec, options["layer"], Limits(memory_mb=options["memory_mb"]),
                            slots=max(8, jobs + 2))
        pending: dict[Future[SubmissionResult], Submission] = {
            pool.submit(grade_notebook, s.path, book.spec, s.student, server=server,
                        **options): s for s in todo}
        for future in as_completed(pending):
            try:
                result = future.result()
            except sandbox.Interrupted:
                continue
            book.finished(result)
    except BaseException:
        sandbox.stop()  # interrupted: kill every sandbox, record nothing cut short
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def _run_dask(todo: list[Submission], book: _Book, address: str,
              options: dict[str, Any]) -> None:
    from distributed import Client
    from distributed import as_completed as dask_completed

    with Client(address) as client:
        futures = {client.submit(_grade_remote, str(s.path), s.student, book.spec.name,
                                 options, pure=False): s for s in todo}
        for future in dask_completed(futures):
            book.finished(SubmissionResult.from_dict(future.result()))


def _grade_remote(path: str, student: str, lab: str, options: dict[str, Any]) -> dict[str, Any]:
    """One submission on a Dask worker (plain data in and out)."""
    return grade_notebook(Path(path), load_lab(lab), student, **options).to_dict()


def grade_class(items: Sequence[Path | Submission], spec: LabSpec, gradebook: Path,
                results: Path, jobs: int = 1, timeout: float = DEFAULT_TIMEOUT,
                memory_mb: int = DEFAULT_MEMORY_MB, secret: str | None = None,
                dask_address: str | None = None, progress: Progress | None = None,
                layer: str | None = None, retry: Sequence[str] = ()
                ) -> list[SubmissionResult]:
    """Grade ``items`` (notebooks, or :class:`~grader.submissions.Submission` s) into
    ``gradebook`` (CSV) and ``results`` (JSON), resumably; returns this run's results in the
    order given. ``secret`` ``None`` is practice grading. ``progress(result, reused)`` is
    called as each submission finishes. Raises :class:`GradebookError` (before grading
    anything) when the existing gradebook cannot be updated safely. Finished rows whose
    notebook and set-up are unchanged are kept, except ``grader error`` rows and rows of the
    statuses in ``retry``, which are graded again."""
    submissions = _as_submissions(items, spec.name)
    stamp = fingerprint(spec, secret, timeout, memory_mb)
    previous, reusable = _load_previous(results, gradebook, spec, stamp,
                                        {s.student for s in submissions})
    book = _Book(spec, gradebook, results, stamp, dict(previous), progress)
    retried = {"grader error", *retry}
    todo = []
    for s in submissions:
        old = previous.get(s.student) if reusable else None
        if s.status:
            book.finished(_refused_row(s, spec, secret is None))
        elif old is not None and old.status not in retried and old.sha256 \
                and old.sha256 == digest(s.path):
            book.finished(old, reused=True)
        else:
            todo.append(s)
    options = {"timeout": timeout, "memory_mb": memory_mb, "secret": secret,
               "layer": layer or (None if dask_address else sandbox.detect_layer())}
    sandbox.resume()
    if dask_address:
        _run_dask(todo, book, dask_address, options)
    elif todo:
        _run_local(todo, book, jobs, options)
    with book.lock:
        book.write()
        return [book.rows[s.student] for s in submissions]


# ------------------------------------------------------------------ writing

def gradebook_rows(results: Sequence[SubmissionResult], spec: LabSpec) -> list[dict[str, Any]]:
    """The CSV's rows: exact exercise points, the total to 0.01, the percent to 0.1."""
    rows = []
    for r in results:
        row: dict[str, Any] = {"student": r.student}
        for ex in spec.exercises:
            row[ex.id] = exact_points(r.exercises[ex.id].points) if ex.id in r.exercises else "0"
        row["total"] = display_points(r.total)
        row["max"] = f"{spec.max_points:g}"
        row["percent"] = f"{100.0 * r.total / spec.max_points:.1f}" if spec.max_points else "0"
        row["status"] = r.status
        row["reason"] = r.reason + (" (practice grading: no course secret, the hidden cases "
                                    "are public)" if r.practice else "")
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
    columns = ["student", *[ex.id for ex in spec.exercises], "total", "max", "percent",
               "status", "reason"]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns)
    writer.writeheader()
    writer.writerows([{k: clean_text(v) if isinstance(v, str) else v for k, v in row.items()}
                      for row in gradebook_rows(results, spec)])
    _atomic_write(path, buffer.getvalue())


def write_results(path: Path, results: Sequence[SubmissionResult], spec: LabSpec,
                  stamp: str = "") -> None:
    """Per-exercise and per-case outcomes and reasons, as JSON (atomically)."""
    layers = sorted({r.sandbox for r in results if r.sandbox})
    data = {
        "lab": spec.name,
        "max": spec.max_points,
        "fingerprint": stamp,
        "sandbox": layers[0] if len(layers) == 1 else ", ".join(layers),
        "practice": any(r.practice for r in results),
        "tolerances": {ex.id: {"rtol": ex.rtol, "atol": ex.atol} for ex in spec.exercises},
        "submissions": [r.to_dict() for r in results],
    }
    _atomic_write(path, json.dumps(_cleaned(data), indent=1, ensure_ascii=False))


def _cleaned(value: Any) -> Any:
    """``value`` with every string's lone surrogates escaped (always writable as UTF-8)."""
    if isinstance(value, str):
        return clean_text(value)
    if isinstance(value, dict):
        return {_cleaned(k): _cleaned(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_cleaned(v) for v in value]
    return value
