"""``grader grade`` for one notebook: ask its code questions in a prison, judge the answers here.

The steps of :func:`grade_notebook`:

1. :func:`~grader.submissions.read_notebook` — a malformed notebook still gets a row;
2. :func:`plan_cases` — the public cases and the student's own hidden cases, seeded from the
   course secret and the student id;
3. a :class:`~grader.server.Session` of the lab's grading server runs the notebook's exercise
   cells (the lab's own example cells only for their definitions) in a fresh, isolated
   process that holds none of the lab's references (:mod:`grader.strip`);
4. :class:`Conversation` asks that process one question at a time — an exercise's arguments,
   or, for a closed-loop exercise, a controller's inputs at each step of an episode the
   grader simulates here — public questions first, hidden ones after;
5. :mod:`grader.scoring` judges every answer against the ``kit`` reference, in this process;
6. :func:`classify` — the submission's status and reason (a crash, a hang, a memory bomb or
   an early exit still yields a row, graded as far as it ran: a process that dies is started
   again without the cell that killed it).

Anything unexpected while grading one submission becomes its row with status ``grader error``
(naming the student and the reason); it never stops the class.
"""

from __future__ import annotations

import importlib
import signal
import threading
import traceback
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from grader import scoring, serialize
from grader.results import CaseOutcome, ExerciseResult, SubmissionResult
from grader.sandbox import Interrupted, Limits, detect_layer, stopping
from grader.server import Ending, GradingServer, ServerLost, Session, SessionLost
from grader.spec import Case, Exercise, LabSpec, course_seed
from grader.submissions import Notebook, SubmissionError, clean_text, read_notebook, student_id

__all__ = ["DEFAULT_MEMORY_MB", "DEFAULT_TIMEOUT", "Conversation", "classify",
           "grade_notebook", "grade_submissions", "plan_cases", "session_budget"]

DEFAULT_TIMEOUT = 120.0
DEFAULT_MEMORY_MB = 2048
RESTARTS = 4
"""fresh processes a submission may need after the first (each without what killed the
one before)."""
MEMORY_WORDS = ("MemoryError", "Memory allocation", "Cannot allocate memory", "out of memory",
                "std::bad_alloc", "failed to allocate", "Unable to allocate")

Plan = dict[str, tuple[tuple[Case, ...], tuple[Case, ...]]]


def plan_cases(spec: LabSpec, student: str, secret: str | None) -> Plan:
    """Each exercise's (public, hidden) cases; the hidden ones are the student's own."""
    return {ex.id: (ex.public, ex.hidden_cases(course_seed(ex.id, student, secret)))
            for ex in spec.exercises}


def case_limit(spec: LabSpec, ex: Exercise, timeout: float) -> float:
    """CPU seconds one case (one step, for a closed-loop exercise) may take."""
    if ex.time_limit:
        return ex.time_limit
    return min(10.0, timeout / (2 * max(1, len(spec.exercises))))


def wall_limit(cpu_seconds: float) -> float:
    """How long the grader waits for an answer that may take ``cpu_seconds`` of CPU time.
    Limits are CPU time (a loaded machine does not fail honest code); this wall-clock bound
    only catches code that sleeps or ignores its alarm, so it is generous: ten times the CPU
    time, plus half a minute."""
    return 10.0 * cpu_seconds + 30.0


EPISODE_CPU = 60.0
"""CPU seconds a submission's controller may use in one closed-loop episode."""


def session_budget(spec: LabSpec, plan: Plan, timeout: float) -> float:
    """The CPU seconds a submission's process may use in all: ``timeout`` for the notebook
    and its quick cases, plus :data:`EPISODE_CPU` per closed-loop case."""
    return timeout + sum(EPISODE_CPU * (len(plan[ex.id][0]) + len(plan[ex.id][1]))
                         for ex in spec.exercises if ex.harness)


# ------------------------------------------------------------------ what happened

@dataclass
class Event:
    """Something that happened to the submission's process, for its status."""

    status: str
    reason: str
    hidden: bool = False


