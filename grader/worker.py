"""The submission side of grading: ``python -I -B grader/worker.py RESULT_FD`` in a sandbox.

Run by path (so nothing of the kit is imported before the real reference modules are in
place), it talks to the grader in two phases, one JSON line each way:

1. The request (standard input) carries the lab's guarded modules' real source — their files
   are stubs inside the sandbox —, the guarded names, the notebook's code cells and each
   exercise's *public* cases. The worker installs the modules and the guards, runs the cells
   in one namespace (a cell that fails is recorded with its position and line, and the next
   one runs, as in a notebook), calls each exercise function on its public cases and answers
   on the result descriptor: cell errors, outcomes, signatures.
2. Only then does the grader send the *hidden* cases. Their answers carry a value, or a
   verdict and a built-in exception type — never a message, a line number or anything else a
   submission could fill with what it was given. Nothing printed is ever reported.

So nothing of a hidden case can reach a report: it was not in the process while the cells,
the public cases and their messages were produced, and afterwards only values and fixed words
leave. The expected outputs never enter the process at all; the grader judges the values.
A process the submission forks never answers for the worker: it leaves at once.
"""

from __future__ import annotations

import builtins
import importlib
import importlib.abc
import importlib.util
import inspect
import json
import os
import re
import signal
import sys
import traceback
from collections.abc import Sequence
from types import FrameType, ModuleType
from typing import Any

TEXT_LIMIT = 500
MAIN_PID = os.getpid()


class CaseTimeout(BaseException):
    """Raised inside a call that ran past its time limit."""


def _short(text: str, limit: int = TEXT_LIMIT) -> str:
    return text if len(text) <= limit else text[:limit] + "…"


def _forked_child_leaves() -> None:
    """A process forked by the submission must not go on running the notebook or answer."""
    if os.getpid() != MAIN_PID:
        os._exit(0)


# ------------------------------------------------------------------ the real modules

class _SourceLoader(importlib.abc.Loader):
    def __init__(self, source: str, path: str) -> None:
        self.source, self.path = source, path

    def exec_module(self, module: ModuleType) -> None:
        code = compile(self.source, self.path, "exec", dont_inherit=True)
        self.source = ""
        exec(code, module.__dict__)


class _Finder(importlib.abc.MetaPathFinder):
    def __init__(self, modules: dict[str, dict[str, Any]]) -> None:
        self.modules = modules

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> Any:
        entry = self.modules.pop(name, None)
        if entry is None:
            return None
        loader = _SourceLoader(entry["source"], entry["path"])
        locations = [os.path.dirname(entry["path"])] if entry.get("package") else None
        return importlib.util.spec_from_file_location(name, entry["path"], loader=loader,
                                                      submodule_search_locations=locations)


def install_modules(modules: dict[str, dict[str, Any]]) -> None:
    """Import the guarded modules from the source the grader sent (their files in the sandbox
    are stubs), then forget the source: a later import of a file gets the stub."""
    finder = _Finder(dict(modules))
    sys.meta_path.insert(0, finder)
    try:
        for name in sorted(modules):
            importlib.import_module(name)
    finally:
        sys.meta_path.remove(finder)
        modules.clear()


def guard_reload(modules: Sequence[str]) -> None:
    """A reload of a guarded module would bring back unguarded functions."""
    guarded = {sys.modules[m] for m in modules if m in sys.modules}
    original = importlib.reload

    def reload(module: Any) -> Any:
        if module in guarded:
            raise PermissionError(f"{module.__name__} holds references blocked while grading")
        return original(module)

    importlib.reload = reload


# ------------------------------------------------------------------ cells

def strip_magics(source: str) -> str:
    """Drop IPython-only lines (``%magic``, ``!shell``) so a cell runs as plain Python."""
    return "\n".join("" if line.lstrip().startswith(("%", "!")) else line
                     for line in source.split("\n"))


def _where(cell: dict[str, Any], line: int | None) -> dict[str, Any]:
    lines = cell["source"].split("\n")
    code = lines[line - 1].strip() if line and 0 < line <= len(lines) else ""
    return {"cell": cell["position"], "first_line": cell["first_line"], "line": line,
            "code": _short(code, 200)}


