"""Hidden cases that tell every catalogued mistake apart, whatever the student's seed.

A lab's hidden cases are drawn from a generator seeded per student (:func:`grader.spec.
course_seed`). Drawn freely, some students' cases miss a mistake that others' catch — an
unwrapped heading goes unseen when no drawn pose crosses ±π — so whether a mistake costs
points would depend on luck. :func:`until_each_shows` draws again until each of the spec's
own models of the exercise's mistakes gives a wrong output on at least one case.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from grader.compare import matches
from grader.spec import Case, Diagnostic

__all__ = ["telling", "until_each_shows"]

Draw = Callable[[np.random.Generator], list[Case]]


def until_each_shows(rng: np.random.Generator, draw: Draw,
                     reference: Callable[..., Any], mistakes: Sequence[Callable[..., Any]],
                     rtol: float = 0.0, atol: float = 1e-9, tries: int = 200) -> list[Case]:
    """Cases from ``draw`` (drawn again while needed) among which each of ``mistakes`` — the
    spec's own models of the exercise's classic mistakes — gives an output that differs from
    ``reference``'s by more than the tolerances (the exercise's own, so that "differs" means
    "loses points") on at least one case.

    ``draw`` should put the telling cases in by construction wherever it can (a counter
    reading just below its roll-over, a heading next to ±π); the redrawing is the guarantee.
    Raises ``RuntimeError`` when ``tries`` draws never do.
    """
    for _ in range(tries):
        cases = draw(rng)
        if all(any(_differs(reference, mistake, case, rtol, atol) for case in cases)
               for mistake in mistakes):
            return cases
    raise RuntimeError(f"no {tries} draws of hidden cases tell every mistake apart")


def _differs(reference: Callable[..., Any], mistake: Callable[..., Any], case: Case,
             rtol: float, atol: float) -> bool:
    try:
        wrong = mistake(*case.args, **case.kwargs)
    except Exception:  # a mistake that fails on the case loses its points there too
        return True
    return not matches(reference(*case.args, **case.kwargs), wrong, rtol, atol)


def telling(draw: Draw, reference: Callable[..., Any], diagnostics: Sequence[Diagnostic],
            rtol: float = 1e-6, atol: float = 1e-9) -> Draw:
    """An exercise's ``hidden`` generator: ``draw``, drawn again until each of the exercise's
    ``diagnostics`` loses points (``rtol``, ``atol``: the exercise's tolerances; the defaults
    are :class:`grader.spec.Exercise`'s)."""
    mistakes = [d.wrong for d in diagnostics]

    def hidden(rng: np.random.Generator) -> list[Case]:
        return until_each_shows(rng, draw, reference, mistakes, rtol, atol)

    return hidden
