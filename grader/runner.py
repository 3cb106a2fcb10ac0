"""The submission's side of grading: run the notebook's exercise cells, then answer questions.

This is all a graded submission's process does (:mod:`grader.zygote` starts it, isolated, in
a process of its own). It holds no reference, no expected value and no course secret; it
never decides whether an answer is right. One frame at a time (:mod:`grader.frames`) it is
told what to do and replies:

``cells``
    run the notebook's code cells in one namespace: exercise cells and cells the student
    added whole; the setup cell statement by statement; the lab's other cells only for their
    definitions (imports, functions, classes, constants) — an example cell's simulation or plot
    is never run while grading. A cell of the student's that fails is recorded with its
    position and line, and the next one runs, as in a notebook; what fails in the lab's own
    cells is left out silently.
``describe``
    which exercise functions the namespace holds, and their signatures.
``call``
    call one function on one question's arguments, within a CPU-time limit; reply with the
    value, or with what went wrong.
``new`` / ``method``
    make an object with a function of the notebook (a controller from ``make_controller``) and
    call its methods one step at a time: a closed-loop episode runs in the grader's process
    and asks the controller across the boundary.

Questions arrive pickled (from the grader, which this process cannot influence); answers leave
as JSON with raw array data (:mod:`grader.serialize`), which the grader decodes without ever
running anything of it. Everything the answers say is the submission's to choose — so the
grader checks each answer itself, keeps the messages of public questions only, and for hidden
ones reads nothing but the value or the kind of failure.
"""

from __future__ import annotations

import ast
import inspect
import os
import pickle
import signal
import socket
import traceback
from types import FrameType
from typing import Any

from grader import frames, serialize

__all__ = ["CaseTimeout", "definitions_only", "serve"]

TEXT_LIMIT = 500
MAIN_PID = os.getpid()


class CaseTimeout(BaseException):
    """Raised inside a cell or a call that used up its CPU time."""


def _short(text: str, limit: int = TEXT_LIMIT) -> str:
    return text if len(text) <= limit else text[:limit] + "…"


def _on_alarm(signum: int, frame: FrameType | None) -> None:
    raise CaseTimeout


def _limit(seconds: float) -> None:
    """Raise :class:`CaseTimeout` after ``seconds`` of this process's CPU time (``0``: none).
    CPU time, not the wall clock: a loaded grading machine does not fail an honest answer."""
    signal.signal(signal.SIGPROF, _on_alarm)
    signal.setitimer(signal.ITIMER_PROF, max(0.0, seconds))


def _forked_child_leaves() -> None:
    """A process the submission forked never goes on answering for it."""
    if os.getpid() != MAIN_PID:
        os._exit(0)


# ------------------------------------------------------------------ cells

def strip_magics(source: str) -> str:
    """Drop IPython-only lines (``%magic``, ``!shell``) so a cell runs as plain Python."""
    return "\n".join("" if line.lstrip().startswith(("%", "!")) else line
                     for line in source.split("\n"))


def _is_definition(node: ast.stmt) -> bool:
    if isinstance(node, (ast.Import, ast.ImportFrom, ast.FunctionDef, ast.AsyncFunctionDef,
                         ast.ClassDef)):
        return True
    if isinstance(node, (ast.Assign, ast.AnnAssign)) and node.value is not None:
        # a constant: literals, containers of them, names and arithmetic, never a call
        return not any(isinstance(n, (ast.Call, ast.Await, ast.Yield, ast.YieldFrom,
                                      ast.NamedExpr, ast.Lambda, ast.ListComp, ast.SetComp,
                                      ast.DictComp, ast.GeneratorExp, ast.Subscript))
                       for n in ast.walk(node.value))
    return False


def definitions_only(tree: ast.Module) -> ast.Module:
    """``tree`` with only its top-level definitions: what a lab's own cell contributes to
    the exercises (its imports, functions, classes and constants), never its work."""
    tree.body = [node for node in tree.body if _is_definition(node)]
    return tree