def describe_cell_error(cell: dict[str, Any], exc: BaseException) -> dict[str, Any]:
    """Where and what: the cell as the student sees it, the line, the error."""
    if isinstance(exc, SyntaxError):
        text = f"{type(exc).__name__}: {exc.msg}"
        return {**_where(cell, exc.lineno), "kind": "syntax", "error": text}
    frames = [f for f in traceback.extract_tb(exc.__traceback__) if f.filename == cell["file"]]
    line = frames[-1].lineno if frames else None
    if isinstance(exc, SystemExit):
        kind, text = "exit", f"SystemExit({exc.code!r})"
    elif isinstance(exc, CaseTimeout):
        kind, text = "timeout", "the cell ran past its time limit"
    elif isinstance(exc, MemoryError):
        kind, text = "memory", "MemoryError: the cell ran out of memory"
    elif isinstance(exc, NotImplementedError):
        kind, text = "not implemented", "NotImplementedError: it uses an unfinished exercise"
    else:
        kind, text = "error", f"{type(exc).__name__}: {exc}"
    return {**_where(cell, line), "kind": kind, "error": _short(text)}


def run_cells(cells: list[dict[str, Any]], namespace: dict[str, Any],
              cell_time_limit: float = 0.0) -> list[dict[str, Any]]:
    """Execute the notebook's code cells in order; each cell that fails (or runs past
    ``cell_time_limit`` seconds, when given) becomes an error record and the next cell runs."""
    errors = []
    for cell in cells:
        cell["file"] = f"<cell {cell['position']}>"
        try:
            code = compile(strip_magics(cell["source"]), cell["file"], "exec")
            if cell_time_limit > 0:
                signal.signal(signal.SIGALRM, _on_alarm)
                signal.setitimer(signal.ITIMER_REAL, cell_time_limit)
            try:
                exec(code, namespace)
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
        except (Exception, SystemExit, CaseTimeout) as exc:
            error = describe_cell_error(cell, exc)
            if error["kind"] == "timeout":
                error["error"] = (f"the cell did not finish within {cell_time_limit:g} s "
                                  f"(an endless loop?)")
            errors.append(error)
        _forked_child_leaves()
    return errors


def missing(function: str, cell_errors: list[dict[str, Any]],
            cells: list[dict[str, Any]]) -> str:
    """Why the notebook has no ``function``, naming the cell that should have made it."""
    text = f"the notebook defines no function {function!r}"
    defining = re.compile(rf"^\s*def\s+{re.escape(function)}\s*\(", re.MULTILINE)
    by_position = {e["cell"]: e for e in cell_errors}
    for cell in cells:
        error = by_position.get(cell["position"])
        if error is not None and defining.search(cell["source"]):
            at = f" at line {error['line']}" if error.get("line") else ""
            return (f"{text}: cell {cell['position']} (`{cell['first_line']}`) did not run — "
                    f"{error['error']}{at}")
    return text


# ------------------------------------------------------------------ cases

def _on_alarm(signum: int, frame: FrameType | None) -> None:
    raise CaseTimeout


def builtin_type(exc: BaseException) -> str:
    """The first built-in exception class ``exc`` is an instance of (its own class's name is
    the submission's to choose, so it is never reported)."""
    for klass in type(exc).__mro__:
        if getattr(builtins, klass.__name__, None) is klass:
            return klass.__name__
    return "Exception"


def signature_of(fn: Any) -> str:
    try:
        return _short(str(inspect.signature(fn)), 200)
    except (TypeError, ValueError):
        return "(?)"


def _call_and_encode(fn: Any, args: Any, kwargs: Any) -> Any:
    from grader import serialize

    return serialize.encode(fn(*args, **kwargs))


