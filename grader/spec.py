"""Exercise specifications: what a student writes, what it is compared with, how it scores.

A lab's exercises live in ``grader/labs/labNN.py`` as a module-level ``EXERCISES`` tuple of
:class:`Exercise`. Each names the function the student defines in the notebook, the ``kit``
reference that computes the expected output, public cases (shown in the notebook's check
cell) and a generator of hidden cases (seeded, used only when grading), tolerances, points,
and diagnostics: functions that reproduce a typical mistake, so a wrong answer that equals
a known mistake's output gets that mistake's hint.
"""

from __future__ import annotations

import hashlib
import importlib
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Case", "Diagnostic", "Exercise", "LabSpec", "course_seed", "lab_names", "load_lab"]

LABS = ("lab01", "lab02", "lab03", "lab04", "lab05")


@dataclass(frozen=True)
class Case:
    """One call of the student's function: ``fn(*args, **kwargs)``."""

    name: str
    args: tuple[Any, ...]
    kwargs: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Diagnostic:
    """A known mistake: ``wrong`` returns what a function with that mistake returns."""

    name: str
    wrong: Callable[..., Any]
    hint: str


@dataclass(frozen=True)
class Exercise:
    id: str
    """``labNN.function_name``."""
    function: str
    """the name the student's notebook defines."""
    reference: Callable[..., Any]
    """computes the expected output in the grader's process."""
    points: float
    public: tuple[Case, ...]
    hidden: Callable[[np.random.Generator], Sequence[Case]]
    title: str = ""
    rtol: float = 1e-6
    atol: float = 1e-9
    diagnostics: tuple[Diagnostic, ...] = ()
    blocked: tuple[str, ...] = ()
    """``module:attribute`` names made unusable inside a submission while it is graded."""

    def hidden_cases(self, seed: int) -> tuple[Case, ...]:
        return tuple(self.hidden(np.random.default_rng(seed)))


@dataclass(frozen=True)
class LabSpec:
    name: str
    title: str
    exercises: tuple[Exercise, ...]

    def exercise(self, name_or_id: str) -> Exercise:
        for ex in self.exercises:
            if name_or_id in (ex.id, ex.function):
                return ex
        raise KeyError(f"{self.name} has no exercise {name_or_id!r}; exercises: "
                       f"{[ex.function for ex in self.exercises]}")

    @property
    def max_points(self) -> float:
        return float(sum(ex.points for ex in self.exercises))


def lab_names() -> tuple[str, ...]:
    return LABS


def normalise_lab(lab: str | int) -> str:
    """``1``, ``"1"``, ``"01"``, ``"lab01"`` → ``"lab01"``."""
    text = str(lab).lower().removeprefix("lab")
    if not text.isdigit():
        raise ValueError(f"a lab is a number like 01 or a name like lab01; got {lab!r}")
    name = f"lab{int(text):02d}"
    if name not in LABS:
        raise ValueError(f"no such lab {name}; the kit has {', '.join(LABS)}")
    return name


def load_lab(lab: str | int) -> LabSpec:
    """The exercises of one lab (``"lab01"``, ``"01"`` or ``1``)."""
    name = normalise_lab(lab)
    module = importlib.import_module(f"grader.labs.{name}")
    spec = module.SPEC
    if not isinstance(spec, LabSpec):
        raise TypeError(f"grader.labs.{name}.SPEC is not a LabSpec")
    return spec


def course_seed(exercise_id: str, student: str = "", secret: str | None = None) -> int:
    """Seed for an exercise's hidden cases, derived from the course secret.

    The instructor keeps the secret (environment variable ``KIT_COURSE_SECRET``); without it
    nobody can regenerate the hidden cases. ``student`` gives each student their own variant.
    """
    key = secret if secret is not None else os.environ.get("KIT_COURSE_SECRET", "kit-default")
    digest = hashlib.sha256(f"{key}\0{exercise_id}\0{student}".encode()).digest()
    return int.from_bytes(digest[:8], "little")
