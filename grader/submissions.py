"""Which notebooks a grading run grades, and whose they are.

``grader grade SUBMISSION... --lab NN`` takes notebooks and folders. In a folder:

* a notebook directly inside (``alice.ipynb``) is one student's, named by the file;
* a notebook in a sub-folder (``alice/01-kinematics.ipynb``, ``alice/work/lab.ipynb``) belongs
  to the student the top sub-folder names, and only the notebook *of the lab being graded*
  counts: its file name starts with the lab's number (``01-``), or — without such a prefix —
  its cells say which lab it is (nbgrader ids ``lab01.…`` or a ``checker("lab01")`` call).
  The student's other labs are listed as skipped.

A notebook given by name is graded under its folder's name when its file name carries the
lab's number, else under its own name. A notebook whose name or cells say it is another lab
is skipped, wherever it is. The metadata ``{"kit": {"student": "..."}}`` names the student
outright. Student ids are NFC-normalised (``Zoë`` typed on a Mac and on Linux are one
student), and two notebooks for one student are an error that names both.
"""

from __future__ import annotations

import hashlib
import re
import unicodedata
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import nbformat

__all__ = ["Found", "Notebook", "Submission", "find_submissions", "lab_of_name",
           "normalise_student", "read_notebook", "student_id"]

PREFIX = re.compile(r"^(\d{2})-")
GRADE_ID = re.compile(r"^(lab\d{2})\.")
CHECKER = re.compile(r"""checker\(\s*["']?(?:lab)?(\d{1,2})["']?\s*\)""")


def normalise_student(text: str) -> str:
    """The id a student is graded and filed under: NFC, surrounding blanks removed."""
    return unicodedata.normalize("NFC", text).strip()


def lab_of_name(path: Path) -> str | None:
    """``01-kinematics.ipynb`` → ``lab01``; no number prefix → ``None``."""
    match = PREFIX.match(path.name)
    return f"lab{match.group(1)}" if match else None


def student_id(path: Path, lab: str) -> str:
    """``alice.ipynb`` → alice; ``alice/01-kinematics.ipynb`` → alice (lab01)."""
    if lab_of_name(path) == lab and path.parent.name:
        return normalise_student(path.parent.name)
    return normalise_student(path.stem)


@dataclass(frozen=True)
class Notebook:
    """A submitted notebook as read: its code cells with the positions a student sees."""

    path: Path
    text: str
    sha256: str
    cells: tuple[dict[str, Any], ...]
    """code cells: ``source``, ``position`` (1-based, among all cells), ``first_line``."""
    student: str | None
    """from the notebook's ``kit.student`` metadata."""
    lab: str | None
    """which lab its cells say it is."""


def _first_line(source: str) -> str:
    line = next((ln.strip() for ln in source.splitlines() if ln.strip()), "")
    return line if len(line) <= 60 else line[:59] + "…"


def _lab_of_cells(nb: Any) -> str | None:
    labs = set()
    for cell in nb.cells:
        grade_id = cell.get("metadata", {}).get("nbgrader", {}).get("grade_id", "")
        match = GRADE_ID.match(str(grade_id))
        if match:
            labs.add(match.group(1))
        if cell.cell_type == "code":
            labs |= {f"lab{int(m):02d}" for m in CHECKER.findall(cell.source)}
    return labs.pop() if len(labs) == 1 else None


def read_notebook(path: Path) -> Notebook:
    """Read a submission; ``ValueError`` says why a notebook cannot be read."""
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    try:
        nb = nbformat.reads(text, as_version=4)
    except Exception as exc:  # nbformat raises several types for bad JSON and bad schema
        raise ValueError(f"{type(exc).__name__}: {str(exc)[:200]}") from None
    kit_meta = nb.metadata.get("kit")
    named = kit_meta.get("student") if isinstance(kit_meta, dict) else None
    cells = tuple({"source": c.source, "position": i, "first_line": _first_line(c.source)}
                  for i, c in enumerate(nb.cells, start=1) if c.cell_type == "code")
    return Notebook(path, text, hashlib.sha256(raw).hexdigest(), cells,
                    normalise_student(str(named)) if named else None, _lab_of_cells(nb))


@dataclass(frozen=True)
class Submission:
    student: str
    path: Path


@dataclass
class Found:
    submissions: list[Submission] = field(default_factory=list)
    skipped: list[tuple[Path, str]] = field(default_factory=list)
    """notebooks not graded, and why."""


def _peek(path: Path) -> Notebook | None:
    try:
        return read_notebook(path)
    except (OSError, ValueError):
        return None  # graded anyway: its row will say it is malformed


def _consider(found: Found, path: Path, lab: str, student: str, in_student_folder: bool) -> None:
    by_name = lab_of_name(path)
    nb = _peek(path)
    by_cells = nb.lab if nb is not None else None
    if by_name is not None and by_name != lab:
        found.skipped.append((path, f"its name says {by_name}"))
    elif by_name is None and by_cells is not None and by_cells != lab:
        found.skipped.append((path, f"its cells are {by_cells}'s"))
    elif in_student_folder and by_name is None and by_cells is None:
        found.skipped.append((path, f"neither its name nor its cells say it is {lab}"))
    else:
        named = nb.student if nb is not None else None
        found.submissions.append(Submission(named or student, path))


def _notebooks(folder: Path) -> list[Path]:
    return sorted(q for q in folder.rglob("*.ipynb") if ".ipynb_checkpoints" not in q.parts)


def find_submissions(paths: Sequence[Path], lab: str) -> Found:
    """The notebooks to grade for ``lab`` and their students (see the module's rules).

    Raises ``FileNotFoundError`` for a path that does not exist and ``ValueError`` when two
    notebooks belong to one student.
    """
    found = Found()
    for p in paths:
        if p.is_dir():
            for q in _notebooks(p):
                relative = q.relative_to(p)
                if len(relative.parts) == 1:
                    _consider(found, q, lab, student_id(q, lab) if lab_of_name(q) != lab
                              else normalise_student(p.resolve().name), False)
                else:
                    _consider(found, q, lab, normalise_student(relative.parts[0]), True)
        elif p.exists():
            _consider(found, p, lab, student_id(p, lab), False)
        else:
            raise FileNotFoundError(f"{p}: no such submission")
    _refuse_duplicates(found.submissions)
    return found


def _refuse_duplicates(submissions: list[Submission]) -> None:
    seen: dict[str, list[Path]] = {}
    for s in submissions:
        seen.setdefault(s.student, []).append(s.path)
    clashes = {k: v for k, v in seen.items() if len(v) > 1}
    if clashes:
        lines = [f"  {student}: {', '.join(str(p) for p in clashes[student])}"
                 for student in sorted(clashes)]
        raise ValueError("more than one notebook for one student (remove all but one, or "
                         "name the student in each notebook's kit.student metadata):\n"
                         + "\n".join(lines))
