"""Release checks itself against the specs: a solution cell no exercise names, an exercise with
no solution cell, a check of no exercise, or a notebook without a spec is an error naming the
cell and the spec entry — and nothing is written. The README's example of adding an exercise
is the real procedure: its spec and cells, released and graded, earn every point."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import nbformat
import pytest

from grader import release
from grader.grade import grade_notebook
from grader.spec import Case, Exercise, LabSpec, lab_names

ROOT = Path(__file__).resolve().parents[2]


def spec(lab: str, *functions: str) -> LabSpec:
    return LabSpec(lab, "a test lab", tuple(
        Exercise(id=f"{lab}.{f}", function=f, reference=lambda: 1, points=1,
                 public=(Case("one", ()),), hidden=lambda rng: []) for f in functions))


def solutions(tmp_path: Path, *cells: str) -> Path:
    folder = tmp_path / "solutions"
    folder.mkdir(exist_ok=True)
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("# Lab 07")] + [
        nbformat.v4.new_code_cell(c) for c in cells]
    nbformat.write(nb, folder / "07-test.ipynb")
    return folder


SOLVED = "def {f}():\n    '''doc'''\n    ### BEGIN SOLUTION\n    return 1\n    ### END SOLUTION"


def test_a_solution_cell_without_a_spec_entry_names_the_cell_and_the_spec(tmp_path):
    sol = solutions(tmp_path, SOLVED.format(f="f"), SOLVED.format(f="extra"))
    with pytest.raises(release.ReleaseError) as err:
        release.release(sol, tmp_path / "labs", {"lab07": spec("lab07", "f")})
    assert re.search(r"07-test\.ipynb cell 3 \(`def extra\(\):`\) is a solution cell, but "
                     r"grader/labs/lab07\.py has no exercise whose function is 'extra'",
                     str(err.value))
    assert not (tmp_path / "labs").exists()  # nothing released


def test_a_spec_entry_without_a_solution_cell_names_both(tmp_path):
    sol = solutions(tmp_path, SOLVED.format(f="f"), "check(f)")
    problems = release.check_release(sol, tmp_path / "labs", {"lab07": spec("lab07", "f", "g")})
    assert problems == [f"grader/labs/lab07.py: exercise lab07.g (function 'g') has no "
                        f"solution cell in {sol / '07-test.ipynb'}"]


def test_a_check_of_no_exercise_and_a_missing_spec_are_errors(tmp_path):
    sol = solutions(tmp_path, SOLVED.format(f="f"), "check(f)\ncheck(h)")
    (problem,) = release.check_release(sol, tmp_path / "labs", {"lab07": spec("lab07", "f")})
    assert "cell 3 (`check(f)`) checks 'h', which is no exercise of grader/labs/lab07.py" \
        in problem
    with pytest.raises(release.ReleaseError, match=r"has 1 solution cells but "
                                                   r"grader/labs/lab07\.py does not exist"):
        release.release(solutions(tmp_path, SOLVED.format(f="f")), tmp_path / "labs", {})


def test_every_shipped_lab_has_a_spec_and_matches_it():
    notebooks = sorted(p.name[:2] for p in (ROOT / "solutions").glob("[0-9][0-9]-*.ipynb"))
    assert [f"lab{n}" for n in notebooks] == list(lab_names())
    assert release.check_release(ROOT / "solutions", ROOT / "labs") == []


def readme_blocks() -> dict[str, str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("### Adding an exercise", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```(\w+)\n(.*?)```", section, re.S)
    return {kind: code for kind, code in blocks}


def test_the_readme_example_of_adding_an_exercise_releases_and_grades(tmp_path):
    """The README's spec entry and notebook cells, as a lab of their own: release accepts
    them, the released cell raises NotImplementedError, the solution earns every point, and
    the mistake its diagnostic describes gets that hint."""
    blocks = readme_blocks()
    assert set(blocks) >= {"python", "ipynb"}, "the README shows the spec and the cells"
    namespace: dict = {}
    exec("from grader.spec import Case, Diagnostic, Exercise\n" + blocks["python"], namespace)
    (exercise,) = [v for v in namespace.values() if isinstance(v, Exercise)]
    lab = LabSpec("lab01", "the README's example", (exercise,))
    cells = [c.strip("\n") for c in blocks["ipynb"].split("\n# ---\n")]
    folder = tmp_path / "solutions"
    folder.mkdir()
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell('from grader import checker\ncheck = checker("lab01")')]
    nb.cells += [nbformat.v4.new_code_cell(c) for c in cells]
    nbformat.write(nb, folder / "01-example.ipynb")
    (released,) = release.release(folder, tmp_path / "labs", {"lab01": lab})
    stub = next(c for c in nbformat.read(released, as_version=4).cells
                if f"def {exercise.function}(" in c.source)
    assert "raise NotImplementedError()" in stub.source
    result = grade_notebook(folder / "01-example.ipynb", lab)
    assert result.total == exercise.points and result.cell_errors == [], result.exercises
    (mistake,) = exercise.diagnostics
    tree = ast.parse(blocks["python"])
    wrong_def = next(n for n in tree.body if isinstance(n, ast.FunctionDef)
                     and n.name == mistake.wrong.__name__)
    wrong_def.name = exercise.function
    solution = next(c for c in nb.cells if f"def {exercise.function}(" in c.source)
    solution.source = ast.unparse(wrong_def)
    nbformat.write(nb, tmp_path / "wrong.ipynb")
    wrong = grade_notebook(tmp_path / "wrong.ipynb", lab).exercises[exercise.id]
    assert wrong.points == 0 and mistake.hint in wrong.reason, wrong.reason
