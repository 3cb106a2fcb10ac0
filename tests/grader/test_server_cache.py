"""A grading server belongs to one spec object. Its submissions' processes lose the modules of
*its* spec's references, so a spec of the same name (a course's own lab01, an exercise being
written, as the README's example is graded in tests/grader/test_release.py) must never lend
its server to the shipped lab: a submission that imports the kit's reference would then be
graded against itself and earn every point."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import nbformat

from grader.grade import grade_notebook, server_for
from grader.sandbox import Limits, detect_layer
from grader.spec import LabSpec, load_lab


def _notebook(path: Path, source: str) -> Path:
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("# my lab"), nbformat.v4.new_code_cell(source)]
    nbformat.write(nb, path)
    return path


def test_a_spec_of_the_same_name_never_lends_its_server_to_the_shipped_lab(tmp_path):
    shipped = load_lab("lab01")
    exercise = next(e for e in shipped.exercises if e.function == "turning_radius")
    assert exercise.blocked  # the shipped lab hides the kit's reference from submissions
    own = LabSpec("lab01", "a course's own lab01", (dataclasses.replace(exercise, blocked=()),))
    layer = detect_layer()
    copying = _notebook(tmp_path / "copying.ipynb", "from kit.kinematics import turning_radius")
    # the course's own lab01 first: it hides nothing of the kit from its submissions
    mine = grade_notebook(copying, own, layer=layer).exercises[exercise.id]
    assert mine.points == exercise.points, mine.reason  # its spec allows it
    graded = grade_notebook(copying, shipped, layer=layer).exercises[exercise.id]
    assert graded.points == 0 and "does not exist while lab01 is graded" in graded.reason, \
        graded.reason
    limits = Limits()
    assert server_for(own, layer, limits) is not server_for(shipped, layer, limits)
    assert server_for(shipped, layer, limits).spec is shipped
    # a server given by hand must be the spec's own: otherwise a grader error, not a grade
    lent = grade_notebook(copying, shipped, layer=layer, server=server_for(own, layer, limits))
    assert lent.status == "grader error" and "another lab01 spec" in lent.reason, lent.reason
