"""``grader feedback``: one Markdown file per student from the JSON results.

Each file lists the student's points per exercise, every public case's verdict with its
message and hint, and for the hidden cases only how many passed and the hints of known
mistakes — never a hidden case's inputs or expected outputs (the results never hold them).
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

__all__ = ["write_feedback"]


def _safe_name(student: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", student).strip("._") or "student"


def _hint(message: str) -> str:
    _, _, hint = message.partition("; this is what ")
    return f"this is what {hint}" if hint else ""


def render(submission: dict[str, Any], lab: str, maximum: float,
           tolerances: dict[str, Any]) -> str:
    lines = [f"# {lab}: feedback for {submission['student']}", "",
             f"**{submission['total']:g} / {maximum:g} points** — {submission['status']}"
             + ("" if submission["status"] == "ok" else f": {submission['reason']}"), ""]
    for exercise_id, ex in submission["exercises"].items():
        lines.append(f"## {exercise_id}: {ex['points']:g} / {ex['max_points']:g}")
        tol = tolerances.get(exercise_id)
        if tol:
            lines.append(f"*Compared with rtol = {tol['rtol']:g}, atol = {tol['atol']:g}.*")
        lines.append("")
        public = [c for c in ex["cases"] if c["public"]]
        hidden = [c for c in ex["cases"] if not c["public"]]
        if not ex["cases"]:
            lines.append(f"- {ex['reason']}")
        for case in public:
            mark = "✓" if case["passed"] else "✗"
            text = f"- {mark} public case '{case['case']}'"
            if not case["passed"]:
                text += f": {case['message']}"
            lines.append(text)
        if hidden:
            passed = sum(c["passed"] for c in hidden)
            lines.append(f"- hidden cases: {passed} of {len(hidden)} pass")
            hints = sorted({_hint(c["message"]) for c in hidden if not c["passed"]} - {""})
            for hint in hints:
                lines.append(f"  - {hint}")
            statuses = sorted({c["message"] for c in hidden if not c["passed"] and
                               not c["message"].startswith("wrong output")})
            for status in statuses[:3]:  # errors and time-outs say nothing about the case
                lines.append(f"  - {status}")
        lines.append("")
    return "\n".join(lines)


def write_feedback(results_json: Path, out_dir: Path) -> list[Path]:
    """Write ``<student>.md`` for every submission in ``results_json``."""
    data = json.loads(results_json.read_text(encoding="utf-8"))
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for submission in data["submissions"]:
        path = out_dir / f"{_safe_name(submission['student'])}.md"
        path.write_text(render(submission, data["lab"], data["max"], data.get("tolerances", {})),
                        encoding="utf-8")
        written.append(path)
    return written
