"""Run All runs: the guard that `checker(...)` installs in IPython turns an unfinished
exercise into one line and lets every other error through (grader/runall.py)."""

from __future__ import annotations

import ast

import pytest
from IPython.core.interactiveshell import InteractiveShell

from grader import runall

STUB = "def forward_kinematics(w, r, s):\n    '''doc'''\n    raise NotImplementedError()\n"


@pytest.fixture
def shell(monkeypatch):
    monkeypatch.delenv("KIT_GRADING", raising=False)
    monkeypatch.delenv("NBGRADER_EXECUTION", raising=False)
    ip = InteractiveShell()
    guard = runall.install(["constraint_matrices", "forward_kinematics"], shell=ip)
    assert guard is not None
    yield ip
    ip.ast_transformers.clear()


def test_a_stub_becomes_one_line_naming_the_exercise_and_the_next_cell_runs(shell, capsys):
    shell.run_cell(STUB)
    result = shell.run_cell("v = forward_kinematics([1, 1], 0.05, 0.36)\nprint('after')")
    assert result.success
    assert capsys.readouterr().out == \
        "needs `forward_kinematics` (exercise 2) — not implemented yet\n"
    assert shell.run_cell("x = 2 + 2").success and shell.user_ns["x"] == 4


def test_a_later_cell_needing_a_skipped_result_says_so(shell, capsys):
    shell.run_cell(STUB)
    shell.run_cell("path = forward_kinematics([1, 1], 0.05, 0.36)")
    capsys.readouterr()
    result = shell.run_cell("print(path)")
    assert result.success
    assert "needs the results of an earlier cell" in capsys.readouterr().out
    # and once a cell defines it, the name is no longer reported as missing
    shell.run_cell("path = 3")
    assert shell.run_cell("path + 1").result == 4


def test_real_mistakes_still_raise(shell):
    assert isinstance(shell.run_cell("1 / 0").error_in_exec, ZeroDivisionError)
    assert isinstance(shell.run_cell("undefined_name").error_in_exec, NameError)
    # NotImplementedError from code that is not an exercise stub is a real error too
    result = shell.run_cell("def helper():\n    raise NotImplementedError\nhelper()")
    assert isinstance(result.error_in_exec, NotImplementedError)


def test_the_last_expression_is_still_displayed(shell):
    result = shell.run_cell("a = 20\na + 1", store_history=True)
    assert result.result == 21 and shell.user_ns["Out"][result.execution_count] == 21
    # a trailing ";" still hides it
    assert shell.run_cell("a + 1;", store_history=True).result is None


def test_future_imports_stay_first(shell):
    result = shell.run_cell("from __future__ import annotations\nx: undefined_type = 3\nx")
    assert result.success and result.result == 3


def test_installing_twice_keeps_one_guard(shell):
    runall.install(["forward_kinematics"], shell=shell)
    guards = [t for t in shell.ast_transformers if isinstance(t, runall.RunAllGuard)]
    assert len(guards) == 1 and guards[0].exercises == ("forward_kinematics",)


@pytest.mark.parametrize("variable", ["KIT_GRADING", "NBGRADER_EXECUTION"])
def test_nothing_is_installed_while_grading(monkeypatch, variable):
    monkeypatch.setenv(variable, "1")
    ip = InteractiveShell()
    assert runall.install(["forward_kinematics"], shell=ip) is None
    assert not any(isinstance(t, runall.RunAllGuard) for t in ip.ast_transformers)


def test_nothing_is_installed_outside_ipython(monkeypatch):
    monkeypatch.delenv("KIT_GRADING", raising=False)
    monkeypatch.delenv("NBGRADER_EXECUTION", raising=False)
    assert runall.install(["forward_kinematics"], shell=object()) is None


def test_defined_names_lists_what_a_cell_binds():
    tree = ast.parse("import numpy as np\nfrom a.b import c\nx, (y, z) = 1, (2, 3)\n"
                     "def f(): q = 1\nfor i in range(3):\n    s = i\nw += 1\nprint(k)")
    assert runall.defined_names(tree) == ("np", "c", "x", "y", "z", "f", "i", "s", "w")
