"""What grading found: per case, per exercise, per submission (the JSON results' shape).

Points are kept exact (an exercise earns ``points × passed / cases``); only displays round:
the gradebook's total to 0.01 and its percent to 0.1.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

__all__ = ["STATUSES", "CaseOutcome", "ExerciseResult", "SubmissionResult", "display_points",
           "exact_points"]

STATUSES = ("ok", "timeout", "memory", "crashed", "output limit", "malformed notebook",
            "refused", "duplicate", "grader error")
"""a submission's status; ``grader error`` means the grader failed, not the student (a
re-run retries it); ``refused`` is a file the grader does not read (a link, a device, a FIFO);
``duplicate`` is two notebooks of the lab for one student."""


def display_points(value: float) -> str:
    """Points as shown to people: rounded to 0.01 (10.548 → ``10.55``)."""
    return f"{round(value, 2):g}"


def exact_points(value: float) -> str:
    """Points as stored: the shortest text that reads back as the same float."""
    return str(int(value)) if float(value).is_integer() else repr(float(value))


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
    memory, crashed, not graded."""
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
    practice: bool = False
    """graded without a course secret: the hidden cases are public."""

    @property
    def total(self) -> float:
        """The exact sum of the exercises' points."""
        return float(sum(e.points for e in self.exercises.values()))

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
                   data.get("sha256", ""), bool(data.get("practice", False)))
