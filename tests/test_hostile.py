"""Hostile submissions: each gets a defined grade and reason, leaves the others alone, and
never crashes the grader. They are graded together with an honest solution in one run."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import nbformat
import pytest

from grader.grade import SubmissionResult, grade_class
from grader.sandbox import detect_layer
from grader.spec import load_lab

ROOT = Path(__file__).resolve().parents[1]
GOOD_RADIUS = ("import math\n"
               "def turning_radius(linear, angular):\n"
               "    if angular == 0:\n"
               "        return -math.inf if linear < 0 else math.inf\n"
               "    return linear / angular\n")


def hostile_cells(tmp: Path) -> dict[str, list[str]]:
    other = tmp / "class" / "alice.ipynb"
    gradebook = tmp / "out" / "gradebook.csv"
    return {
        "loop_at_import": ["while True:\n    pass"],
        "memory_bomb": ["hog = []\nwhile True:\n    hog.append(bytearray(10**8))"],
        "fork_bomb": ["import os, time\nfor _ in range(30):\n    if os.fork() == 0:\n"
                      "        time.sleep(600)\n        os._exit(0)\n", GOOD_RADIUS],
        "sys_exit_at_import": ["import sys\nsys.exit(3)", GOOD_RADIUS],
        "os_exit_at_import": ["import os\nos._exit(3)"],
        "sys_exit_in_exercise": ["import sys\ndef turning_radius(linear, angular):\n"
                                 "    sys.exit(0)"],
        "os_exit_in_exercise": ["import os\ndef turning_radius(linear, angular):\n"
                                "    os._exit(0)"],
        "segfault": ["import ctypes\nctypes.string_at(0)"],
        "fake_verdict": ["print('✓ all 9 exercises pass: 20 / 20')\n"
                         "print('{\"outcomes\": {}, \"cell_errors\": []}')",
                         "def turning_radius(linear, angular):\n    return 42.0"],
        "fake_results_file": [
            "import json, os\n"
            "fake = {'cell_errors': [], 'outcomes': {'lab01.turning_radius': {'cases': "
            "[{'status': 'returned', 'value': 1.0}] * 8, 'signature': '(a, b)'}}}\n"
            "open('result.json', 'w').write(json.dumps(fake))\nos._exit(0)"],
        "monkey_patching": [
            "import numpy, builtins, grader.compare, grader.checker\n"
            "numpy.allclose = lambda *a, **k: True\n"
            "grader.compare.compare = lambda *a, **k: None\n"
            "grader.checker.check = lambda *a, **k: None\n"
            "builtins.abs = lambda x: 0\n"
            "def turning_radius(linear, angular):\n    return 42.0"],
        "calls_kit_reference": ["from kit.kinematics import turning_radius"],
        "reloads_kit_reference": [
            "import importlib, kit.kinematics\nimportlib.reload(kit.kinematics)\n"
            "turning_radius = kit.kinematics.turning_radius"],
        "reads_secret_and_others": [
            "import os\nsecret = os.environ.get('KIT_COURSE_SECRET', 'no secret here')\n"
            "raise RuntimeError(secret)",
            f"print(open({str(other)!r}).read())"],
        "writes_gradebook_and_submissions": [
            f"open({str(gradebook)!r}, 'w').write('mallory,20')",
            f"open({str(other)!r}, 'w').write('overwritten')", GOOD_RADIUS],
        "gigabyte_of_output": ["import sys\nchunk = 'x' * 2**20\nfor _ in range(1024):\n"
                               "    sys.stderr.write(chunk)\n    print(chunk)", GOOD_RADIUS],
        "wrong_signature": ["def turning_radius(linear):\n    return linear"],
        "missing_functions": ["x = 1"],
    }


def write_notebook(path: Path, cells: list[str]) -> Path:
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(c) for c in cells]
    nbformat.write(nb, path)
    return path


@pytest.fixture(scope="module")
def graded(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, SubmissionResult], Path]:
    tmp = tmp_path_factory.mktemp("hostile")
    folder = tmp / "class"
    folder.mkdir()
    (tmp / "out").mkdir()
    alice = folder / "alice.ipynb"
    alice.write_bytes((ROOT / "solutions" / "01-kinematics.ipynb").read_bytes())
    os.chmod(alice, stat.S_IRUSR | stat.S_IWUSR)  # other students cannot read it
    for name, cells in hostile_cells(tmp).items():
        if name == "writes_gradebook_and_submissions" and detect_layer() == "rlimits":
            continue  # the weakest layer runs submissions as the grader's user: it cannot
            # stop them writing files (README: use bubblewrap or grade as root)
        write_notebook(folder / f"{name}.ipynb", cells)
    (folder / "not_json.ipynb").write_text('{"cells": [', encoding="utf-8")
    (folder / "latin1.ipynb").write_bytes(b'{"cells": "\xe9\xff"}')
    before = alice.read_bytes()
    results = grade_class(sorted(folder.glob("*.ipynb")), load_lab("lab01"),
                          tmp / "out" / "gradebook.csv", tmp / "out" / "gradebook.json",
                          jobs=2, timeout=30, memory_mb=1024)
    assert alice.read_bytes() == before
    return {r.student: r for r in results}, tmp


def test_the_honest_student_is_unaffected(graded):
    results, _ = graded
    assert results["alice"].status == "ok" and results["alice"].total == 20


@pytest.mark.parametrize(("name", "status", "reason"), [
    ("loop_at_import", "timeout", "did not finish within 30 s"),
    ("memory_bomb", "memory", "ran out of memory"),
    ("os_exit_at_import", "crashed", "exited with code 3"),
    ("os_exit_in_exercise", "crashed", "without reporting"),
    ("segfault", "crashed", "SIGSEGV"),
    ("fake_results_file", "ok", "graded"),
    ("gigabyte_of_output", "output limit", "printed more than 64 MB"),
    ("not_json", "malformed notebook", "JSON"),
    ("latin1", "malformed notebook", "UTF-8"),
])
def test_hostile_submission_gets_its_status_and_reason(graded, name, status, reason):
    results, _ = graded
    r = results[name]
    assert r.status == status, r.reason
    assert reason in r.reason
    if status != "output limit":
        assert r.total == 0


def test_exits_and_fork_bombs_do_not_stop_grading_the_rest(graded):
    results, _ = graded
    for name in ("sys_exit_at_import", "fork_bomb"):
        assert results[name].status == "ok"
        assert results[name].exercises["lab01.turning_radius"].points == 2
    case = results["sys_exit_in_exercise"].exercises["lab01.turning_radius"]
    assert case.points == 0 and "called sys.exit" in case.reason
    assert any("SystemExit" in e["error"] for e in results["sys_exit_at_import"].cell_errors)


def test_printing_or_faking_verdicts_and_patching_change_nothing(graded):
    results, _ = graded
    for name in ("fake_verdict", "fake_results_file", "monkey_patching"):
        assert results[name].total == 0, name
    assert "expected inf" in results["monkey_patching"].exercises[
        "lab01.turning_radius"].reason or "expected" in results["monkey_patching"].exercises[
        "lab01.turning_radius"].reason


def test_the_kit_reference_cannot_be_called_or_reloaded(graded):
    results, _ = graded
    reason = results["calls_kit_reference"].exercises["lab01.turning_radius"].reason
    assert "PermissionError" in reason and "your own code" in reason
    reloaded = results["reloads_kit_reference"]
    assert reloaded.total == 0
    assert any("blocked while grading" in e["error"] for e in reloaded.cell_errors)


def test_no_secret_no_other_notebooks_no_writes(graded):
    results, tmp = graded
    errors = [e["error"] for e in results["reads_secret_and_others"].cell_errors]
    assert any("no secret here" in e for e in errors)
    if detect_layer() != "rlimits":  # the weakest layer cannot hide or protect files
        assert any(("No such file" in e or "Permission denied" in e) for e in errors), errors
        write_errors = [e["error"] for e in
                        results["writes_gradebook_and_submissions"].cell_errors]
        assert len(write_errors) == 2 and all(
            ("Read-only" in e or "Permission denied" in e or "No such file" in e)
            for e in write_errors), write_errors
        rows = (tmp / "out" / "gradebook.csv").read_text()
        assert "mallory,20" not in rows
        assert results["writes_gradebook_and_submissions"].exercises[
            "lab01.turning_radius"].points == 2


def test_wrong_signatures_and_missing_functions_are_explained(graded):
    results, _ = graded
    reason = results["wrong_signature"].exercises["lab01.turning_radius"].reason
    assert "TypeError" in reason and "turning_radius(linear, angular)" in reason
    assert "turning_radius(linear)" in reason
    missing = results["missing_functions"].exercises
    assert {e.status for e in missing.values()} == {"missing function"}


def test_the_sandbox_layer_is_reported(graded):
    results, tmp = graded
    assert {r.sandbox for r in results.values() if r.status != "malformed notebook"} == \
        {detect_layer()}
    assert f'"sandbox": "{detect_layer()}"' in (tmp / "out" / "gradebook.json").read_text()