@dataclass
class Conversation:
    """One submission's grading: sessions, cells, questions, events."""

    server: GradingServer
    spec: LabSpec
    notebook: Notebook
    plan: Plan
    timeout: float
    memory_mb: int
    cells: list[dict[str, Any]] = field(default_factory=list)
    cell_errors: list[dict[str, Any]] = field(default_factory=list)
    functions: dict[str, Any] = field(default_factory=dict)
    events: list[Event] = field(default_factory=list)
    session: Session | None = None
    hidden: bool = False
    restarts: int = 0
    described: bool = False
    stdout_bytes: int = 0
    stderr_bytes: int = 0

    def __post_init__(self) -> None:
        self.cells = [dict(c) for c in self.notebook.cells]
        self.cpu_seconds = int(session_budget(self.spec, self.plan, self.timeout)) + 1

    # -- processes

    def _session(self) -> Session | None:
        """The live session, or a fresh one whose cells have run; ``None`` once no more
        restarts are allowed."""
        while self.session is None:
            if self.restarts > RESTARTS:
                return None
            self.restarts += 1
            session = self.server.session(self.memory_mb, self.cpu_seconds)
            runnable = [c for c in self.cells if c.get("mode") != "skip"]
            try:
                header, _ = session.ask("cells", {"cells": runnable,
                                                  "cpu_limit": self.timeout / 2},
                                        wall=wall_limit(self.timeout / 2))
                header2, _ = session.ask("describe", {"functions": [
                    ex.function for ex in self.spec.exercises]}, wall=30.0)
            except SessionLost as lost:
                self._lost_in_cells(session, lost)
                continue
            if not self.described:  # the first run whose cells all ran, the lost cell
                # left out: a cell that killed the process does not hide the functions the
                # other cells define
                self.described = True
                self.cell_errors += _clean_errors(header.get("errors"))
                functions = header2.get("functions")
                self.functions = functions if isinstance(functions, dict) else {}
            self.session = session
        return self.session

    def _lost_in_cells(self, session: Session, lost: SessionLost) -> None:
        ending = session.finish(lost.why, not self.hidden)
        event = self._ended(ending, cpu_limit=self.timeout / 2)
        cell = next((c for c in self.cells if c["position"] == lost.cell), None)
        if cell is None:
            return
        cell["mode"] = "skip"
        kind = {"memory": "memory", "timeout": "timeout"}.get(event.status if event else "",
                                                             "crashed")
        text = event.reason if event else "the process ended"
        self.cell_errors.append({"cell": cell["position"], "first_line": cell["first_line"],
                                 "line": None, "code": "", "kind": kind,
                                 "error": f"{text}; the grader ran the notebook again "
                                          f"without this cell"})

    def end(self, lost: str = "") -> None:
        if self.session is not None:
            self._ended(self.session.finish(lost, read_stderr=not self.hidden))
            self.session = None

    def _ended(self, ending: Ending, cpu_limit: float = 0.0) -> Event | None:
        self.stdout_bytes = max(self.stdout_bytes, ending.stdout_bytes)
        self.stderr_bytes = max(self.stderr_bytes, ending.stderr_bytes)
        event = classify_ending(ending, self.cpu_seconds, self.memory_mb, self.hidden)
        if event is not None:
            self.events.append(event)
        return event

    # -- questions

    def ask(self, op: str, payload: dict[str, Any], cpu_limit: float
            ) -> tuple[dict[str, Any], list[bytes]]:
        """One question to the live session (:class:`SessionLost` if it dies on it: the
        session is ended and the next question starts a fresh one)."""
        session = self._session()
        if session is None:
            raise SessionLost("ended")
        payload = {**payload, "cpu_limit": cpu_limit}
        try:
            return session.ask(op, payload, wall=wall_limit(cpu_limit))
        except SessionLost as lost:
            self.end(lost.why)
            raise

    def cases(self, ex: Exercise, cases: Sequence[Case], public: bool
              ) -> list[tuple[str, CaseOutcome]]:
        labels = [c.name if public else f"hidden case {i}" for i, c in enumerate(cases, 1)]
        limit = case_limit(self.spec, ex, self.timeout)
        out: list[tuple[str, CaseOutcome]] = []
        given_up = ""
        for case, label in zip(cases, labels, strict=True):
            if given_up:  # one endless loop or dead process per exercise is enough to know
                out.append(scoring.lost_case(label, public, given_up))
                continue
            if ex.harness:
                result = self._episode(ex, case, label, public, limit)
            else:
                result = self._call(ex, case, label, public, limit)
            if result[0] == "lost" or result[0] == "timeout":
                given_up = result[1].message if public else (
                    "did not return in time" if result[0] == "timeout" else "stopped")
                result = ("timeout" if "time" in given_up else "error", result[1])
            out.append(result)
        return out

    def _call(self, ex: Exercise, case: Case, label: str, public: bool, limit: float
              ) -> tuple[str, CaseOutcome]:
        try:
            header, blobs = self.ask("call", {"function": ex.function, "args": case.args,
                                              "kwargs": case.kwargs}, limit)
        except SessionLost as lost:
            return "lost", scoring.lost_case(label, public, _lost_words(lost, limit))[1]
        signature = str(self.functions.get(ex.function, {}).get("signature", ""))[:200]
        return scoring.judge_answer(ex, case, header, blobs, label, public, limit, signature)

    def _episode(self, ex: Exercise, case: Case, label: str, public: bool, limit: float
                 ) -> tuple[str, CaseOutcome]:
        """A closed-loop case: the harness (a simulated episode) runs here and asks the
        submission's controller across the boundary step by step."""
        module, _, name = ex.harness.partition(":")
        harness = getattr(importlib.import_module(module), name)
        factory = RemoteFactory(self, ex.function, public, limit)
        try:
            result = harness(factory, *case.args, **case.kwargs)
        except SessionLost as lost:
            return "lost", scoring.lost_case(label, public, _lost_words(lost, limit))[1]
        except NotImplementedError:
            return "not implemented", CaseOutcome(label, public, False, "not implemented yet")
        return scoring.judge_value(ex, case, result, label, public)

    def run(self) -> dict[str, ExerciseResult]:
        scored: dict[str, list[tuple[str, CaseOutcome]]] = {}
        missing: dict[str, str] = {}
        for ex in self.spec.exercises:          # the public questions first …
            if self._session() is None:
                break
            found = self.functions.get(ex.function, {})
            if not found.get("callable"):
                missing[ex.id] = self._missing(ex, found)
                continue
            scored[ex.id] = self.cases(ex, self.plan[ex.id][0], True)
        self.hidden = True                      # … hidden ones only once those are in
        for ex in self.spec.exercises:
            if ex.id in scored:
                scored[ex.id] += self.cases(ex, self.plan[ex.id][1], False)
        self.end()
        results = {}
        for ex in self.spec.exercises:
            if ex.id in missing:
                results[ex.id] = ExerciseResult(ex.id, 0.0, ex.points, "missing function",
                                                missing[ex.id][:scoring.MESSAGE_LIMIT])
            elif ex.id in scored:
                results[ex.id] = scoring.score(ex, scored[ex.id])
            else:
                results[ex.id] = ExerciseResult(ex.id, 0.0, ex.points, "not graded",
                                                "not run: the notebook's process could not "
                                                "be started again")
        scoring.upstream_notes(self.spec.exercises, results)
        return results

    def _missing(self, ex: Exercise, found: dict[str, Any]) -> str:
        if found.get("exists"):
            return f"{ex.function!r} is a {found.get('type')}, not a function"
        text = f"the notebook defines no function {ex.function!r}"
        import re

        defining = re.compile(rf"^\s*def\s+{re.escape(ex.function)}\s*\(", re.MULTILINE)
        by_position = {e["cell"]: e for e in self.cell_errors}
        for cell in self.cells:
            error = by_position.get(cell["position"])
            if error is not None and defining.search(cell["source"]):
                at = f" at line {error['line']}" if error.get("line") else ""
                return (f"{text}: cell {cell['position']} (`{cell['first_line']}`) did not "
                        f"run — {error['error']}{at}")
        return text


