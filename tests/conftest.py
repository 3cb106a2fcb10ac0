"""Shared fixtures: where ../shared/data is, and a marker for tests that need it; a result
computed once for all test workers; and hypothesis set up to judge examples, never the
machine's speed."""

from __future__ import annotations

import fcntl
import os
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, settings

# hypothesis fails an example slower than 200 ms and a strategy slow to generate data: on a
# busy machine both happen to correct code. Every property test here runs without either
# check (its own @settings may still ask for them).
settings.register_profile("kit", deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("kit")

ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = ROOT.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        pytest.skip("../shared/data is not beside this checkout")
    return SHARED_DATA


def _corrupt(frame: bytes, data: Any) -> bytes:
    """One byte of ``frame`` flipped, dropped or inserted, as hypothesis's ``data`` draws."""
    from hypothesis import strategies as st

    out = bytearray(frame)
    kind = data.draw(st.sampled_from(["flip", "drop", "insert"]))
    pos = data.draw(st.integers(0, len(out) - 1))
    if kind == "flip":
        out[pos] ^= 1 << data.draw(st.integers(0, 7))
    elif kind == "drop":
        del out[pos]
    else:
        out.insert(pos, data.draw(st.integers(0, 255)))
    return bytes(out)


@pytest.fixture(scope="session")
def corrupt() -> Callable[[bytes, Any], bytes]:
    """The parsers' fuzz tests share one way of corrupting a frame."""
    return _corrupt


def solved_release(lab: str, dest: Path, old: str | None = None, new: str = "",
                   extra: tuple[str, ...] = ()) -> Path:
    """The released notebook of ``lab`` with the solution's exercise cells put in, as an
    honest student hands it in (the release's cell metadata kept); with ``old``, that text
    replaced by ``new`` in the one cell holding it (a student's mistake); ``extra`` cells
    added at the end as a student would add them."""
    import nbformat

    number = lab[-2:]
    (released,) = (ROOT / "labs").glob(f"{number}-*.ipynb")
    (solution,) = (ROOT / "solutions").glob(f"{number}-*.ipynb")
    nb = nbformat.read(released, as_version=4)
    answers = {c.get("id"): c.source for c in nbformat.read(solution, as_version=4).cells
               if c.cell_type == "code" and "### BEGIN SOLUTION" in c.source}
    for cell in nb.cells:
        if cell.get("id") in answers:
            cell.source = answers[cell.get("id")]
    if old is not None:
        hits = [c for c in nb.cells if c.cell_type == "code" and old in c.source]
        assert len(hits) == 1, f"{old!r} must occur in exactly one cell of {released.name}"
        hits[0].source = hits[0].source.replace(old, new)
    nb.cells += [nbformat.v4.new_code_cell(source) for source in extra]
    dest.parent.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, dest)
    return dest


@pytest.fixture(scope="session")
def solved():
    """:func:`solved_release`: an honest (or deliberately mistaken) submission of a lab."""
    return solved_release


@pytest.fixture(scope="session")
def weakest_layer_allowed() -> list[str]:
    """``["--allow-no-isolation"]`` where only the rlimits sandbox layer works here (a
    developer who is not root: both isolating layers run each submission as a user of its
    own), else ``[]`` (CI, as root). The ``grader grade`` command lines of tests about
    something else than the layer then grade on that layer instead of being refused."""
    from grader.sandbox import detect_layer

    return ["--allow-no-isolation"] if detect_layer() == "rlimits" else []


@pytest.fixture(scope="session")
def once_for_all_workers(tmp_path_factory: pytest.TempPathFactory
                         ) -> Callable[[str, Callable[[], Any]], Any]:
    """``once(key, compute)``: ``compute()``'s value, computed by one test process of the run.

    A module-scoped fixture is made once per pytest-xdist worker that runs one of its tests,
    so an expensive one (a class graded under a sandbox layer) was made again by every worker
    that took some of its tests. The first worker to ask computes the value under an
    exclusive lock and leaves it pickled in the run's shared temporary folder; the others
    wait for the lock and load it. A ``compute`` that raises leaves nothing, and the next
    worker to ask computes again. Paths in the value stay valid: no worker's temporary folder
    is removed before the run ends. Without xdist it is ``compute()``."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        return lambda key, compute: compute()
    shared = tmp_path_factory.getbasetemp().parent

    def once(key: str, compute: Callable[[], Any]) -> Any:
        stored = shared / f"once-{key}.pickle"
        with open(shared / f"once-{key}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)      # released when the file closes
            if stored.exists():
                return pickle.loads(stored.read_bytes())
            value = compute()
            partial = stored.with_suffix(".partial")
            partial.write_bytes(pickle.dumps(value))
            partial.replace(stored)
            return value

    return once


@pytest.fixture(scope="session")
def demo_run(tmp_path_factory: pytest.TempPathFactory, once_for_all_workers
             ) -> tuple[int, str, Path]:
    """``make demo``'s run (``sim.navdemo.main``, seed 7: the office mapped, then navigated
    on that map among people), once in a test run: its exit status, what it printed and the
    folder it wrote."""
    def run() -> tuple[int, str, Path]:
        import contextlib
        import io

        from sim import navdemo

        out, printed = tmp_path_factory.mktemp("demo"), io.StringIO()
        with contextlib.redirect_stdout(printed):
            status = navdemo.main(out, seed=7)
        return status, printed.getvalue(), out

    return once_for_all_workers("make-demo-seed-7", run)
