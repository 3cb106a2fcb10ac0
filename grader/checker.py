"""The check cells of a lab notebook.

In the notebook's setup cell::

    from grader import checker
    check = checker("lab01")

and after an exercise::

    check(forward_kinematics)

``check`` runs the exercise's public cases in the kernel (with a progress bar where they are
closed-loop episodes, which take seconds) and prints one verdict: every case passed; or "not
implemented yet"; or how many cases fail and, for up to three of them, what was expected, what
came back and a hint. It never raises, so a student's notebook always runs top
to bottom. While a submission is being graded (``KIT_GRADING=1``) it does nothing: grading runs
the cases itself. Under nbgrader's autograder (``NBGRADER_EXECUTION=autograde``) a failing
check raises, since that is how nbgrader scores a test cell.

``checker(lab)`` puts the lab's references behind guards (:mod:`grader.guard`): while ``check``
runs an exercise, calling the kit's reference for it fails with the kit's explanation, as it
does while grading — so a ✓ here is never a 0 there.
"""

from __future__ import annotations

import os
import sys
import traceback
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from grader import guard, runall
from grader.compare import compare, matches
from grader.spec import Case, Exercise, LabSpec, load_lab
from kit.progress import progress

SHOWN_FAILURES = 3

__all__ = ["CaseResult", "Checker", "checker", "run_case"]


@dataclass(frozen=True)
class CaseResult:
    case: str
    passed: bool
    status: str
    """``passed``, ``wrong``, ``not implemented``, ``error``."""
    message: str = ""


def diagnose(exercise: Exercise, case: Case, got: Any) -> str:
    """The hints of every known mistake whose output equals ``got`` (some mistakes give the
    same numbers: swapped wheels and a flipped turn sign, for instance)."""
    found = []
    for diag in exercise.diagnostics:
        try:
            wrong = diag.wrong(*case.args, **case.kwargs)
        except Exception:  # a diagnostic that does not apply to this case
            continue
        if matches(wrong, got, exercise.rtol, exercise.atol):
            found.append(f"this is what {diag.name} gives: {diag.hint}")
    return "; or ".join(found)


def explain(exercise: Exercise, case: Case, got: Any) -> tuple[str, str] | None:
    """``None`` when ``got`` is the reference's output for ``case``, else (problem, hint).

    A known mistake of the exercise that reproduces ``got`` gives the hint; failing that,
    :func:`grader.compare.compare` adds a generic one (degrees, 2π, signs, swaps) to the
    problem itself.
    """
    expected = exercise.reference(*case.args, **case.kwargs)
    problem = compare(expected, got, exercise.rtol, exercise.atol, hints=False)
    if problem is None:
        return None
    hint = diagnose(exercise, case, got)
    if hint:
        return problem, hint
    return str(compare(expected, got, exercise.rtol, exercise.atol)), ""


def harnessed(fn: Callable[..., Any], harness: str) -> Callable[..., Any]:
    """``fn`` run by a closed-loop harness (``module:function``, e.g. a simulated episode):
    ``harness(fn, *case.args)``."""
    import importlib

    module, _, name = harness.partition(":")
    run = getattr(importlib.import_module(module), name)

    def call(*args: Any, **kwargs: Any) -> Any:
        return run(fn, *args, **kwargs)

    return call


def judge(exercise: Exercise, case: Case, got: Any) -> CaseResult:
    """Compare one output with the reference's, both computed in this process."""
    if exercise.harness and hasattr(got, "passed"):   # a closed-loop episode's result
        return CaseResult(case.name, bool(got.passed), "passed" if got.passed else "wrong",
                          "" if got.passed else str(got.message))
    verdict = explain(exercise, case, got)
    if verdict is None:
        return CaseResult(case.name, True, "passed")
    problem, hint = verdict
    return CaseResult(case.name, False, "wrong", problem + (f"\n  {hint}" if hint else ""))


