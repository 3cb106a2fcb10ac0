"""Exercise specifications: what a student writes, what it is compared with, how it scores.

A lab's exercises live in ``grader/labs/labNN.py`` as a module-level ``SPEC`` (a
:class:`LabSpec`); the labs are discovered from those file names, so adding a lab is adding
its spec file and its solution notebook ``solutions/NN-name.ipynb``. Each :class:`Exercise`
names the function the student defines in the notebook, the ``kit`` reference that computes
the expected output, public cases (shown in the notebook's check cell) and a generator of
hidden cases (seeded, used only when grading), tolerances, points, the references a student
must not call, and diagnostics: functions that reproduce a typical mistake, so a wrong answer
that equals a known mistake's output gets that mistake's hint.

The hidden cases are seeded from the course secret, which :func:`read_secret` reads — the one
place that does: ``--secret-file`` or the environment variable ``KIT_COURSE_SECRET``. Without
one, grading is practice (:data:`PRACTICE_SECRET`, public) and says so.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import pkgutil
import re
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["PRACTICE_SECRET", "Case", "Diagnostic", "Exercise", "LabSpec", "SecretError",
           "course_seed", "lab_names", "load_lab", "normalise_lab", "read_secret"]

PRACTICE_SECRET = "kit-practice"
"""the public seed of practice grading (no course secret): anyone can regenerate its cases."""
SECRET_VARIABLE = "KIT_COURSE_SECRET"


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
    harness: str = ""
    """Closed-loop grading: ``"module:function"`` (importable in the sandbox, e.g. a
    simulator episode) called as ``harness(student_function, *case.args)`` instead of the
    student's function itself; what it returns is compared with ``reference(*case.args)``."""
    time_limit: float = 0.0
    """Seconds per case (0: the grader's default, at most 10 s); a harness running a
    simulated episode needs longer."""
    uses: tuple[str, ...] = ()
    """Functions of the lab's earlier exercises that the student's solution of this one calls
    (``scan_to_points`` uses ``beam_angles``): when one of them fails its own cases, a failure
    here says so, pointing the student upstream."""

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

    def guarded_names(self) -> list[str]:
        """Every ``module:name`` out of reach while an exercise runs: the exercises'
        ``blocked`` lists, and each reference that is a function of the spec's own module."""
        names = {name for ex in self.exercises for name in ex.blocked}
        module = sys.modules.get(f"grader.labs.{self.name}")
        for ex in self.exercises:
            name = getattr(ex.reference, "__name__", "")
            if module is not None and getattr(module, name, None) is ex.reference:
                names.add(f"{module.__name__}:{name}")
        return sorted(names)


def lab_names() -> tuple[str, ...]:
    """The labs that have a spec: every ``grader/labs/labNN.py``, in order."""
    from grader import labs

    return tuple(sorted(info.name for info in pkgutil.iter_modules(labs.__path__)
                        if re.fullmatch(r"lab\d{2}", info.name)))


def normalise_lab(lab: str | int) -> str:
    """``1``, ``"1"``, ``"01"``, ``"lab01"`` → ``"lab01"``."""
    text = str(lab).lower().removeprefix("lab")
    if not text.isdigit():
        raise ValueError(f"a lab is a number like 01 or a name like lab01; got {lab!r}")
    name = f"lab{int(text):02d}"
    known = lab_names()
    if name not in known:
        raise ValueError(f"no such lab {name}; the kit has {', '.join(known)}")
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

    Without the secret nobody can regenerate the hidden cases; ``None`` is practice (the
    public :data:`PRACTICE_SECRET`). ``student`` gives each student their own variant.
    """
    key = PRACTICE_SECRET if secret is None else secret
    digest = hashlib.sha256(f"{key}\0{exercise_id}\0{student}".encode()).digest()
    return int.from_bytes(digest[:8], "little")


class SecretError(ValueError):
    """A course secret that is given but cannot be used."""


def read_secret(secret_file: Path | None = None,
                environ: Mapping[str, str] | None = None) -> str | None:
    """The course secret: the text of ``secret_file`` (surrounding blanks removed) when one
    is given, else the environment variable ``KIT_COURSE_SECRET``; ``None`` when neither.

    Raises :class:`SecretError` for a file that cannot be read or holds nothing.
    """
    if secret_file is not None:
        try:
            text = Path(secret_file).read_text(encoding="utf-8").strip()
        except (OSError, UnicodeDecodeError) as exc:
            raise SecretError(f"cannot read the course secret from {secret_file}: {exc}") \
                from None
        if not text:
            raise SecretError(f"{secret_file} is empty: it should hold the course secret")
        return text
    value = (os.environ if environ is None else environ).get(SECRET_VARIABLE, "").strip()
    return value or None
