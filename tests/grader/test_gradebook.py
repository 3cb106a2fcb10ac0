"""The gradebook never loses or invents rows: subset regrades, changed set-ups, per-student
folders holding several labs, Unicode ids, exact points, and grader errors as rows."""

from __future__ import annotations

import csv
import json
import unicodedata
from pathlib import Path

import nbformat
import pytest

from grader import grade
from grader.feedback import write_feedback
from grader.gradebook import GradebookError, grade_class, gradebook_rows
from grader.results import CaseOutcome, ExerciseResult, SubmissionResult, display_points
from grader.spec import load_lab
from grader.submissions import find_submissions, normalise_student

SPEC = load_lab("lab01")
RADIUS = SPEC.exercise("turning_radius")
GOOD = ("import math\ndef turning_radius(linear, angular):\n"
        "    if angular == 0:\n        return -math.inf if linear < 0 else math.inf\n"
        "    return linear / angular\n")
NO_STRAIGHT = "def turning_radius(linear, angular):\n    return linear / angular\n"


def notebook(path: Path, *cells: str, lab_cell: str | None = None) -> Path:
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(c) for c in ((lab_cell,) if lab_cell else ()) + cells]
    path.parent.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, path)
    return path


def rows(path: Path) -> dict[str, dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as fh:
        return {row["student"]: row for row in csv.DictReader(fh)}


def radius_points(row: dict[str, str]) -> float:
    return float(row[RADIUS.id])


def test_grading_a_subset_into_an_existing_gradebook_keeps_the_other_rows(tmp_path):
    folder = tmp_path / "class"
    for name in ("ann", "ben", "cai"):
        notebook(folder / f"{name}.ipynb", GOOD if name != "ben" else NO_STRAIGHT)
    out, results = tmp_path / "gb.csv", tmp_path / "gb.json"
    grade_class(sorted(folder.glob("*.ipynb")), SPEC, out, results, jobs=2)
    before = rows(out)
    assert set(before) == {"ann", "ben", "cai"}
    assert radius_points(before["ben"]) < RADIUS.points == radius_points(before["ann"])
    notebook(folder / "ben.ipynb", GOOD)  # a late fix, graded on its own
    seen: list[tuple[str, bool]] = []
    grade_class([folder / "ben.ipynb"], SPEC, out, results,
                progress=lambda r, reused: seen.append((r.student, reused)))
    after = rows(out)
    assert set(after) == {"ann", "ben", "cai"} and seen == [("ben", False)]
    assert radius_points(after["ben"]) == RADIUS.points
    assert after["ann"] == before["ann"] and after["cai"] == before["cai"]
    data = json.loads(results.read_text(encoding="utf-8"))
    assert [s["student"] for s in data["submissions"]] == ["ann", "ben", "cai"]


def test_a_changed_set_up_is_refused_for_a_subset_and_accepted_for_everyone(tmp_path):
    folder = tmp_path / "class"
    for name in ("ann", "ben"):
        notebook(folder / f"{name}.ipynb", GOOD)
    out, results = tmp_path / "gb.csv", tmp_path / "gb.json"
    grade_class(sorted(folder.glob("*.ipynb")), SPEC, out, results, secret="first")
    saved = (out.read_bytes(), results.read_bytes())
    with pytest.raises(GradebookError, match=r"another set-up .* \(ann\)"):
        grade_class([folder / "ben.ipynb"], SPEC, out, results, secret="second")
    assert (out.read_bytes(), results.read_bytes()) == saved  # nothing lost or mixed
    seen: list[bool] = []
    grade_class(sorted(folder.glob("*.ipynb")), SPEC, out, results, secret="second",
                progress=lambda r, reused: seen.append(reused))
    assert seen == [False, False] and set(rows(out)) == {"ann", "ben"}
    seen.clear()  # same set-up, same notebooks: nothing is graded again
    grade_class(sorted(folder.glob("*.ipynb")), SPEC, out, results, secret="second",
                progress=lambda r, reused: seen.append(reused))
    assert seen == [True, True]


def test_gradebooks_that_cannot_be_updated_safely_are_refused(tmp_path):
    folder = tmp_path / "class"
    notebook(folder / "ann.ipynb", GOOD)
    out, results = tmp_path / "gb.csv", tmp_path / "gb.json"
    out.write_text("student,total\nzed,20\n", encoding="utf-8")
    with pytest.raises(GradebookError, match=r"gb\.json.*does not"):
        grade_class([folder / "ann.ipynb"], SPEC, out, results)
    assert "zed" in out.read_text()
    out.unlink()
    grade_class([folder / "ann.ipynb"], SPEC, out, results)
    with pytest.raises(GradebookError, match="holds lab01's grades, not lab02's"):
        grade_class([folder / "ann.ipynb"], load_lab("lab02"), out, results)
    results.write_text("{not json", encoding="utf-8")
    with pytest.raises(GradebookError, match="cannot be read"):
        grade_class([folder / "ann.ipynb"], SPEC, out, results)


def test_a_multi_lab_per_student_folder_grades_one_notebook_per_student(tmp_path):
    root = tmp_path / "submissions"
    notebook(root / "alice" / "01-kinematics.ipynb", GOOD)
    notebook(root / "alice" / "03-drivers.ipynb", "x = 3")
    notebook(root / "alice" / "scratch.ipynb", "y = 1")
    notebook(root / "bob" / "01-kinematics.ipynb", NO_STRAIGHT)
    notebook(root / "carol" / "work" / "my lab.ipynb", GOOD,
             lab_cell='from grader import checker\ncheck = checker("lab01")')
    notebook(root / "dan" / "notes.ipynb", "z = 2", lab_cell='check = checker("lab03")')
    found = find_submissions([root], "lab01")
    assert sorted((s.student, s.path.name) for s in found.submissions) == [
        ("alice", "01-kinematics.ipynb"), ("bob", "01-kinematics.ipynb"),
        ("carol", "my lab.ipynb")]
    assert sorted((p.relative_to(root).as_posix(), why) for p, why in found.skipped) == [
        ("alice/03-drivers.ipynb", "its name says lab03"),
        ("alice/scratch.ipynb", "neither its name nor its cells say it is lab01"),
        ("dan/notes.ipynb", "its cells are lab03's")]
    graded = grade_class(found.submissions, SPEC, tmp_path / "gb.csv", tmp_path / "gb.json",
                         jobs=2)
    assert [r.student for r in graded] == ["alice", "bob", "carol"]
    assert set(rows(tmp_path / "gb.csv")) == {"alice", "bob", "carol"}
    notebook(root / "alice" / "01-kinematics-v2.ipynb", GOOD)
    # two notebooks of the lab for one student: her row says so, naming both; the class goes on
    found = find_submissions([root], "lab01")
    alice = next(s for s in found.submissions if s.student == "alice")
    assert alice.status == "duplicate"
    assert "01-kinematics.ipynb" in alice.reason and "01-kinematics-v2.ipynb" in alice.reason
    graded = {r.student: r for r in grade_class(found.submissions, SPEC, tmp_path / "gb.csv",
                                                 tmp_path / "gb.json", jobs=2)}
    assert graded["alice"].status == "duplicate" and graded["alice"].total == 0
    assert graded["bob"].status == graded["carol"].status == "ok"


def test_unicode_ids_give_distinct_correct_rows_and_feedback_files(tmp_path):
    """李明 and 王芳 no longer both become student.md, nor Zoë Zo.md; the NFC and NFD
    spellings of Zoë are one student, Zoe another."""
    folder = tmp_path / "class"
    zoe_nfc, zoe_nfd = "Zo\u00eb", unicodedata.normalize("NFD", "Zo\u00eb")
    assert zoe_nfc != zoe_nfd
    for name in ("李明", "王芳", zoe_nfc, "Zoe"):
        notebook(folder / f"{name}.ipynb", GOOD if name != "Zoe" else NO_STRAIGHT)
    out, results = tmp_path / "gb.csv", tmp_path / "gb.json"
    graded = grade_class(sorted(folder.glob("*.ipynb")), SPEC, out, results, jobs=2)
    assert sorted(r.student for r in graded) == sorted(["李明", "王芳", zoe_nfc, "Zoe"])
    book = rows(out)
    assert set(book) == {"李明", "王芳", zoe_nfc, "Zoe"}
    assert radius_points(book["Zoe"]) < radius_points(book[zoe_nfc]) == RADIUS.points
    files = write_feedback(results, tmp_path / "feedback")
    assert sorted(f.name for f in files) == sorted(f"{n}.md" for n in
                                                   ("李明", "王芳", zoe_nfc, "Zoe"))
    assert sorted(p.name for p in (tmp_path / "feedback").iterdir()) == \
        sorted(f.name for f in files)
    assert "feedback for 李明" in (tmp_path / "feedback" / "李明.md").read_text(encoding="utf-8")
    # the other spelling of Zoë is the same student: it updates her row
    (folder / f"{zoe_nfc}.ipynb").unlink()
    notebook(folder / f"{zoe_nfd}.ipynb", NO_STRAIGHT)
    assert normalise_student(zoe_nfd) == zoe_nfc
    grade_class([folder / f"{zoe_nfd}.ipynb"], SPEC, out, results)
    book = rows(out)
    assert set(book) == {"李明", "王芳", zoe_nfc, "Zoe"}
    assert radius_points(book[zoe_nfc]) < RADIUS.points
    notebook(folder / f"{zoe_nfc}.ipynb", GOOD)
    zoe = [s for s in find_submissions([folder], "lab01").submissions if s.student == zoe_nfc]
    assert len(zoe) == 1 and zoe[0].status == "duplicate"  # one row, both files named


def test_points_are_exact_and_only_displayed_totals_are_rounded():
    """Three 2-point exercises at 5 of 6 cases: 1.666… each, 5 in all — not the 5.01 that
    summing rounded points gives."""
    two_points = [ex for ex in SPEC.exercises if ex.points == 2][:3]
    exercises = {ex.id: ExerciseResult(ex.id, ex.points * 5 / 6, ex.points, "partly passed", "",
                                       [CaseOutcome(f"c{i}", True, i < 5) for i in range(6)])
                 for ex in two_points}
    result = SubmissionResult("ann", "ann.ipynb", "ok", "graded", exercises)
    assert result.total == pytest.approx(5.0, rel=1e-15)
    (row,) = gradebook_rows([result], SPEC)
    assert row["total"] == "5" and row["percent"] == f"{100 * 5 / SPEC.max_points:.1f}"
    assert sum(float(display_points(float(row[ex.id]))) for ex in two_points) == \
        pytest.approx(5.01)  # what rounding each exercise first would have given
    assert all(float(row[ex.id]) == 2 * 5 / 6 for ex in two_points)  # exact in the CSV


def test_a_grader_failure_on_one_notebook_is_its_row_and_the_class_goes_on(tmp_path,
                                                                        monkeypatch):
    folder = tmp_path / "class"
    for name in ("ann", "ben", "cai"):
        notebook(folder / f"{name}.ipynb", GOOD)
    real = grade.Conversation.run

    def flaky(self):
        if self.notebook.path.stem == "ben":
            raise FileNotFoundError("…/grade-xxxx/stdout.txt")
        return real(self)

    monkeypatch.setattr(grade.Conversation, "run", flaky)
    out, results = tmp_path / "gb.csv", tmp_path / "gb.json"
    graded = {r.student: r for r in grade_class(sorted(folder.glob("*.ipynb")), SPEC, out,
                                                results, jobs=2)}
    assert graded["ben"].status == "grader error" and "ben's notebook" in graded["ben"].reason
    assert "stdout.txt" in graded["ben"].reason
    assert graded["ann"].status == graded["cai"].status == "ok"
    assert rows(out)["ben"]["status"] == "grader error"
    monkeypatch.setattr(grade.Conversation, "run", real)
    seen: list[tuple[str, bool]] = []
    grade_class(sorted(folder.glob("*.ipynb")), SPEC, out, results,
                progress=lambda r, reused: seen.append((r.student, reused)))
    assert sorted(seen) == [("ann", True), ("ben", False), ("cai", True)]  # retried
    assert rows(out)["ben"]["status"] == "ok"