def run_case(exercise: Exercise, fn: Callable[..., Any], case: Case) -> CaseResult:
    """One public case: the student's function with the references refusing, then the
    verdict (computed outside that scope, with the real references)."""
    if exercise.harness:                       # closed loop: the harness runs fn
        fn = harnessed(fn, exercise.harness)
    try:
        got = guard.call_refusing(fn, *case.args, **case.kwargs)
    except NotImplementedError:
        return CaseResult(case.name, False, "not implemented", "not implemented yet")
    except Exception as exc:
        frame = traceback.extract_tb(exc.__traceback__)[-1]
        return CaseResult(case.name, False, "error",
                          f"raised {type(exc).__name__}: {exc} (line {frame.lineno})")
    return judge(exercise, case, got)


class Checker:
    """``check(fn)`` for one lab."""

    def __init__(self, spec: LabSpec) -> None:
        self.spec = spec

    def __call__(self, fn: Callable[..., Any], exercise: str | None = None) -> None:
        if os.environ.get("KIT_GRADING"):
            return
        try:
            ex = self.spec.exercise(exercise or str(getattr(fn, "__name__", "")))
        except KeyError as exc:
            print(f"✗ {exc.args[0]}")
            return
        if not callable(fn):
            print(f"✗ {ex.id}: check() needs the function itself, not {type(fn).__name__}")
            return
        reference = guard.reference_name(fn)
        if reference is not None:
            verdict = f"✗ {ex.id}: {guard.explanation(reference)}"
            print(verdict)
            if os.environ.get("NBGRADER_EXECUTION") == "autograde":
                raise AssertionError(verdict)
            return
        cases: Iterable[Case] = ex.public
        if ex.harness:  # closed-loop episodes take seconds each: show that one is running
            cases = progress(ex.public, desc=f"checking {ex.function}", unit="episode")
        results = [run_case(ex, fn, case) for case in cases]
        if any(r.status == "not implemented" for r in results):
            print(f"… {ex.id}: not implemented yet")
            if os.environ.get("NBGRADER_EXECUTION") == "autograde":
                raise AssertionError(f"{ex.id}: not implemented")
            return
        failed = [r for r in results if not r.passed]
        label = f" ({fn.__name__} checked as {ex.function})" if fn.__name__ != ex.function else ""
        if not failed:
            points = "point" if ex.points == 1 else "points"
            print(f"✓ {ex.id}{label}: all {len(results)} public "
                  f"{'case passes' if len(results) == 1 else 'cases pass'} "
                  f"({ex.points:g} {points} when graded, with hidden cases too)")
            return
        shown = "\n".join(f"  case '{r.case}': {r.message}" for r in failed[:SHOWN_FAILURES])
        more = len(failed) - SHOWN_FAILURES
        upstream = self._upstream(ex, sys._getframe(1).f_globals)
        verdict = (f"✗ {ex.id}{label}: {len(failed)} of {len(results)} public cases fail.\n"
                   f"{shown}" + (f"\n  … and {more} more" if more > 0 else "")
                   + (f"\n  {upstream}" if upstream else ""))
        print(verdict)
        if os.environ.get("NBGRADER_EXECUTION") == "autograde" and not label:
            raise AssertionError(verdict)  # nbgrader scores a test cell by whether it raises


    def _upstream(self, ex: Exercise, namespace: dict[str, Any]) -> str:
        """"your `beam_angles` fails its own check: fix it first" when an earlier exercise
        this one uses (``Exercise.uses``) fails its public cases in the notebook."""
        wrong = []
        for name in ex.uses:
            fn = namespace.get(name)
            try:
                upstream = self.spec.exercise(name)
            except KeyError:
                continue
            if callable(fn) and not all(run_case(upstream, fn, c).passed
                                        for c in upstream.public):
                wrong.append(f"`{name}`")
        if not wrong:
            return ""
        return (f"your {' and '.join(wrong)} {'fails its' if len(wrong) == 1 else 'fail their'} "
                f"own check: fix {'it' if len(wrong) == 1 else 'them'} first")


def checker(lab: str | int) -> Checker:
    """The ``check`` function of a lab's notebook: guards the lab's references and, in
    IPython, lets Run All go past unfinished exercises (:mod:`grader.runall`)."""
    spec = load_lab(lab)
    guard.install(spec.guarded_names(), namespaces=[sys._getframe(1).f_globals])
    runall.install(ex.function for ex in spec.exercises)
    return Checker(spec)
