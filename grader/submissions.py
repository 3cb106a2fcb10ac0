"""Which notebooks a grading run grades, whose they are, and reading them safely.

``grader grade SUBMISSION... --lab NN`` takes notebooks and folders. In a folder:

* a notebook directly inside (``alice.ipynb``) is one student's, named by the file;
* a notebook in a sub-folder (``alice/01-kinematics.ipynb``, ``alice/work/lab.ipynb``) belongs
  to the student the top sub-folder names, and only the notebook *of the lab being graded*
  counts: its file name starts with the lab's number (``01-``), or — without such a prefix —
  its cells say which lab it is (nbgrader ids ``lab01.…`` or a ``checker("lab01")`` call).
  The student's other labs are listed as skipped.

**The student is named by where the instructor put the file**, never by what the notebook
says: a notebook's ``{"kit": {"student": "..."}}`` metadata is only compared with that name,
and a mismatch is noted on the file's own row. Student ids are NFC-normalised (``Zoë`` typed on
a Mac and on Linux are one student). Two notebooks of the lab for one student are that
student's row (``duplicate``), naming both; the rest of the class is graded.

**The grader reads only regular files inside the folders it was given**: the walk never
follows a link; a symbolic link, a hard link to a file outside the submissions, a device, a
FIFO or a socket that would be a submission is refused on its student's row (``refused``),
and nothing of what it points to is ever opened or quoted. A notebook is opened without
following links and checked to be a regular file on the open descriptor itself. Names that are
not UTF-8, text that is not UTF-8, JSON that is not a notebook and strings holding lone
surrogates are that student's row (``malformed notebook``), with a reason that quotes nothing
of the file but positions and escaped names.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import stat
import unicodedata
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["MAX_NOTEBOOK_BYTES", "Found", "Notebook", "Submission", "SubmissionError",
           "clean_text", "digest", "find_submissions", "lab_of_name", "normalise_student",
           "one_row_per_student", "read_notebook", "student_id"]

PREFIX = re.compile(r"^(\d{2})-")
GRADE_ID = re.compile(r"^(lab\d{2})\.")
CHECKER = re.compile(r"""checker\(\s*["']?(?:lab)?(\d{1,2})["']?\s*\)""")
MAX_NOTEBOOK_BYTES = 64 * 1024 * 1024
SURROGATE = re.compile("[\ud800-\udfff]")


class SubmissionError(ValueError):
    """A submission that cannot be graded: ``status`` is ``malformed notebook`` or
    ``refused``; the message quotes nothing of the file."""

    def __init__(self, status: str, reason: str) -> None:
        super().__init__(reason)
        self.status = status


def clean_text(text: str) -> str:
    """``text`` with every lone surrogate written as its escape (``\\ud800``): what the
    gradebook, the JSON, the feedback and the terminal can always hold."""
    return SURROGATE.sub(lambda m: f"\\u{ord(m.group()):04x}", text)


def normalise_student(text: str) -> str:
    """The id a student is graded and filed under: NFC, surrounding blanks removed; a name
    that is not UTF-8 (the file system's bytes, decoded with ``surrogateescape``) keeps its
    bytes as escapes (``caf\xe9``)."""
    if SURROGATE.search(text):
        try:
            text = os.fsencode(text).decode("utf-8", "backslashreplace")
        except UnicodeEncodeError:
            pass
    return unicodedata.normalize("NFC", clean_text(text)).strip()


def _name_problem(name: str) -> str:
    """Why a file or folder name (as the file system gave it) is not text, or ``""``."""
    if SURROGATE.search(name):
        raw = os.fsencode(name)
        return f"its name is not UTF-8 text ({raw!r})"
    return ""


def lab_of_name(path: Path) -> str | None:
    """``01-kinematics.ipynb`` → ``lab01``; no number prefix → ``None``."""
    match = PREFIX.match(path.name)
    return f"lab{match.group(1)}" if match else None


def student_id(path: Path, lab: str) -> str:
    """``alice.ipynb`` → alice; ``alice/01-kinematics.ipynb`` → alice (lab01)."""
    if lab_of_name(path) == lab and path.parent.name:
        return normalise_student(path.parent.name)
    return normalise_student(path.stem)


# ------------------------------------------------------------------ reading one notebook

@dataclass(frozen=True)
class Notebook:
    """A submitted notebook as read: its code cells with the positions a student sees."""

    path: Path
    text: str
    sha256: str
    cells: tuple[dict[str, Any], ...]
    """code cells: ``source``, ``position`` (1-based, among all cells), ``first_line`` and
    ``mode`` — ``run`` for exercise cells and cells the student added (every cell of a
    notebook without the release's cell metadata), ``setup`` for the setup cell (statement by
    statement), ``definitions`` for the lab's other cells (their imports, functions and
    constants only)."""
    student: str | None
    """who the notebook's ``kit.student`` metadata claims it is (only ever compared)."""
    lab: str | None
    """which lab its cells say it is."""


def _first_line(source: str) -> str:
    line = next((ln.strip() for ln in source.splitlines() if ln.strip()), "")
    return line if len(line) <= 60 else line[:59] + "…"


def _source(cell: dict[str, Any]) -> str:
    source = cell.get("source", "")
    if isinstance(source, list) and all(isinstance(s, str) for s in source):
        return "".join(source)
    if isinstance(source, str):
        return source
    raise SubmissionError("malformed notebook", "a cell's source is not text")


def _nbgrader(cell: dict[str, Any]) -> dict[str, Any] | None:
    meta = cell.get("metadata")
    nbgrader = meta.get("nbgrader") if isinstance(meta, dict) else None
    return nbgrader if isinstance(nbgrader, dict) else None


def _mode(cell: dict[str, Any], source: str, released: bool) -> str:
    """How the grader runs a cell. The lab's own cells are known by the release's cell
    metadata; in a notebook without any (not made from the release), every cell is the
    student's."""
    nbgrader = _nbgrader(cell)
    if CHECKER.search(source) and not (nbgrader or {}).get("solution"):
        return "setup"
    if not released or nbgrader is None or nbgrader.get("solution"):
        return "run"  # an exercise cell, or a cell the student added
    return "definitions"


def _surrogate_at(value: Any, where: str) -> str | None:
    if isinstance(value, str):
        return where if SURROGATE.search(value) else None
    items = value.items() if isinstance(value, dict) else enumerate(value) \
        if isinstance(value, list) else ()
    for key, item in items:
        if isinstance(key, str) and SURROGATE.search(key):
            return where
        found = _surrogate_at(item, where)
        if found:
            return found
    return None


def _lab_of_cells(cells: list[dict[str, Any]]) -> str | None:
    labs = set()
    for cell in cells:
        meta = cell.get("metadata")
        nbgrader = meta.get("nbgrader", {}) if isinstance(meta, dict) else {}
        grade_id = nbgrader.get("grade_id", "") if isinstance(nbgrader, dict) else ""
        match = GRADE_ID.match(str(grade_id))
        if match:
            labs.add(match.group(1))
        if cell.get("cell_type") == "code":
            labs |= {f"lab{int(m):02d}" for m in CHECKER.findall(_source(cell))}
    return labs.pop() if len(labs) == 1 else None


def _open_regular(path: Path, dir_fd: int | None = None) -> bytes:
    """The bytes of ``path``, opened without following a link and checked on the descriptor
    to be a regular file of a sane size."""
    flags = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(path.name if dir_fd is not None else path, flags, dir_fd=dir_fd)
    except OSError as exc:
        if exc.errno == 40:  # ELOOP: the name is a symbolic link
            raise SubmissionError("refused", "a symbolic link: the grader reads only "
                                  "regular files and never follows a link") from None
        raise SubmissionError("malformed notebook", f"cannot be opened: "
                              f"{exc.strerror}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise SubmissionError("refused", f"{_kind(info.st_mode)}, not a regular file")
        if info.st_size > MAX_NOTEBOOK_BYTES:
            raise SubmissionError("malformed notebook", f"{info.st_size} bytes, more than the "
                                  f"{MAX_NOTEBOOK_BYTES // 2**20} MB a notebook may have")
        chunks, total = [], 0
        while True:
            chunk = os.read(fd, 1 << 20)
            if not chunk:
                break
            total += len(chunk)
            if total > MAX_NOTEBOOK_BYTES:
                raise SubmissionError("malformed notebook", "larger than a notebook may be")
            chunks.append(chunk)
        return b"".join(chunks)
    finally:
        os.close(fd)


def _kind(mode: int) -> str:
    for test, word in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"),
                       (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISLNK, "a symbolic link")):
        if test(mode):
            return word
    return "not a regular file"


def parse_notebook(raw: bytes, path: Path) -> Notebook:
    """A notebook from its bytes; :class:`SubmissionError` says why not, quoting nothing."""
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SubmissionError("malformed notebook", f"not UTF-8 text ({exc.reason} at byte "
                              f"{exc.start})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise SubmissionError("malformed notebook", f"not JSON (line {exc.lineno}, column "
                              f"{exc.colno}: {exc.msg})") from None
    except RecursionError:
        raise SubmissionError("malformed notebook", "JSON nested too deeply") from None
    if not isinstance(data, dict) or not isinstance(data.get("cells"), list) \
            or not all(isinstance(c, dict) for c in data["cells"]):
        raise SubmissionError("malformed notebook", "JSON, but not a notebook (no list of "
                              "cells)")
    if data.get("nbformat") != 4:
        raise SubmissionError("malformed notebook", f"notebook format "
                              f"{clean_text(str(data.get('nbformat')))[:20]}; the kit reads "
                              f"format 4")
    for position, cell in enumerate(data["cells"], start=1):
        if _surrogate_at(cell, f"cell {position}"):
            raise SubmissionError("malformed notebook", f"cell {position} holds a lone "
                                  f"surrogate (an escape like \\ud800 that is not Unicode text)")
    if _surrogate_at({k: v for k, v in data.items() if k != "cells"}, "metadata"):
        raise SubmissionError("malformed notebook", "its metadata holds a lone surrogate (an "
                              "escape like \\ud800 that is not Unicode text)")
    released = any(_nbgrader(c) is not None for c in data["cells"])
    cells = tuple({"source": _source(c), "position": i, "first_line": _first_line(_source(c)),
                   "mode": _mode(c, _source(c), released)}
                  for i, c in enumerate(data["cells"], start=1) if c.get("cell_type") == "code")
    meta = data.get("metadata")
    kit_meta = meta.get("kit") if isinstance(meta, dict) else None
    named = kit_meta.get("student") if isinstance(kit_meta, dict) else None
    return Notebook(path, text, hashlib.sha256(raw).hexdigest(), cells,
                    normalise_student(str(named)) if named else None,
                    _lab_of_cells(data["cells"]))


def read_notebook(path: Path, dir_fd: int | None = None) -> Notebook:
    """Read a submission (never through a link); :class:`SubmissionError` says why not."""
    problem = _name_problem(path.name)
    if problem:
        raise SubmissionError("malformed notebook", problem)
    return parse_notebook(_open_regular(path, dir_fd), path)


def digest(path: Path) -> str:
    """SHA-256 of a submission's bytes (read as :func:`read_notebook` reads), or ``""``."""
    try:
        return hashlib.sha256(_open_regular(path)).hexdigest()
    except SubmissionError:
        return ""


# ------------------------------------------------------------------ finding them

@dataclass(frozen=True)
class Submission:
    student: str
    path: Path
    status: str = ""
    """``""``: to be graded; else the row's status (``refused``, ``duplicate``,
    ``malformed notebook``) with ``reason``."""
    reason: str = ""


@dataclass
class Found:
    submissions: list[Submission] = field(default_factory=list)
    skipped: list[tuple[Path, str]] = field(default_factory=list)
    """notebooks not graded, and why."""


@dataclass
class _Entry:
    path: Path
    student: str
    in_student_folder: bool
    problem: tuple[str, str] | None = None
    notebook: Notebook | None = None
    info: os.stat_result | None = None


def _walk(folder: Path, parts: tuple[str, ...] = ()) -> Iterator[tuple[Path, tuple[str, ...],
                                                                         os.DirEntry[str]]]:
    """Every entry under ``folder``, depth first, never following a link."""
    try:
        entries = sorted(os.scandir(folder), key=lambda e: e.name)
    except OSError:
        return
    for entry in entries:
        if entry.name == ".ipynb_checkpoints":
            continue
        yield folder / entry.name, (*parts, entry.name), entry
        if entry.is_dir(follow_symlinks=False):
            yield from _walk(folder / entry.name, (*parts, entry.name))


def _candidate(entry: os.DirEntry[str], depth: int) -> bool:
    """Whether an entry would be a submission: a notebook's name, or a student's folder that
    is not a real folder."""
    if entry.name.endswith(".ipynb"):
        return True
    return depth == 1 and entry.is_symlink()


def _entries(root: Path) -> list[_Entry]:
    found: list[_Entry] = []
    seen: dict[tuple[int, int], int] = {}
    for path, parts, entry in _walk(root):
        if not _candidate(entry, len(parts)):
            continue
        try:
            info = entry.stat(follow_symlinks=False)
        except OSError:
            continue
        student = normalise_student(parts[0] if len(parts) > 1 else Path(parts[0]).stem)
        item = _Entry(path, student, len(parts) > 1, info=info)
        name_problem = _name_problem(parts[0]) or _name_problem(entry.name)
        if name_problem:
            item.problem = ("malformed notebook", name_problem)
        elif stat.S_ISLNK(info.st_mode):
            item.problem = ("refused", f"{_shown(root, path)} is a symbolic link: the grader "
                            f"reads only regular files and never follows a link")
        elif not stat.S_ISREG(info.st_mode):
            item.problem = ("refused", f"{_shown(root, path)} is {_kind(info.st_mode)}, not a "
                            f"regular file")
        else:
            key = (info.st_dev, info.st_ino)
            seen[key] = seen.get(key, 0) + 1
        found.append(item)
    for item in found:
        linked = item.info
        if item.problem is None and linked is not None and \
                linked.st_nlink > seen.get((linked.st_dev, linked.st_ino), 0):
            item.problem = ("refused", f"{_shown(root, item.path)} is a hard link to a file "
                            f"outside the submissions: the grader reads only what is inside")
    return found


def _shown(root: Path, path: Path) -> str:
    try:
        return clean_text(str(path.relative_to(root.parent)))
    except ValueError:
        return clean_text(str(path))


def _classify(item: _Entry, lab: str, found: Found) -> Submission | None:
    by_name = lab_of_name(item.path)
    if item.problem is not None:
        if by_name is not None and by_name != lab:
            found.skipped.append((item.path, f"its name says {by_name}"))
            return None
        if item.in_student_folder and by_name is None and item.path.suffix == ".ipynb":
            found.skipped.append((item.path, f"not read ({item.problem[1]}), and its name "
                                  f"does not say it is {lab}"))
            return None
        return Submission(item.student, item.path, *item.problem)
    try:
        item.notebook = read_notebook(item.path)
    except SubmissionError as exc:
        if by_name is not None and by_name != lab:
            found.skipped.append((item.path, f"its name says {by_name}"))
            return None
        if item.in_student_folder and by_name is None:
            found.skipped.append((item.path, f"its name does not say it is {lab}, and it "
                                  f"cannot be read"))
            return None
        return Submission(item.student, item.path, exc.status, str(exc))
    by_cells = item.notebook.lab
    if by_name is not None and by_name != lab:
        found.skipped.append((item.path, f"its name says {by_name}"))
    elif by_name is None and by_cells is not None and by_cells != lab:
        found.skipped.append((item.path, f"its cells are {by_cells}'s"))
    elif item.in_student_folder and by_name is None and by_cells is None:
        found.skipped.append((item.path, f"neither its name nor its cells say it is {lab}"))
    else:
        return Submission(item.student, item.path)
    return None


def find_submissions(paths: Sequence[Path], lab: str) -> Found:
    """The notebooks to grade for ``lab`` and their students (see the module's rules).

    Raises ``FileNotFoundError`` only for a path the instructor named that does not exist;
    everything about a student's files becomes that student's row.
    """
    found = Found()
    for p in paths:
        if p.is_symlink() and not p.is_dir():
            student = normalise_student(p.stem)
            found.submissions.append(Submission(student, p, "refused", f"{clean_text(p.name)} "
                                                f"is a symbolic link: the grader reads only "
                                                f"regular files and never follows a link"))
        elif p.is_dir():
            for item in _entries(p.resolve()):
                submission = _classify(item, lab, found)
                if submission is not None:
                    found.submissions.append(submission)
        elif p.exists() or os.path.lexists(p):
            item = _Entry(p, student_id(p, lab), False)
            name_problem = _name_problem(p.name)
            if name_problem:
                item.problem = ("malformed notebook", name_problem)
            submission = _classify(item, lab, found)
            if submission is not None:
                found.submissions.append(submission)
        else:
            raise FileNotFoundError(f"{clean_text(str(p))}: no such submission")
    found.submissions = one_row_per_student(found.submissions, lab)
    return found


def one_row_per_student(submissions: list[Submission], lab: str) -> list[Submission]:
    """Two notebooks of the lab for one student become one ``duplicate`` row naming both."""
    by_student: dict[str, list[Submission]] = {}
    for s in submissions:
        by_student.setdefault(s.student, []).append(s)
    out = []
    for student, items in by_student.items():
        if len(items) == 1:
            out.append(items[0])
            continue
        names = ", ".join(clean_text(str(s.path)) for s in items)
        out.append(Submission(student, items[0].path, "duplicate",
                              f"{len(items)} notebooks of {lab} for {student}: {names} — keep "
                              f"one and grade again"))
    return out