def call_case(fn: Any, case: dict[str, Any], time_limit: float, public: bool) -> dict[str, Any]:
    """One call; a public case's failure says what happened, a hidden one's only a verdict."""
    from grader import guard, serialize

    args, kwargs = serialize.decode(case["args"]), serialize.decode(case["kwargs"])
    signal.signal(signal.SIGALRM, _on_alarm)
    signal.setitimer(signal.ITIMER_REAL, time_limit)
    try:
        return {"status": "returned",
                "value": guard.call_refusing(_call_and_encode, fn, args, kwargs)}
    except CaseTimeout:
        return {"status": "timeout"}
    except NotImplementedError:
        return {"status": "not implemented"}
    except MemoryError:
        return {"status": "memory"}
    except SystemExit as exc:
        return {"status": "exit", **({"message": f"called sys.exit({exc.code!r})"}
                                     if public else {})}
    except serialize.EncodeError as exc:
        return {"status": "unencodable", **({"message": str(exc)} if public else {})}
    except Exception as exc:
        if not public:
            return {"status": "error", "type": builtin_type(exc)}
        tb = traceback.extract_tb(exc.__traceback__)
        line = f" (line {tb[-1].lineno})" if tb else ""
        return {"status": "error", "type": builtin_type(exc),
                "message": _short(f"raised {type(exc).__name__}: {exc}{line}")}
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        _forked_child_leaves()


def harnessed(fn: Any, harness: str) -> Any:
    """``fn`` itself, or, for closed-loop grading, ``harness(fn, ...)`` (``module:function``)."""
    if not harness:
        return fn
    module, _, name = harness.partition(":")
    run = getattr(importlib.import_module(module), name)

    def call(*args: Any, **kwargs: Any) -> Any:
        return run(fn, *args, **kwargs)

    return call


def call_cases(fn: Any, cases: list[dict[str, Any]], time_limit: float,
               public: bool, harness: str = "") -> list[dict[str, Any]]:
    fn = harnessed(fn, harness)
    results: list[dict[str, Any]] = []
    for case in cases:
        if results and results[-1]["status"] == "timeout":
            # one endless loop per exercise is enough to know; keep the time for the rest
            results.append({"status": "timeout"})
        else:
            results.append(call_case(fn, case, time_limit, public))
    return results


# ------------------------------------------------------------------ the two phases

def _read(stream: Any) -> dict[str, Any]:
    line = stream.readline()
    if not line:
        raise SystemExit("the grader closed the request")
    message = json.loads(line)
    if not isinstance(message, dict):
        raise SystemExit("malformed request")
    return message


def _send(channel: Any, message: dict[str, Any]) -> None:
    channel.write(json.dumps(message).encode() + b"\n")
    channel.flush()


def public_phase(request: dict[str, Any], namespace: dict[str, Any]) -> dict[str, Any]:
    cells = request["cells"]
    cell_errors = run_cells(cells, namespace, request.get("cell_time_limit", 0.0))
    outcomes: dict[str, Any] = {}
    for exercise in request["exercises"]:
        fn = namespace.get(exercise["function"])
        if fn is None:
            outcomes[exercise["id"]] = {"missing": missing(exercise["function"], cell_errors,
                                                           cells)}
        elif not callable(fn):
            outcomes[exercise["id"]] = {"missing": f"{exercise['function']!r} is a "
                                                   f"{type(fn).__name__}, not a function"}
        else:
            outcomes[exercise["id"]] = {
                "signature": signature_of(fn),
                "cases": call_cases(fn, exercise["cases"],
                                    exercise.get("time_limit") or request["case_time_limit"],
                                    True, exercise.get("harness", ""))}
    return {"phase": "public", "cell_errors": cell_errors, "outcomes": outcomes}


def hidden_phase(request: dict[str, Any], namespace: dict[str, Any],
                 time_limit: float) -> dict[str, Any]:
    outcomes = {}
    for exercise in request["exercises"]:
        fn = namespace.get(exercise["function"])
        if callable(fn):
            outcomes[exercise["id"]] = {"cases": call_cases(
                fn, exercise["cases"], exercise.get("time_limit") or time_limit, False,
                exercise.get("harness", ""))}
    return {"phase": "hidden", "outcomes": outcomes}


def main(argv: Sequence[str]) -> int:
    channel = os.fdopen(int(argv[0]), "wb")
    stdin = sys.stdin.buffer
    request = _read(stdin)
    install_modules(request.pop("modules"))
    from grader import guard

    guard.install(request["blocked"])
    guard_reload(sorted({name.partition(":")[0] for name in request["blocked"]}))
    namespace: dict[str, Any] = {"__name__": "__main__"}
    _send(channel, public_phase(request, namespace))
    hidden = _read(stdin)
    _send(channel, hidden_phase(hidden, namespace, request["case_time_limit"]))
    channel.close()
    os._exit(0)  # skip whatever atexit handlers the submission registered


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
