"""``grader feedback``: one Markdown file per student from the JSON results.

Each file lists the student's points per exercise, every public case's verdict with its
message and hint, the cells that failed (as the student sees them: position, first line, the
line that failed), and for the hidden cases only how many passed, the hints of known mistakes
and fixed verdicts — never a hidden case's inputs, expected outputs, printed text or an
exception's words (the results never hold them).

File names keep the student's id — ``李明.md``, ``Zoë.md`` — with only characters no file
system accepts replaced; two ids that would give one file name (``a/b`` and ``a_b``, or
``Zoe`` and ``zoe`` on a case-insensitive disk) get distinct names, and the count printed is
the number of files written.
"""

from __future__ import annotations

import hashlib
import json
import re
import unicodedata
from pathlib import Path
from typing import Any

from grader.results import display_points

__all__ = ["file_names", "render", "write_feedback"]

UNSAFE = re.compile(r'[\x00-\x1f\x7f/\\:*?"<>|]+')
MAX_NAME_BYTES = 200


def _safe_name(student: str) -> str:
    """A file name for ``student``: Unicode kept (NFC), path separators and control
    characters replaced, never hidden, empty or longer than the file system allows."""
    name = UNSAFE.sub("_", unicodedata.normalize("NFC", student)).strip().strip(".")
    name = name or "student"
    if len(name.encode("utf-8")) > MAX_NAME_BYTES:
        digest = hashlib.sha256(student.encode()).hexdigest()[:8]
        name = name.encode("utf-8")[:MAX_NAME_BYTES - 9].decode("utf-8", "ignore") + "-" + digest
    return name


def file_names(students: list[str]) -> list[str]:
    """A file name (without ``.md``) for each student, in order, distinct even on a
    case-insensitive disk."""
    taken: set[str] = set()
    names = []
    for student in students:
        base = _safe_name(student)
        name, n = base, 2
        while name.casefold() in taken:
            name, n = f"{base}-{n}", n + 1
        taken.add(name.casefold())
        names.append(name)
    return names


def _hint(message: str) -> str:
    _, _, hint = message.partition("; this is what ")
    return f"this is what {hint}" if hint else ""


def _cell_errors(errors: list[dict[str, Any]]) -> list[str]:
    if not errors:
        return []
    lines = ["## Cells that failed", ""]
    for e in errors:
        at = f", line {e['line']}" if e.get("line") else ""
        lines.append(f"- cell {e.get('cell')} (`{e.get('first_line', '')}`){at}: {e.get('error')}")
        if e.get("code"):
            lines.append(f"  `{e['code']}`")
    return [*lines, ""]


def _exercise(exercise_id: str, ex: dict[str, Any], tol: dict[str, Any] | None) -> list[str]:
    lines = [f"## {exercise_id}: {display_points(ex['points'])} / {ex['max_points']:g}"]
    if tol:
        lines.append(f"*Compared with rtol = {tol['rtol']:g}, atol = {tol['atol']:g}.*")
    lines.append("")
    public = [c for c in ex["cases"] if c["public"]]
    hidden = [c for c in ex["cases"] if not c["public"]]
    if not ex["cases"]:
        lines.append(f"- {ex['reason']}")
    for case in public:
        mark = "✓" if case["passed"] else "✗"
        lines.append(f"- {mark} public case '{case['case']}'"
                     + ("" if case["passed"] else f": {case['message']}"))
    if hidden:
        passed = sum(c["passed"] for c in hidden)
        lines.append(f"- hidden cases: {passed} of {len(hidden)} pass")
        failing = [c["message"] for c in hidden if not c["passed"]]
        for hint in sorted({_hint(m) for m in failing} - {""}):
            lines.append(f"  - {hint}")
        verdicts = sorted({m.partition(";")[0] for m in failing} - {"wrong output"})
        for verdict in verdicts[:3]:  # fixed words: timed out, raised
            lines.append(f"  - {verdict}")
    return [*lines, ""]


def render(submission: dict[str, Any], lab: str, maximum: float,
           tolerances: dict[str, Any]) -> str:
    lines = [f"# {lab}: feedback for {submission['student']}", "",
             f"**{display_points(submission['total'])} / {maximum:g} points** — "
             f"{submission['status']}"
             + ("" if submission["status"] == "ok" else f": {submission['reason']}"), ""]
    if submission.get("practice"):
        lines += ["*Practice grading: these hidden cases are not secret.*", ""]
    lines += _cell_errors(list(submission.get("cell_errors", [])))
    for exercise_id, ex in submission["exercises"].items():
        lines += _exercise(exercise_id, ex, tolerances.get(exercise_id))
    return "\n".join(lines)


def write_feedback(results_json: Path, out_dir: Path) -> list[Path]:
    """Write ``<student>.md`` for every submission in ``results_json``; returns the files."""
    data = json.loads(results_json.read_text(encoding="utf-8"))
    out_dir.mkdir(parents=True, exist_ok=True)
    submissions = data["submissions"]
    names = file_names([s["student"] for s in submissions])
    written = []
    for submission, name in zip(submissions, names, strict=True):
        path = out_dir / f"{name}.md"
        path.write_text(render(submission, data["lab"], data["max"], data.get("tolerances", {})),
                        encoding="utf-8")
        written.append(path)
    return written