def _lost_words(lost: SessionLost, limit: float) -> str:
    if lost.why == "timeout":
        return f"did not answer within its time limit ({limit:g} s of CPU time)"
    if lost.why == "too large":
        return "its answer was larger than the grader reads"
    if lost.why == "unreadable":
        return "its answer was not an answer (something wrote to the grader's channel)"
    return "its process ended while answering"


def _clean_errors(errors: Any) -> list[dict[str, Any]]:
    keep = ("cell", "first_line", "line", "code", "kind", "error")
    out = []
    for e in errors if isinstance(errors, list) else []:
        if isinstance(e, dict):
            out.append({k: clean_text(str(e.get(k)))[:500] if isinstance(e.get(k), str)
                        else e.get(k) if isinstance(e.get(k), int) else None for k in keep})
    return out[:100]


# ------------------------------------------------------------------ closed loop

class RemoteError(RuntimeError):
    """The controller in the submission's process raised (``kind`` is its exception's type
    name, for public episodes only)."""

    def __init__(self, kind: str, message: str) -> None:
        super().__init__(message)
        self.kind = kind


class RemoteTimeout(TimeoutError):
    """The controller used up its CPU time on one call."""


class RemoteFactory:
    """``make_controller`` as the harness sees it: each call makes the object in the
    submission's process, and returns a :class:`RemoteObject` that calls its methods there."""

    METHODS = ("set_plan", "compute_velocity_commands")

    def __init__(self, conversation: Conversation, function: str, public: bool,
                 limit: float) -> None:
        self.conversation, self.function, self.public, self.limit = (conversation, function,
                                                                      public, limit)

    def __call__(self, *args: Any) -> RemoteObject:
        header, _ = self.conversation.ask("new", {"function": self.function, "args": args,
                                                  "methods": self.METHODS}, self.limit)
        _raise_failure(header, self.public)
        methods = header.get("methods")
        return RemoteObject(self, int(header.get("value", 0)),
                            [m for m in methods if m in self.METHODS]
                            if isinstance(methods, list) else [])


