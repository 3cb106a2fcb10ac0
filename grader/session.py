"""One worker's run, seen from the grader: two JSON lines each way, under one deadline.

The request goes to the worker's standard input and its answers come back on a pipe of their
own; what the submission prints goes to files without a name on disk, which the grader only
measures (and, before any hidden case was sent, reads the last line of). Every read and write
is bounded by the deadline and by a size cap, so a submission that stops reading, floods its
answer or never answers only costs its own time.
"""

from __future__ import annotations

import json
import os
import select
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from grader.sandbox import Sandbox, unlinked_file

__all__ = ["RESULT_LIMIT", "Run", "run_worker"]

RESULT_LIMIT = 64 * 1024 * 1024
WORKER = Path(__file__).with_name("worker.py")


@dataclass
class Run:
    """What happened: the answers that arrived, how the process ended, what it printed."""

    public: dict[str, Any] | None = None
    hidden: dict[str, Any] | None = None
    hidden_sent: bool = False
    returncode: int | None = None
    timed_out: bool = False
    too_large: bool = False
    unreadable: str = ""
    stdout_bytes: int = 0
    stderr_bytes: int = 0
    stderr_tail: str = ""
    """the last printed error lines — only while no hidden case had been sent."""


class _Pipes:
    """The grader's ends: requests out, answers in, both non-blocking."""

    def __init__(self, deadline: float) -> None:
        self.deadline = deadline
        self.child_stdin, self.requests = os.pipe()
        self.answers, self.child_answers = os.pipe()
        os.set_blocking(self.requests, False)
        os.set_blocking(self.answers, False)
        self.buffer = b""
        self.received = 0

    def remaining(self) -> float:
        return max(0.0, self.deadline - time.monotonic())

    def send(self, message: dict[str, Any]) -> bool:
        data = memoryview(json.dumps(message).encode() + b"\n")
        while data:
            _, ready, _ = select.select([], [self.requests], [], self.remaining())
            if not ready:
                return False
            try:
                data = data[os.write(self.requests, data):]
            except (BrokenPipeError, BlockingIOError):
                return False
        return True

    def receive(self) -> tuple[bytes | None, str]:
        """The next line, or ``None`` with why not: ``"eof"``, ``"timeout"``, ``"too large"``."""
        while b"\n" not in self.buffer:
            ready, _, _ = select.select([self.answers], [], [], self.remaining())
            if not ready:
                return None, "timeout"
            try:
                chunk = os.read(self.answers, 1 << 16)
            except BlockingIOError:
                continue
            if not chunk:
                return None, "eof"
            self.received += len(chunk)
            if self.received > RESULT_LIMIT:
                return None, "too large"
            self.buffer += chunk
        line, _, self.buffer = self.buffer.partition(b"\n")
        return line, ""

    def close_child_ends(self) -> None:
        """Once the worker has them: its ends, closed here exactly once."""
        for name in ("child_stdin", "child_answers"):
            fd = getattr(self, name)
            if fd >= 0:
                os.close(fd)
                setattr(self, name, -1)

    def close(self) -> None:
        self.close_child_ends()
        for name in ("requests", "answers"):
            fd = getattr(self, name)
            if fd >= 0:
                os.close(fd)
                setattr(self, name, -1)


def _tail(fh: Any, limit: int = 4096) -> str:
    size = os.fstat(fh.fileno()).st_size
    fh.seek(max(0, size - limit))
    return fh.read().decode("utf-8", "replace")


def _answer(pipes: _Pipes, run: Run, phase: str) -> dict[str, Any] | None:
    line, problem = pipes.receive()
    if line is None:
        run.timed_out = problem == "timeout"
        run.too_large = problem == "too large"
        return None
    try:
        answer = json.loads(line)
    except ValueError:  # no parser detail: its positions are the submission's to choose
        run.unreadable = f"its {phase} answer is not JSON"
        return None
    if not isinstance(answer, dict) or answer.get("phase") != phase:
        run.unreadable = f"its answer is not the {phase} phase's"
        return None
    return answer


def _exchange(pipes: _Pipes, run: Run, first: dict[str, Any],
              second: Callable[[dict[str, Any]], dict[str, Any]]) -> None:
    if not pipes.send(first):
        run.timed_out = pipes.remaining() == 0
        return
    run.public = _answer(pipes, run, "public")
    if run.public is None:
        return
    run.hidden_sent = True
    if not pipes.send(second(run.public)):
        run.timed_out = pipes.remaining() == 0
        return
    run.hidden = _answer(pipes, run, "hidden")


def run_worker(box: Sandbox, first: dict[str, Any],
               second: Callable[[dict[str, Any]], dict[str, Any]], timeout: float) -> Run:
    """Start the worker in ``box``, send ``first``; once its public answer is in, send
    ``second(answer)``; collect everything within ``timeout`` seconds. Never raises for
    anything the submission does; the sandbox is gone when this returns."""
    run = Run()
    pipes = _Pipes(time.monotonic() + timeout)
    with unlinked_file() as out, unlinked_file() as err:
        proc: subprocess.Popen[bytes] | None = None
        try:
            proc = box.start([sys.executable, "-I", "-B", str(WORKER), str(pipes.child_answers)],
                             stdin=pipes.child_stdin, stdout=out, stderr=err,
                             pass_fds=(pipes.child_answers,))
            pipes.close_child_ends()
            _exchange(pipes, run, first, second)
            try:
                run.returncode = proc.wait(timeout=min(5.0, pipes.remaining()) or 0.01)
            except subprocess.TimeoutExpired:
                run.timed_out = run.timed_out or pipes.remaining() == 0
        finally:
            if proc is not None:
                box.finish(proc)
                if run.returncode is None and not run.timed_out:
                    run.returncode = proc.returncode
            pipes.close()
        run.stdout_bytes = os.fstat(out.fileno()).st_size
        run.stderr_bytes = os.fstat(err.fileno()).st_size
        if not run.hidden_sent:
            run.stderr_tail = _tail(err)
    return run
