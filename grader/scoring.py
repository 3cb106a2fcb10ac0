"""Judging a submission's answers, in the grader's process, against the kit's references.

Every answer (:mod:`grader.runner`) is either a value or the kind of failure the submission's
process says it met; this module turns them into case outcomes and an exercise's points. The
reference runs here (:func:`grader.checker.explain`), never in the submission's process.

What a case's message may say depends on whether the case is public: a public case shows what
was expected and what came back, the exception's text, a hint; a **hidden** case says only
*passed*, *wrong output* (with a known mistake's hint, which names no input), *timed out* or
*raised* — nothing the submission could have chosen to carry its inputs out (not even which
exception it raised).

Scoring: each exercise earns ``points × passed cases / all cases`` (public and hidden),
exactly.
"""

from __future__ import annotations

import inspect
from collections.abc import Sequence
from typing import Any

from grader import serialize
from grader.checker import explain
from grader.results import CaseOutcome, ExerciseResult
from grader.spec import Case, Exercise

__all__ = ["HIDDEN_WORDS", "MESSAGE_LIMIT", "judge_answer", "lost_case", "score",
           "upstream_notes"]

MESSAGE_LIMIT = 500
HIDDEN_WORDS = {"wrong": "wrong output", "timeout": "timed out", "error": "raised"}
"""all a hidden case's failure may say (besides a known mistake's hint)."""


def reference_signature(ex: Exercise) -> str:
    """The reference's parameters as a student would write them (no annotations)."""
    try:
        params = inspect.signature(ex.reference).parameters.values()
    except (TypeError, ValueError):
        return "(?)"
    shown = [p.name if p.default is inspect.Parameter.empty else f"{p.name}={p.default!r}"
             for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return f"({', '.join(shown)})"


def _public_failure(answer: dict[str, Any], limit: float) -> tuple[str, str]:
    status = str(answer.get("status"))
    message = str(answer.get("message", ""))[:MESSAGE_LIMIT]
    if status == "timeout":
        where = str(answer.get("where", ""))[:80]
        return "timeout", (f"did not return within {limit:g} s of CPU time (an endless loop?"
                           f"{f' in {where}' if where else ''})")
    if status == "not implemented":
        return "not implemented", "not implemented yet"
    if status == "memory":
        return "memory", "ran out of memory"
    if status == "unencodable":
        return "error", f"returned something that cannot be graded: {message}"
    if status in ("error", "exit") and message:
        return "error", message
    return "error", "the answer was not understood"


def judge_answer(ex: Exercise, case: Case, answer: dict[str, Any], blobs: list[bytes],
                 label: str, public: bool, limit: float, signature: str = ""
                 ) -> tuple[str, CaseOutcome]:
    """(status, outcome) of one answer: ``passed``, ``wrong``, ``timeout``, ``memory``,
    ``not implemented`` or ``error``."""
    if answer.get("status") != "returned":
        status, message = _public_failure(answer, limit)
        if not public:
            status = "timeout" if status == "timeout" else "error"
            return status, CaseOutcome(label, False, False, HIDDEN_WORDS[status])
        if status == "error" and "TypeError" in message and "argument" in message:
            message += (f"; the exercise calls it as {ex.function}{reference_signature(ex)}, "
                        f"the notebook defines {ex.function}{signature}")
        return status, CaseOutcome(label, True, False, message)
    try:
        value = serialize.decode(answer.get("value"), blobs=blobs)
    except serialize.DecodeError as exc:
        return "error", CaseOutcome(label, public, False, f"unreadable output: {exc}"
                                    if public else HIDDEN_WORDS["error"])
    return judge_value(ex, case, value, label, public)


def judge_value(ex: Exercise, case: Case, value: Any, label: str, public: bool
                ) -> tuple[str, CaseOutcome]:
    """A returned value against the reference's, computed here."""
    if ex.harness and hasattr(value, "passed"):        # a closed-loop episode's result
        if value.passed:
            return "passed", CaseOutcome(label, public, True)
        text = value.message if public else value.category
        return "wrong", CaseOutcome(label, public, False, str(text)[:MESSAGE_LIMIT])
    verdict = explain(ex, case, value)
    if verdict is None:
        return "passed", CaseOutcome(label, public, True)
    problem, hint = verdict
    message = problem if public else HIDDEN_WORDS["wrong"]  # never a hidden case's numbers
    return "wrong", CaseOutcome(label, public, False, message + (f"; {hint}" if hint else ""))


def lost_case(label: str, public: bool, why: str) -> tuple[str, CaseOutcome]:
    """A case the submission's process never answered (it died, hung or was not started)."""
    status = "timeout" if "time" in why else "error"
    return status, CaseOutcome(label, public, False, why if public else HIDDEN_WORDS[status])


def score(ex: Exercise, scored: Sequence[tuple[str, CaseOutcome]]) -> ExerciseResult:
    """An exercise's points and reason from its cases' (status, outcome)."""
    statuses = [s for s, _ in scored]
    results = [r for _, r in scored]
    passed = sum(r.passed for r in results)
    points = ex.points * passed / len(results) if results else 0.0
    if results and passed == len(results):
        return ExerciseResult(ex.id, points, ex.points, "passed",
                              f"all {len(results)} cases pass", list(results))
    for status in ("not implemented", "timeout", "memory", "error", "wrong"):
        if status in statuses:
            first = next(r for r, s in zip(results, statuses, strict=True) if s == status)
            reason = "not implemented yet" if status == "not implemented" else (
                f"{len(results) - passed} of {len(results)} cases fail; "
                f"{first.case}: {first.message}")
            label = "partly passed" if passed and status == "wrong" else status
            return ExerciseResult(ex.id, points, ex.points, label, reason, list(results))
    return ExerciseResult(ex.id, points, ex.points, "error", "no cases were run",
                          list(results))


def upstream_notes(exercises: Sequence[Exercise], results: dict[str, ExerciseResult]) -> None:
    """Point a failing exercise at the earlier exercises it uses that fail their own cases
    (``Exercise.uses``): one mistake upstream shows up downstream too."""
    by_function = {ex.function: ex for ex in exercises}
    unfinished = ("missing function", "not implemented", "not graded")
    for ex in exercises:
        mine = results.get(ex.id)
        if mine is None or mine.points >= mine.max_points or mine.status in unfinished:
            continue
        upstream = [results.get(by_function[n].id) for n in ex.uses if n in by_function]
        wrong = [r.id.split(".", 1)[1] for r in upstream
                 if r is not None and r.points < r.max_points and r.status not in unfinished]
        if wrong:
            names = " and ".join(f"`{n}`" for n in wrong)
            mine.reason += (f"; your {names} {'fails its' if len(wrong) == 1 else 'fail their'} "
                            f"own cases: fix {'it' if len(wrong) == 1 else 'them'} first")
