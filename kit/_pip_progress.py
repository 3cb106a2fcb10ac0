"""``pip install`` with a one-line count instead of pip's page of output (the Makefile's
install steps).

``python -m kit._pip_progress "LABEL" -- PIP-INSTALL-ARGUMENTS`` prints ``LABEL``, runs
``python -m pip install ARGUMENTS`` and, on a terminal, keeps one line up to date with what
pip is doing — the packages it has looked at, the ones it is installing — then says how many
it installed and how long it took. Away from a terminal (a CI log) only the label and the
summary are printed. When pip fails, everything it printed is shown and its exit status is
returned, so nothing of an error is lost.

Runs with the standard library alone: the Makefile calls it before the kit's dependencies
are installed (``import kit`` imports nothing).
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TextIO

__all__ = ["Count", "follow", "main", "summary"]

_LOOKED_AT = ("Collecting ", "Requirement already satisfied: ", "Processing ", "Obtaining ")


@dataclass
class Count:
    """What pip reported: packages looked at, packages it installs, the lines it printed."""

    looked_at: int = 0
    installing: list[str] = field(default_factory=list)
    installed: int = 0
    lines: list[str] = field(default_factory=list)


def follow(lines: Iterable[str], out: TextIO, live: bool) -> Count:
    """Read pip's output line by line; on a terminal (``live``) rewrite one status line.

    >>> import io
    >>> pip = ["Collecting numpy", "Requirement already satisfied: tqdm in ./x",
    ...        "Installing collected packages: numpy, robotics-kit",
    ...        "Successfully installed numpy-2.4.6 robotics-kit-0.1.0"]
    >>> c = follow(pip, io.StringIO(), live=False)
    >>> c.looked_at, c.installing, c.installed
    (2, ['numpy', 'robotics-kit'], 2)
    """
    count = Count()
    for raw in lines:
        line = raw.rstrip("\r\n")
        count.lines.append(line)
        status = ""
        if line.startswith(_LOOKED_AT):
            count.looked_at += 1
            status = f"  looked at {count.looked_at} packages"
        elif line.startswith("Installing collected packages: "):
            names = line.split(": ", 1)[1]
            count.installing = [n.strip() for n in names.split(",") if n.strip()]
            status = f"  installing {len(count.installing)} packages ..."
        elif line.startswith("Successfully installed "):
            count.installed = len(line.split()) - 2
        if live and status:
            out.write(f"\r{status:<60s}")
            out.flush()
    if live:
        out.write("\r" + " " * 60 + "\r")
    return count


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 60 else \
        f"{int(seconds // 60)} min {round(seconds % 60):02d} s"


def main(argv: Sequence[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) < 2 or args[1] != "--":
        print("usage: python -m kit._pip_progress LABEL -- PIP-INSTALL-ARGUMENTS",
              file=sys.stderr)
        return 2
    label, pip_args = args[0], args[2:]
    out = sys.stdout
    print(label, flush=True)
    start = time.monotonic()
    with subprocess.Popen([sys.executable, "-m", "pip", "install", *pip_args],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          bufsize=1) as proc:
        assert proc.stdout is not None
        count = follow(proc.stdout, out, live=out.isatty())
    took = _minutes(time.monotonic() - start)
    if proc.returncode != 0:
        print("\n".join(count.lines), file=sys.stderr)
        print(f"  pip failed (exit status {proc.returncode}) after {took}: its output is above",
              file=sys.stderr)
        return proc.returncode
    print(summary(count, took))
    return 0


def summary(count: Count, took: str) -> str:
    """The step's last line.

    >>> summary(Count(looked_at=3, installing=["a"], installed=1), "4 s")
    '  1 packages installed in 4 s (2 already there)'
    >>> summary(Count(looked_at=3), "2 s")
    '  nothing to install (3 packages already there, 2 s)'
    """
    already = count.looked_at - len(count.installing)
    if count.installed:
        return f"  {count.installed} packages installed in {took}" + \
            (f" ({already} already there)" if already > 0 else "")
    return f"  nothing to install ({count.looked_at} packages already there, {took})"


if __name__ == "__main__":
    sys.exit(main())
