"""Every released lab runs top to bottom in a real kernel with no exception: a cell that needs
an unfinished exercise prints one line naming it (grader/runall.py), and every check cell
says "not implemented yet". (The solution notebooks are checked by nbval: `make nbval`.)"""

from __future__ import annotations

import re
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from grader.spec import load_lab

ROOT = Path(__file__).resolve().parents[1]
LAB_NOTEBOOKS = sorted((ROOT / "labs").glob("[0-9][0-9]-*.ipynb"))
SOLUTION_NOTEBOOKS = sorted((ROOT / "solutions").glob("[0-9][0-9]-*.ipynb"))
NEEDS = re.compile(r"needs `(\w+)` \(exercise (\d+)\) — not implemented yet")


def lab_of(path: Path) -> str:
    return "lab" + path.name[:2]


@pytest.mark.slow
@pytest.mark.parametrize("path", LAB_NOTEBOOKS, ids=lambda p: p.name)
def test_student_lab_runs_top_to_bottom_without_an_exception(path, monkeypatch):
    monkeypatch.setenv("KIT_FAST", "1")
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    for variable in ("KIT_GRADING", "NBGRADER_EXECUTION"):
        monkeypatch.delenv(variable, raising=False)
    nb = nbformat.read(path, as_version=4)
    # allow_errors=False: the first exception anywhere fails the test with its traceback;
    # the time-outs only stop a hung kernel, far beyond what a cell takes on a busy machine
    NotebookClient(nb, timeout=1800, startup_timeout=600, allow_errors=False,
                   kernel_name="python3",
                   resources={"metadata": {"path": str(path.parent)}}).execute()
    functions = [ex.function for ex in load_lab(lab_of(path)).exercises]
    verdicts, needs = {}, []
    for cell in nb.cells:
        if cell.cell_type != "code":
            continue
        text = "".join(o.get("text", "") for o in cell.outputs if o.output_type == "stream")
        needs += NEEDS.findall(text)
        match = re.fullmatch(r"check\((\w+)\)", cell.source.strip().splitlines()[0])
        if match:
            verdicts[match.group(1)] = text
    assert verdicts, "no check cells found"
    for function, text in verdicts.items():
        assert "not implemented yet" in text, (function, text)
    for function, number in needs:  # each skipped cell names a real exercise, rightly numbered
        assert functions.index(function) + 1 == int(number)


@pytest.mark.parametrize("path", SOLUTION_NOTEBOOKS, ids=lambda p: p.name)
def test_exercise_numbers_in_the_text_follow_the_spec(path):
    """"**Exercise N.**" introduces the N-th exercise of the lab's spec, which is the number
    a skipped cell's message gives."""
    functions = [ex.function for ex in load_lab(lab_of(path)).exercises]
    nb = nbformat.read(path, as_version=4)
    number = None
    seen = []
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            found = re.findall(r"\*\*Exercise (\d+)\.\*\*", cell.source)
            if found:
                number = int(found[-1])
        elif "### BEGIN SOLUTION" in cell.source:
            name = re.search(r"^def (\w+)\(", cell.source, re.MULTILINE)
            assert name and number is not None, cell.source[:80]
            assert functions[number - 1] == name.group(1), (number, name.group(1))
            seen.append(name.group(1))
    assert seen == functions


@pytest.mark.parametrize("path", SOLUTION_NOTEBOOKS, ids=lambda p: p.name)
def test_every_exercise_stub_states_what_it_takes_and_returns(path):
    """The released stub keeps only the signature and the docstring: that docstring must say
    what comes in (a line per argument group) and what goes out ("Returns ...")."""
    import ast

    nb = nbformat.read(path, as_version=4)
    for cell in nb.cells:
        if "### BEGIN SOLUTION" not in cell.source:
            continue
        tree = ast.parse(cell.source)
        fn = next(n for n in tree.body if isinstance(n, ast.FunctionDef))
        doc = ast.get_docstring(fn) or ""
        assert "Returns" in doc or "Return" in doc, (fn.name, doc)
        assert len(doc.splitlines()) >= 3, (fn.name, doc)
        for arg in fn.args.args:
            assert arg.arg in doc, (fn.name, arg.arg)


# text that differs from machine to machine: a signed zero (its sign follows the CPU's vector
# code path), a numpy scalar's repr (numpy 2 prints np.int64(3), numpy 1 prints 3), a memory
# address, an object id; nbval compares the stored outputs as text
VOLATILE = {
    "a negative zero": re.compile(r"(?<![\w.])-0\.?0*(?![\d.])"),
    "a numpy scalar's repr": re.compile(r"\bnp\.(?:int|uint|float|bool)\w*\("),
    "a memory address": re.compile(r"\bat 0x[0-9a-f]{6,}"),
}


def stored_texts(nb):
    """(cell position, text) of every stored output nbval compares."""
    for position, cell in enumerate(nb.cells, start=1):
        if cell.cell_type != "code":
            continue
        tags = cell.metadata.get("tags", [])
        if any(t in ("nbval-ignore-output", "nbval-skip") for t in tags):
            continue
        for output in cell.get("outputs", []):
            text = output.get("text") or output.get("data", {}).get("text/plain", "")
            yield position, "".join(text) if isinstance(text, list) else text


@pytest.mark.parametrize("path", SOLUTION_NOTEBOOKS, ids=lambda p: p.name)
def test_stored_outputs_hold_nothing_that_differs_between_machines(path):
    nb = nbformat.read(path, as_version=4)
    for position, text in stored_texts(nb):
        for what, pattern in VOLATILE.items():
            match = pattern.search(text)
            assert match is None, (f"cell {position} stores {what}: "
                                   f"{text[max(0, match.start() - 40):match.end() + 20]!r}")


def test_the_volatile_patterns_find_what_they_should():
    zero = VOLATILE["a negative zero"]
    assert zero.search("expected [-0.      ,  0.4]") and zero.search("x = -0 m")
    assert zero.search("-0.000 s") and not zero.search("-0.05") and not zero.search("10-0.5")
    assert not zero.search("[0.     , 0.15708]") and not zero.search("x-0.1")


def test_nbvals_sanitizer_unsigns_zeros_and_nothing_else():
    """The file `make nbval` passes to --nbval-sanitize-with, applied as nbval applies it."""
    import configparser

    config = configparser.ConfigParser()
    config.read(ROOT / "tests" / "nbval_sanitize.cfg")
    rules = [(re.compile(config[s]["regex"]), config[s]["replace"]) for s in config.sections()]

    def sanitize(text):
        for pattern, replace in rules:
            text = pattern.sub(replace, text)
        return text

    assert sanitize("expected [ 0.15708, -0.     ]") == "expected [ 0.15708, 0.     ]"
    assert sanitize("x -0.000 m, -0 s") == "x 0.000 m, 0 s"
    assert sanitize("-0.00e+00") == "0.00e+00"
    assert sanitize("-0.05 and 10-0.5 and -0.01e+00") == "-0.05 and 10-0.5 and -0.01e+00"
