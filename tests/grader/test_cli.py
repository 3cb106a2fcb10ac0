"""``grader grade`` as an instructor runs it: the secret read in one place and required, the
weakest layer refused, skipped notebooks listed, a progress bar, a summary, exit codes that
count grader errors; ``grader feedback`` says how many files it wrote."""

from __future__ import annotations

import csv
from pathlib import Path

import nbformat
import pytest

from grader import cli, grade
from grader.spec import SecretError, read_secret

GOOD = ("import math\ndef turning_radius(linear, angular):\n"
        "    if angular == 0:\n        return -math.inf if linear < 0 else math.inf\n"
        "    return linear / angular\n")


def notebook(path: Path, *cells: str) -> Path:
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(c) for c in cells]
    path.parent.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, path)
    return path


@pytest.fixture()
def folder(tmp_path, monkeypatch):
    monkeypatch.delenv("KIT_COURSE_SECRET", raising=False)
    for name in ("ann", "ben"):
        notebook(tmp_path / "class" / f"{name}.ipynb", GOOD)
    notebook(tmp_path / "class" / "03-drivers.ipynb", "x = 1")
    return tmp_path


def grade_args(tmp: Path, *extra: str) -> list[str]:
    return ["grade", str(tmp / "class"), "--lab", "01", "--out", str(tmp / "gb.csv"), *extra]


def test_without_a_secret_grading_is_refused_unless_practice(folder, capsys,
                                                           weakest_layer_allowed):
    assert cli.main(grade_args(folder, *weakest_layer_allowed)) == 2
    err = capsys.readouterr().err
    assert "no course secret" in err and "--practice" in err and "KIT_COURSE_SECRET" in err
    assert not (folder / "gb.csv").exists()
    assert cli.main(grade_args(folder, "--practice", *weakest_layer_allowed)) == 0
    out = capsys.readouterr().out
    assert "practice grading" in out
    with open(folder / "gb.csv", newline="", encoding="utf-8") as fh:
        reasons = [row["reason"] for row in csv.DictReader(fh)]
    assert len(reasons) == 2 and all("practice grading" in r for r in reasons)


def test_the_secret_comes_from_the_environment_or_a_file(folder, capsys, monkeypatch, tmp_path,
                                                          weakest_layer_allowed):
    secret = tmp_path / "secret.txt"
    secret.write_text("  s3cret\n", encoding="utf-8")
    assert read_secret(secret) == "s3cret"
    assert read_secret(None, {"KIT_COURSE_SECRET": "env-secret"}) == "env-secret"
    assert read_secret(None, {}) is None
    (tmp_path / "empty.txt").write_text("\n", encoding="utf-8")
    with pytest.raises(SecretError, match=r"empty\.txt is empty"):
        read_secret(tmp_path / "empty.txt")
    with pytest.raises(SecretError, match="cannot read the course secret from"):
        read_secret(tmp_path / "missing.txt")
    assert cli.main(grade_args(folder, "--secret-file", str(secret),
                               *weakest_layer_allowed)) == 0
    out = capsys.readouterr().out
    assert "practice" not in out and "skipped" in out and "03-drivers.ipynb" in out
    assert cli.main(grade_args(folder, "--secret-file", str(tmp_path / "missing.txt"))) == 2
    assert "cannot read the course secret" in capsys.readouterr().err


def test_the_rlimits_layer_is_refused_for_a_class_unless_allowed(folder, capsys, monkeypatch):
    monkeypatch.setattr(cli, "detect_layer", lambda: "rlimits")
    assert cli.main(grade_args(folder, "--practice")) == 2
    err = capsys.readouterr().err
    assert "cannot keep a submission from reading" in err and "--allow-no-isolation" in err
    assert not (folder / "gb.csv").exists()