def _where(cell: dict[str, Any], line: int | None) -> dict[str, Any]:
    lines = cell["source"].split("\n")
    code = lines[line - 1].strip() if line and 0 < line <= len(lines) else ""
    return {"cell": cell["position"], "first_line": cell["first_line"], "line": line,
            "code": _short(code, 200)}


def describe_cell_error(cell: dict[str, Any], exc: BaseException) -> dict[str, Any]:
    """Where and what: the cell as the student sees it, the line, the error."""
    if isinstance(exc, SyntaxError):
        return {**_where(cell, exc.lineno), "kind": "syntax",
                "error": f"{type(exc).__name__}: {exc.msg}"}
    found = [f for f in traceback.extract_tb(exc.__traceback__) if f.filename == cell["file"]]
    line = found[-1].lineno if found else None
    if isinstance(exc, SystemExit):
        kind, text = "exit", f"SystemExit({exc.code!r})"
    elif isinstance(exc, CaseTimeout):
        kind, text = "timeout", "the cell used up its CPU time (an endless loop?)"
    elif isinstance(exc, MemoryError):
        kind, text = "memory", "MemoryError: the cell ran out of memory"
    elif isinstance(exc, NotImplementedError):
        kind, text = "not implemented", "NotImplementedError: it uses an unfinished exercise"
    else:
        kind, text = "error", f"{type(exc).__name__}: {exc}"
    return {**_where(cell, line), "kind": kind, "error": _short(text)}


def run_cells(sock: socket.socket, cells: list[dict[str, Any]], namespace: dict[str, Any],
              cpu_limit: float) -> list[dict[str, Any]]:
    """Execute the cells in order; each that fails (or uses up ``cpu_limit`` seconds) becomes
    an error record, and the next one runs. Before each cell a ``started`` frame says which
    one runs, so the grader knows where a process that dies died."""
    errors = []
    for cell in cells:
        cell["file"] = f"<cell {cell['position']}>"
        frames.send(sock, {"op": "started", "cell": cell["position"]})
        mode = cell.get("mode", "run")
        try:
            tree = ast.parse(strip_magics(cell["source"]), cell["file"])
            if mode == "run":
                _run(compile(tree, cell["file"], "exec"), namespace, cpu_limit)
            else:
                _run_quietly(tree, cell["file"], namespace, cpu_limit, mode == "definitions")
        except (Exception, SystemExit, CaseTimeout) as exc:
            errors.append(describe_cell_error(cell, exc))
        _forked_child_leaves()
    return errors


def _run(code: Any, namespace: dict[str, Any], cpu_limit: float) -> None:
    _limit(cpu_limit)
    try:
        exec(code, namespace)
    finally:
        _limit(0)


def _run_quietly(tree: ast.Module, file: str, namespace: dict[str, Any], cpu_limit: float,
                 definitions: bool) -> None:
    """A lab's own cell: statement by statement (only its definitions unless it is the setup
    cell), and what fails is left out silently — the student did not write it, and only what
    the exercises need from it matters."""
    statements = definitions_only(tree).body if definitions else tree.body
    for node in statements:
        code = compile(ast.Module(body=[node], type_ignores=[]), file, "exec")
        try:
            _run(code, namespace, cpu_limit)
        except CaseTimeout:
            raise
        except (Exception, SystemExit):
            continue


# ------------------------------------------------------------------ questions

def signature_of(fn: Any) -> str:
    try:
        return _short(str(inspect.signature(fn)), 200)
    except (TypeError, ValueError):
        return "(?)"


