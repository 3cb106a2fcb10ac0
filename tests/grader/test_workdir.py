"""make lab / make reset: working copies that never lose a student's file."""

from __future__ import annotations

import subprocess
import sys
from datetime import datetime
from pathlib import Path

import pytest

from grader.workdir import WorkdirError, copy_new, main, reset_lab


@pytest.fixture
def released(tmp_path: Path) -> Path:
    labs = tmp_path / "labs"
    labs.mkdir()
    (labs / "01-kinematics.ipynb").write_text("fresh 01")
    (labs / "02-odometry.ipynb").write_text("fresh 02")
    (labs / "data").mkdir()
    (labs / "data" / "map.yaml").write_text("map")
    return labs


def test_copy_never_overwrites_and_a_second_copy_changes_nothing(released, tmp_path):
    work = tmp_path / "work"
    assert len(copy_new(released, work)) == 3
    (work / "01-kinematics.ipynb").write_text("my answers")
    assert copy_new(released, work) == []
    assert (work / "01-kinematics.ipynb").read_text() == "my answers"
    (released / "03-drivers.ipynb").write_text("fresh 03")  # a new lab is released
    assert copy_new(released, work) == [work / "03-drivers.ipynb"]


def test_reset_gives_a_fresh_lab_and_keeps_the_old_file_beside_it(released, tmp_path):
    work = tmp_path / "work"
    copy_new(released, work)
    (work / "01-kinematics.ipynb").write_text("my answers")
    when = datetime(2026, 3, 4, 5, 6, 7)
    fresh, kept = reset_lab("01", released, work, now=when)
    assert fresh.read_text() == "fresh 01"
    assert kept == work / "01-kinematics.before-reset-20260304-050607.ipynb"
    assert kept.read_text() == "my answers"
    _, again = reset_lab("lab1", released, work, now=when)  # the same second: a new name
    assert again is not None and again != kept and kept.read_text() == "my answers"
    assert (work / "02-odometry.ipynb").read_text() == "fresh 02"  # other labs untouched


def test_reset_of_a_lab_never_copied_just_copies(released, tmp_path):
    fresh, kept = reset_lab("2", released, tmp_path / "work")
    assert kept is None and fresh.read_text() == "fresh 02"


@pytest.mark.parametrize(("lab", "message"), [("07", "no lab 07"), ("x1", "a number")])
def test_bad_labs_are_named(released, tmp_path, lab, message):
    with pytest.raises(WorkdirError, match=message):
        reset_lab(lab, released, tmp_path / "work")
    assert main(["--labs", str(released), "--work", str(tmp_path / "w"), "reset", lab]) == 2


def test_missing_release_folder(tmp_path):
    with pytest.raises(WorkdirError, match="not a folder"):
        copy_new(tmp_path / "nothing", tmp_path / "work")


def test_make_lab_copies_twice_and_make_reset_keeps_the_old_file(tmp_path):
    """The Makefile's own recipes (JupyterLab itself is not started here)."""
    root = Path(__file__).resolve().parents[2]
    work = tmp_path / "work"
    args = [sys.executable, "-m", "grader.workdir", "--labs", str(root / "labs"),
            "--work", str(work)]
    for _ in range(2):
        subprocess.run([*args, "copy"], check=True, cwd=root, capture_output=True)
    (work / "01-kinematics.ipynb").write_text("{}")
    out = subprocess.run([*args, "reset", "01"], check=True, cwd=root, capture_output=True,
                         text=True).stdout
    assert "your previous file is" in out
    assert len(list(work.glob("01-kinematics*.ipynb"))) == 2
