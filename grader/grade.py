"""``grader grade`` for one notebook: run it in a sandbox, score its outputs here.

The steps of :func:`grade_notebook`, each its own function:

1. :func:`~grader.submissions.read_notebook` — a malformed notebook still gets a row;
2. :func:`plan_cases` — the public cases and the student's own hidden cases, seeded from the
   course secret and the student id;
3. :func:`guarded_modules` — the lab's references, whose files the sandbox replaces by stubs
   and whose real source travels in the request;
4. :func:`grader.session.run_worker` — the worker runs the cells and calls the exercise
   functions, public cases first, hidden ones only after that answer is in;
5. :func:`score_exercise` — every output judged against the ``kit`` reference, in this
   process; a hidden case's message is a verdict, never its inputs, printed text or an
   exception's words;
6. :func:`classify` — the submission's status and reason (a crash, a hang, a memory bomb or
   an early exit still yields a row, graded as far as it ran).

Anything unexpected while grading one submission becomes its row with status ``grader error``
(naming the student and the reason); it never stops the class.

Scoring: each exercise earns ``points × passed cases / all cases`` (public and hidden),
exactly.
"""

from __future__ import annotations

import builtins
import functools
import importlib
import inspect
import os
import signal
import traceback
from collections.abc import Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from grader import serialize
from grader.checker import explain
from grader.guard import stub_source
from grader.results import CaseOutcome, ExerciseResult, SubmissionResult
from grader.sandbox import (
    ISOLATING,
    MPL_DIR,
    Interrupted,
    Limits,
    Sandbox,
    detect_layer,
    stopping,
)
from grader.session import Run, run_worker
from grader.spec import Case, Exercise, LabSpec, course_seed
from grader.submissions import Notebook, read_notebook, student_id

__all__ = ["DEFAULT_MEMORY_MB", "DEFAULT_TIMEOUT", "classify", "grade_notebook",
           "grade_submissions", "guarded_modules", "plan_cases", "run_submission",
           "score_exercise", "session_budget"]

DEFAULT_TIMEOUT = 120.0
DEFAULT_MEMORY_MB = 2048
MESSAGE_LIMIT = 500
PACKAGES_WITH_REFERENCES = ("kit.", "sim.", "hardware.")

Plan = dict[str, tuple[tuple[Case, ...], tuple[Case, ...]]]


def _not_graded(spec: LabSpec, status: str, reason: str) -> dict[str, ExerciseResult]:
    return {ex.id: ExerciseResult(ex.id, 0.0, ex.points, status, reason)
            for ex in spec.exercises}


# ------------------------------------------------------------------ 2. the cases

def plan_cases(spec: LabSpec, student: str, secret: str | None) -> Plan:
    """Each exercise's (public, hidden) cases; the hidden ones are the student's own."""
    return {ex.id: (ex.public, ex.hidden_cases(course_seed(ex.id, student, secret)))
            for ex in spec.exercises}


# ------------------------------------------------------------------ 3. the references

@functools.lru_cache(maxsize=32)
def _module_entry(name: str) -> tuple[str, str, bool]:
    module = importlib.import_module(name)
    path = str(Path(str(module.__file__)).resolve())
    return path, Path(path).read_text(encoding="utf-8"), hasattr(module, "__path__")


def guarded_modules(names: Iterable[str]) -> dict[str, dict[str, Any]]:
    """The kit modules holding guarded names: their real path, source and kind. Inside the
    sandbox their files are stubs; the worker gets the source from the request."""
    modules = {q.partition(":")[0] for q in names}
    entries = {}
    for name in sorted(m for m in modules if m.startswith(PACKAGES_WITH_REFERENCES)):
        path, source, package = _module_entry(name)
        entries[name] = {"path": path, "source": source, "package": package}
    return entries


# ------------------------------------------------------------------ 4. running it

def _encoded(cases: Sequence[Case]) -> list[dict[str, Any]]:
    return [{"args": serialize.encode(c.args), "kwargs": serialize.encode(c.kwargs)}
            for c in cases]


def _requests(spec: LabSpec, notebook: Notebook, plan: Plan, timeout: float
              ) -> tuple[dict[str, Any], dict[str, Any]]:
    names = spec.guarded_names()
    first = {
        "modules": guarded_modules(names),
        "blocked": names,
        "cells": [dict(c) for c in notebook.cells],
        # a cell that never ends (an example calling the student's endless loop) loses its own
        # half of the budget, not the grading of every exercise
        "cell_time_limit": timeout / 2,
        # each exercise may lose at most one case to an endless loop: half the budget in all
        "case_time_limit": min(10.0, timeout / (2 * max(1, len(spec.exercises)))),
        "exercises": [{"id": ex.id, "function": ex.function, "cases": _encoded(plan[ex.id][0]),
                       "harness": ex.harness, "time_limit": ex.time_limit}
                      for ex in spec.exercises],
    }
    second = {"exercises": [{"id": ex.id, "function": ex.function,
                             "cases": _encoded(plan[ex.id][1]), "harness": ex.harness,
                             "time_limit": ex.time_limit} for ex in spec.exercises]}
    return first, second