def _failure(exc: BaseException) -> dict[str, Any]:
    """What went wrong in a call, in the words a public case may show."""
    if isinstance(exc, CaseTimeout):
        mine = [f for f in traceback.extract_tb(exc.__traceback__)
                if f.filename.startswith("<cell ")]
        return {"status": "timeout", **({"where": f"{mine[-1].filename[1:-1]}, line "
                                                  f"{mine[-1].lineno}"} if mine else {})}
    if isinstance(exc, NotImplementedError):
        return {"status": "not implemented"}
    if isinstance(exc, MemoryError):
        return {"status": "memory"}
    if isinstance(exc, SystemExit):
        return {"status": "exit", "message": f"called sys.exit({exc.code!r})"}
    if isinstance(exc, serialize.EncodeError):
        return {"status": "unencodable", "message": str(exc)}
    frames_ = traceback.extract_tb(exc.__traceback__)
    mine = [f for f in frames_ if f.filename.startswith("<cell ")]
    where = f" ({mine[-1].filename[1:-1]}, line {mine[-1].lineno})" if mine else ""
    return {"status": "error", "type": type(exc).__name__,
            "message": _short(f"raised {type(exc).__name__}: {exc}{where}")}


def _answer(fn: Any, args: tuple[Any, ...], kwargs: dict[str, Any], cpu_limit: float
            ) -> tuple[dict[str, Any], list[bytes]]:
    blobs: list[bytes] = []
    try:
        _limit(cpu_limit)
        try:
            value = fn(*args, **kwargs)
        finally:
            _limit(0)
        return {"status": "returned", "value": serialize.encode(value, blobs=blobs)}, blobs
    except (Exception, SystemExit, CaseTimeout) as exc:
        return _failure(exc), []
    finally:
        _forked_child_leaves()


class _Service:
    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self.namespace: dict[str, Any] = {"__name__": "__main__"}
        self.objects: dict[int, Any] = {}

    def handle(self, header: dict[str, Any], payload: Any) -> tuple[dict[str, Any],
                                                                   list[bytes]]:
        op = header["op"]
        if op == "cells":
            return {"errors": run_cells(self.sock, payload["cells"], self.namespace,
                                        payload["cpu_limit"])}, []
        if op == "describe":
            out = {}
            for name in payload["functions"]:
                fn = self.namespace.get(name)
                out[name] = {"exists": fn is not None, "callable": callable(fn),
                             "type": type(fn).__name__,
                             "signature": signature_of(fn) if callable(fn) else ""}
            return {"functions": out}, []
        if op == "call":
            fn = self.namespace.get(payload["function"])
            if not callable(fn):
                return {"status": "error", "type": "NameError",
                        "message": f"the notebook defines no function {payload['function']}"}, []
            return _answer(fn, payload["args"], payload["kwargs"], payload["cpu_limit"])
        if op == "new":
            fn = self.namespace.get(payload["function"])
            if not callable(fn):
                return {"status": "error", "type": "NameError",
                        "message": f"the notebook defines no function {payload['function']}"}, []
            handle = len(self.objects) + 1
            holder: list[Any] = []

            def make(*args: Any) -> None:
                holder.append(fn(*args))

            answer, blobs = _answer(make, payload["args"], {}, payload["cpu_limit"])
            if answer["status"] == "returned":
                self.objects[handle] = holder[0]
                answer = {"status": "returned", "value": handle,
                          "methods": sorted(m for m in payload.get("methods", ())
                                            if callable(getattr(holder[0], m, None)))}
            return answer, blobs
        if op == "method":
            obj = self.objects.get(payload["handle"])
            method = getattr(obj, payload["method"], None)
            if not callable(method):
                return {"status": "error", "type": "AttributeError",
                        "message": f"the object has no method {payload['method']}()"}, []
            return _answer(method, payload["args"], payload.get("kwargs", {}),
                           payload["cpu_limit"])
        return {"status": "error", "message": f"unknown question {op!r}"}, []


def serve(sock: socket.socket) -> None:
    """Answer the grader's frames until it says ``bye`` or closes the stream; never returns."""
    global MAIN_PID
    MAIN_PID = os.getpid()
    service = _Service(sock)
    while True:
        try:
            header, blobs = frames.recv(sock)
        except (frames.FrameError, OSError, ValueError):
            os._exit(0)
        if header.get("op") == "bye":
            os._exit(0)
        payload = pickle.loads(blobs[0]) if blobs else {}
        reply, out = service.handle(header, payload)
        reply["id"] = header.get("id")
        try:
            frames.send(sock, reply, out)
        except OSError:
            os._exit(0)
