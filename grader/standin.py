"""The student's functions in the kit's whole system, the kit's where one is not done yet.

The last sections of a lab run the kit's full stack — AMCL on a real bag, SLAM on a
benchmark log, a scan pipeline on the simulated robot — with the student's exercises in
place of the kit's pieces. An exercise that is not done yet (its stub raises
``NotImplementedError``), or that cannot even run its first public case, must not stop the
run: the kit's version stands in for it, and one line says so::

    yours = Yours("lab07")                              # in the setup cell
    ...
    parts = yours.pieces(log_likelihoods, normalize_log_weights)
    node = Amcl(office_map, params, log_likelihoods=parts[0], normalize=parts[1])

:meth:`Yours.pieces` gives ``None`` for a piece that is not done (the kit's keyword default:
its own function), :meth:`Yours.function` the exercise's reference instead — the kit's
computation with the exercise's own signature — for cells that call the function
themselves. A student's function that runs but is wrong is used as it is: that is the
point of seeing it in the whole system.
"""

from __future__ import annotations

import copy
import traceback
from collections.abc import Callable
from typing import Any

from grader.spec import Exercise, LabSpec, load_lab

__all__ = ["Yours"]


class Yours:
    """The stand-in rule of one lab (``Yours("lab07")``)."""

    def __init__(self, lab: str | int) -> None:
        self.spec: LabSpec = load_lab(lab)

    def _exercise(self, fn: Callable[..., Any]) -> tuple[Exercise, int]:
        name = str(getattr(fn, "__name__", ""))
        for number, ex in enumerate(self.spec.exercises, start=1):
            if ex.function == name:
                return ex, number
        raise ValueError(f"{name or repr(fn)} is not an exercise of {self.spec.name}; its "
                         f"exercises are {[ex.function for ex in self.spec.exercises]}")

    def missing(self, fn: Callable[..., Any]) -> str | None:
        """``None`` when ``fn`` runs its exercise's first public case, else why not (one
        line, for the notice)."""
        ex, number = self._exercise(fn)
        case = ex.public[0]
        try:
            fn(*copy.deepcopy(case.args), **copy.deepcopy(case.kwargs))
        except NotImplementedError as exc:
            names = [e.function for e in self.spec.exercises]
            stub = [frame.f_code.co_name for frame, _ in traceback.walk_tb(exc.__traceback__)
                    if frame.f_code.co_name in names]
            if stub and stub[-1] != ex.function:     # an earlier exercise it calls
                return (f"`{ex.function}` (exercise {number}) needs `{stub[-1]}` (exercise "
                        f"{names.index(stub[-1]) + 1}), not done yet")
            return f"`{ex.function}` (exercise {number}) is not done yet"
        except Exception as exc:  # any failure of the student's code
            return (f"`{ex.function}` (exercise {number}) raises {type(exc).__name__} on its "
                    f"first public case")
        return None

    def pieces(self, *functions: Callable[..., Any]) -> tuple[Callable[..., Any] | None, ...]:
        """Each function if it runs, else ``None`` (the kit's own piece), with a notice."""
        out: list[Callable[..., Any] | None] = []
        for fn in functions:
            why = self.missing(fn)
            if why is not None:
                print(f"{why}: the kit's version stands in")
            out.append(fn if why is None else None)
        return tuple(out)

    def function(self, fn: Callable[..., Any]) -> Callable[..., Any]:
        """``fn`` if it runs, else the exercise's reference (same arguments), with a
        notice."""
        ex, _ = self._exercise(fn)
        why = self.missing(fn)
        if why is None:
            return fn
        print(f"{why}: the kit's version stands in")
        return ex.reference

    def reference(self, fn: Callable[..., Any]) -> Callable[..., Any]:
        """The kit's version of ``fn``'s exercise, with the exercise's signature."""
        return self._exercise(fn)[0].reference

    def done(self, *functions: Callable[..., Any]) -> bool:
        """Whether every one of ``functions`` runs (no notice printed)."""
        return all(self.missing(fn) is None for fn in functions)
