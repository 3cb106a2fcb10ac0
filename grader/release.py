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

Release checks itself against the lab's spec (``grader/labs/labNN.py``) before writing
anything: a solution cell whose function no exercise names, an exercise with no solution cell,
a ``check(...)`` of no exercise, or a notebook with solution cells and no spec at all is a
:class:`ReleaseError` naming the cell and the spec entry.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

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
                     lab: str | None = None, spec: Any | None = None) -> nbformat.NotebookNode:
    """The student version of one solution notebook (a new object)."""
    student = copy.deepcopy(nb)
    points: dict[str, float] = {}
    if lab is not None:
        if spec is None:
            from grader.spec import load_lab

            spec = load_lab(lab)
        points = {ex.function: ex.points for ex in spec.exercises}
    for index, cell in enumerate(student.cells):
        where = f"{name}, cell {index + 1}"
        if lab is not None:
            cell.metadata["nbgrader"] = nbgrader_metadata(cell, index, points, lab)
        cell.metadata.pop("execution", None)  # the instructor's run's timings
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


def _first_line(source: str) -> str:
    line = next((ln.strip() for ln in source.splitlines() if ln.strip()), "")
    return line if len(line) <= 60 else line[:59] + "…"


def spec_problems(nb: nbformat.NotebookNode, name: str, lab: str, spec: Any | None) -> list[str]:
    """Where notebook ``name`` and the spec of ``lab`` disagree (empty: they match)."""
    where = f"grader/labs/{lab}.py"
    cells = [(i, c) for i, c in enumerate(nb.cells, start=1) if c.cell_type == "code"]
    solution_cells = [(i, c) for i, c in cells if BEGIN in c.source]
    if spec is None:
        return [f"{name} has {len(solution_cells)} solution cells but {where} does not exist: "
                f"add the lab's spec"] if solution_cells else []
    functions = {ex.function: ex for ex in spec.exercises}
    problems, defined = [], set()
    for i, cell in solution_cells:
        found = DEFINES.findall(cell.source)
        function = found[0] if found else None
        defined.add(function)
        if function not in functions:
            problems.append(f"{name} cell {i} (`{_first_line(cell.source)}`) is a solution cell, "
                            f"but {where} has no exercise whose function is {function!r}")
    for ex in spec.exercises:
        if ex.function not in defined:
            problems.append(f"{where}: exercise {ex.id} (function {ex.function!r}) has no "
                            f"solution cell in {name}")
    for i, cell in cells:
        for match in CHECK_CELL.finditer(cell.source):
            exercise = match.group(2) or match.group(1)
            if exercise not in functions:
                problems.append(f"{name} cell {i} (`{_first_line(cell.source)}`) checks "
                                f"{exercise!r}, which is no exercise of {where}")
    return problems


def _specs(specs: Mapping[str, Any] | None) -> Mapping[str, Any]:
    if specs is not None:
        return specs
    from grader.spec import lab_names, load_lab

    return {lab: load_lab(lab) for lab in lab_names()}


def _checked(src: Path, specs: Mapping[str, Any]) -> tuple[nbformat.NotebookNode, str]:
    nb = nbformat.read(src, as_version=4)
    lab = f"lab{src.name[:2]}"
    problems = spec_problems(nb, str(src), lab, specs.get(lab))
    if problems:
        raise ReleaseError("\n".join(problems))
    return nb, lab


def release(solutions: Path, labs: Path, specs: Mapping[str, Any] | None = None) -> list[Path]:
    """Write the student version of every ``NN-*.ipynb`` of ``solutions`` into ``labs``,
    after checking every notebook against its spec (``specs``: lab name → spec, for tests;
    by default the specs in ``grader/labs/``)."""
    sources = _lab_notebooks(solutions)
    if not sources:
        raise ReleaseError(f"{solutions}: no lab notebooks (NN-name.ipynb) to release")
    known = _specs(specs)
    checked = [(src, *_checked(src, known)) for src in sources]  # all checked, then written
    labs.mkdir(parents=True, exist_ok=True)
    written = []
    for src, nb, lab in checked:
        out = labs / src.name
        nbformat.write(release_notebook(nb, src.name, lab if lab in known else None,
                                        known.get(lab)), out)
        written.append(out)
    return written


def check_release(solutions: Path, labs: Path, specs: Mapping[str, Any] | None = None
                  ) -> list[str]:
    """What differs between ``labs`` and a fresh release of ``solutions``, and where a solution
    notebook and its spec disagree (empty: up to date)."""
    problems = []
    known = _specs(specs)
    expected_names = {p.name for p in _lab_notebooks(solutions)}
    for src in _lab_notebooks(solutions):
        nb = nbformat.read(src, as_version=4)
        lab = f"lab{src.name[:2]}"
        mismatch = spec_problems(nb, str(src), lab, known.get(lab))
        problems += mismatch
        target = labs / src.name
        if mismatch:
            continue
        if not target.exists():
            problems.append(f"{target} is missing: run `grader release`")
            continue
        fresh = nbformat.writes(release_notebook(nb, src.name, lab if lab in known else None,
                                                 known.get(lab)))
        if fresh != nbformat.writes(nbformat.read(target, as_version=4)):
            problems.append(f"{target} is out of date with {src}: run `grader release`")
    for extra in _lab_notebooks(labs):
        if extra.name not in expected_names:
            problems.append(f"{extra} has no solution notebook")
    return problems
