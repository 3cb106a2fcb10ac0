"""Grading a class: resumable and idempotent, feedback without leaks, Dask, sandbox layers,
nbgrader compatibility."""

from __future__ import annotations

import csv
import json
import os
import pickle
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import nbformat
import pytest

from grader import checker, release
from grader.feedback import write_feedback
from grader.gradebook import grade_class
from grader.results import display_points
from grader.spec import load_lab

ROOT = Path(__file__).resolve().parents[1]
SOLUTION = ROOT / "solutions" / "01-kinematics.ipynb"
LAB = ROOT / "labs" / "01-kinematics.ipynb"
SWAP = ("return np.asarray(wheel_speeds, dtype=float) @ J.T",
        "return np.asarray(wheel_speeds, dtype=float)[..., ::-1] @ J.T")


def make_class(folder: Path, count: int, solved) -> dict[str, str]:
    """``count`` submissions cycling through a solved release, an untouched one and one with
    a swapped-wheel bug; returns student → kind."""
    folder.mkdir(parents=True)
    honest = solved("lab01", folder.parent / "honest.ipynb")
    buggy = solved("lab01", folder.parent / "buggy.ipynb", *SWAP)
    kinds = {}
    for i in range(count):
        kind = ("solution", "untouched", "swapped")[i % 3]
        path = folder / f"student{i:03d}.ipynb"
        shutil.copy({"solution": honest, "untouched": LAB, "swapped": buggy}[kind], path)
        kinds[path.stem] = kind
    return kinds


def read_rows(path: Path) -> dict[str, dict[str, str]]:
    with open(path, newline="") as fh:
        return {row["student"]: row for row in csv.DictReader(fh)}


@pytest.mark.slow
def test_a_class_of_100_grades_correctly_and_resumes_after_an_interruption(
        tmp_path, solved, weakest_layer_allowed):
    kinds = make_class(tmp_path / "class", 100, solved)
    out = tmp_path / "gradebook.csv"
    command = [sys.executable, "-m", "grader", "grade", str(tmp_path / "class"), "--lab", "01",
               "--out", str(out), "--jobs", "2", *weakest_layer_allowed]
    env = {**os.environ, "KIT_COURSE_SECRET": "class-of-100"}
    first = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             start_new_session=True, env=env)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:
        time.sleep(0.5)
        if out.exists() and len(read_rows(out)) >= 50:
            break
    os.killpg(first.pid, signal.SIGKILL)  # the instructor's laptop dies halfway
    first.wait()
    halfway = read_rows(out)  # atomic writes: a complete, readable file
    assert 50 <= len(halfway) < 100
    second = subprocess.run(command, capture_output=True, text=True, timeout=600, check=True,
                            env=env)
    summary = re.search(r"graded (\d+), kept (\d+) unchanged", second.stdout)
    assert summary is not None
    graded, kept = int(summary.group(1)), int(summary.group(2))
    # every row finished before the kill is kept (the JSON is written before the CSV, and a
    # few more may have finished between reading the CSV and the kill)
    assert graded + kept == 100 and len(halfway) <= kept <= len(halfway) + 10
    rows = read_rows(out)
    assert len(rows) == 100
    totals = {kind: {rows[s]["total"] for s, k in kinds.items() if k == kind}
              for kind in ("solution", "untouched", "swapped")}
    full = load_lab("lab01").max_points
    assert totals["solution"] == {display_points(full)} and totals["untouched"] == {"0"}
    assert len(totals["swapped"]) == 1 and full - 3 < float(next(iter(totals["swapped"]))) < full
    assert {row["status"] for row in rows.values()} == {"ok"}
    # a third run regrades nothing; changing one notebook regrades only that one
    third = subprocess.run(command, capture_output=True, text=True, timeout=600, check=True,
                           env=env)
    assert "graded 0, kept 100 unchanged" in third.stdout
    shutil.copy(tmp_path / "honest.ipynb", tmp_path / "class" / "student001.ipynb")  # untouched
    fourth = subprocess.run(command, capture_output=True, text=True, timeout=600, check=True,
                            env=env)
    assert "graded 1, kept 99 unchanged" in fourth.stdout
    assert read_rows(out)["student001"]["total"] == display_points(full)


def test_dask_cluster_grades_like_local_jobs(tmp_path, solved):
    """One submission of each kind (a solution, an untouched lab, swapped wheels), graded by
    two local jobs and by a two-worker Dask cluster: the same totals. The workers are threads
    of this process (worker processes took 20-30 s to start on a busy machine, more than
    the grading); what crosses to a remote worker is plain data and a function pickled by
    reference, checked here."""
    distributed = pytest.importorskip("distributed")
    from grader import gradebook

    assert pickle.loads(pickle.dumps(gradebook._grade_remote)) is gradebook._grade_remote
    make_class(tmp_path / "class", 3, solved)
    paths = sorted((tmp_path / "class").glob("*.ipynb"))
    spec = load_lab("lab01")
    local = grade_class(paths, spec, tmp_path / "a.csv", tmp_path / "a.json", jobs=2)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        remote = grade_class(paths, spec, tmp_path / "b.csv", tmp_path / "b.json",
                             dask_address=cluster.scheduler_address)
    full = spec.max_points
    fk = spec.exercise("forward_kinematics")
    swapped = [c for c in local[2].exercises[fk.id].cases]
    lost = fk.points * sum(not c.passed for c in swapped) / len(swapped)
    assert [r.total for r in remote] == [r.total for r in local]
    assert [r.total for r in local] == pytest.approx([full, 0.0, full - lost], rel=1e-12)
    assert 0 < lost < fk.points