@pytest.mark.parametrize(("euid", "tools", "said"), [
    (1000, ("bwrap", "unshare"), "not running as root"),
    (0, (), "neither bubblewrap (bwrap) nor unshare is installed"),
    (0, ("bwrap", "unshare"), "readable by other users (a checkout or .venv made under umask 077"),
])
def test_the_refusal_says_why_no_isolating_layer_works(folder, capsys, monkeypatch, euid, tools,
                                                      said):
    """A user who is not root is told so, not that bubblewrap is missing where it is
    installed."""
    import shutil

    monkeypatch.setattr(cli, "detect_layer", lambda: "rlimits")
    monkeypatch.setattr("os.geteuid", lambda: euid)
    monkeypatch.setattr(shutil, "which", lambda tool: f"/usr/bin/{tool}" if tool in tools
                        else None)
    assert cli.main(grade_args(folder, "--practice")) == 2
    err = capsys.readouterr().err
    assert said in err and "rlimits" in err and "--allow-no-isolation" in err
    if euid:
        assert "missing" not in err and "not installed" not in err


def test_a_run_ends_with_a_summary_and_counts_grader_errors_in_its_exit_code(
        folder, capsys, monkeypatch, weakest_layer_allowed):
    real = grade.Conversation.run

    def failing_for_ben(self):
        if self.notebook.path.stem == "ben":
            raise RuntimeError("disk full")
        return real(self)

    monkeypatch.setattr(grade.Conversation, "run", failing_for_ben)
    assert cli.main(grade_args(folder, "--practice", "--jobs", "2", *weakest_layer_allowed)) == 1
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-1].startswith("1 rows are grader errors") and lines[-1].endswith(": ben")
    table = lines[lines.index(next(ln for ln in lines if ln.startswith("status"))):]
    assert table[1].split() == ["ok", "1"] and table[2].split() == ["grader", "error", "1"]
    assert table[3].startswith("points: mean 1, median 1 of 20 (2 rows)")


def test_the_progress_bar_shows_count_rate_and_eta(capsys):
    from grader.results import SubmissionResult
    from grader.spec import load_lab

    bar = cli._Progress(4, load_lab("lab01"), enabled=True)
    bar(SubmissionResult("ann", "ann.ipynb", "ok", "graded"), False)
    bar(SubmissionResult("ben", "ben.ipynb", "timeout", "did not finish"), False)
    bar.close()
    captured = capsys.readouterr()
    assert "ann" in captured.out and "timeout (did not finish)" in captured.out
    assert "2/4" in captured.err and "submission" in captured.err and "<" in captured.err


def test_feedback_prints_the_number_of_files_it_wrote(folder, capsys, weakest_layer_allowed):
    assert cli.main(grade_args(folder, "--practice", *weakest_layer_allowed)) == 0
    capsys.readouterr()
    assert cli.main(["feedback", str(folder / "gb.json"), "--out", str(folder / "fb")]) == 0
    assert capsys.readouterr().out.strip() == f"wrote 2 feedback files to {folder / 'fb'}"
    assert sorted(p.name for p in (folder / "fb").iterdir()) == ["ann.md", "ben.md"]


def test_a_cell_that_ends_the_process_is_left_out_and_the_rest_still_graded(
        tmp_path, capsys, monkeypatch, weakest_layer_allowed):
    """The notebook's cells run again without the cell that ended the process, and the
    functions the other cells define are graded (they were all 'missing' before: only the
    first run's functions counted)."""
    monkeypatch.delenv("KIT_COURSE_SECRET", raising=False)
    notebook(tmp_path / "class" / "cat.ipynb", GOOD, "import os\nos._exit(3)")
    notebook(tmp_path / "class" / "dan.ipynb", GOOD)
    assert cli.main(grade_args(tmp_path, "--practice", *weakest_layer_allowed)) == 0
    with open(tmp_path / "gb.csv", newline="", encoding="utf-8") as fh:
        rows = {row["student"]: row for row in csv.DictReader(fh)}
    honest = rows["dan"]["lab01.turning_radius"]
    assert float(honest) > 0
    assert rows["cat"]["lab01.turning_radius"] == honest
    feedback = (tmp_path / "gb.json").read_text(encoding="utf-8")
    assert "ran the notebook again without this cell" in feedback