class RemoteObject:
    """A controller living in the submission's process (a harness checks its answers, and
    does not time its calls: the submission's process does, on its own CPU time)."""

    __kit_remote__ = True

    def __init__(self, factory: RemoteFactory, handle: int, methods: list[str]) -> None:
        self._factory, self._handle = factory, handle
        for name in methods:
            setattr(self, name, self._method(name))

    def _method(self, name: str) -> Callable[..., Any]:
        def call(*args: Any, **kwargs: Any) -> Any:
            f = self._factory
            header, blobs = f.conversation.ask("method", {"handle": self._handle, "method": name,
                                                          "args": args, "kwargs": kwargs},
                                               f.limit)
            _raise_failure(header, f.public)
            try:
                return serialize.decode(header.get("value"), blobs=blobs)
            except serialize.DecodeError:
                raise RemoteError("ValueError", "returned something that is not a value") \
                    from None
        call.__name__ = name
        return call


def _raise_failure(header: dict[str, Any], public: bool) -> None:
    status = header.get("status")
    if status == "returned":
        return
    if status == "timeout":
        raise RemoteTimeout(f"used up its CPU time on one call{_place(header, public)}")
    if status == "not implemented":
        raise NotImplementedError
    kind = str(header.get("type", "Exception"))
    message = clean_text(str(header.get("message", "")))[:300] if public else ""
    message = message.removeprefix(f"raised {kind}: ")
    if kind == "ControlError":
        from kit.navigation import ControlError

        raise ControlError(message.rpartition(" (cell ")[0] or message or "control failed"
                           if public else "control failed")
    if status == "memory":
        kind, message = "MemoryError", "ran out of memory"
    raise RemoteError(kind if public else "an exception", message or "(no message)")


def _place(header: dict[str, Any], public: bool) -> str:
    where = str(header.get("where", "")) if public else ""
    return f" ({clean_text(where)[:80]})" if where else ""


# ------------------------------------------------------------------ the verdict