def worker_env(layer: str) -> dict[str, str]:
    """The worker's whole environment (nothing of the grader's: no secret, no tokens)."""
    env = {"LANG": "C.UTF-8", "KIT_GRADING": "1", "KIT_FAST": "1", "MPLBACKEND": "Agg",
           "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "NUMBA_NUM_THREADS": "1", "KIT_GRADER_PID": str(os.getpid())}
    if layer in ISOLATING:
        env["MPLCONFIGDIR"] = MPL_DIR
    return env


def session_budget(spec: LabSpec, plan: Plan, timeout: float) -> float:
    """The worker's whole wall-time budget: ``timeout`` for the notebook and its quick cases,
    plus, for each exercise with its own ``time_limit`` (a closed-loop episode), that limit for
    every one of its cases, so that a class's slow but honest controllers all finish."""
    return timeout + sum(ex.time_limit * (len(plan[ex.id][0]) + len(plan[ex.id][1]))
                         for ex in spec.exercises if ex.time_limit)


def run_submission(spec: LabSpec, notebook: Notebook, plan: Plan, limits: Limits,
                   timeout: float, layer: str) -> tuple[Run, str]:
    """Run one notebook in a fresh sandbox within :func:`session_budget`; returns what
    happened and the layer."""
    first, second = _requests(spec, notebook, plan, timeout)
    stubs = {entry["path"]: stub_source(module, spec.name)
             for module, entry in first["modules"].items()}
    box = Sandbox.create(layer, limits, worker_env(layer),
                         files={notebook.path.name: notebook.text}, stubs=stubs)
    return run_worker(box, first, lambda public: second,
                      session_budget(spec, plan, timeout)), layer


# ------------------------------------------------------------------ 5. scoring

def _reference_signature(ex: Exercise) -> str:
    """The reference's parameters as a student would write them (no annotations)."""
    try:
        params = inspect.signature(ex.reference).parameters.values()
    except (TypeError, ValueError):
        return "(?)"
    shown = [p.name if p.default is inspect.Parameter.empty else f"{p.name}={p.default!r}"
             for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return f"({', '.join(shown)})"


def _builtin_name(text: Any) -> str:
    """A hidden case's exception type, believed only if it is a built-in exception's name."""
    klass = getattr(builtins, str(text), None) if str(text).isidentifier() else None
    return str(text) if isinstance(klass, type) and issubclass(klass, BaseException) \
        else "an exception"


def _failure(got: dict[str, Any], public: bool, limit: float) -> tuple[str, str]:
    """(status, message) of a case that returned nothing; hidden ones in fixed words."""
    status = str(got.get("status"))
    fixed = {"timeout": f"did not return within {limit:g} s",
             "not implemented": "not implemented yet", "memory": "ran out of memory"}
    if status in fixed:
        return status, fixed[status]
    if status == "exit":
        return "error", str(got.get("message", ""))[:MESSAGE_LIMIT] if public else \
            "called sys.exit"
    if status == "unencodable":
        return "error", ("returned something that cannot be graded: "
                         f"{str(got.get('message', ''))[:MESSAGE_LIMIT]}" if public else
                         "returned a value that cannot be graded")
    if status == "error":
        return "error", str(got.get("message", ""))[:MESSAGE_LIMIT] if public else \
            f"raised {_builtin_name(got.get('type'))}"
    return "error", "the worker's answer was not understood"


def _judge(ex: Exercise, case: Case, got: Any, label: str, public: bool, limit: float
           ) -> tuple[str, CaseOutcome]:
    if not isinstance(got, dict) or got.get("status") != "returned":
        status, message = _failure(got if isinstance(got, dict) else {}, public, limit)
        return status, CaseOutcome(label, public, False, message)
    try:
        value = serialize.decode(got["value"])
    except (serialize.DecodeError, KeyError) as exc:
        return "error", CaseOutcome(label, public, False, f"unreadable output: {exc}"
                                    if public else "unreadable output")
    verdict = explain(ex, case, value)
    if verdict is None:
        return "passed", CaseOutcome(label, public, True)
    problem, hint = verdict
    message = problem if public else "wrong output"  # never a hidden case's numbers
    return "wrong", CaseOutcome(label, public, False, message + (f"; {hint}" if hint else ""))


def _case_outcomes(ex: Exercise, cases: Sequence[Case], answers: Any, public: bool,
                   lost: str, limit: float, signature: str) -> list[tuple[str, CaseOutcome]]:
    labels = [c.name if public else f"hidden case {i}" for i, c in enumerate(cases, start=1)]
    if not isinstance(answers, list) or len(answers) != len(cases):
        return [("error", CaseOutcome(label, public, False, lost)) for label in labels]
    out = []
    for case, got, label in zip(cases, answers, labels, strict=True):
        status, outcome = _judge(ex, case, got, label, public, limit)
        if public and status == "error" and "TypeError" in outcome.message \
                and "argument" in outcome.message:
            outcome.message += (f"; the exercise calls it as {ex.function}"
                                f"{_reference_signature(ex)}, the notebook defines "
                                f"{ex.function}{signature}")
        out.append((status, outcome))
    return out


def score_exercise(ex: Exercise, cases: tuple[Sequence[Case], Sequence[Case]],
                   public: dict[str, Any], hidden: dict[str, Any] | None, lost: str,
                   limit: float) -> ExerciseResult:
    """Points and reason of one exercise from the worker's answers (``hidden`` is ``None``
    when the run ended before the hidden cases answered; ``lost`` then says why)."""
    if "missing" in public:
        return ExerciseResult(ex.id, 0.0, ex.points, "missing function",
                              str(public["missing"])[:MESSAGE_LIMIT])
    signature = str(public.get("signature", "(?)"))[:200]
    scored = _case_outcomes(ex, cases[0], public.get("cases"), True,
                            "the worker's answer was incomplete", limit, signature)
    scored += _case_outcomes(ex, cases[1], None if hidden is None else hidden.get("cases"),
                             False, lost, limit, signature)
    statuses = [s for s, _ in scored]
    results = [r for _, r in scored]
    passed = sum(r.passed for r in results)
    points = ex.points * passed / len(results) if results else 0.0
    if passed == len(results):
        return ExerciseResult(ex.id, points, ex.points, "passed",
                              f"all {len(results)} cases pass", results)
    for status in ("not implemented", "timeout", "memory", "error", "wrong"):
        if status in statuses:
            first = next(r for r, s in zip(results, statuses, strict=True) if s == status)
            reason = "not implemented yet" if status == "not implemented" else (
                f"{len(results) - passed} of {len(results)} cases fail; "
                f"{first.case}: {first.message}")
            label = "partly passed" if passed and status == "wrong" else status
            return ExerciseResult(ex.id, points, ex.points, label, reason, results)
    return ExerciseResult(ex.id, points, ex.points, "error", "unknown outcome", results)


# ------------------------------------------------------------------ 6. the verdict

def _ending(run: Run, layer: str, limits: Limits) -> tuple[str, str]:
    """How the process ended, as (status, reason), in words a hidden case cannot colour."""
    if run.timed_out:
        return "timeout", "did not finish within its time limit (an endless loop?)"
    if run.too_large:
        return "output limit", "its results were larger than the grader reads"
    if run.unreadable:
        return "crashed", f"the submission's process left an unreadable result: {run.unreadable}"
    code = run.returncode if run.returncode is not None else 0
    if layer != "rlimits" and 128 < code < 128 + 65:
        code = -(code - 128)  # the sandbox reports its child's signal as 128 + n
    if code < 0:
        name = signal.Signals(-code).name
        if name == "SIGXCPU":
            return "timeout", f"used more than {limits.cpu_seconds} s of CPU"
        return "crashed", f"the process was killed by {name}"
    if code != 0:
        return "crashed", f"the process exited with code {code} before reporting"
    return "crashed", "the process ended without reporting results"


def classify(run: Run, layer: str, limits: Limits, timeout: float) -> tuple[str, str]:
    """The submission's status and reason."""
    if run.public is None or run.hidden is None:
        status, reason = _ending(run, layer, limits)
        if status == "timeout" and run.timed_out:
            reason = f"did not finish within {timeout:g} s (an endless loop?)"
        last = run.stderr_tail.strip().splitlines()[-1:] if run.stderr_tail.strip() else []
        if last and "MemoryError" in last[0]:
            status, reason = "memory", f"ran out of memory (limit {limits.memory_mb} MB)"
        elif last and status == "crashed":
            reason += f": {last[0][:200]}"
        if run.public is not None:
            # an exit code or a signal is the submission's to choose: while it held hidden
            # inputs, they could carry them out, so only the kind of ending is told
            if status == "crashed":
                reason = "the process ended"
            reason = f"{reason} while running the hidden cases; graded as far as it ran"
        return status, reason
    errors = run.public.get("cell_errors", [])
    if any(e.get("kind") == "memory" for e in errors if isinstance(e, dict)):
        return "memory", (f"ran out of memory (limit {limits.memory_mb} MB); graded as far "
                          f"as it ran")
    endless = [e for e in errors if isinstance(e, dict) and e.get("kind") == "timeout"]
    if endless:
        return "timeout", (f"cell {endless[0].get('cell')}: {endless[0].get('error')}; the "
                           f"cells after it ran and the exercises were graded")
    if max(run.stdout_bytes, run.stderr_bytes) >= limits.file_mb * 1024 * 1024:
        return "output limit", (f"printed more than {limits.file_mb} MB; the rest was dropped; "
                                f"graded as far as it ran")
    return "ok", "graded"


def _exercises(spec: LabSpec, plan: Plan, run: Run, status: str, reason: str,
               limit: float) -> dict[str, ExerciseResult]:
    if run.public is None:
        return _not_graded(spec, status, reason)
    public = run.public.get("outcomes", {})
    hidden = run.hidden.get("outcomes", {}) if run.hidden is not None else None
    lost = f"not run: {reason}"
    results = {}
    for ex in spec.exercises:
        mine = public.get(ex.id) if isinstance(public, dict) else None
        if not isinstance(mine, dict):
            mine = {"missing": "the worker's answer was incomplete"}
        theirs = hidden.get(ex.id, {}) if isinstance(hidden, dict) else None
        results[ex.id] = score_exercise(ex, plan[ex.id], mine, theirs, lost, limit)
    return results


def _cell_errors(run: Run) -> list[dict[str, Any]]:
    errors = run.public.get("cell_errors", []) if run.public else []
    keep = ("cell", "first_line", "line", "code", "kind", "error")
    return [{k: e.get(k) for k in keep} for e in errors if isinstance(e, dict)][:100]


def grade_notebook(path: Path, spec: LabSpec, student: str | None = None,
                   timeout: float = DEFAULT_TIMEOUT, memory_mb: int = DEFAULT_MEMORY_MB,
                   secret: str | None = None, layer: str | None = None) -> SubmissionResult:
    """Grade one notebook. Never raises for anything the submission does, nor for anything
    else that goes wrong with this one notebook (that becomes a ``grader error`` row);
    :class:`~grader.sandbox.Interrupted` is let through when grading is being stopped.

    ``secret`` seeds the hidden cases; ``None`` grades a practice run (public seed).
    """
    who = student or student_id(path, spec.name)
    try:
        return _grade(path, spec, who, student is not None, timeout, memory_mb, secret, layer)
    except Interrupted:
        raise
    except Exception as exc:
        detail = "".join(traceback.format_exception_only(type(exc), exc)).strip()
        return SubmissionResult(who, str(path), "grader error",
                                f"the grader failed on {who}'s notebook: {detail[:300]}",
                                _not_graded(spec, "not graded", "grader error"),
                                practice=secret is None)


def _grade(path: Path, spec: LabSpec, who: str, named: bool, timeout: float, memory_mb: int,
           secret: str | None, layer: str | None) -> SubmissionResult:
    practice = secret is None
    try:
        notebook = read_notebook(path)
    except (OSError, ValueError) as exc:
        return SubmissionResult(who, str(path), "malformed notebook", str(exc),
                                _not_graded(spec, "not graded", "malformed notebook"),
                                practice=practice)
    who = who if named else (notebook.student or who)
    plan = plan_cases(spec, who, secret)
    budget = session_budget(spec, plan, timeout)
    limits = Limits(memory_mb=memory_mb, cpu_seconds=int(budget) + 1)
    layer = layer or detect_layer()
    run, layer = run_submission(spec, notebook, plan, limits, timeout, layer)
    if stopping():  # its sandbox was killed by the interruption, not by the submission
        raise Interrupted("grading is being stopped")
    status, reason = classify(run, layer, limits, budget)
    limit = min(10.0, timeout / (2 * max(1, len(spec.exercises))))
    if any(ex.time_limit for ex in spec.exercises):
        limit = max(limit, *(ex.time_limit for ex in spec.exercises))
    return SubmissionResult(who, str(path), status, reason,
                            _exercises(spec, plan, run, status, reason, limit),
                            _cell_errors(run), layer, notebook.sha256, practice)


def grade_submissions(paths: Iterable[Path], spec: LabSpec, jobs: int = 1,
                      timeout: float = DEFAULT_TIMEOUT, memory_mb: int = DEFAULT_MEMORY_MB,
                      secret: str | None = None, layer: str | None = None
                      ) -> list[SubmissionResult]:
    """Grade many notebooks, ``jobs`` at a time (each in its own sandboxed process)."""
    items = list(paths)
    chosen = layer or detect_layer()
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        return list(pool.map(lambda p: grade_notebook(p, spec, None, timeout, memory_mb,
                                                      secret, chosen), items))
