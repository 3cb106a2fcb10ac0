"""``Exercise.uses``: the earlier exercises whose functions a solution calls, so that a failure
caused upstream can say "your ``X`` fails its own check: fix it first"."""

from __future__ import annotations

import ast
from pathlib import Path

import nbformat
import numpy as np
import pytest

from grader.labs._hidden import telling, until_each_shows
from grader.spec import Case, Diagnostic, lab_names, load_lab

ROOT = Path(__file__).resolve().parents[3]
LABS_WITH_EVERY_USE = ("lab01", "lab02", "lab03", "lab04", "lab05")
"""Labs whose ``uses`` must name every earlier exercise the solution calls (the later labs
declare theirs as their authors add them)."""


def solution_calls(lab: str) -> dict[str, set[str]]:
    """For each exercise function of ``lab``: the other exercise functions its solution cell
    calls by name."""
    spec = load_lab(lab)
    names = {ex.function for ex in spec.exercises}
    path = next((ROOT / "solutions").glob(f"{lab[3:]}-*.ipynb"))
    calls: dict[str, set[str]] = {}
    for cell in nbformat.read(path, as_version=4).cells:
        if cell.cell_type != "code" or "### BEGIN SOLUTION" not in cell.source:
            continue
        for node in ast.walk(ast.parse(cell.source)):
            if isinstance(node, ast.FunctionDef) and node.name in names:
                called = {n.func.id for n in ast.walk(node)
                          if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}
                calls[node.name] = called & (names - {node.name})
    return calls


@pytest.mark.parametrize("lab", lab_names())
def test_uses_names_earlier_exercises_of_the_same_lab(lab):
    functions = [ex.function for ex in load_lab(lab).exercises]
    for k, ex in enumerate(load_lab(lab).exercises):
        for used in ex.uses:
            assert used in functions[:k], (ex.id, used, functions[:k])


@pytest.mark.parametrize("lab", LABS_WITH_EVERY_USE)
def test_uses_are_exactly_the_exercises_the_solution_calls(lab):
    calls = solution_calls(lab)
    for ex in load_lab(lab).exercises:
        assert set(ex.uses) == calls.get(ex.function, set()), ex.id


def test_the_first_labs_declare_what_the_issue_names():
    assert load_lab("lab01").exercise("forward_kinematics").uses == ("constraint_matrices",)
    assert load_lab("lab03").exercise("velocity_frame").uses == ("crc16_xmodem",)


# ------------------------------------------------------------------ hidden cases that tell

def _sign_draw(rng):
    """Mostly positive numbers: a forgotten abs() shows only on the rare negative one."""
    return [Case(f"x{i}", (float(rng.uniform(-0.05, 1.0)),)) for i in range(3)]


def test_until_each_shows_redraws_until_every_mistake_loses_points():
    mistakes = [lambda x: x, lambda x: -abs(x)]          # abs forgotten, sign always flipped
    for seed in range(50):
        cases = until_each_shows(np.random.default_rng(seed), _sign_draw, abs, mistakes)
        assert any(c.args[0] < 0 for c in cases)          # the forgotten abs() shows


def test_until_each_shows_respects_the_tolerances():
    """A mistake within the exercise's tolerance loses nothing, so it cannot be told apart."""
    def reference(x):
        return x

    def slightly_off(x):
        return x * (1 + 1e-9)

    with pytest.raises(RuntimeError, match="tell every mistake apart"):
        until_each_shows(np.random.default_rng(0), _sign_draw, reference, [slightly_off],
                         rtol=1e-6, atol=1e-9, tries=20)
    assert until_each_shows(np.random.default_rng(0), _sign_draw, reference, [slightly_off],
                            rtol=0.0, atol=0.0)


def test_a_mistake_that_raises_counts_as_shown():
    def raises_on_negative(x):
        if x < 0:
            raise ValueError("negative")
        return abs(x)

    cases = telling(_sign_draw, abs, [Diagnostic("raises", raises_on_negative, "")])(
        np.random.default_rng(1))
    assert any(c.args[0] < 0 for c in cases)
