"""Feedback files: Unicode names that never collide, failing cells shown as the student sees
them, practice grading said, exact points displayed to 0.01."""

from __future__ import annotations

import json
import unicodedata

from grader.feedback import file_names, render, write_feedback


def test_file_names_keep_unicode_and_never_collide():
    students = ["李明", "王芳", "Zoë", "Zoe", "zoe", "a/b", "a_b", "..", "", "x" * 300, "ok"]
    names = file_names(students)
    assert names[:5] == ["李明", "王芳", "Zoë", "Zoe", "zoe-2"]  # distinct on a case-blind disk
    assert names[5] == "a_b" and names[6] == "a_b-2"
    assert names[7] == "student" and names[8] == "student-2"
    assert len(names[9].encode()) <= 200 and names[9].startswith("xxx")
    assert len({n.casefold() for n in names}) == len(names)
    assert all("/" not in n and not n.startswith(".") for n in names)
    assert file_names([unicodedata.normalize("NFD", "Zoë")]) == ["Zoë"]  # NFC on disk


def test_written_files_are_the_ones_counted(tmp_path):
    data = {"lab": "lab01", "max": 2.0, "tolerances": {}, "submissions": [
        {"student": name, "total": 0.0, "status": "ok", "reason": "graded", "exercises": {}}
        for name in ("Zoe", "zoe", "李明")]}
    (tmp_path / "r.json").write_text(json.dumps(data, ensure_ascii=False), encoding="utf-8")
    written = write_feedback(tmp_path / "r.json", tmp_path / "fb")
    assert len(written) == 3 == len(list((tmp_path / "fb").iterdir()))
    assert [p.name for p in written] == ["Zoe.md", "zoe-2.md", "李明.md"]


def test_feedback_shows_failing_cells_practice_and_rounded_points():
    submission = {
        "student": "ann", "total": 2 * 5 / 6 + 1, "status": "ok", "reason": "graded",
        "practice": True,
        "cell_errors": [{"cell": 7, "first_line": "def forward_kinematics(wheel_speeds, r…",
                         "line": 4, "code": "return x +", "kind": "syntax",
                         "error": "SyntaxError: invalid syntax"}],
        "exercises": {"lab01.turning_radius": {
            "points": 2 * 5 / 6, "max_points": 2, "status": "partly passed", "reason": "",
            "cases": [{"case": "straight", "public": True, "passed": False,
                       "message": "the output: expected inf, got nan"},
                      {"case": "hidden case 1", "public": False, "passed": False,
                       "message": "raised ZeroDivisionError"},
                      {"case": "hidden case 2", "public": False, "passed": True, "message": ""}]}}}
    text = render(submission, "lab01", 20, {"lab01.turning_radius": {"rtol": 1e-6,
                                                                     "atol": 1e-9}})
    assert "**2.67 / 20 points** — ok" in text
    assert "Practice grading" in text
    assert "- cell 7 (`def forward_kinematics(wheel_speeds, r…`), line 4: SyntaxError" in text
    assert "`return x +`" in text
    assert "## lab01.turning_radius: 1.67 / 2" in text
    assert "✗ public case 'straight': the output: expected inf, got nan" in text
    assert "hidden cases: 1 of 2 pass" in text and "  - raised ZeroDivisionError" in text