def classify_ending(ending: Ending, cpu_seconds: int, memory_mb: int, hidden: bool
                    ) -> Event | None:
    """What a process's end says about the submission, or ``None`` for a clean end."""
    if ending.unknown:
        return Event("grader error", f"{ending.unknown}; a re-run retries this submission")
    if not ending.started and not ending.killed_by_grader:
        last = ending.stderr_tail.strip().splitlines()[-1:] or ["no output"]
        return Event("grader error", f"the submission's process failed in the grader's own "
                     f"set-up, before any of its code ran ({clean_text(last[0])[-200:]}); a "
                     f"re-run retries this submission")
    if ending.lost == "timeout":
        return Event("timeout", "stopped answering (an endless loop that ignored its time "
                     "limit?)", hidden)
    if ending.lost == "too large":
        return Event("output limit", "its answers were larger than the grader reads", hidden)
    if ending.lost == "unreadable":
        return Event("crashed", "something in the notebook wrote to the grader's channel",
                     hidden)
    sig = ending.signal
    if ending.lost == "ended" and sig is None and ending.exit in (0, None):
        return Event("crashed", "the process ended while the grader waited for an answer",
                     hidden)
    if sig == signal.SIGKILL and not ending.killed_by_grader:
        if ending.cpu >= cpu_seconds - 1:
            return Event("timeout", f"used more than {cpu_seconds} s of CPU", hidden)
        return Event("grader error", "its sandbox was killed from outside (SIGKILL, not by "
                     "its limits); a re-run retries this submission")
    if sig == signal.SIGXCPU:
        return Event("timeout", f"used more than {cpu_seconds} s of CPU", hidden)
    died = sig not in (None, signal.SIGKILL) or ending.exit not in (0, None)
    near_limit = ending.maxrss_kb * 1024 >= 0.75 * memory_mb * 1024 * 1024
    if died and (near_limit or any(w in ending.stderr_tail for w in MEMORY_WORDS)):
        return Event("memory", f"ran out of memory (limit {memory_mb} MB)", hidden)
    if sig not in (None, signal.SIGKILL):
        return Event("crashed", f"the process was killed by {signal.Signals(sig).name}", hidden)
    if ending.exit not in (0, None):
        return Event("crashed", f"the process exited with code {ending.exit}", hidden)
    return None


ORDER = ("grader error", "memory", "timeout", "crashed", "output limit")
HIDDEN_ENDINGS = {"memory": "ran out of memory", "timeout": "ran out of time",
                  "crashed": "the process ended", "output limit": "printed too much"}


def classify(conversation: Conversation, limits: Limits) -> tuple[str, str]:
    """The submission's status and reason, from what happened to its processes and cells."""
    events = list(conversation.events)
    for error in conversation.cell_errors:
        if error.get("kind") == "memory":
            events.append(Event("memory", f"ran out of memory (limit {conversation.memory_mb} "
                                f"MB) in cell {error.get('cell')}"))
        elif error.get("kind") == "timeout":
            events.append(Event("timeout", f"cell {error.get('cell')}: {error.get('error')}; "
                                f"the cells after it ran and the exercises were graded"))
    if max(conversation.stdout_bytes, conversation.stderr_bytes) >= limits.file_mb * 2**20:
        events.append(Event("output limit", f"printed more than {limits.file_mb} MB; the rest "
                            f"was dropped"))
    for status in ORDER:
        found = [e for e in events if e.status == status]
        if found:
            e = found[0]
            if e.hidden and status != "grader error":
                # while it held hidden inputs only the kind of ending is told: its exit code,
                # signal or answer are the submission's to choose
                return status, f"{HIDDEN_ENDINGS[status]} while running the hidden cases; " \
                               f"graded as far as it ran"
            suffix = "" if status == "grader error" else "; graded as far as it ran"
            return status, e.reason + suffix
    return "ok", "graded"


# ------------------------------------------------------------------ entry points

_SERVERS: dict[tuple[int, str, int, int, int], GradingServer] = {}
_SERVERS_LOCK = threading.Lock()


def server_for(spec: LabSpec, layer: str, limits: Limits, slots: int = 8) -> GradingServer:
    """The grading server for ``spec`` in ``layer`` (one per process, started on first use).

    Servers are told apart by the spec object itself, not its name: a server strips from its
    submissions' processes the modules of *its* spec's references, so another spec of the
    same name (a course's own lab01, an exercise being written) gets a server of its own and
    never lends its server, with the wrong modules stripped, to the shipped lab. (The server
    holds its spec, so the ``id`` in the key cannot be reused while the server is kept.)"""
    key = (id(spec), layer, limits.file_mb, limits.processes, limits.scratch_mb)
    with _SERVERS_LOCK:
        server = _SERVERS.get(key)
        if server is None:
            server = _SERVERS[key] = GradingServer(spec, layer, limits, slots)
        return server


