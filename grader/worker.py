"""The submission side of grading: ``python -m grader.worker`` in a fresh process.

It reads one request (JSON on standard input: the notebook's code cells, the exercises'
function names and case inputs, and the reference functions to block), runs the cells in one
namespace — a cell that fails is recorded and the next one runs, as in a notebook —, calls
each exercise function on each case, and writes the encoded outputs as JSON to the result
channel. Nothing else leaves the process: the expected outputs never enter it, and the
grader judges the outputs in its own process.

Results go to ``result.json`` in the scratch directory, which the grader reads with a size
cap; what the submission prints goes to files the grader only skims (their size is capped by
the file-size limit), so nothing printed can pose as a result.
"""

from __future__ import annotations

import importlib
import inspect
import json
import os
import signal
import sys
import traceback
from types import FrameType
from typing import Any

from grader import serialize

TEXT_LIMIT = 500


class CaseTimeout(BaseException):
    """Raised inside a call that ran past its time limit."""


def _short(text: str) -> str:
    return text if len(text) <= TEXT_LIMIT else text[:TEXT_LIMIT] + "…"


def strip_magics(source: str) -> str:
    """Drop IPython-only lines (``%magic``, ``!shell``) so a cell runs as plain Python."""
    return "\n".join("" if line.lstrip().startswith(("%", "!")) else line
                     for line in source.split("\n"))


def _blocked(qualified: str) -> Any:
    def refuse(*args: Any, **kwargs: Any) -> Any:
        raise PermissionError(f"{qualified} is the kit's reference for this exercise: while "
                              f"grading, the exercise must be solved with your own code")
    return refuse


def block_references(names: list[str]) -> None:
    """Replace the reference functions with ones that refuse, and refuse to reload their
    modules (a reload would bring the originals back)."""
    # import the blocked modules' packages first (and the emulators, which are built on
    # the drivers), so that the kit's own modules bind the real functions; only names
    # looked up afterwards — the student's — get the refusing ones
    import pkgutil

    packages = {q.partition(":")[0].rpartition(".")[0] for q in names}
    packages = {p for p in packages if "." in p}  # sub-packages such as kit.drivers
    if "kit.drivers" in packages:
        packages.add("hardware.emulators")
    for package in sorted(packages - {""}):
        root = importlib.import_module(package)
        for info in pkgutil.walk_packages(root.__path__, package + "."):
            if info.name.endswith("__main__"):
                continue
            importlib.import_module(info.name)
    modules = set()
    for qualified in names:
        module_name, _, attr = qualified.partition(":")
        module = importlib.import_module(module_name)
        setattr(module, attr, _blocked(f"{module_name}.{attr}"))
        modules.add(module)
    original_reload = importlib.reload

    def guarded_reload(module: Any) -> Any:
        if module in modules:
            raise PermissionError(f"{module.__name__} holds references blocked while grading")
        return original_reload(module)

    importlib.reload = guarded_reload


def _on_alarm(signum: int, frame: FrameType | None) -> None:
    raise CaseTimeout


def run_cells(cells: list[str], namespace: dict[str, Any]) -> list[dict[str, Any]]:
    errors = []
    for index, source in enumerate(cells):
        try:
            code = compile(strip_magics(source), f"<cell {index}>", "exec")
            exec(code, namespace)
        except SystemExit as exc:
            errors.append({"cell": index, "error": f"SystemExit({exc.code!r})"})
        except CaseTimeout:
            errors.append({"cell": index, "error": "cell ran past its time limit"})
        except MemoryError:
            errors.append({"cell": index, "error": "MemoryError: the cell ran out of memory"})
        except Exception as exc:
            errors.append({"cell": index, "error": _short(f"{type(exc).__name__}: {exc}")})
    return errors


def signature_of(fn: Any) -> str:
    try:
        return str(inspect.signature(fn))
    except (TypeError, ValueError):
        return "(?)"


def call_case(fn: Any, case: dict[str, Any], time_limit: float) -> dict[str, Any]:
    args = serialize.decode(case["args"])
    kwargs = serialize.decode(case["kwargs"])
    signal.setitimer(signal.ITIMER_REAL, time_limit)
    try:
        value = fn(*args, **kwargs)
    except CaseTimeout:
        return {"status": "timeout", "message": f"did not return within {time_limit:g} s"}
    except NotImplementedError:
        return {"status": "not implemented", "message": "not implemented yet"}
    except MemoryError:
        return {"status": "memory", "message": "ran out of memory"}
    except SystemExit as exc:
        return {"status": "error", "message": f"called sys.exit({exc.code!r})"}
    except Exception as exc:
        tb = traceback.extract_tb(exc.__traceback__)
        line = f" (line {tb[-1].lineno})" if tb else ""
        return {"status": "error", "message": _short(f"raised {type(exc).__name__}: {exc}{line}")}
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
    try:
        return {"status": "returned", "value": serialize.encode(value)}
    except serialize.EncodeError as exc:
        return {"status": "error", "message": f"returned something that cannot be graded: {exc}"}


def main() -> int:
    request = json.loads(sys.stdin.buffer.read())
    result = open("result.json", "wb")
    os.environ["KIT_GRADING"] = "1"
    signal.signal(signal.SIGALRM, _on_alarm)
    block_references(request["blocked"])
    namespace: dict[str, Any] = {"__name__": "__main__"}
    cell_errors = run_cells(request["cells"], namespace)
    outcomes: dict[str, Any] = {}
    for exercise in request["exercises"]:
        fn = namespace.get(exercise["function"])
        if fn is None:
            outcomes[exercise["id"]] = {"missing": f"the notebook defines no function "
                                                   f"{exercise['function']!r}"}
            continue
        if not callable(fn):
            outcomes[exercise["id"]] = {"missing": f"{exercise['function']!r} is a "
                                                   f"{type(fn).__name__}, not a function"}
            continue
        results: list[dict[str, Any]] = []
        for case in exercise["cases"]:
            if results and results[-1]["status"] == "timeout":
                # one endless loop per exercise is enough to know; keep the time for the rest
                results.append({"status": "timeout", "message": "skipped after a timeout"})
            else:
                results.append(call_case(fn, case, float(request["case_time_limit"])))
        outcomes[exercise["id"]] = {"cases": results, "signature": signature_of(fn)}
    payload = json.dumps({"cell_errors": cell_errors, "outcomes": outcomes}).encode()
    result.seek(0)
    result.truncate()
    result.write(payload)
    result.close()
    os._exit(0)  # skip whatever atexit handlers the submission registered


if __name__ == "__main__":
    sys.exit(main())
