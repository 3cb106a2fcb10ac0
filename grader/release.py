"""``grader release``: instructor notebooks (``solutions/``) → student notebooks (``labs/``).

Code between ``### BEGIN SOLUTION`` and ``### END SOLUTION`` (the nbgrader/otter markers) is
replaced, at the same indentation, by ``# YOUR CODE HERE`` and ``raise NotImplementedError()``
— exactly what nbgrader's ``generate_assignment`` writes. Outputs and execution counts are
cleared. Markdown between ``<!-- BEGIN SOLUTION -->`` and ``<!-- END SOLUTION -->`` becomes
``YOUR ANSWER HERE``.

Cells also get nbgrader's metadata (schema 3), so a course already on nbgrader can import the
labs: an exercise cell is a solution cell (``grade_id`` = the exercise id), a ``check(fn)``
cell is an autograded test cell with the exercise's points (under nbgrader's autograder,
``check`` raises when a case fails, which is how nbgrader scores), every other cell is
locked.
"""

from __future__ import annotations

import copy
import re
from pathlib import Path

import nbformat

__all__ = ["ReleaseError", "check_release", "release", "release_notebook", "strip_solutions"]

BEGIN, END = "### BEGIN SOLUTION", "### END SOLUTION"
MD_BEGIN, MD_END = "<!-- BEGIN SOLUTION -->", "<!-- END SOLUTION -->"


class ReleaseError(ValueError):
    """A solution notebook whose markers do not pair up; the message names cell and line."""


def _strip(source: str, begin: str, end: str, replacement: list[str], where: str) -> str:
    out: list[str] = []
    inside = False
    for number, line in enumerate(source.split("\n"), start=1):
        marker = line.strip()
        if marker == begin:
            if inside:
                raise ReleaseError(f"{where}, line {number}: {begin} inside another solution")
            inside = True
            indent = line[: len(line) - len(line.lstrip())]
            out.extend(indent + r for r in replacement)
        elif marker == end:
            if not inside:
                raise ReleaseError(f"{where}, line {number}: {end} without {begin}")
            inside = False
        elif not inside:
            out.append(line)
    if inside:
        raise ReleaseError(f"{where}: {begin} is never closed by {end}")
    return "\n".join(out)


def strip_solutions(source: str, where: str = "cell") -> str:
    """Replace every solution region of a code cell's source."""
    return _strip(source, BEGIN, END, ["# YOUR CODE HERE", "raise NotImplementedError()"], where)


CHECK_CELL = re.compile(r"^check\((\w+)(?:,\s*exercise=\"(\w+)\")?\)", re.MULTILINE)
DEFINES = re.compile(r"^def (\w+)\(", re.MULTILINE)


def nbgrader_metadata(cell: nbformat.NotebookNode, index: int,
                      points: dict[str, float], lab: str) -> dict[str, object]:
    """nbgrader's cell metadata for one solution-notebook cell."""
    base: dict[str, object] = {"schema_version": 3, "grade": False, "solution": False,
                               "locked": True, "grade_id": f"cell-{index:02d}"}
    if cell.cell_type != "code":
        return base
    source = cell.source
    if BEGIN in source:
        defined = DEFINES.findall(source)
        name = defined[0] if defined else f"cell-{index:02d}"
        return {**base, "solution": True, "locked": False, "grade_id": f"{lab}.{name}"}
    match = CHECK_CELL.search(source)
    if match:
        exercise = match.group(2) or match.group(1)
        if exercise in points and match.group(2) is None:
            return {**base, "grade": True, "points": points[exercise],
                    "grade_id": f"{lab}.{exercise}-check"}
    return base


def release_notebook(nb: nbformat.NotebookNode, name: str = "notebook",
                     lab: str | None = None) -> nbformat.NotebookNode:
    """The student version of one solution notebook (a new object)."""
    student = copy.deepcopy(nb)
    points: dict[str, float] = {}
    if lab is not None:
        from grader.spec import load_lab

        points = {ex.function: ex.points for ex in load_lab(lab).exercises}
    for index, cell in enumerate(student.cells):
        where = f"{name}, cell {index}"
        if lab is not None:
            cell.metadata["nbgrader"] = nbgrader_metadata(cell, index, points, lab)
        if cell.cell_type == "code":
            cell.source = strip_solutions(cell.source, where)
            cell.outputs = []
            cell.execution_count = None
        elif cell.cell_type == "markdown":
            cell.source = _strip(cell.source, MD_BEGIN, MD_END, ["YOUR ANSWER HERE"], where)
    return student


def _lab_of(path: Path) -> str | None:
    from grader.spec import lab_names

    name = f"lab{path.name[:2]}"
    return name if name in lab_names() else None


def _lab_notebooks(folder: Path) -> list[Path]:
    return sorted(p for p in folder.glob("[0-9][0-9]-*.ipynb"))


def release(solutions: Path, labs: Path) -> list[Path]:
    """Write the student version of every ``NN-*.ipynb`` of ``solutions`` into ``labs``."""
    sources = _lab_notebooks(solutions)
    if not sources:
        raise ReleaseError(f"{solutions}: no lab notebooks (NN-name.ipynb) to release")
    labs.mkdir(parents=True, exist_ok=True)
    written = []
    for src in sources:
        nb = nbformat.read(src, as_version=4)
        out = labs / src.name
        nbformat.write(release_notebook(nb, src.name, _lab_of(src)), out)
        written.append(out)
    return written


def check_release(solutions: Path, labs: Path) -> list[str]:
    """What differs between ``labs`` and a fresh release of ``solutions`` (empty: up to date)."""
    problems = []
    expected_names = {p.name for p in _lab_notebooks(solutions)}
    for src in _lab_notebooks(solutions):
        target = labs / src.name
        if not target.exists():
            problems.append(f"{target} is missing: run `grader release`")
            continue
        fresh = nbformat.writes(release_notebook(nbformat.read(src, as_version=4), src.name,
                                                 _lab_of(src)))
        if fresh != nbformat.writes(nbformat.read(target, as_version=4)):
            problems.append(f"{target} is out of date with {src}: run `grader release`")
    for extra in _lab_notebooks(labs):
        if extra.name not in expected_names:
            problems.append(f"{extra} has no solution notebook")
    return problems
