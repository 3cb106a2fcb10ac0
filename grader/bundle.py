"""``grader bundle OUT``: the student hand-out.

What a course that must keep its solutions away from students gives them: the released labs
(``labs/``, checked up to date with ``solutions/`` first), the kit's packages (``kit``,
``sim``, ``hardware``, and ``grader`` for the notebooks' ``check``), ``pyproject.toml``, and a
``Makefile`` and ``README.md`` written for students (``make lab``, ``make reset LAB=NN``,
``make demo``). Never ``solutions/``, ``.git``, the tests or benchmarks, compiled files, nor
any course secret (the hidden cases are seeded from a secret only the instructor holds). The
bundle installs itself: ``make lab`` there creates ``.venv`` from ``pyproject.toml`` and opens
JupyterLab on a ``work/`` copy of the labs.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

from grader.release import check_release

__all__ = ["BundleError", "bundle"]

PACKAGES = ("kit", "sim", "hardware", "grader")
IGNORED = shutil.ignore_patterns("__pycache__", "*.pyc", "*.pyo", ".ipynb_checkpoints",
                                 "*.egg-info")

MAKEFILE = """\
# The kit, for students. Each command creates .venv from pyproject.toml the first time.
#   make lab             copy labs/ into work/ (never overwriting your files), open JupyterLab
#   make reset LAB=01    a fresh copy of one lab in work/ (your old file is kept beside it)
#   make demo            the simulated Uiabot's route through the office (PNG + ROS 2 bag)

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
JUPYTER_ARGS ?=
# JupyterLab refuses to run as root unless told; containers often run as root
ROOT_FLAG := $(if $(filter 0,$(shell id -u)),--allow-root,)

.PHONY: lab reset demo

$(STAMP): pyproject.toml
\t@echo "make: creating the virtual environment .venv with $$($(PYTHON) --version)"
\t@$(PYTHON) -m venv $(VENV)
\t@echo "make: updating pip in .venv"
\t@$(BIN)/python -m pip install --quiet --upgrade pip
\t@$(BIN)/python -m kit._pip_progress "make: installing the kit, the libraries it runs on \\
\tand JupyterLab: 2-4 min the first time" -- --no-compile -e ".[lab]"
\t@touch $(STAMP)

lab: $(STAMP)
\tmkdir -p work
\tfor f in labs/*.ipynb; do [ -e "work/$${f#labs/}" ] || cp "$$f" work/; done
\t$(BIN)/jupyter lab --notebook-dir=work $(ROOT_FLAG) $(JUPYTER_ARGS)

reset: $(STAMP)
\t@test -n "$(LAB)" || { echo "usage: make reset LAB=01"; exit 2; }
\tmkdir -p work
\tstamp=$$(date +%Y%m%d-%H%M%S); for f in labs/$(LAB)-*.ipynb; do n="$${f#labs/}"; \\
\t  if [ -e "work/$$n" ]; then mv "work/$$n" "work/$${n%.ipynb}.$$stamp.ipynb"; fi; \\
\t  cp "$$f" work/; echo "fresh work/$$n"; done

demo: $(STAMP)
\t$(BIN)/python -m sim demo --out out
"""

GITIGNORE = ".venv/\nwork/\nout/\n__pycache__/\n*.egg-info/\n"


class BundleError(ValueError):
    """The bundle cannot be made (stale labs, a folder that is not empty)."""


def _section(readme: str, title: str) -> str:
    match = re.search(rf"^## {re.escape(title)}\n(.*?)(?=^## |\Z)", readme, re.S | re.M)
    return match.group(1).strip() if match else ""


README = """{intro}

## Quick start (Python ≥ 3.10, `make` and a C compiler)

```sh
make lab     # creates .venv, copies labs/ into work/, opens JupyterLab there
```

The first `make lab` installs the kit and its dependencies into `.venv` (a few minutes).
`make reset LAB=01` gives you a fresh copy of one lab and keeps your old file beside it;
`make demo` runs the simulated Uiabot through the office.

## For students

{students}
"""


def student_readme(readme: str) -> str:
    """The repository's README cut down to what a student needs."""
    return README.format(intro=readme.split("\n## ", 1)[0].strip(),
                         students=_section(readme, "For students"))


def bundle(out: Path, root: Path = Path(".")) -> list[Path]:
    """Write the student bundle of the checkout at ``root`` into ``out`` (which must not
    exist or be empty); returns the files written."""
    if out.exists() and any(out.iterdir()):
        raise BundleError(f"{out} is not empty: the bundle goes into a new folder")
    stale = check_release(root / "solutions", root / "labs")
    if stale:
        raise BundleError("labs/ must be released from solutions/ first (`grader release`):\n"
                          + "\n".join(stale))
    out.mkdir(parents=True, exist_ok=True)
    for name in PACKAGES:
        shutil.copytree(root / name, out / name, ignore=IGNORED)
    (out / "labs").mkdir()
    for lab in sorted((root / "labs").glob("[0-9][0-9]-*.ipynb")):
        shutil.copy2(lab, out / "labs" / lab.name)
    shutil.copy2(root / "pyproject.toml", out / "pyproject.toml")
    (out / "Makefile").write_text(MAKEFILE, encoding="utf-8")
    (out / "README.md").write_text(student_readme((root / "README.md").read_text(
        encoding="utf-8")), encoding="utf-8")
    (out / ".gitignore").write_text(GITIGNORE, encoding="utf-8")
    return sorted(p for p in out.rglob("*") if p.is_file())