def test_feedback_files_never_leak_hidden_cases(tmp_path, solved):
    make_class(tmp_path / "class", 3, solved)
    paths = sorted((tmp_path / "class").glob("*.ipynb"))
    spec = load_lab("lab01")
    grade_class(paths, spec, tmp_path / "gb.csv", tmp_path / "gb.json")
    files = write_feedback(tmp_path / "gb.json", tmp_path / "feedback")
    assert [f.name for f in files] == ["student000.md", "student001.md", "student002.md"]
    text = (tmp_path / "feedback" / "student002.md").read_text()
    assert "lab01.forward_kinematics: 0.33 / 3" in text
    assert "public case 'turn in place'" in text and "expected" in text
    assert "hidden cases: 0 of 5 pass" in text and "swapped wheels" in text
    # the hidden cases' inputs and expected values appear nowhere
    ex = spec.exercise("forward_kinematics")
    from grader.spec import course_seed

    hidden = ex.hidden_cases(course_seed(ex.id, "student002"))
    for case in hidden:
        expected = ex.reference(*case.args)
        for number in [*case.args[0].ravel()[:2], *expected.ravel()[:2]]:
            assert f"{float(number):.4f}"[:-1] not in text
    assert "not implemented yet" in (tmp_path / "feedback" / "student001.md").read_text()


@pytest.mark.parametrize("layer", ["bwrap", "unshare", "rlimits"])
def test_every_sandbox_layer_grades_and_is_reported(tmp_path, layer, solved):
    from grader.sandbox import layer_works

    if not layer_works(layer):
        pytest.skip(f"the {layer} layer cannot run here (it needs root and {layer}, and a kit "
                    f"installation other users can read)")
    folder = tmp_path / "class"
    folder.mkdir()
    solved("lab01", folder / "alice.ipynb")
    os.chmod(folder / "alice.ipynb", 0o600)
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(f"open({str(folder / 'alice.ipynb')!r}).read()")]
    nbformat.write(nb, folder / "eve.ipynb")
    env = {**os.environ, "KIT_SANDBOX": layer}
    command = [sys.executable, "-m", "grader", "grade", str(folder), "--lab", "1", "--practice",
               "--out", str(tmp_path / "gb.csv")]
    if layer == "rlimits":
        refused = subprocess.run(command, env=env, capture_output=True, text=True, timeout=300)
        assert refused.returncode == 2 and "--allow-no-isolation" in refused.stderr
        assert not (tmp_path / "gb.csv").exists()
        command.append("--allow-no-isolation")
    subprocess.run(command, env=env, check=True, capture_output=True, timeout=300)
    data = json.loads((tmp_path / "gb.json").read_text())
    by = {s["student"]: s for s in data["submissions"]}
    assert data["sandbox"] == layer and by["alice"]["total"] == load_lab("lab01").max_points
    if layer != "rlimits":
        assert "No such file" in by["eve"]["cell_errors"][0]["error"]


def test_released_labs_carry_nbgrader_metadata_like_nbgraders_own(shared_data):
    ours = nbformat.read(LAB, as_version=4)
    theirs = nbformat.read(shared_data / "nbgrader-samples" / "nbgrader-docs-ps1" / "source" /
                           "problem1.ipynb", as_version=4)
    their_keys = {frozenset(c.metadata["nbgrader"]) for c in theirs.cells
                  if "nbgrader" in c.metadata}
    our_keys = {frozenset(c.metadata["nbgrader"]) for c in ours.cells}
    assert our_keys <= their_keys | {frozenset({"grade", "grade_id", "locked", "points",
                                                "schema_version", "solution"})}
    meta = [c.metadata["nbgrader"] for c in ours.cells]
    graded = {m["grade_id"]: m["points"] for m in meta if m["grade"]}
    spec = load_lab("lab01")
    assert graded == {f"{ex.id}-check": ex.points for ex in spec.exercises}
    solutions = {m["grade_id"] for m in meta if m["solution"]}
    assert solutions == {ex.id for ex in spec.exercises}
    assert len({m["grade_id"] for m in meta}) == len(meta)  # nbgrader needs unique ids
    assert release.check_release(ROOT / "solutions", ROOT / "labs") == []


def test_check_raises_under_nbgraders_autograder(monkeypatch, capsys):
    monkeypatch.setenv("NBGRADER_EXECUTION", "autograde")
    check = checker("lab01")

    def turning_radius(linear, angular):
        return angular / linear

    with pytest.raises(AssertionError, match=r"lab01\.turning_radius"):
        check(turning_radius)

    def rpm_to_drive_units(rpm, counts_per_rev=400):
        return round(rpm * counts_per_rev / 60 * 2**17 / 20000)

    check(rpm_to_drive_units)  # a passing check does not raise
    assert "✓" in capsys.readouterr().out
