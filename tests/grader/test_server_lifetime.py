"""A grading server lives as long as the process that keeps it, whichever thread started it,
and its restart budget counts stops in a row: a long-lived process (an instructor grading in
a notebook, a Dask worker, a test worker) can grade run after run.

Before, a server forked by a grading pool's thread was killed by the kernel's parent-death
signal when that pool shut down; the process's fifth run found it "stopped too often" and
gave every submission a grader error."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import pytest

from grader.grade import (
    classify_ending,
    close_servers,
    grade_notebook,
    grade_submissions,
    server_for,
)
from grader.sandbox import Limits, detect_layer
from grader.server import GradingServer, ServerLost, serving
from grader.spec import load_lab

ROOT = Path(__file__).resolve().parents[2]


def untouched_lab01() -> Path:
    (path,) = (ROOT / "labs").glob("01-*.ipynb")
    return path


def kill_from_outside(server: GradingServer) -> None:
    """What an administrator's ``kill -9`` of the server's process group does."""
    assert server.proc is not None
    os.killpg(server.proc.pid, signal.SIGKILL)
    deadline = time.monotonic() + 30
    while server.alive():
        assert time.monotonic() < deadline, "the killed server is still alive"
        time.sleep(0.05)


def test_a_server_outlives_the_threads_that_started_and_used_it():
    """Six ``grade_submissions`` runs in one process, each with its own short-lived pool of
    two threads (the first run's threads start the server): one server start in all, every
    row graded."""
    spec = load_lab("lab01")
    path = untouched_lab01()
    layer = detect_layer()
    close_servers()
    try:
        for run in range(6):
            rows = grade_submissions([path, path], spec, jobs=2, layer=layer)
            assert [r.status for r in rows] == ["ok", "ok"], (run, [r.reason for r in rows])
            assert all(r.total == 0 for r in rows)
            server = server_for(spec, layer, Limits())
            assert server.alive() and server.starts == 1, run
    finally:
        close_servers()


def test_stops_separated_by_graded_sessions_never_use_up_the_restarts():
    """Killed from outside more often than ``RESTARTS`` over its life, a server that grades
    between the kills is started again each time."""
    spec = load_lab("lab01")
    path = untouched_lab01()
    with serving(spec, detect_layer(), Limits(), slots=1) as server:
        for kill in range(server.RESTARTS + 2):
            kill_from_outside(server)
            row = grade_notebook(path, spec, server=server)
            assert row.status == "ok", (kill, row.reason)
            assert server.starts == kill + 2


def test_a_server_that_keeps_stopping_is_given_up_after_restarts_in_a_row():
    """Killed again during every session it serves, the server is started again
    ``RESTARTS`` times, then refused with a clear reason."""
    spec = load_lab("lab01")
    limits = Limits()
    with serving(spec, detect_layer(), limits, slots=1) as server:
        kill_from_outside(server)
        for _ in range(server.RESTARTS):
            session = server.session(limits.memory_mb, limits.cpu_seconds)
            kill_from_outside(server)
            ending = session.finish(lost="ended")
            assert "killed from outside" in ending.unknown
        with pytest.raises(ServerLost, match="stopped too often"):
            server.session(limits.memory_mb, limits.cpu_seconds)
        assert server.starts == server.RESTARTS + 1


def test_a_process_that_fails_in_the_graders_own_set_up_is_a_grader_error():
    """A submission's process that ends before its set-up is done (here its CPU limit cannot
    be set) ran none of the student's code: a grader error with the set-up's last line, not
    'crashed (exit code 70)' on the student's row. A process that was set up ends clean."""
    spec = load_lab("lab01")
    limits = Limits()
    with serving(spec, detect_layer(), limits, slots=1) as server:
        broken = server.session(limits.memory_mb, -5).finish()
        assert broken.exit == 70 and not broken.started
        event = classify_ending(broken, 5, limits.memory_mb, hidden=False)
        assert event is not None and event.status == "grader error"
        assert "grader's own set-up" in event.reason and "ValueError" in event.reason
        assert "re-run retries" in event.reason
        fine = server.session(limits.memory_mb, limits.cpu_seconds).finish()
        assert fine.started and fine.exit == 0
        assert classify_ending(fine, limits.cpu_seconds, limits.memory_mb, False) is None
