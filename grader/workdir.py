"""The students' working copies: ``make lab`` and ``make reset LAB=NN``.

``labs/`` stays the pristine release; students work in a git-ignored ``work/``.
:func:`copy_new` copies every released file that ``work/`` does not have yet and never
overwrites one (the same on every system, unlike ``cp -n``, whose exit status differs between
coreutils versions). :func:`reset_lab` gives one lab back fresh and keeps the student's file
beside it, renamed with the time of the reset.

    python -m grader.workdir copy              # labs/ → work/, keeping what is there
    python -m grader.workdir reset 01          # a fresh work/01-*.ipynb, the old one kept
"""

from __future__ import annotations

import argparse
import shutil
import sys
from datetime import datetime
from pathlib import Path

__all__ = ["WorkdirError", "copy_new", "main", "reset_lab"]


class WorkdirError(ValueError):
    """A lab that does not exist, or a source folder that is missing."""


def copy_new(source: Path, dest: Path) -> list[Path]:
    """Copy every file under ``source`` to the same place under ``dest`` unless it exists.

    Returns the files written. Files already in ``dest`` are left exactly as they are.
    """
    if not source.is_dir():
        raise WorkdirError(f"{source} is not a folder of released labs")
    written = []
    for path in sorted(source.rglob("*")):
        if not path.is_file() or ".ipynb_checkpoints" in path.parts:
            continue
        target = dest / path.relative_to(source)
        if target.exists():
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(path, target)
        written.append(target)
    return written


def _released(source: Path, lab: str) -> Path:
    number = lab.lower().removeprefix("lab")
    if not number.isdigit():
        raise WorkdirError(f"a lab is a number such as 01; got {lab!r}")
    matches = sorted(source.glob(f"{int(number):02d}-*.ipynb"))
    if not matches:
        available = ", ".join(p.name for p in sorted(source.glob("[0-9][0-9]-*.ipynb")))
        raise WorkdirError(f"no lab {int(number):02d} in {source}; the labs: {available}")
    return matches[0]


def reset_lab(lab: str, source: Path, dest: Path, now: datetime | None = None
              ) -> tuple[Path, Path | None]:
    """A fresh copy of lab ``lab`` (``"01"``, ``"1"`` or ``"lab01"``) in ``dest``.

    The student's file, if any, is renamed to ``NN-name.before-reset-YYYYmmdd-HHMMSS.ipynb``
    first: nothing is lost. Returns (the fresh file, the kept one or ``None``).
    """
    released = _released(source, lab)
    target = dest / released.name
    kept = None
    if target.exists():
        stamp = (now or datetime.now()).strftime("%Y%m%d-%H%M%S")
        kept = target.with_name(f"{target.stem}.before-reset-{stamp}{target.suffix}")
        counter = 1
        while kept.exists():
            kept = target.with_name(f"{target.stem}.before-reset-{stamp}-{counter}"
                                    f"{target.suffix}")
            counter += 1
        target.rename(kept)
    dest.mkdir(parents=True, exist_ok=True)
    shutil.copy2(released, target)
    return target, kept


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m grader.workdir",
                                     description="Students' working copies of the labs.")
    parser.add_argument("--labs", type=Path, default=Path("labs"), help="the released labs")
    parser.add_argument("--work", type=Path, default=Path("work"), help="the working copies")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("copy", help="copy released labs that work/ does not have yet")
    reset = sub.add_parser("reset", help="a fresh copy of one lab, the old file kept")
    reset.add_argument("lab", help="the lab's number, e.g. 01")
    args = parser.parse_args(argv)
    try:
        if args.command == "copy":
            written = copy_new(args.labs, args.work)
            print(f"{len(written)} new file(s) in {args.work}/; files already there are kept")
        else:
            fresh, kept = reset_lab(args.lab, args.labs, args.work)
            print(f"fresh copy: {fresh}" + (f"; your previous file is {kept}" if kept else ""))
    except WorkdirError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