def close_servers() -> None:
    """Stop every grading server this process started."""
    with _SERVERS_LOCK:
        servers = list(_SERVERS.values())
        _SERVERS.clear()
    for server in servers:
        server.close()


def _not_graded(spec: LabSpec, status: str, reason: str) -> dict[str, ExerciseResult]:
    return {ex.id: ExerciseResult(ex.id, 0.0, ex.points, status, reason)
            for ex in spec.exercises}


def grade_notebook(path: Path, spec: LabSpec, student: str | None = None,
                   timeout: float = DEFAULT_TIMEOUT, memory_mb: int = DEFAULT_MEMORY_MB,
                   secret: str | None = None, layer: str | None = None,
                   server: GradingServer | None = None, claimed_check: bool = True
                   ) -> SubmissionResult:
    """Grade one notebook. Never raises for anything the submission does, nor for anything
    else that goes wrong with this one notebook (that becomes a ``grader error`` row);
    :class:`~grader.sandbox.Interrupted` is let through when grading is being stopped.

    ``student`` names the row (by default the file or folder name); ``secret`` seeds the hidden
    cases, ``None`` grades a practice run (public seed).
    """
    who = student or student_id(path, spec.name)
    try:
        return _grade(path, spec, who, timeout, memory_mb, secret, layer, server)
    except Interrupted:
        raise
    except (Exception, ServerLost) as exc:
        detail = clean_text("".join(traceback.format_exception_only(type(exc), exc)).strip())
        return SubmissionResult(who, clean_text(str(path)), "grader error",
                                f"the grader failed on {who}'s notebook: {detail[:300]}; a "
                                f"re-run retries it",
                                _not_graded(spec, "not graded", "grader error"),
                                practice=secret is None)


def _grade(path: Path, spec: LabSpec, who: str, timeout: float, memory_mb: int,
           secret: str | None, layer: str | None, server: GradingServer | None
           ) -> SubmissionResult:
    practice = secret is None
    try:
        notebook = read_notebook(path)
    except SubmissionError as exc:
        return SubmissionResult(who, clean_text(str(path)), exc.status, str(exc),
                                _not_graded(spec, "not graded", exc.status), practice=practice)
    limits = Limits(memory_mb=memory_mb)
    layer = layer or detect_layer()
    server = server or server_for(spec, layer, limits)
    if server.spec is not spec:  # its sandboxes strip another spec's reference modules
        raise ValueError(f"the grading server was started for another {spec.name} spec than "
                         f"the one being graded")
    plan = plan_cases(spec, who, secret)
    conversation = Conversation(server, spec, notebook, plan, timeout, memory_mb)
    try:
        exercises = conversation.run()
    except ServerLost as exc:
        conversation.end()
        if stopping():
            raise Interrupted("grading is being stopped") from None
        return SubmissionResult(who, clean_text(str(path)), "grader error",
                                f"{exc}; a re-run retries this submission",
                                _not_graded(spec, "not graded", "grader error"),
                                conversation.cell_errors, layer, notebook.sha256, practice)
    finally:
        conversation.end()
    if stopping():  # its sandbox was killed by the interruption, not by the submission
        raise Interrupted("grading is being stopped")
    status, reason = classify(conversation, limits)
    if notebook.student and notebook.student != who:
        reason += (f"; its metadata names another student ({notebook.student!r}): graded as "
                   f"{who}'s, whose file it is")
    return SubmissionResult(who, clean_text(str(path)), status, reason, exercises,
                            conversation.cell_errors, layer, notebook.sha256, practice)


def grade_submissions(paths: Iterable[Path], spec: LabSpec, jobs: int = 1,
                      timeout: float = DEFAULT_TIMEOUT, memory_mb: int = DEFAULT_MEMORY_MB,
                      secret: str | None = None, layer: str | None = None
                      ) -> list[SubmissionResult]:
    """Grade many notebooks, ``jobs`` at a time (each in its own isolated process)."""
    from concurrent.futures import ThreadPoolExecutor

    items = list(paths)
    chosen = layer or detect_layer()
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        return list(pool.map(lambda p: grade_notebook(p, spec, None, timeout, memory_mb,
                                                      secret, chosen), items))
